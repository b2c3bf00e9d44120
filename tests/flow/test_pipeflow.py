"""Validation of the transient power-law pipe-flow reference simulator (pumpid.pipeflow)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pumpid.flow.pipeflow import (
    J01,
    Pipe,
    PipeNumerics,
    PowerLawFluid,
    newtonian_slowest_time_constant,
    power_law_time_scale,
    radial_grid,
    simulate_pipe_flow,
    steady_power_law_flow_rate,
    steady_power_law_velocity,
    szymanski_flow_rate,
)

POLYMER_PIPE = Pipe(radius=5e-3, length=1.0)
RHO = 1000.0


def _t63(t: np.ndarray, q: np.ndarray, q_final: float) -> float:
    """Time at which a monotone step response first reaches 1 - 1/e of its final value."""
    x = q / q_final
    level = 1.0 - math.exp(-1.0)
    i = int(np.argmax(x >= level))
    assert i > 0, "response never reached 63 % (or started above it)"
    return float(np.interp(level, x[i - 1 : i + 1], t[i - 1 : i + 1]))


# ----------------------------------------------------------------------------------------------
# Newtonian start-up against Szymanski's exact series
# ----------------------------------------------------------------------------------------------

NEWTONIAN_CASES = [
    # (radius m, length m, rho kg/m3, mu Pa s, dp Pa): polymer-ish, then very different scales
    pytest.param(5e-3, 1.0, 1000.0, 10.0, 1e5, id="polymer-mu10"),
    pytest.param(5e-3, 1.0, 1000.0, 100.0, 1e6, id="polymer-mu100"),
    pytest.param(0.1, 20.0, 900.0, 0.5, 50.0, id="wide-pipe-oil"),
    pytest.param(50e-6, 0.01, 1000.0, 1e-3, 1e3, id="micro-water"),
]


@pytest.mark.parametrize(("radius", "length", "rho", "mu", "dp"), NEWTONIAN_CASES)
@pytest.mark.parametrize("dp_as_callable", [False, True])
def test_newtonian_startup_matches_szymanski(radius, length, rho, mu, dp, dp_as_callable):
    pipe = Pipe(radius, length)
    fluid = PowerLawFluid.newtonian(mu, rho)
    tau = newtonian_slowest_time_constant(mu, rho, pipe)
    t = np.concatenate([[0.0], np.geomspace(1e-3 * tau, 20.0 * tau, 300)])
    dp_in = (lambda _t: dp) if dp_as_callable else np.full_like(t, dp)
    res = simulate_pipe_flow(t, dp_in, fluid=fluid, pipe=pipe)
    exact = szymanski_flow_rate(t, dp, mu, rho, pipe)

    assert res.q[0] == 0.0
    late = t >= 0.01 * tau
    rel = np.abs(res.q[late] / exact[late] - 1.0)
    assert rel.max() < 1e-4, f"max relative error {rel.max():.2e}"
    # The last point is steady Poiseuille flow, which the scheme reproduces almost exactly.
    q_s = math.pi * radius**4 * dp / (8.0 * mu * length)
    assert res.q[-1] == pytest.approx(q_s, rel=1e-6)
    assert res.info["regularization"] == "none (n = 1)"


def test_newtonian_result_is_a_physical_start_up():
    pipe, mu = POLYMER_PIPE, 30.0
    tau = newtonian_slowest_time_constant(mu, RHO, pipe)
    t = np.linspace(0.0, 5 * tau, 200)
    res = simulate_pipe_flow(
        t, 2e5, fluid=PowerLawFluid(mu, 1.0, RHO), pipe=pipe, return_profile=True
    )
    assert res.w is not None and res.r is not None
    assert res.w.shape == (t.size, res.info["n_radial"])
    assert np.all(np.diff(res.q) > 0.0)  # monotone start-up
    # Q is the r-weighted integral of the returned cell means.
    faces, nodes = radial_grid(res.info["n_radial"], pipe.radius, res.info["wall_clustering"])
    np.testing.assert_allclose(res.r, nodes)
    vol = 0.5 * np.diff(faces**2)
    np.testing.assert_allclose(2.0 * math.pi * res.w @ vol, res.q, rtol=1e-12, atol=0.0)
    # Velocity is largest on the axis and vanishes toward the wall.
    assert np.all(np.diff(res.w[-1]) < 0.0)
    assert res.w[-1, -1] < 1e-2 * res.w[-1, 0]
    assert res.info["wall_time_s"] < 5.0  # a typical call is a fraction of a second


def test_szymanski_series_limits():
    pipe, mu = POLYMER_PIPE, 20.0
    dp = 3e5
    nu = mu / RHO
    R, L = pipe.radius, pipe.length
    q_s = math.pi * R**4 * dp / (8.0 * mu * L)
    tau = newtonian_slowest_time_constant(mu, RHO, pipe)
    assert tau == pytest.approx(RHO * R**2 / (mu * 2.404825557695773**2), rel=1e-14)
    assert pytest.approx(2.404825557695773, rel=1e-14) == J01

    # Zero at and before the step, steady Poiseuille flow long after it.
    q = szymanski_flow_rate(np.array([-1.0, 0.0, 60.0 * tau]), dp, mu, RHO, pipe)
    assert q[0] == 0.0 and q[1] == 0.0
    assert q[2] == pytest.approx(q_s, rel=1e-13)

    # Late times: a single exponential with the slowest time constant.
    s = np.array([0.5, 1.0, 2.0])  # nu t / R^2
    q = szymanski_flow_rate(s * R**2 / nu, dp, mu, RHO, pipe)
    slowest = 32.0 * np.exp(-(J01**2) * s) / J01**4
    np.testing.assert_allclose(1.0 - q / q_s, slowest, rtol=1e-5)

    # Early times: the core accelerates as a plug (Q = pi R^2 dp t / (rho L)) minus the
    # displacement of the Stokes wall layer, 1 - 8/(3 sqrt(pi)) sqrt(nu t)/R + O(nu t / R^2).
    s = np.array([1e-8, 1e-7, 1e-6])
    t = s * R**2 / nu
    q = szymanski_flow_rate(t, dp, mu, RHO, pipe)
    plug = math.pi * R**2 * dp * t / (RHO * L)
    layer = 1.0 - 8.0 / (3.0 * math.sqrt(math.pi)) * np.sqrt(s)
    assert np.all(np.abs(q / plug - layer) < 20.0 * s)
    assert np.all(np.abs(q / plug - 1.0) > 0.5 * (1.0 - layer))  # the layer term is resolved

    # Explicit truncation agrees with the automatic choice once the omitted terms are dead.
    t = np.linspace(0.01, 3.0, 50) * tau
    np.testing.assert_allclose(
        szymanski_flow_rate(t, dp, mu, RHO, pipe, n_terms=400),
        szymanski_flow_rate(t, dp, mu, RHO, pipe),
        rtol=1e-13,
    )
    assert np.all(np.diff(szymanski_flow_rate(t, dp, mu, RHO, pipe)) > 0.0)
    with pytest.raises(ValueError, match="n_terms"):
        szymanski_flow_rate(t, dp, mu, RHO, pipe, n_terms=0)


# ----------------------------------------------------------------------------------------------
# Power-law fluids
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [0.3, 0.5, 0.8])
def test_steady_power_law_flow_rate(n):
    fluid = PowerLawFluid(K=40.0, n=n, rho=RHO)
    dp = 2e5
    ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
    t = np.concatenate([[0.0], np.geomspace(1e-3 * ts, 40.0 * ts, 200)])
    res = simulate_pipe_flow(t, dp, fluid=fluid, pipe=POLYMER_PIPE, return_profile=True)
    q_formula = steady_power_law_flow_rate(dp, fluid, POLYMER_PIPE)
    assert res.q[-1] == pytest.approx(q_formula, rel=1e-4)  # brief asks for 1e-3
    assert np.all(np.diff(res.q) >= -1e-7 * res.q[-1])  # monotone up to the time tolerance
    # The profile itself is the power-law profile (relative to the centre-line velocity).
    w_exact = steady_power_law_velocity(res.r, dp, fluid, POLYMER_PIPE)
    np.testing.assert_allclose(res.w[-1], w_exact, rtol=0, atol=2e-4 * w_exact[0])


def test_steady_formula_reduces_to_poiseuille_and_keeps_sign():
    mu, dp = 12.0, 7e4
    fluid = PowerLawFluid(mu, 1.0, RHO)
    q_s = math.pi * POLYMER_PIPE.radius**4 * dp / (8.0 * mu * POLYMER_PIPE.length)
    assert steady_power_law_flow_rate(dp, fluid, POLYMER_PIPE) == pytest.approx(q_s, rel=1e-14)
    q = steady_power_law_flow_rate(
        np.array([-dp, 0.0, dp]), PowerLawFluid(5.0, 0.4, RHO), POLYMER_PIPE
    )
    assert q[0] == -q[2] and q[1] == 0.0 and q[2] > 0.0


def test_start_from_steady_profile_stays_steady():
    fluid = PowerLawFluid(K=40.0, n=0.5, rho=RHO)
    dp = 1e5
    ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
    t = np.linspace(0.0, 5 * ts, 50)
    res = simulate_pipe_flow(
        t,
        dp,
        fluid=fluid,
        pipe=POLYMER_PIPE,
        initial_velocity=lambda r: steady_power_law_velocity(r, dp, fluid, POLYMER_PIPE),
    )
    q_s = steady_power_law_flow_rate(dp, fluid, POLYMER_PIPE)
    np.testing.assert_allclose(res.q, q_s, rtol=5e-5)


def test_truncated_regularization_agrees_with_carreau():
    fluid = PowerLawFluid(K=40.0, n=0.5, rho=RHO)
    dp = 1e5
    ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
    t = np.linspace(0.0, 4 * ts, 80)
    common = {"fluid": fluid, "pipe": POLYMER_PIPE}
    a = simulate_pipe_flow(t, dp, numerics=PipeNumerics(n_radial=100), **common)
    b = simulate_pipe_flow(t, dp, numerics=PipeNumerics(n_radial=100, regularization="truncated"),
                           **common)
    assert a.info["gamma_reg"] == b.info["gamma_reg"] > 0.0
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-6 * a.q.max())


# ----------------------------------------------------------------------------------------------
# Numerical convergence
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1.0, 0.5])
def test_grid_refinement_changes_q_by_less_than_tolerance(n):
    fluid = PowerLawFluid(K=30.0, n=n, rho=RHO)
    dp = 1e5
    ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
    t = np.concatenate([[0.0], np.geomspace(0.01 * ts, 10.0 * ts, 120)])
    qs = {
        m: simulate_pipe_flow(t, dp, fluid=fluid, pipe=POLYMER_PIPE,
                              numerics=PipeNumerics(n_radial=m)).q[1:]
        for m in (100, 200, 400)
    }
    d1 = np.max(np.abs(qs[200] / qs[100] - 1.0))
    d2 = np.max(np.abs(qs[400] / qs[200] - 1.0))
    assert d2 < 1e-4  # default grid vs refined: well inside the 1e-4 target
    assert d1 < 1e-4
    assert 2.5 < d1 / d2 < 6.0  # second-order convergence (ratio ~4)


def test_time_tolerance_is_not_limiting():
    fluid = PowerLawFluid(K=30.0, n=0.6, rho=RHO)
    dp = 1e5
    ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
    t = np.linspace(0.0, 6 * ts, 150)
    common = {"fluid": fluid, "pipe": POLYMER_PIPE}
    a = simulate_pipe_flow(t, dp, numerics=PipeNumerics(n_radial=100), **common)
    b = simulate_pipe_flow(t, dp, numerics=PipeNumerics(n_radial=100, rtol=1e-10), **common)
    c = simulate_pipe_flow(t, dp, numerics=PipeNumerics(n_radial=100, rtol=1e-10, method="Radau"),
                           **common)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-6 * b.q.max())
    np.testing.assert_allclose(c.q, b.q, rtol=0, atol=1e-8 * b.q.max())


# ----------------------------------------------------------------------------------------------
# Arbitrary histories, superposition, breakpoints
# ----------------------------------------------------------------------------------------------


def test_piecewise_linear_ramp_history():
    fluid = PowerLawFluid(K=30.0, n=0.4, rho=RHO)
    ts = power_law_time_scale(1e5, fluid, POLYMER_PIPE)
    t = np.linspace(0.0, 40.0 * ts, 401)  # the knots below are output times
    # ramp up, hold, ramp down through zero to a reverse pressure drop, release to zero
    t_knots = np.array([0.0, 2.0, 14.0, 16.0, 26.0, 27.0]) * ts
    dp_knots = np.array([0.0, 1e5, 1e5, -5e4, -5e4, 0.0])
    res = simulate_pipe_flow(t, (t_knots, dp_knots), fluid=fluid, pipe=POLYMER_PIPE)
    np.testing.assert_allclose(res.dp, np.interp(t, t_knots, dp_knots))
    q_fwd = steady_power_law_flow_rate(1e5, fluid, POLYMER_PIPE)
    assert res.q[0] == 0.0
    assert np.all(res.q[(t > 0.0) & (t <= 14.0 * ts)] > 0.0)  # forward push, forward flow
    hold = (t > 4.0 * ts) & (t <= 14.0 * ts)
    assert res.q[hold][-1] == pytest.approx(q_fwd, rel=2e-3)  # nearly steady after the hold
    assert np.all(np.diff(res.q[hold]) > 0.0)
    reverse = (t > 20.0 * ts) & (t <= 26.0 * ts)
    assert np.all(res.q[reverse] < 0.0)  # reverse push, reverse flow
    assert abs(res.q[-1]) < 1e-6 * q_fwd  # back at rest after the release
    # The same history given as an array aligned with t, or as a callable, agrees.
    aligned = simulate_pipe_flow(t, res.dp, fluid=fluid, pipe=POLYMER_PIPE)
    func = simulate_pipe_flow(
        t, lambda s: np.interp(s, t_knots, dp_knots), fluid=fluid, pipe=POLYMER_PIPE
    )
    for other in (aligned, func):
        np.testing.assert_allclose(other.q, res.q, rtol=0, atol=1e-4 * q_fwd)


def test_no_drive_means_no_flow():
    res = simulate_pipe_flow(
        np.linspace(0.0, 1.0, 20), 0.0, fluid=PowerLawFluid(30.0, 0.5, RHO), pipe=POLYMER_PIPE
    )
    assert np.all(res.q == 0.0)


def test_linear_superposition_newtonian():
    fluid = PowerLawFluid(K=25.0, n=1.0, rho=RHO)
    tau = newtonian_slowest_time_constant(fluid.K, RHO, POLYMER_PIPE)
    t = np.linspace(0.0, 8.0 * tau, 300)

    def dp1(s):
        return 1e5 * min(s / (2.0 * tau), 1.0)

    def dp2(s):
        return -4e4 * math.sin(2.0 * math.pi * s / (3.0 * tau)) + 2e4

    common = {"fluid": fluid, "pipe": POLYMER_PIPE,
              "numerics": PipeNumerics(n_radial=100, rtol=1e-10)}
    q1 = simulate_pipe_flow(t, dp1, **common).q
    q2 = simulate_pipe_flow(t, dp2, **common).q
    q12 = simulate_pipe_flow(t, lambda s: dp1(s) + dp2(s), **common).q
    scale = np.max(np.abs(q12))
    np.testing.assert_allclose(q12, q1 + q2, rtol=0, atol=1e-8 * scale)
    assert np.max(np.abs(q2)) > 0.1 * scale  # both parts matter


def test_breakpoint_restart_for_delayed_step():
    mu, dp = 10.0, 1e5
    fluid = PowerLawFluid.newtonian(mu, RHO)
    tau = newtonian_slowest_time_constant(mu, RHO, POLYMER_PIPE)
    t_step = 1.37 * tau  # deliberately not an output time
    t = np.linspace(0.0, 6.0 * tau, 301)
    res = simulate_pipe_flow(
        t,
        lambda s: dp if s > t_step else 0.0,
        fluid=fluid,
        pipe=POLYMER_PIPE,
        breakpoints=[t_step],
    )
    exact = szymanski_flow_rate(t - t_step, dp, mu, RHO, POLYMER_PIPE)
    assert res.info["segments"] == 2
    assert np.all(res.q[t <= t_step] == 0.0)
    late = t >= t_step + 0.01 * tau
    np.testing.assert_allclose(res.q[late], exact[late], rtol=1e-4)


# ----------------------------------------------------------------------------------------------
# Shear-thinning: dependence of the apparent time constant on the step size
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("n", "direction"), [(0.4, "slower"), (1.0, "same"), (1.5, "faster")])
def test_apparent_time_constant_depends_on_step_size(n, direction):
    """Measured t63 of the step response for two step sizes.

    Without regularization the model is self-similar: with U = (dp R^(n+1) / (K L))^(1/n) the
    flow rate after a step of size ``a dp`` is ``a^(1/n) Q(t / a^((1-n)/n))`` of the one after
    ``dp``, so any time constant scales as ``dp^((1-n)/n)``. A larger step drives higher shear
    rates, hence (for n < 1) a lower viscosity and slower momentum diffusion: the response of a
    shear-thinning fluid in this rigid-pipe model is *slower* for a larger step. The test
    asserts the measured direction and the exponent.
    """
    fluid = PowerLawFluid(K=30.0, n=n, rho=RHO)
    small, large = 5e4, 2e5
    t63 = {}
    for dp in (small, large):
        ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
        t = np.linspace(0.0, 6.0 * ts, 1200)
        res = simulate_pipe_flow(t, dp, fluid=fluid, pipe=POLYMER_PIPE)
        t63[dp] = _t63(t, res.q, steady_power_law_flow_rate(dp, fluid, POLYMER_PIPE))
    ratio = t63[large] / t63[small]
    expected = (large / small) ** ((1.0 - n) / n)
    assert ratio == pytest.approx(expected, rel=1e-3)
    if direction == "slower":
        assert ratio > 2.0
    elif direction == "faster":
        assert ratio < 0.8
    else:
        assert ratio == pytest.approx(1.0, abs=1e-3)


def test_power_law_self_similarity():
    n = 0.4
    fluid = PowerLawFluid(K=30.0, n=n, rho=RHO)
    a, dp = 3.0, 6e4
    ts = power_law_time_scale(dp, fluid, POLYMER_PIPE)
    t = np.linspace(0.0, 5.0 * ts, 200)
    stretch = a ** ((1.0 - n) / n)
    base = simulate_pipe_flow(t, dp, fluid=fluid, pipe=POLYMER_PIPE).q
    scaled = simulate_pipe_flow(t * stretch, a * dp, fluid=fluid, pipe=POLYMER_PIPE).q
    np.testing.assert_allclose(
        scaled, a ** (1.0 / n) * base, rtol=0, atol=1e-6 * a ** (1.0 / n) * base.max()
    )


# ----------------------------------------------------------------------------------------------
# Input validation
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"K": 0.0, "n": 0.5, "rho": 1000.0}, "consistency"),
        ({"K": 1.0, "n": -0.5, "rho": 1000.0}, "flow index"),
        ({"K": 1.0, "n": 0.5, "rho": math.inf}, "density"),
        ({"K": "abc", "n": 0.5, "rho": 1000.0}, "real number"),
    ],
)
def test_fluid_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PowerLawFluid(**kwargs)


@pytest.mark.parametrize(
    ("radius", "length", "match"),
    [(0.0, 1.0, "radius"), (-1e-3, 1.0, "radius"), (1e-3, math.nan, "length")],
)
def test_pipe_validation(radius, length, match):
    with pytest.raises(ValueError, match=match):
        Pipe(radius, length)


def test_dataclasses_are_frozen_and_normalized():
    fluid = PowerLawFluid(np.float32(2.0), 1, 1000)
    assert isinstance(fluid.n, float) and fluid.n == 1.0
    with pytest.raises(AttributeError):
        fluid.K = 3.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        POLYMER_PIPE.radius = 1.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("t", "dp", "kwargs", "match"),
    [
        ([0.0, 1.0, 1.0], 1e4, {}, "strictly increasing"),
        ([[0.0, 1.0]], 1e4, {}, "1-D"),
        ([0.0, math.nan], 1e4, {}, "finite"),
        ([0.0, 1.0, 2.0], [1.0, 2.0], {}, "aligned"),
        ([0.0, 1.0, 2.0], [1.0, math.inf, 2.0], {}, "finite"),
        ([0.0, 1.0], ([1.0, 0.5], [0.0, 1.0]), {}, "increasing"),
        ([0.0, 1.0], 1e4, {"numerics": {"n_radial": 100}}, "PipeNumerics"),
        ([0.0, 1.0], 1e4, {"initial_velocity": np.zeros(7)}, "initial_velocity"),
        ([0.0, 1.0], lambda s: math.nan, {}, "non-finite"),
    ],
)
def test_simulate_validation(t, dp, kwargs, match):
    with pytest.raises(ValueError, match=match):
        simulate_pipe_flow(t, dp, fluid=PowerLawFluid(10.0, 0.5, RHO), pipe=POLYMER_PIPE, **kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_radial": 2}, "n_radial"),
        ({"n_radial": 10.5}, "n_radial"),
        ({"rtol": 0.5}, "rtol"),
        ({"regularization": "papanastasiou"}, "regularization"),
        ({"method": "RK45"}, "method"),
        ({"gamma_reg": -1.0}, "gamma_reg"),
        ({"gamma_reg_factor": 0.0}, "gamma_reg_factor"),
        ({"wall_clustering": 1.0}, "wall_clustering"),
    ],
)
def test_numerics_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PipeNumerics(**kwargs)


def test_numerics_defaults_are_the_simulators():
    fluid = PowerLawFluid(K=30.0, n=0.6, rho=RHO)
    t = np.linspace(0.0, 3 * power_law_time_scale(1e5, fluid, POLYMER_PIPE), 40)
    default = simulate_pipe_flow(t, 1e5, fluid=fluid, pipe=POLYMER_PIPE)
    given = simulate_pipe_flow(t, 1e5, fluid=fluid, pipe=POLYMER_PIPE,
                               numerics=PipeNumerics(n_radial=200.0, rtol=1e-7))
    np.testing.assert_array_equal(default.q, given.q)
    info = default.info
    assert (info["n_radial"], info["rtol"], info["method"], info["wall_clustering"]) == (
        200, 1e-7, "BDF", 0.5)
    with pytest.raises(AttributeError):
        PipeNumerics().n_radial = 10  # type: ignore[misc]
