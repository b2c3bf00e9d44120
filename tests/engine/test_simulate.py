"""Simulation: exact FOH vs the closed-form modal response, sensitivities, Euler, states."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid import FirstOrder, Kelvin, MassSpringDamper, Maxwell, simulate, simulate_sensitivities

from ..conftest import well_load
from ..exact import modal_response

MODELS = [FirstOrder(tau=1.3), MassSpringDamper(m=2.0, c=1.1, k=30.0),
          Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0), Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0)]
T = np.linspace(0.0, 15.0, 1501)
LOAD = well_load(T, period=40.0) / 100.0  # smooth: no stroke wrap inside the record


def _reference(model, t, load, x0):
    """Closed-form response of x' = A x + B F with F linear between samples."""
    a, b = model.matrices()
    return modal_response(a, b, t, load, x0)


#: pumpid's exact discretization agrees with the closed form to about 1e-14 of the signal
#: (rounding); the bound leaves a margin of about 100 without hiding a real error.
EXACT_TOL = 1e-12


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_exact_matches_the_closed_form_response(model) -> None:
    ref = _reference(model, T, LOAD, np.zeros(model.n_states()))
    for name in model.outputs:
        y = simulate(model, T, LOAD, observe=name)
        k = model.states.index(name)
        assert np.max(np.abs(y - ref[:, k])) <= EXACT_TOL * np.max(np.abs(ref[:, k]))


def test_closed_form_reference_is_the_first_order_solution() -> None:
    # The reference itself, checked against u = tau f0 (1 - exp(-t/tau)) + tau s (t - tau
    # (1 - exp(-t/tau))) for f = f0 + s t from rest.
    tau, f0, slope = 1.3, 2.0, 0.7
    t = np.linspace(0.0, 6.0, 61)
    u = modal_response([[-1 / tau]], [1.0], t, f0 + slope * t, [0.0])[:, 0]
    decay = 1.0 - np.exp(-t / tau)
    exact = tau * f0 * decay + tau * slope * (t - tau * decay)
    np.testing.assert_allclose(u, exact, rtol=1e-13, atol=1e-15)


def test_non_uniform_time_is_handled_exactly() -> None:
    rng = np.random.default_rng(3)
    t = np.sort(np.concatenate([[0.0, 15.0], rng.uniform(0, 15, 900)]))
    load = np.interp(t, T, LOAD)
    model = MODELS[2]
    assert np.ptp(np.diff(t)) > 1e-3  # clearly non-uniform
    ref = _reference(model, t, load, np.zeros(3))
    y = simulate(model, t, load, observe="u")
    assert np.max(np.abs(y - ref[:, 0])) <= EXACT_TOL * np.max(np.abs(ref[:, 0]))


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("state", ["rest", "equilibrium", "periodic"])
def test_sensitivities_match_central_differences(model, state) -> None:
    y, dy = simulate_sensitivities(model, T, LOAD, initial_state=state)
    np.testing.assert_allclose(y, simulate(model, T, LOAD, initial_state=state), rtol=1e-12,
                               atol=1e-14)
    for i, name in enumerate(model.param_names()):
        v = getattr(model, name)
        h = 1e-5 * v
        yp = simulate(model.replace(**{name: v + h}), T, LOAD, initial_state=state)
        ym = simulate(model.replace(**{name: v - h}), T, LOAD, initial_state=state)
        fd = (yp - ym) / (2 * h)
        assert np.max(np.abs(dy[:, i] - fd)) <= 1e-6 * np.max(np.abs(fd)) + 1e-12


def test_euler_sensitivities_are_exact_for_the_euler_recursion() -> None:
    model = MODELS[3]
    _y, dy = simulate_sensitivities(model, T, LOAD, integrator="euler")
    h = 1e-6 * model.k1
    yp = simulate(model.replace(k1=model.k1 + h), T, LOAD, integrator="euler")
    ym = simulate(model.replace(k1=model.k1 - h), T, LOAD, integrator="euler")
    fd = (yp - ym) / (2 * h)
    np.testing.assert_allclose(dy[:, 3], fd, rtol=1e-5, atol=1e-9 * np.max(np.abs(fd)))


def test_euler_is_the_paper_recursion() -> None:
    model = Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0)
    t = np.arange(300) * 0.01
    load = 10 + np.sin(t)
    a, b = model.matrices()
    x = np.zeros(3)
    expected = [x[2]]
    for n in range(t.size - 1):
        x = x + 0.01 * (a @ x + b * load[n])
        expected.append(x[2])
    np.testing.assert_allclose(simulate(model, t, load, observe="u2", integrator="euler"), expected,
                               rtol=1e-12, atol=1e-13 * np.max(np.abs(expected)))


def test_dead_weight_responses_settle_as_in_model_notes() -> None:
    # Paper Figs. 4-5: k0 = 4, m = 1, c1 = 0.2, k1 = 4, dead weight W0 = 10 from rest.
    t = np.linspace(0.0, 2000.0, 20001)
    w0 = np.full_like(t, 10.0)
    kel = Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0)
    mx = Maxwell(k0=4.0, m=1.0, c1=0.2, k1=4.0)
    assert simulate(kel, t, w0, observe="u2")[-1] == pytest.approx(2.5, rel=1e-6)
    assert simulate(kel, t, w0, observe="u")[-1] == pytest.approx(5.0, rel=1e-6)
    assert simulate(mx, t, w0)[-1] == pytest.approx(2.5, rel=1e-6)


def test_equilibrium_start_stays_put_under_constant_load() -> None:
    model = MODELS[2]
    y = simulate(model, T, np.full_like(T, 7.0), initial_state="equilibrium", observe="u")
    np.testing.assert_allclose(y, 7.0 * model.static_gain("u"), rtol=1e-10)


@pytest.mark.parametrize("integrator", ["exact", "euler"])
def test_periodic_state_matches_a_long_run(integrator) -> None:
    model = Kelvin(k0=4.0, m=1.0, c1=2.0, k1=4.0)
    dt, n = 0.02, 400
    t = np.arange(n) * dt
    long_t = np.arange(100 * n) * dt
    force = lambda s: 10 + 3 * np.sin(2 * np.pi * s / (n * dt))  # noqa: E731
    periodic = simulate(model, t, force(t), initial_state="periodic", all_states=True,
                        integrator=integrator)
    long = simulate(model, long_t, force(long_t), all_states=True, integrator=integrator)
    np.testing.assert_allclose(periodic, long[-n:], atol=1e-10)


def test_given_initial_state_and_scale() -> None:
    model = FirstOrder(tau=2.0)
    t = np.linspace(0, 5, 51)
    y = simulate(model, t, np.zeros_like(t), initial_state=[3.0], scale=2.0)
    np.testing.assert_allclose(y, 6.0 * np.exp(-t / 2.0), rtol=1e-12)
    y2 = simulate(model, t, np.zeros_like(t), initial_state={"u": 3.0})
    np.testing.assert_allclose(y2, 3.0 * np.exp(-t / 2.0), rtol=1e-12)


@pytest.mark.parametrize(
    ("t", "load", "message"),
    [
        ([0, 1, 2], [1, 2], "does not match"),
        ([0, 1, 1], [1, 2, 3], "strictly increasing"),
        ([0, np.nan, 2], [1, 2, 3], "NaN"),
        ([0, 1, 2], [1, np.inf, 3], "inf"),
        ([0], [1], "at least 2"),
    ],
)
def test_bad_input_names_the_problem(t, load, message) -> None:
    with pytest.raises(ValueError, match=message):
        simulate(MODELS[0], t, load)


def test_unknown_options_are_rejected() -> None:
    with pytest.raises(ValueError, match="integrator"):
        simulate(MODELS[0], T, LOAD, integrator="rk4")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown mode"):
        simulate(MODELS[0], T, LOAD, initial_state="steady")
    with pytest.raises(ValueError, match="has 3 states"):
        simulate(MODELS[2], T, LOAD, initial_state=[1.0])
    with pytest.raises(TypeError, match="model instance"):
        simulate(Kelvin, T, LOAD)  # type: ignore[arg-type]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("state", ["rest", "equilibrium", "periodic", "given"])
def test_euler_matches_the_explicit_recursion(model, state) -> None:
    """The Euler integrator is x[k+1] = x[k] + dt (A x[k] + B F[k]) from every start."""
    a, b = model.matrices()
    dt = T[1] - T[0]
    n = model.n_states()
    if state == "given":
        x = np.full(n, 0.3)
        init = [0.3] * n
    elif state == "equilibrium":
        x = -np.linalg.solve(a, b * LOAD[0])
        init = state
    elif state == "rest":
        x = np.zeros(n)
        init = state
    else:
        # Periodic: Phi_T x0 + response from rest over one period = x0 (closing step dt).
        phi = np.eye(n) + dt * a
        x_rest = np.zeros(n)
        for k in range(T.size):
            x_rest = phi @ x_rest + dt * b * LOAD[k]
        x = np.linalg.solve(np.eye(n) - np.linalg.matrix_power(phi, T.size), x_rest)
        init = state
    states = [x]
    for k in range(T.size - 1):
        x = x + dt * (a @ x + b * LOAD[k])
        states.append(x)
    expected = np.array(states)
    got = simulate(model, T, LOAD, initial_state=init, integrator="euler", all_states=True)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_non_finite_euler_parameters_give_non_finite_output_not_an_error() -> None:
    t = np.linspace(0.0, 7.5, 200)
    load = 5500.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5)
    with np.errstate(all="ignore"):
        y = simulate(Kelvin(k0=1e200, m=1e-200, c1=900.0, k1=5200.0), t, load,
                     integrator="euler")
    assert y.shape == t.shape and not np.all(np.isfinite(y))


@pytest.mark.parametrize("factor", [1e-9, 1e-3, 1e3, 1e9])
@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_exact_for_parameters_far_from_unit_scale(model, factor) -> None:
    # Every parameter times the same factor (the response scales by 1/factor for the
    # mechanical models), and an input gain far from one: the exact integrator keeps full
    # relative precision, where a plain matrix exponential of the augmented system would
    # need dozens of squarings.
    scaled = type(model).from_values(model.values * factor)
    ref = _reference(scaled, T, LOAD, np.zeros(model.n_states()))
    k = model.output_index(None)
    y = simulate(scaled, T, LOAD)
    assert np.max(np.abs(y - ref[:, k])) <= EXACT_TOL * np.max(np.abs(ref[:, k]))


@pytest.mark.parametrize("gain", [1e-12, 1e12])
def test_exact_for_an_input_gain_far_from_one(gain) -> None:
    from pumpid.flow.surrogates import FirstOrderLag

    lag = FirstOrderLag(tau=0.2, gain=gain)
    t = np.linspace(0.0, 3.0, 301)
    u = 1e-5 * np.clip(t - 0.1, 0.0, 1.0)
    a, b = lag.matrices()
    ref = modal_response(a, b, t, u, [0.0])[:, 0]
    assert np.max(np.abs(simulate(lag, t, u) - ref)) <= EXACT_TOL * np.max(np.abs(ref))
