"""The Levenberg-Marquardt machine on problems whose answers are known.

Driven through :func:`pumpid.engine.solvers.run_python` (the same compiled state machine the
card drivers step through) with residuals of ``a exp(-k t)`` in ``z = (ln a, ln k)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize

from pumpid import Stop
from pumpid.engine import lm
from pumpid.engine.solvers import run_python

T = np.linspace(0.0, 3.0, 60)


def _problem(amp: float, rate: float, noise: float = 0.0, seed: int = 0):
    rng = np.random.default_rng(seed)
    data = amp * np.exp(-rate * T) + noise * rng.standard_normal(T.size)
    calls: list[np.ndarray] = []

    def evaluate(z: np.ndarray):
        calls.append(z.copy())
        a, k = math.exp(z[0]), math.exp(z[1])
        model = a * np.exp(-k * T)
        rows = np.vstack([model, -k * T * model, model - data])
        r_fac = np.zeros((2, 2))
        c = np.zeros(2)
        cost = lm.householder(rows, 2, r_fac, c)
        return cost, r_fac, c

    return data, evaluate, calls


def _solve(evaluate, z0, lo=(-np.inf, -np.inf), hi=(np.inf, np.inf), budget=200):
    return run_python(evaluate, np.asarray(z0, float), np.asarray(lo, float),
                      np.asarray(hi, float), tol=1e-12, max_evaluations=budget, n_capped=2)


@pytest.mark.parametrize("cond", [1.0, 1e6])
def test_householder_factor_matches_the_normal_equations(cond) -> None:
    rng = np.random.default_rng(1)
    q, n = 4, 50
    jac = rng.standard_normal((q, n))
    jac[-1] = jac[0] + jac[-1] / cond  # nearly dependent columns when cond is large
    r = rng.standard_normal(n)
    rows = np.vstack([jac, r])
    r_fac = np.zeros((q, q))
    qtr = np.zeros(q)
    cost = lm.householder(rows.copy(), q, r_fac, qtr)
    gram = jac @ jac.T
    assert cost == pytest.approx(0.5 * r @ r, rel=1e-13)
    np.testing.assert_allclose(r_fac.T @ r_fac, gram, rtol=1e-10, atol=1e-10 * np.abs(gram).max())
    np.testing.assert_allclose(r_fac.T @ qtr, jac @ r, rtol=1e-9, atol=1e-9)
    assert np.allclose(np.tril(r_fac, -1), 0.0)


@pytest.mark.parametrize(("amp", "rate"), [(1.0, 0.5), (5.0, 2.0), (0.2, 1.2), (30.0, 0.1)])
def test_reaches_the_optimum_from_far(amp, rate) -> None:
    _data, evaluate, _calls = _problem(amp, rate)
    out = _solve(evaluate, np.log([amp * 2.5, rate / 3.0]))
    assert out.stops[0].converged
    np.testing.assert_allclose(np.exp(out.z[0]), [amp, rate], rtol=1e-10)


def test_noisy_problem_matches_scipy_least_squares() -> None:
    data, evaluate, _calls = _problem(2.0, 0.7, noise=0.05, seed=3)
    out = _solve(evaluate, np.log([1.0, 1.0]))
    assert out.stops[0] in (Stop.GTOL, Stop.FTOL, Stop.XTOL)

    def residual(z):
        return np.exp(z[0]) * np.exp(-np.exp(z[1]) * T) - data

    ref = scipy.optimize.least_squares(residual, np.log([1.0, 1.0]), method="lm", xtol=1e-15,
                                       ftol=1e-15, gtol=1e-15)
    # The minimum is unique and well conditioned: both solvers land on it to within their
    # tolerances (the cost agrees far more tightly than the parameters can).
    np.testing.assert_allclose(out.z[0], ref.x, rtol=1e-6)
    assert out.cost[0] == pytest.approx(ref.cost, rel=1e-12)


def test_a_bound_holds_the_coordinate_and_frees_the_others() -> None:
    # The true rate (ln 2 = 0.69) lies above the bound 0.0: the rate stops there, and the
    # amplitude is the best one for that rate.
    _data, evaluate, _calls = _problem(3.0, 2.0)
    out = _solve(evaluate, np.log([1.0, 0.5]), hi=(np.inf, 0.0))
    assert out.stops[0].converged
    assert out.z[0, 1] == 0.0
    basis = np.exp(-T)
    best_amp = (basis @ (3.0 * np.exp(-2.0 * T))) / (basis @ basis)
    assert np.exp(out.z[0, 0]) == pytest.approx(best_amp, rel=1e-6)


def test_log_steps_are_capped() -> None:
    _data, evaluate, calls = _problem(1.0, 1.0)
    z0 = np.log([1e4, 1.0])  # amplitude 1e4 times too large
    _solve(evaluate, z0)
    steps = np.abs(np.diff(np.vstack(calls), axis=0))
    assert np.all(steps[:, 0] <= lm.MAX_LOG_STEP + 1e-12)


def test_failures_and_budgets_are_reported() -> None:
    _data, evaluate, _calls = _problem(1.0, 1.0)

    def broken(z):
        _cost, r_fac, c = evaluate(z)
        return math.nan, r_fac, c

    out = _solve(broken, np.log([3.0, 0.2]))
    assert out.stops[0] is Stop.NOT_FINITE and not math.isfinite(out.cost[0])
    short = _solve(evaluate, np.log([3.0, 0.2]), budget=3)
    assert short.stops[0] is Stop.BUDGET and short.evaluations[0] == 3
    assert "maximum number of model evaluations" in short.messages[0]


def test_a_trial_point_that_cannot_be_evaluated_shrinks_the_step() -> None:
    _data, evaluate, _calls = _problem(2.0, 0.3)
    seen = {"n": 0}

    def sometimes(z):
        seen["n"] += 1
        if seen["n"] == 2:  # the first trial point fails: the solver must recover
            return math.nan, np.zeros((2, 2)), np.zeros(2)
        return evaluate(z)

    out = _solve(sometimes, np.log([5.0, 1.0]))
    assert out.stops[0].converged
    np.testing.assert_allclose(np.exp(out.z[0]), [2.0, 0.3], rtol=1e-9)


def test_an_exact_start_stops_at_once() -> None:
    _data, evaluate, calls = _problem(2.0, 0.3)
    out = _solve(evaluate, np.log([2.0, 0.3]))
    assert out.stops[0].converged and out.evaluations[0] <= 2 and len(calls) <= 2


def test_a_coordinate_the_residual_ignores_stays_put() -> None:
    # A third coordinate with an empty Jacobian column (a parameter the data do not see):
    # the steps stay finite and never move it.
    data = 2.0 * np.exp(-0.3 * T)

    def evaluate(z):
        a, k = math.exp(z[0]), math.exp(z[1])
        model = a * np.exp(-k * T)
        rows = np.vstack([model, -k * T * model, np.zeros_like(T), model - data])
        r_fac = np.zeros((3, 3))
        c = np.zeros(3)
        return lm.householder(rows, 3, r_fac, c), r_fac, c

    z0 = np.array([math.log(6.0), math.log(1.5), 0.7])
    out = run_python(evaluate, z0, np.full(3, -np.inf), np.full(3, np.inf), tol=1e-12,
                     max_evaluations=300, n_capped=2)
    assert np.all(np.isfinite(out.z)) and out.z[0, 2] == 0.7
    np.testing.assert_allclose(np.exp(out.z[0, :2]), [2.0, 0.3], rtol=1e-8)


def _svd_cases():
    rng = np.random.default_rng(11)
    cases = [np.zeros((3, 3)), np.array([[-2.5]]), np.eye(4)]
    for n in (2, 3, 5, 7):
        cases.append(rng.standard_normal((n, n)))
        # A scaled factor R of an ill-conditioned problem (columns over 12 decades).
        cases.append(np.triu(rng.standard_normal((n, n))) * np.logspace(0, -12, n))
        rank_deficient = rng.standard_normal((n, n))
        rank_deficient[:, n // 2] = 0.0
        cases.append(rank_deficient)
    return cases


@pytest.mark.parametrize("a", _svd_cases())
def test_the_small_svd_factors_like_lapack(a) -> None:
    u, sig, vt = lm.small_svd(a)
    n = a.shape[0]
    assert np.all(np.diff(sig) <= 0.0) and np.all(sig >= 0.0)
    np.testing.assert_allclose(vt @ vt.T, np.eye(n), atol=1e-13)
    np.testing.assert_allclose(u @ np.diag(sig) @ vt, a, rtol=0.0,
                               atol=1e-14 * max(float(np.abs(a).max()), 1e-300))
    reference = np.linalg.svd(a, compute_uv=False)
    np.testing.assert_allclose(sig, reference, rtol=1e-9, atol=1e-14 * reference[0])
    # The columns of u that carry a singular value are orthonormal; the others are zero.
    kept = sig > 1e-14 * max(sig[0], 1e-300)
    np.testing.assert_allclose(u[:, kept].T @ u[:, kept], np.eye(int(kept.sum())),
                               atol=1e-12)
    assert np.all(u[:, sig == 0.0] == 0.0)


@pytest.mark.parametrize("a", _svd_cases())
def test_the_pseudo_inverse_is_numpys(a) -> None:
    # np.linalg.pinv's default cut (1e-15 of the largest singular value); where a
    # singular value sits near that cut the two may keep it or not, so the ill-conditioned
    # factors are compared on what they do to a (the Moore-Penrose identities).
    pinv = lm.pseudo_inverse(a, 1e-15)
    reference = np.linalg.pinv(a)
    scale = max(float(np.abs(a).max()), 1e-300)
    np.testing.assert_allclose(a @ pinv @ a, a, rtol=0.0, atol=1e-10 * scale)
    np.testing.assert_allclose(pinv @ a @ pinv, pinv, rtol=0.0,
                               atol=1e-10 * max(float(np.abs(pinv).max()), 1e-300))
    if np.linalg.cond(a) < 1e8:
        np.testing.assert_allclose(pinv, reference, rtol=1e-9,
                                   atol=1e-12 * max(float(np.abs(reference).max()), 1e-300))


@pytest.mark.parametrize("amp, rate, noise", [(2.0, 1.5, 0.0), (1.0, 0.3, 0.05), (5.0, 4.0, 0.2)])
def test_the_residual_alone_decides_a_step_as_the_machine_does(amp, rate, noise) -> None:
    # A driver that costs a trial point first computes its Jacobian only where the machine
    # takes the step: the same path, with the Jacobian evaluated at accepted points only.
    _data, evaluate, calls = _problem(amp, rate, noise)

    def cost(z: np.ndarray) -> float:
        return evaluate(z)[0]

    z0 = np.log([amp * 8.0, rate / 6.0])
    full = _solve(evaluate, z0)
    n_full = len(calls)
    calls.clear()
    lazy = run_python(lambda z: evaluate(z), z0, np.full(2, -np.inf), np.full(2, np.inf),
                      tol=1e-12, max_evaluations=200, n_capped=2, cost=cost)
    # ``cost`` goes through evaluate too: the lazy run's evaluate calls are its trial
    # costs plus the Jacobians at the start and at each accepted point.
    assert np.array_equal(lazy.z, full.z)
    assert lazy.cost[0] == full.cost[0]
    assert lazy.accepted[0] == full.accepted[0]
    assert lazy.evaluations[0] == full.evaluations[0]
    jacobians = len(calls) - (int(lazy.evaluations[0]) - 1)
    assert jacobians == 1 + int(lazy.accepted[0]) <= n_full


def test_accepts_is_the_machines_verdict_on_a_cost() -> None:
    _data, evaluate, _calls = _problem(2.0, 1.5)
    z0 = np.log([8.0, 0.5])
    first, r, c = evaluate(z0)
    state = lm.start(z0, first, r, c, np.full(2, -np.inf), np.full(2, np.inf), 1e-12, 2,
                     100, False, 0.0, np.zeros(0))
    assert lm.propose(state)
    pred = float(state[7][lm_index("_PRED")])
    assert pred > 0.0
    for gain in (-1.0, 0.0, 0.5e-4, 2e-4, 0.3, 1.0):
        trial = first - gain * pred
        assert lm.accepts(state, trial) == (gain >= 1e-4)
    assert not lm.accepts(state, math.nan)
    assert not lm.accepts(state, math.inf)


def lm_index(name: str) -> int:
    """The position of a named entry in the machine's float state."""
    return int(getattr(lm, name))
