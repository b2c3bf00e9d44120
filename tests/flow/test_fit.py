"""Flow records (reading, units, validation), the flow fit, and the two physics checks.

Physics checks
--------------
1. Newtonian start-up. Szymanski's series gives Q/Qs = 1 - 32 sum_k exp(-t/tau_k)/j_k^4,
   tau_k = rho R^2/(mu j_k^2). The slowest mode tau1 carries 32/j1^4 = 95.7 % of the
   amplitude and the faster ones make the early rise steeper, so the least-squares time
   constant of a first-order lag is *below* tau1. Two analytic markers bracket it: the
   initial slope (dQ/dt(0+) = 8 Qs nu/R^2, i.e. tau = j1^2/8 tau1 = 0.723 tau1) and the
   area (int (1 - Q/Qs) dt = 32 sum 1/j_k^6 R^2/nu = R^2/(6 nu), i.e. tau = j1^2/6 tau1 =
   0.964 tau1); the least-squares value on a window of 5 tau1 with 201 uniform samples lies
   between them. Its exact expected value is computed here independently -- a
   one-parameter least-squares fit (gain eliminated in closed form) of
   G (1 - exp(-t/tau)) to the Szymanski series on the same samples -- and the pumpid fit of
   pumpid.pipeflow's record must match it to 1e-4 (measured: 5e-6; the simulator's flow
   rate is within ~1e-5 of the series).
2. Shear-thinning start-up (n = 0.4). Self-similarity Q_a(t) = a^(1/n) Q_1(t/a^m),
   m = (1-n)/n = 1.5, makes the linear lag's fitted tau grow like dp^1.5.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from pumpid.cards import CardError
from pumpid.flow import (
    FLOW_UNITS,
    PRESSURE_UNITS,
    convert_flow,
    convert_pressure,
    fit_flow,
    fit_flow_records,
    flow_record,
    read_flow_record,
    simulate_flow_record,
    step_response_study,
)
from pumpid.flow.pipeflow import (
    J01,
    Pipe,
    PowerLawFluid,
    newtonian_slowest_time_constant,
    szymanski_flow_rate,
)
from pumpid.flow.records import normalize_flow_unit
from pumpid.flow.report import plot_tau_vs_step, write_flow_outputs, write_study_outputs

DATA = Path(__file__).parents[1] / "data" / "flow"
PIPE = Pipe(radius=5e-3, length=1.0)


# --------------------------------------------------------------------------- units
def test_unit_factors_are_exact():
    assert convert_pressure([1.0], "psi", "Pa")[0] == pytest.approx(6894.757293168361, rel=1e-15)
    assert convert_pressure([2.5], "bar", "kPa")[0] == pytest.approx(250.0, rel=1e-15)
    assert convert_pressure([1.0], "MPa")[0] == 1e6
    assert convert_flow([60.0], "L/min", "L/s")[0] == pytest.approx(1.0, rel=1e-15)
    assert convert_flow([1.0], "gpm")[0] == pytest.approx(3.785411784e-3 / 60, rel=1e-15)
    assert convert_flow([3600.0], "m3/h")[0] == pytest.approx(1.0, rel=1e-15)
    assert convert_flow([1.0], "mL/s")[0] == pytest.approx(1e-6, rel=1e-15)
    assert normalize_flow_unit(" LPM ") == "L/min"
    assert {"Pa", "kPa", "MPa", "bar", "psi"} <= set(PRESSURE_UNITS)
    assert {"m^3/s", "L/s", "L/min", "mL/s", "m^3/h", "gpm"} <= set(FLOW_UNITS)
    with pytest.raises(CardError, match="unknown pressure unit"):
        convert_pressure([1.0], "furlong")


# --------------------------------------------------------------------------- reading
def test_read_rig_record_with_pressures_and_units_then_fit():
    rec = read_flow_record(DATA / "rig_pressures_kpa_lpm.csv")
    assert rec.dp_unit == "Pa" and rec.q_unit == "m^3/s"
    assert rec.n == 241
    assert rec.dp.max() == pytest.approx(300e3, rel=1e-12)  # (p_in - p_out) kPa -> Pa
    text = " ".join(rec.notes)
    assert "p_in - p_out" in text and "kPa to Pa" in text and "L/min to m^3/s" in text
    res = fit_flow(rec)
    assert res.converged
    assert res.params["tau"] == pytest.approx(0.8, rel=1e-6)
    assert res.params["gain"] == pytest.approx(4e-10, rel=1e-6)
    assert res.extra["flow"]["initial_state"].startswith("rest")
    assert set(res.extra["stderr"]) == {"tau", "gain"}
    lo, hi = res.extra["ci95"]["tau"]
    assert lo <= res.params["tau"] <= hi
    # Explicit conversion back to the rig's units is noted and exact.
    rig = rec.to_units("kPa", "L/min")
    assert rig.q.max() == pytest.approx(rec.q.max() * 6e4, rel=1e-14)
    assert any("converted from Pa to kPa" in n for n in rig.notes)


def test_read_with_explicit_columns_and_units(tmp_path):
    path = tmp_path / "cfd.csv"
    t = np.linspace(0, 1, 20)
    path.write_text("time;delta;Q\n" + "".join(
        f"{a};{2.0 if a > 0 else 0.0};{1.5 * (1 - math.exp(-a / 0.1))}\n" for a in t))
    rec = read_flow_record(path, columns={"t": "time", "dp": "delta", "q": "Q"},
                           dp_unit="bar", q_unit="L/s")
    assert rec.dp.max() == pytest.approx(2e5)
    assert rec.q.max() == pytest.approx(1.5e-3 * (1 - math.exp(-10)), rel=1e-12)
    with pytest.raises(CardError, match="no column 'flow'") as info:
        read_flow_record(path, columns={"t": "time", "dp": "delta", "q": "flow"})
    assert info.value.line == 1
    with pytest.raises(CardError, match="unknown column role"):
        read_flow_record(path, columns={"x": "time"})


@pytest.mark.parametrize(("name", "match", "line", "field"), [
    ("bad_number.csv", "not a number: 'abc'", 8, "q"),
    ("nan_value.csv", "not a finite number", 10, "dp"),
    ("time_backwards.csv", "strictly increasing", 13, "t"),
    ("too_short.csv", "5 samples; at least 10", None, "t"),
    ("unknown_unit.csv", "unknown pressure unit 'furlongs'", None, "dp"),
    ("constant_dp.csv", "constant", None, "dp"),
])
def test_malformed_records_name_file_line_and_field(name, match, line, field):
    with pytest.raises(CardError, match=match) as info:
        read_flow_record(DATA / name)
    err = info.value
    assert err.path is not None and err.path.endswith(name)
    assert err.line == line
    assert err.field == field
    assert isinstance(err, ValueError)


def test_more_malformed_inputs(tmp_path):
    with pytest.raises(CardError, match="no such file"):
        read_flow_record(tmp_path / "missing.csv")
    empty = tmp_path / "empty.csv"
    empty.write_text("# only a comment\n\n")
    with pytest.raises(CardError, match="no header"):
        read_flow_record(empty)
    nodp = tmp_path / "nodp.csv"
    nodp.write_text("t,q\n" + "".join(f"{i},{i}\n" for i in range(12)))
    with pytest.raises(CardError, match="no pressure-drop column"):
        read_flow_record(nodp)
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("t,dp,q\n" + "".join(f"{i},{i},{i}\n" for i in range(12)) + "12,1\n")
    with pytest.raises(CardError, match="2 fields") as info:
        read_flow_record(ragged)
    assert info.value.line == 14
    flat = tmp_path / "flat.csv"
    flat.write_text("t,dp,q\n" + "".join(f"{i},{i},3\n" for i in range(12)))
    with pytest.raises(CardError, match="flow rate is constant"):
        read_flow_record(flat)


def test_step_from_rest_is_accepted_and_noted():
    rec = simulate_flow_record(np.linspace(0, 0.005, 41), 1e5,
                               fluid=PowerLawFluid.newtonian(10.0, 1000.0), pipe=PIPE)
    assert rec.step_from_rest
    path_text = rec.to_csv()
    assert path_text.splitlines()[0] == "t [s],dp [Pa],q [m^3/s]"


def test_q_to_dp_needs_the_first_order_model():
    rec = read_flow_record(DATA / "step_si.csv")
    with pytest.raises(ValueError, match="first-order model only"):
        fit_flow(rec, "power-law", direction="q->dp")
    with pytest.raises(ValueError, match="direction"):
        fit_flow(rec, direction="sideways")  # type: ignore[arg-type]


def test_equilibrium_start_is_chosen_for_records_that_start_flowing():
    rec = read_flow_record(DATA / "rig_pressures_kpa_lpm.csv")
    late = flow_record(rec.t[100:] - rec.t[100], rec.dp[100:], rec.q[100:])
    res = fit_flow(late)
    assert res.extra["flow"]["initial_state"].startswith("equilibrium")


# --------------------------------------------------------------------------- physics 1
def _expected_tau_from_szymanski(t, mu, rho, dp):
    """Independent 1-parameter least squares: G (1 - exp(-t/tau)) against the series."""
    qs = szymanski_flow_rate(t, dp, mu, rho, PIPE)

    def cost(log_tau: float) -> float:
        x = 1.0 - np.exp(-t / math.exp(log_tau))
        gain = (x @ qs) / (x @ x)  # best gain for this tau, in closed form
        return float(np.sum((gain * x - qs) ** 2))

    tau1 = newtonian_slowest_time_constant(mu, rho, PIPE)
    sol = minimize_scalar(cost, bounds=(math.log(0.5 * tau1), math.log(1.5 * tau1)),
                          method="bounded", options={"xatol": 1e-12})
    return math.exp(sol.x)


def test_newtonian_startup_time_constant_vs_slowest_bessel_mode():
    mu, rho, dp = 10.0, 1000.0, 1e5
    tau1 = newtonian_slowest_time_constant(mu, rho, PIPE)
    t = np.linspace(0.0, 5.0 * tau1, 201)
    rec = simulate_flow_record(t, dp, fluid=PowerLawFluid.newtonian(mu, rho), pipe=PIPE)
    res = fit_flow(rec, "first-order")
    assert res.converged
    tau_fit = res.params["tau"]
    expected = _expected_tau_from_szymanski(t, mu, rho, dp)
    assert expected / tau1 == pytest.approx(0.94608, abs=5e-5)  # the derived relation
    assert tau_fit == pytest.approx(expected, rel=1e-4)
    # Bracket: initial-slope and area time constants (j1^2/8 and j1^2/6 of tau1), both < tau1.
    assert J01**2 / 8 * tau1 < tau_fit < J01**2 / 6 * tau1 < tau1
    # Fit quality reported: a first-order lag explains 99.96 % of the start-up's variance,
    # and its gain is within 1 % of Poiseuille's pi R^4 / (8 mu L).
    assert 0.9995 < res.r2 < 1.0
    poiseuille = math.pi * PIPE.radius**4 / (8 * mu * PIPE.length)
    assert res.params["gain"] == pytest.approx(poiseuille, rel=0.01)


# --------------------------------------------------------------------------- physics 2
@pytest.fixture(scope="module")
def study():
    fluid = PowerLawFluid(K=10.0, n=0.4, rho=1000.0)
    return step_response_study(fluid, PIPE, [2.5e4, 5e4, 1e5, 2e5, 4e5])


def test_linear_time_constant_grows_with_the_step_like_self_similarity(study):
    taus = study.tau_linear
    assert np.all(np.diff(taus) > 0)  # a larger step responds more slowly (n < 1)
    assert study.predicted_exponent == pytest.approx(1.5)
    # Common record length for all steps, so not an exact rescaling: "roughly" 1.5.
    assert study.exponent() == pytest.approx(1.5, abs=0.1)
    assert all(r.r2 > 0.99 for r in study.linear)


def test_shear_thinning_surrogate_captures_the_step_dependence_power_law_lag_does_not(study):
    st = study.joint["shear-thinning"]
    pl = study.joint["power-law"]
    # One parameter set for all five steps: the flow-dependent time constant follows the steps
    # with the self-similar exponent and fits every step at least as well as the per-step
    # linear fits do on average ...
    assert study.exponent(study.apparent_tau["shear-thinning"]) == pytest.approx(1.5, abs=0.1)
    assert np.min(study.joint_r2("shear-thinning")) > 0.995
    assert st.params["n"] == pytest.approx(0.4, abs=0.02)  # recovers the fluid's index
    # ... while the Hammerstein power-law lag has ONE time constant for every step.
    assert study.exponent(study.apparent_tau["power-law"]) == pytest.approx(0.0, abs=1e-3)
    assert np.min(study.joint_r2("power-law")) < 0.5
    assert st.r2 > pl.r2
    text = study.table()
    assert "self-similarity predicts (1-n)/n = 1.5000" in text


def test_study_outputs_and_plot(study, tmp_path):
    fig = plot_tau_vs_step(study)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert ax.get_ylabel() == "time constant tau [s]"
    assert fig.axes[1].get_xlabel() == "pressure-drop step dp [Pa]"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("linear" in s for s in labels) and any("ShearThinningLag" in s for s in labels)
    paths = write_study_outputs(study, tmp_path)
    for key in ("csv", "study_json", "report", "tau_vs_step"):
        assert paths[key].is_file()
    html = paths["report"].read_text(encoding="utf-8")
    assert "time constant vs pressure-drop step" in html
    assert "does NOT capture" in html  # the honest verdict on the Hammerstein model


def test_joint_fit_of_first_order_lag_and_report_files(tmp_path):
    rec = read_flow_record(DATA / "rig_pressures_kpa_lpm.csv")
    joint = fit_flow_records([rec, rec], "first-order")
    assert joint.params["tau"] == pytest.approx(0.8, rel=1e-6)
    assert len(joint.extra["records"]) == 2
    res = fit_flow(rec)
    paths = write_flow_outputs(res, tmp_path / "out")
    for key in ("flow", "characteristic", "residuals", "history", "json", "report"):
        assert paths[key].is_file()
    html = paths["report"].read_text(encoding="utf-8")
    assert "pressure drop in, flow rate out" in html


def test_a_single_level_is_said_only_where_n_cannot_be_told():
    # A ramp visits every level (n = 0.40005 +- 6e-5 beside "any n fits equally"), and the
    # shear-thinning model's n shapes the transient of a single step.
    fluid = PowerLawFluid(K=10.0, n=0.4, rho=1000.0)
    t = np.linspace(0.0, 0.3, 121)
    step = simulate_flow_record(t, 1e5, fluid=fluid, pipe=PIPE)
    ramp = simulate_flow_record(t, 1e5 * np.clip(t / 0.15, 0.0, 1.0), fluid=fluid, pipe=PIPE)

    def said(rec, model):
        return any("visits a single level" in w for w in fit_flow(rec, model).warnings)

    assert said(step, "power-law")
    # Its noise does not make a second level (fixed bins split a noisy level in two).
    rng = np.random.default_rng(1)
    for _ in range(20):
        noisy = flow_record(step.t, step.dp * (1 + 0.005 * rng.standard_normal(step.n)),
                            step.q)
        assert said(noisy, "power-law")
    assert not said(ramp, "power-law")
    assert not said(step, "shear-thinning")
