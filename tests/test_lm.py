"""The batched Levenberg-Marquardt core on problems whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid import lm

T = np.linspace(0.0, 3.0, 60)


def _exp_problem(amp: np.ndarray, rate: np.ndarray, noise: float = 0.0, seed: int = 0,
                 data: np.ndarray | None = None):
    """Residuals a * exp(-k t) - data in z = (ln a, ln k), one problem per row."""
    if data is None:
        rng = np.random.default_rng(seed)
        data = amp[:, None] * np.exp(-rate[:, None] * T) + noise * rng.standard_normal(
            (amp.size, T.size))

    def evaluate(z: np.ndarray, idx: np.ndarray):
        a, k = np.exp(z[:, 0]), np.exp(z[:, 1])
        model = a[:, None] * np.exp(-k[:, None] * T)
        r = model - data[idx]
        jac = np.stack([model, -k[:, None] * T * model], axis=1)  # (b, 2, N)
        return lm.reduce(jac, r)

    return data, evaluate


def _solve(evaluate, z0, lo=None, hi=None, **kw):
    lo = np.full_like(z0, -np.inf) if lo is None else lo
    hi = np.full_like(z0, np.inf) if hi is None else hi
    first = evaluate(z0, np.arange(z0.shape[0]))
    opts = {"n_capped": 2, "tol": 1e-12, "max_evaluations": 200} | kw
    return lm.solve(evaluate, z0, first, lo, hi, **opts)


@pytest.mark.parametrize("cond", [1.0, 1e6])
def test_reduce_matches_the_normal_equations(cond) -> None:
    rng = np.random.default_rng(1)
    b, q, n = 12, 4, 50
    jac = rng.standard_normal((b, q, n))
    jac[:, -1] = jac[:, 0] + jac[:, -1] / cond  # nearly dependent columns when cond is large
    r = rng.standard_normal((b, n))
    cost, r_fac, qtr = lm.reduce(jac, r)
    gram = jac @ np.swapaxes(jac, 1, 2)
    np.testing.assert_allclose(cost, 0.5 * np.sum(r * r, axis=1), rtol=1e-13)
    np.testing.assert_allclose(np.swapaxes(r_fac, 1, 2) @ r_fac, gram, rtol=1e-10,
                               atol=1e-10 * np.abs(gram).max())
    np.testing.assert_allclose((np.swapaxes(r_fac, 1, 2) @ qtr[..., None])[..., 0],
                               (jac @ r[..., None])[..., 0], rtol=1e-9, atol=1e-9)
    assert np.allclose(np.tril(r_fac, -1), 0.0)
    # One problem takes LAPACK's QR on the rows themselves: the same factor as a stacked QR,
    # and its rows untouched unless it may overwrite them.
    rows = np.concatenate([jac, r[:, None, :]], axis=1)
    stacked = lm.reduce_rows(rows[:2])
    for i in range(2):
        one = rows[i:i + 1].copy()
        out = lm.reduce_rows(one)
        np.testing.assert_array_equal(one, rows[i:i + 1])
        for a, c in zip(out, stacked, strict=True):
            np.testing.assert_allclose(a[0], c[i], rtol=1e-12, atol=1e-12)
        again = lm.reduce_rows(one, overwrite=True)
        for a, c in zip(again, out, strict=True):
            np.testing.assert_array_equal(a, c)


def test_many_problems_at_once_reach_their_own_optimum() -> None:
    amp = np.array([1.0, 5.0, 0.2, 30.0])
    rate = np.array([0.5, 2.0, 1.2, 0.1])
    _data, evaluate = _exp_problem(amp, rate)
    z0 = np.log(np.column_stack([amp * 2.5, rate / 3.0]))
    out = _solve(evaluate, z0)
    assert np.all(out.code == lm.CONVERGED)
    np.testing.assert_allclose(np.exp(out.z), np.column_stack([amp, rate]), rtol=1e-10)
    # Solved alone, each problem gives the same answer (the batch does not couple them).
    for i in range(4):
        _d, single = _exp_problem(amp[i:i + 1], rate[i:i + 1])
        alone = _solve(single, z0[i:i + 1])
        np.testing.assert_allclose(alone.z[0], out.z[i], rtol=1e-12)


def test_noisy_problem_matches_scipy_least_squares() -> None:
    import scipy.optimize

    data, evaluate = _exp_problem(np.array([2.0]), np.array([0.7]), noise=0.05, seed=3)
    out = _solve(evaluate, np.log([[1.0, 1.0]]))
    assert out.code[0] == lm.CONVERGED and lm.TESTS[out.test[0]] in ("gtol", "ftol", "xtol")

    def residual(z):
        return np.exp(z[0]) * np.exp(-np.exp(z[1]) * T) - data[0]

    ref = scipy.optimize.least_squares(residual, np.log([1.0, 1.0]), method="lm", xtol=1e-15,
                                       ftol=1e-15, gtol=1e-15)
    np.testing.assert_allclose(out.z[0], ref.x, rtol=1e-6)
    assert out.cost[0] == pytest.approx(ref.cost, rel=1e-12)


def test_a_bound_holds_the_coordinate_and_frees_the_others() -> None:
    # The true rate (ln 2 = 0.69) lies above the bound 0.0: the rate stops there, and the
    # amplitude is the best one for that rate.
    _data, evaluate = _exp_problem(np.array([3.0]), np.array([2.0]))
    z0 = np.log([[1.0, 0.5]])
    hi = np.array([[np.inf, 0.0]])
    out = _solve(evaluate, z0, hi=hi)
    assert out.code[0] == lm.CONVERGED
    assert out.z[0, 1] == 0.0
    k = 1.0
    basis = np.exp(-k * T)
    best_amp = (basis @ (3.0 * np.exp(-2.0 * T))) / (basis @ basis)
    # ftol = 1e-12 on the cost pins the free coordinate to ~1e-6 of its own scale.
    assert np.exp(out.z[0, 0]) == pytest.approx(best_amp, rel=1e-6)


def test_log_steps_are_capped() -> None:
    seen = []
    _data, evaluate = _exp_problem(np.array([1.0]), np.array([1.0]))

    def spy(z, idx):
        seen.append(z.copy())
        return evaluate(z, idx)

    z0 = np.log([[1e4, 1.0]])  # amplitude 1e4 times too large
    _solve(spy, z0)
    steps = np.abs(np.diff(np.vstack([z0, *seen]), axis=0))
    assert np.all(steps[:, 0] <= lm.MAX_LOG_STEP + 1e-12)


def test_failures_and_budgets_are_reported() -> None:
    _data, evaluate = _exp_problem(np.array([1.0, 1.0]), np.array([1.0, 2.0]))

    def broken_first(z, idx):
        cost, r_fac, qtr = evaluate(z, idx)
        cost = cost.copy()
        cost[idx == 0] = np.nan
        return cost, r_fac, qtr

    z0 = np.log([[3.0, 0.2], [3.0, 0.2]])
    out = _solve(broken_first, z0)
    assert out.code[0] == lm.FAILED and out.code[1] == lm.CONVERGED
    short = _solve(evaluate, z0, max_evaluations=2)
    assert np.all(short.code == lm.EXHAUSTED) and np.all(short.evaluations == 2)


def test_an_exact_fit_stops_on_zero_or_a_tiny_step() -> None:
    _data, evaluate = _exp_problem(np.array([2.0]), np.array([0.3]))
    out = _solve(evaluate, np.log([[2.0, 0.3]]))
    assert out.code[0] == lm.CONVERGED and out.evaluations[0] <= 1


def test_one_problem_runs_the_same_iteration_as_the_batch() -> None:
    # With a bound that becomes active on the way (the rate is capped below its true value),
    # the single-problem loop and the batched one take the same steps.
    amp, rate = np.array([3.0, 1.5]), np.array([2.0, 0.4])
    _data, evaluate = _exp_problem(amp, rate, noise=0.01, seed=5)
    z0 = np.log(np.column_stack([amp * 4.0, rate * 0.2]))
    hi = np.array([[np.inf, np.log(1.2)], [np.inf, np.inf]])
    both = _solve(evaluate, z0, hi=hi)
    for i in range(2):
        _d, single = _exp_problem(amp[i:i + 1], rate[i:i + 1], data=_data[i:i + 1])
        alone = _solve(single, z0[i:i + 1], hi=hi[i:i + 1])
        assert alone.code[0] == both.code[i] == lm.CONVERGED
        np.testing.assert_allclose(alone.z[0], both.z[i], rtol=1e-9, atol=1e-12)
    assert both.z[0, 1] == np.log(1.2)


def test_single_problem_failure_and_budget() -> None:
    _data, evaluate = _exp_problem(np.array([1.0]), np.array([1.0]))

    def broken(z, idx):
        cost, r_fac, qtr = evaluate(z, idx)
        return np.full_like(cost, np.nan), r_fac, qtr

    z0 = np.log([[3.0, 0.2]])
    assert _solve(broken, z0).code[0] == lm.FAILED
    short = _solve(evaluate, z0, max_evaluations=2)
    assert short.code[0] == lm.EXHAUSTED and short.evaluations[0] == 2


def test_damped_steps_with_a_held_or_empty_column_stay_finite() -> None:
    # A zero column (a held coordinate, or a parameter the data do not see) and a radius
    # smaller than the Gauss-Newton step: the damped step is finite, has the radius's
    # length, and does not move the empty coordinate.
    r_s = np.array([[[2.0, 0.0, 0.5], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]])
    c = np.array([[1.0, 0.3, -2.0]])
    step, fits = lm._steps(r_s, c, np.array([0.1]))
    assert np.all(np.isfinite(step)) and not fits[0]
    assert step[0, 1] == 0.0
    assert np.linalg.norm(step[0]) == pytest.approx(0.1, rel=0.11)


def test_the_float_radius_rule_is_the_batched_one() -> None:
    cases = [(delta, rho, p_norm, gn)
             for delta in (1e-3, 1.0, 50.0)
             for rho in (-np.inf, -1.0, 0.0, 0.1, 0.25, 0.5, 0.75, 1.0, 3.0, np.nan)
             for p_norm in (0.0, 1e-4, 0.7, 200.0, np.inf)
             for gn in (False, True)]
    delta, rho, p_norm, gn = (np.array(col) for col in zip(*cases, strict=True))
    with np.errstate(all="ignore"):
        batched = lm._next_radius(delta, rho, p_norm, gn)
    one = [lm._next_radius_one(*case) for case in cases]
    np.testing.assert_array_equal(one, batched)
