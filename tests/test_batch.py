"""fit_many(): same answers as the single fit, chunking, the fast simulation path, bad input.

This is the smoke version of benchmarks/bench_fit.py: it checks the fast paths' answers, never
their time.
"""

from __future__ import annotations

import numpy as np
import pytest

from pumpid import Kelvin, Maxwell, fit, simulate
from pumpid.batch import BatchResult, _Engine, fit_many
from pumpid.simulate import make_grid, propagate

PERIOD = 7.5
T = np.linspace(0.0, PERIOD, 300, endpoint=False)
BASE = np.array([8000.0, 40.0, 900.0, 5000.0])
STARTS = np.array([1.3, 1 / 1.3, 1.3, 1 / 1.3])


def card_load(seed: int) -> np.ndarray:
    """A pumping-card-like load: fluid load picked up and released, plus a ripple."""
    rng = np.random.default_rng(seed)
    phase = T / PERIOD
    on = 0.5 * (1 + np.tanh((phase - 0.08 - 0.05 * rng.random()) / 0.03))
    off = 0.5 * (1 + np.tanh((phase - 0.55 - 0.05 * rng.random()) / 0.04))
    ripple = 300 * np.sin(2 * np.pi * 3 * phase + rng.random())
    return 5000 + 4000 * on * (1 - off) + ripple + 500 * np.sin(2 * np.pi * phase)


def make_cards(cls, n_cards, initial_state="rest", offset=0.0, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    theta = BASE * np.exp(0.25 * rng.standard_normal((n_cards, BASE.size)))
    loads = np.array([card_load(seed * 1000 + i) for i in range(n_cards)])
    disp = np.array([simulate(cls.from_values(th), T, f, initial_state=initial_state)
                     for th, f in zip(theta, loads, strict=True)]) + offset
    disp += noise * np.ptp(disp, axis=1, keepdims=True) * rng.standard_normal(disp.shape)
    return theta, loads, disp


CASES = [(Kelvin, "rest", False), (Maxwell, "rest", False), (Kelvin, "periodic", True)]


@pytest.mark.parametrize(("cls", "state", "offset"), CASES)
def test_noiseless_cards_match_the_single_fit(cls, state, offset) -> None:
    theta, loads, disp = make_cards(cls, 6, state, offset=0.02 if offset else 0.0, seed=1)
    x0 = theta * STARTS
    res = fit_many(cls, T, loads, disp, initial_state=state, offset=offset, x0=x0)
    assert isinstance(res, BatchResult) and len(res) == 6
    assert res.status.tolist() == ["converged"] * 6, res.summary()
    for i in range(6):
        ref = fit(cls.from_values(x0[i]), T, loads[i], disp[i], initial_state=state,
                  offset=offset)
        assert ref.converged, ref.reason
        np.testing.assert_allclose(res.theta[i], ref.model.values, rtol=1e-9)
        np.testing.assert_allclose(res.theta[i], theta[i], rtol=1e-9)
        if offset:
            assert res.offset[i] == pytest.approx(ref.offset, rel=1e-9)
    assert np.all(res.r2 > 1 - 1e-12)


@pytest.mark.parametrize(("cls", "state", "offset"), CASES[:2])
def test_noisy_cards_reach_the_single_fits_optimum(cls, state, offset) -> None:
    theta, loads, disp = make_cards(cls, 6, state, noise=0.01, seed=2)
    x0 = theta * STARTS
    res = fit_many(cls, T, loads, disp, initial_state=state, offset=offset, x0=x0, tol=1e-12)
    assert res.converged.all(), res.summary()
    for i in range(6):
        ref = fit(cls.from_values(x0[i]), T, loads[i], disp[i], initial_state=state,
                  offset=offset)
        assert ref.converged, ref.reason
        # Same optimum: equal cost to rounding, parameters as far as the valley's flatness
        # allows both solvers to pin them.
        assert res.cost[i] == pytest.approx(ref.cost, rel=1e-10)
        np.testing.assert_allclose(res.theta[i], ref.model.values, rtol=1e-7)
        assert res.rmse[i] == pytest.approx(ref.rmse, rel=1e-9)
        assert res.r2[i] == pytest.approx(ref.r2, rel=1e-9)


def test_chunking_and_threads_do_not_change_answers() -> None:
    theta, loads, disp = make_cards(Kelvin, 7, noise=0.005, seed=3)
    x0 = theta * STARTS
    one = fit_many(Kelvin, T, loads, disp, x0=x0)
    for options in ({"chunk": 3}, {"chunk": 1}, {"chunk": 2, "workers": 2}):
        other = fit_many(Kelvin, T, loads, disp, x0=x0, **options)
        np.testing.assert_allclose(other.theta, one.theta, rtol=1e-12)
        assert other.status.tolist() == one.status.tolist()
        np.testing.assert_array_equal(other.iterations, one.iterations)


def test_chunks_large_enough_for_the_gram_route_give_the_same_answers() -> None:
    # Chunks of 8 or more cards factor well-conditioned Jacobians through the Gram matrix,
    # smaller ones through QR: the answers agree to rounding whatever the chunking.
    theta, loads, disp = make_cards(Kelvin, 12, noise=0.005, seed=8)
    x0 = theta * STARTS
    big = fit_many(Kelvin, T, loads, disp, x0=x0, chunk=12)
    for chunk in (8, 5, 1):
        other = fit_many(Kelvin, T, loads, disp, x0=x0, chunk=chunk)
        assert other.status.tolist() == big.status.tolist()
        np.testing.assert_allclose(other.theta, big.theta, rtol=1e-9)


def test_automatic_start_per_card() -> None:
    theta, loads, disp = make_cards(Kelvin, 6, seed=4)
    res = fit_many(Kelvin, T, loads, disp)
    assert res.converged.all(), res.summary()
    np.testing.assert_allclose(res.theta, theta, rtol=1e-8)
    shared = fit_many(Kelvin.from_values(BASE), T, loads, disp)
    np.testing.assert_allclose(shared.start, np.broadcast_to(BASE, (6, 4)))


def test_free_scale_uses_the_gauge_and_records() -> None:
    theta, loads, disp = make_cards(Kelvin, 3, seed=5)
    res = fit_many(Kelvin, T, loads, disp, scale="free", x0=theta * STARTS)
    assert res.gauge_fixed and np.all(res.scale == 1.0)
    rows = res.to_records()
    assert len(rows) == 3 and rows[0]["status"] == "converged" and "k0" in rows[0]
    assert res.result(2)["params"]["m"] == pytest.approx(theta[2, 1], rel=1e-9)
    assert "converged 3" in res.summary()


@pytest.mark.parametrize("state", ["rest", "equilibrium", "periodic", (1e-3, 0.0, 2e-3)])
@pytest.mark.parametrize("integrator", ["exact", "euler"])
def test_engine_evaluation_equals_propagate(state, integrator) -> None:
    grid = make_grid(T)
    theta, loads, _ = make_cards(Kelvin, 3, seed=6)
    for k_obs in (0, 2):
        engine = _Engine(Kelvin, grid, integrator, state, None, k_obs)
        y, dy = engine.evaluate(theta, loads)
        ref = propagate(Kelvin, theta, grid, loads, initial_state=state, integrator=integrator)
        y_ref = ref[..., k_obs]
        dy_ref = ref[..., [3 * (i + 1) + k_obs for i in range(4)]]
        np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-12 * np.abs(y_ref).max())
        np.testing.assert_allclose(np.swapaxes(dy, 1, 2), dy_ref, rtol=0,
                                   atol=1e-12 * np.abs(dy_ref).max())


def test_bad_input_is_reported_with_the_card() -> None:
    _, loads, disp = make_cards(Kelvin, 4, seed=7)
    bad = disp.copy()
    bad[2, 10] = np.nan
    with pytest.raises(ValueError, match=r"displacements: non-finite .* card\(s\) 2"):
        fit_many(Kelvin, T, loads, bad)
    with pytest.raises(ValueError, match="samples per card"):
        fit_many(Kelvin, T, loads[:, :-1], disp)
    with pytest.raises(ValueError, match="cards"):
        fit_many(Kelvin, T, loads[:3], disp)
    with pytest.raises(ValueError, match="at least 10"):
        fit_many(Kelvin, T[:5], loads[:, :5], disp[:, :5])
    flat = disp.copy()
    flat[1] = 1.0
    with pytest.raises(ValueError, match=r"constant in card\(s\) 1"):
        fit_many(Kelvin, T, loads, flat)
    with pytest.raises(ValueError, match="x0"):
        fit_many(Kelvin, T, loads, disp, x0=np.ones((3, 4)))
    with pytest.raises(ValueError, match="x0"):
        fit_many(Kelvin, T, loads, disp, x0=-np.ones(4))
    with pytest.raises(ValueError, match="cannot observe"):
        fit_many(Kelvin, T, loads, disp, observe="F0")
    with pytest.raises(ValueError, match="chunk"):
        fit_many(Kelvin, T, loads, disp, chunk=0)
    with pytest.raises(TypeError, match="model"):
        fit_many("kelvin", T, loads, disp)  # type: ignore[arg-type]


def test_a_card_that_cannot_be_simulated_fails_alone(monkeypatch) -> None:
    theta, loads, disp = make_cards(Kelvin, 5, seed=8)
    loads[3, 0] += 0.125  # the marked card
    marker = loads[3, 0]
    real = _Engine.evaluate

    def evaluate(self, theta, f, far=None):
        if np.any(f[:, 0] == marker):
            raise np.linalg.LinAlgError("Singular matrix")
        return real(self, theta, f, far)

    monkeypatch.setattr(_Engine, "evaluate", evaluate)
    res = fit_many(Kelvin, T, loads, disp, x0=theta * STARTS, chunk=5)
    assert res.status.tolist() == ["converged"] * 3 + ["failed", "converged"]
    assert np.isnan(res.theta[3]).all() and np.isnan(res.rmse[3])
    keep = [0, 1, 2, 4]
    np.testing.assert_allclose(res.theta[keep], theta[keep], rtol=1e-6)
