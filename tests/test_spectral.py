"""The frequency-domain building blocks against plain linear algebra and the state scan."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid.models import Kelvin, MassSpringDamper, Maxwell
from pumpid.simulate import make_grid, observed, propagate
from pumpid.spectral import (
    charpoly_adjugate,
    decayed_response,
    has_decayed,
    numerators,
    response,
    short_length,
)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_charpoly_and_adjugate_are_exact_algebra(n) -> None:
    rng = np.random.default_rng(n)
    psi = rng.standard_normal((5, n, n))
    den, adj = charpoly_adjugate(psi)
    for w in (0.0, 0.3 + 0.7j, -2.0 + 0.1j):
        m = w * np.eye(n) - psi
        powers = w ** np.arange(n + 1)
        det = den @ powers
        np.testing.assert_allclose(det, np.linalg.det(m), rtol=1e-12, atol=1e-12)
        adj_w = np.einsum("bjxy,j->bxy", adj, powers[:n])
        # adj(M) M = det(M) I
        np.testing.assert_allclose(adj_w @ m, det[:, None, None] * np.eye(n), atol=1e-11)


def test_numerators_give_the_resolvent_and_its_derivative() -> None:
    rng = np.random.default_rng(3)
    n, p = 3, 2
    psi = rng.standard_normal((n, n)) * 0.2
    dphi = rng.standard_normal((p, n, n))
    q = rng.standard_normal((1, n * (p + 1)))
    den, adj = charpoly_adjugate(psi)
    num = numerators(den, adj, dphi, q, np.array([0, 2]))  # (T, P+1, r, 2n)
    w = 0.4 - 0.3j
    resolvent = np.linalg.inv(w * np.eye(n) - psi)
    d2 = (den @ w ** np.arange(n + 1)) ** 2
    value = num[0] @ w ** np.arange(2 * n) / d2  # (P+1, r)
    q0 = q[0, :n]
    np.testing.assert_allclose(value[0], (resolvent @ q0)[[0, 2]], rtol=1e-12)
    for i in range(p):
        qi = q[0, n * (i + 1):n * (i + 2)]
        expected = resolvent @ dphi[i] @ resolvent @ q0 + resolvent @ qi
        np.testing.assert_allclose(value[1 + i], expected[[0, 2]], rtol=1e-12)


def test_non_periodic_response_needs_its_start() -> None:
    phi = np.eye(2) * 0.9
    with pytest.raises(ValueError, match="v and phi_n"):
        response(phi, np.ones(2), np.ones(2), np.ones(16), 2, np.array([0]), periodic=False)


@pytest.mark.parametrize("state", ["rest", "periodic", "equilibrium"])
def test_lightly_damped_system_keeps_its_precision(state) -> None:
    # Damping ratio 0.003: the resonance sits within a few bins of the DFT grid.
    model = MassSpringDamper(m=1.0, c=0.06, k=100.0)
    t = np.linspace(0.0, 30.0, 3001)[:-1]
    load = 1.0 + np.sin(2 * np.pi * t / 30.0) + 0.3 * np.sin(2 * np.pi * 50 * t / 30.0)
    grid = make_grid(t)
    rows = list(range(2 * 4))
    fast = observed(MassSpringDamper, model.values, grid, load, rows, initial_state=state)
    scan = propagate(MassSpringDamper, model.values, grid, load, initial_state=state)
    scale = np.max(np.abs(scan), axis=0)
    assert np.max(np.abs(fast - scan) / scale) < 1e-10


def test_batched_parameters_and_loads_broadcast() -> None:
    t = np.linspace(0.0, 10.0, 401)
    grid = make_grid(t)
    theta = np.array([[4.0, 1.0, 0.2, 4.0], [8.0, 1.5, 0.5, 3.0]])
    loads = np.stack([np.sin(t), np.cos(0.5 * t)])
    rows = [2, 5, 8]
    both = observed(Kelvin, theta, grid, loads, rows)
    assert both.shape == (2, 401, 3)
    for i in range(2):
        one = observed(Kelvin, theta[i], grid, loads[i], rows)
        np.testing.assert_allclose(both[i], one, rtol=0, atol=1e-13 * np.abs(one).max())
    shared = observed(Kelvin, theta, grid, loads[0], rows)  # one load, two parameter sets
    np.testing.assert_allclose(shared[1], observed(Kelvin, theta[1], grid, loads[0], rows),
                               rtol=0, atol=1e-13 * np.abs(shared).max())


@pytest.mark.parametrize("state", ["rest", "equilibrium", "periodic"])
def test_every_parameter_set_against_every_load(state) -> None:
    # (1, S, p) parameter sets against (b, 1, N) loads: the start grid's shape scoring.
    t = np.linspace(0.0, 10.0, 201)
    grid = make_grid(t)
    theta = np.array([[4.0, 1.0, 0.2, 4.0], [8.0, 1.5, 0.5, 3.0]])
    loads = np.stack([1.0 + np.sin(t), 2.0 + np.cos(0.5 * t), 0.5 * t])
    grid_out = observed(Kelvin, theta[None], grid, loads[:, None, :], [2],
                        initial_state=state, sensitivities=False)
    assert grid_out.shape == (3, 2, 201, 1)
    for i in range(3):
        for j in range(2):
            one = observed(Kelvin, theta[j], grid, loads[i], [2], initial_state=state,
                           sensitivities=False)
            np.testing.assert_allclose(grid_out[i, j], one, rtol=0,
                                       atol=1e-13 * np.abs(one).max())


@pytest.mark.parametrize("state", ["rest", "periodic"])
def test_the_whole_search_window_is_simulated_to_full_precision(state) -> None:
    # Inside a factor 1000 of the natural scales the frequency-domain route is used and must
    # agree with the scan; beyond (the window reaches a factor 1e6, boundary probes further)
    # the problem sends the parameters to the scan, whatever their conditioning.
    from pumpid.problem import SPECTRAL_RANGE, build_problem

    t = np.linspace(0.0, 7.5, 401)[:-1]
    load = 1000.0 + 500.0 * np.sin(2 * np.pi * t / 7.5) + 100.0 * np.sin(6 * np.pi * t / 7.5)
    problem = build_problem(Kelvin, t, load, np.cos(2 * np.pi * t / 7.5) * 20.0,
                            initial_state=state)
    ref = problem.reference_scales()
    grid = make_grid(t)
    for i in range(4):
        for factor in (1e-9, 1e-6, 1e-2, 1e2, 1e6, 1e9):
            theta = ref.copy()
            theta[i] *= factor
            far = bool(problem.far_from_scale(theta))
            assert far == (abs(np.log(factor)) > SPECTRAL_RANGE)
            y, dy = problem.output_and_sensitivities(theta)
            x = propagate(Kelvin, theta, grid, load, initial_state=state)
            y_ref, dy_ref = x[:, 2], x[:, [5, 8, 11, 14]]
            # Relative to the output and to the Jacobian in log-parameters (what the solver
            # sees), as a fraction of their largest entries. At the edge of the range (a
            # factor 1000) the frequency-domain route was measured at 2e-11 and 1e-9.
            assert np.max(np.abs(y - y_ref)) <= 1e-10 * np.max(np.abs(y_ref))
            log_jac = np.abs((dy - dy_ref) * theta)
            assert np.max(log_jac) <= 1e-8 * np.max(np.abs(dy_ref * theta))
            # The outputs alone (the boundary probes' and the start's route), in a batch with
            # a parameter set near the scales, against the scan of the plain system.
            both = problem.outputs(np.stack([ref, theta]))
            plain = propagate(Kelvin, theta, grid, load, initial_state=state,
                              sensitivities=False)[:, 2]
            np.testing.assert_allclose(both[1], plain, rtol=0,
                                       atol=1e-10 * np.max(np.abs(plain)))


def _response_both_routes(model_cls, theta, t, load, x0=None):
    """The response from ``x0`` (default rest) by both non-periodic routes, and |Phi^L|."""
    from pumpid.simulate import _augment, _discretize_and_power

    grid = make_grid(t)
    n = model_cls.n_states()
    a, b, da, db = model_cls.system_batch(theta)
    a, b = _augment(a, b, da, db)
    phi, g0, g1, phi_n = _discretize_and_power(a, b, grid.dt, "exact", grid.n)
    phi_l = _discretize_and_power(a, b, grid.dt, "exact", short_length(grid.n))[3]
    f = np.asarray(load, dtype=float)
    v = np.zeros(b.shape)
    if x0 is not None:
        v[..., :n] = x0
    v = v - g1 * f[..., 0:1]
    states = np.arange(n)
    short = decayed_response(phi, g0, g1, f, n, states, v, phi_l)
    wide = response(phi, g0, g1, f, n, states, periodic=False, v=v, phi_n=phi_n)
    return short, wide, has_decayed(phi_l, n)


@pytest.mark.parametrize("n_samples", [2001, 2048, 401])
@pytest.mark.parametrize(("model_cls", "theta"), [
    (Kelvin, [9000.0, 45.0, 900.0, 5200.0]),
    (Maxwell, [3000.0, 40.0, 300.0, 3000.0]),
    (MassSpringDamper, [40.0, 300.0, 9000.0]),
])
def test_a_decayed_start_is_computed_on_the_short_grid(model_cls, theta, n_samples) -> None:
    # Both non-periodic routes against the scan, from rest and from a given state; the
    # parameter sets decay within the record, so the N-sample route is the one taken.
    t = np.linspace(0.0, 7.5, n_samples)
    load = 5500.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5) + 300.0 * np.sin(6 * np.pi * t / 7.5)
    theta = np.array(theta)
    n = model_cls.n_states()
    for x0 in (None, np.linspace(0.5, 2.0, n)):
        decayed, wide, taken = _response_both_routes(model_cls, theta, t, load, x0)
        assert taken
        scan = propagate(model_cls, theta, make_grid(t), load,
                         initial_state="rest" if x0 is None else x0)  # (N, size)
        ref = np.moveaxis(scan.reshape(n_samples, -1, n), 0, -1)  # (blocks, n, N)
        scale = np.max(np.abs(ref), axis=-1, keepdims=True)
        assert np.max(np.abs(decayed - ref) / scale) < 1e-11
        assert np.max(np.abs(decayed - wide) / scale) < 1e-11


def test_an_undecayed_start_keeps_the_long_grid(monkeypatch) -> None:
    # A lightly damped record whose free response is still large at its end: the N-sample
    # route would amplify rounding, so the long grid is used (and is exact).
    from pumpid import spectral

    calls = []
    real = spectral.decayed_response
    monkeypatch.setattr(spectral, "decayed_response",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    t = np.linspace(0.0, 3.0, 601)
    load = 1.0 + np.sin(2 * np.pi * t / 3.0)
    model = MassSpringDamper(m=1.0, c=0.05, k=100.0)
    y = observed(MassSpringDamper, model.values, make_grid(t), load, [0, 2, 4, 6])
    assert not calls
    scan = propagate(MassSpringDamper, model.values, make_grid(t), load)[:, [0, 2, 4, 6]]
    assert np.max(np.abs(y - scan) / np.max(np.abs(scan), axis=0)) < 1e-11
    heavy = MassSpringDamper(m=1.0, c=20.0, k=100.0)
    observed(MassSpringDamper, heavy.values, make_grid(t), load, [0, 2, 4, 6])
    assert calls


def test_decayed_batches_broadcast_like_single_sets() -> None:
    t = np.linspace(0.0, 7.5, 500)
    loads = np.stack([5500.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5), 3000.0 + 100.0 * t])
    theta = np.array([[9000.0, 45.0, 900.0, 5200.0], [7000.0, 30.0, 700.0, 4000.0]])
    grid = make_grid(t)
    rows = [2, 5, 8, 11, 14]
    for state in ("rest", "equilibrium"):
        both = observed(Kelvin, theta, grid, loads, rows, initial_state=state)
        for i in range(2):
            one = propagate(Kelvin, theta[i], grid, loads[i], initial_state=state)[:, rows]
            scale = np.max(np.abs(one), axis=0)
            assert np.max(np.abs(both[i] - one) / scale) < 1e-11
    # One parameter set against many loads, and every set against every load (the start
    # grid's shapes), on the decayed route.
    for state in ("rest", (1e-3, 0.0, 2e-3)):
        kw = {"initial_state": state}
        many = observed(Kelvin, theta[0], grid, loads, rows, **kw)
        grid_out = observed(Kelvin, theta[None], grid, loads[:, None, :], rows, **kw)
        assert many.shape == (2, 500, 5) and grid_out.shape == (2, 2, 500, 5)
        for i in range(2):
            for j in range(2):
                one = propagate(Kelvin, theta[j], grid, loads[i], **kw)[:, rows]
                scale = np.max(np.abs(one), axis=0)
                assert np.max(np.abs(grid_out[i, j] - one) / scale) < 1e-11
                if j == 0:
                    assert np.max(np.abs(many[i] - one) / scale) < 1e-11
    assert observed(Kelvin, np.empty((0, 4)), grid, loads[0], rows).shape == (0, 500, 5)
