"""The harmonic residual: Parseval against the exact simulation, its Jacobian, the solver."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pumpid import FirstOrder, Kelvin, LevenbergMarquardt, MassSpringDamper, Maxwell, simulate
from pumpid.engine.problem import CardData, build_problem
from pumpid.engine.spectrum import (
    card_spectrum,
    harmonic_residual,
    harmonic_rows,
    harmonic_width,
)

from ..conftest import well_load

TRUTH = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)
PERIOD = 8.0


def _card(n: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) * PERIOD / n
    load = well_load(t, period=PERIOD, seed=seed)
    y = simulate(TRUTH, t, load, initial_state="periodic", period=PERIOD)
    return t, load, y


def _rows(model, theta, f, d, kmax, scale, offset, n_samples):
    fk = np.empty(kmax + 1, np.complex128)
    dk = np.empty(kmax + 1, np.complex128)
    card_spectrum(f, d, kmax, fk, dk)
    free = np.arange(len(theta), dtype=np.int64)
    rows = np.empty((len(theta) + 3, 1 + 2 * kmax))
    ok = harmonic_rows(np.log(theta), free, model.code(), model.n_states(),
                       model.output_index("u"), PERIOD, n_samples, scale, True, offset,
                       True, fk, dk, rows)
    assert ok
    return rows


def test_the_spectrum_is_numpys_fft() -> None:
    _t, f, y = _card(37)
    fk = np.empty(9, np.complex128)
    dk = np.empty(9, np.complex128)
    card_spectrum(f, y, 8, fk, dk)
    np.testing.assert_allclose(fk, np.fft.rfft(f)[:9], rtol=0, atol=1e-12 * np.abs(f).sum())
    np.testing.assert_allclose(dk, np.fft.rfft(y)[:9], rtol=0, atol=1e-12 * np.abs(y).sum())


def test_every_harmonic_gives_the_exact_cost() -> None:
    # Parseval: on an odd number of samples every harmonic up to (N - 1) / 2 is kept, and
    # the harmonic cost is the time-domain cost but for the hold's aliases (tiny where a
    # card's model has rolled off).
    n = 201
    _t, f, y = _card(n)
    rng = np.random.default_rng(0)
    d = 1.1 * y + 3.0 + 0.02 * np.ptp(y) * rng.standard_normal(n)
    off_theta = TRUTH.values * np.array([1.3, 0.8, 1.1, 0.9])
    scale, offset = 1.05, 2.5
    y_off = simulate(Kelvin(*off_theta), _t, f, initial_state="periodic", period=PERIOD)
    exact = 0.5 * np.sum((scale * y_off + offset - d) ** 2)
    assert harmonic_width(10**6, n) == n
    rows = _rows(Kelvin, off_theta, f, d, (n - 1) // 2, scale, offset, n)
    assert 0.5 * np.sum(rows[-1] ** 2) == pytest.approx(exact, rel=1e-5)
    # The first 24 harmonics carry nearly all of it.
    cut = _rows(Kelvin, off_theta, f, d, 24, scale, offset, n)
    assert 0.5 * np.sum(cut[-1] ** 2) == pytest.approx(exact, rel=0.05)


@pytest.mark.parametrize("model", [Kelvin, Maxwell, MassSpringDamper, FirstOrder])
def test_the_jacobian_is_the_residuals_derivative(model) -> None:
    # Three states, and fewer (the transfer function's polynomials padded to 3 x 3).
    n = 160
    _t, f, y = _card(n)
    theta = {Kelvin: TRUTH.values.copy(), Maxwell: np.array([120.0, 2.0, 60.0, 90.0]),
             MassSpringDamper: np.array([2.0, 30.0, 120.0]),
             FirstOrder: np.array([2.0, 0.5])[: len(FirstOrder.param_names())]}[model]
    p = theta.size
    z = np.r_[np.log(theta), math.log(1.2), 0.7]
    kmax = 12

    def rows_at(zz):
        return _rows(model, np.exp(zz[:p]), f, y, kmax, math.exp(zz[p]), zz[p + 1], n)

    base = rows_at(z)
    for j in range(z.size):
        step = np.zeros(z.size)
        step[j] = 1e-6
        numeric = (rows_at(z + step)[-1] - rows_at(z - step)[-1]) / 2e-6
        scale = np.max(np.abs(base[j])) + 1e-300
        assert np.max(np.abs(numeric - base[j])) <= 1e-6 * scale, j


def _problem(n: int = 200, offset: float = 5.0):
    t, load, y = _card(n)
    return build_problem(Kelvin, [CardData(t, load, y + offset, "periodic", PERIOD)],
                         offset=True)


def test_the_harmonic_polish_finds_the_parameters() -> None:
    problem = _problem()
    start = np.r_[np.log(TRUTH.values) + np.array([0.4, -0.3, 0.5, -0.2]), 4.0]
    exact = LevenbergMarquardt(tol=1e-10).solve(problem, np.array([0]), start[None])
    cheap = LevenbergMarquardt(tol=1e-10, harmonics=24).solve(problem, np.array([0]),
                                                              start[None])
    assert cheap.converged[0] and exact.converged[0]
    # The cut cost's optimum is the exact one's but for the hold's aliases and the cut.
    np.testing.assert_allclose(np.exp(cheap.z[0, :4]), TRUTH.values, rtol=1e-3)
    np.testing.assert_allclose(cheap.z[0], exact.z[0], rtol=1e-3, atol=1e-3)
    # Its cost is the harmonic one: on noiseless data both are near zero.
    assert cheap.cost[0] < 1e-6 * np.ptp(problem.data) ** 2


def test_cards_it_does_not_apply_to_are_fitted_exactly() -> None:
    # From rest (not one period): the harmonic request changes nothing.
    t, load, y = _card(150)
    problem = build_problem(Kelvin, [CardData(t, load, y + 2.0, "rest")], offset=True)
    start = np.r_[np.log(TRUTH.values) + 0.2, 1.0][None]
    plain = LevenbergMarquardt().solve(problem, np.array([0]), start)
    asked = LevenbergMarquardt(harmonics=24).solve(problem, np.array([0]), start)
    np.testing.assert_array_equal(plain.z, asked.z)
    np.testing.assert_array_equal(plain.cost, asked.cost)


def test_bad_requests_are_refused() -> None:
    with pytest.raises(ValueError, match="harmonics"):
        LevenbergMarquardt(harmonics=-1)
    with pytest.raises(ValueError, match="harmonics"):
        LevenbergMarquardt(harmonics=2.5)  # type: ignore[arg-type]


def test_the_history_records_the_harmonic_path() -> None:
    problem = _problem()
    start = np.r_[np.log(TRUTH.values) + 0.3, 4.0][None]
    out = LevenbergMarquardt(harmonics=12).solve(problem, np.array([0]), start, history=True)
    # The same solve as without the history, on the harmonic cost.
    plain = LevenbergMarquardt(harmonics=12).solve(problem, np.array([0]), start)
    exact = LevenbergMarquardt().solve(problem, np.array([0]), start)
    np.testing.assert_array_equal(out.z, plain.z)
    assert out.cost[0] == plain.cost[0] != exact.cost[0]
    assert out.history.shape[0] == out.accepted[0] + 1 >= 3
    assert out.history[-1, -1] == out.cost[0]
    np.testing.assert_array_equal(out.history[-1, :-1], out.z[0])


def test_which_cards_the_harmonic_cost_applies_to() -> None:
    t, load, y = _card(120)
    periodic = CardData(t, load, y, "periodic", PERIOD)
    inferred = CardData(t, load, y, "periodic")
    longer = CardData(t, load, y, "periodic", PERIOD * 1.01)
    rest = CardData(t, load, y, "rest")
    problem = build_problem(Kelvin, [periodic, inferred, longer, rest], offset=True)
    assert [problem.harmonic(k) for k in range(4)] == [True, True, False, False]
    logs = build_problem(Kelvin, [CardData(t, load, y + 10.0, "periodic", PERIOD)],
                         residual="log")
    assert not logs.harmonic(0)


@pytest.mark.parametrize("model", [TRUTH, Maxwell(k0=80.0, m=3.0, c1=40.0, k1=50.0),
                                   MassSpringDamper(m=2.0, c=5.0, k=70.0)])
def test_the_residual_alone_is_the_rows_last_row_to_the_bit(model) -> None:
    # A trial point is costed by the residual alone and the step decided on that cost, so
    # it must be the one the rows give, or the solver's path would change.
    _t, f, y = _card(150)
    n_samples = f.size
    kmax = (harmonic_width(24, n_samples) - 1) // 2
    fk = np.empty(kmax + 1, np.complex128)
    dk = np.empty(kmax + 1, np.complex128)
    card_spectrum(f, y, kmax, fk, dk)
    theta = np.array(list(model.as_dict().values())) * 1.3
    free = np.arange(theta.size, dtype=np.int64)
    rows = np.empty((theta.size + 3, 1 + 2 * kmax))
    args = (np.log(theta), free, model.code(), model.n_states(), model.output_index("u"),
            PERIOD, n_samples)
    assert harmonic_rows(*args, 0.8, True, 2.5, True, fk, dk, rows)
    out = np.empty(1 + 2 * kmax)
    assert harmonic_residual(*args, 0.8, 2.5, fk, dk, out)
    assert np.array_equal(out, rows[-1])
