"""fit(): recovery, both methods, scale symmetry and gauge, failures, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pumpid import FirstOrder, FitResult, Kelvin, MassSpringDamper, Maxwell, fit, simulate

from .conftest import well_load

T = np.linspace(0.0, 20.0, 2001)
LOAD = well_load(T)
KELVIN = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)
MAXWELL = Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0)


def _start(model, factor=1.3):
    """A guess off by a factor in alternating directions."""
    vals = model.values * np.array([factor, 1 / factor] * 2)[: model.values.size]
    return type(model).from_values(vals)


@pytest.mark.parametrize(("model", "observe"),
                         [(KELVIN, "u2"), (KELVIN, "u"), (MAXWELL, "u")])
def test_lm_recovers_all_parameters_from_noiseless_data(model, observe) -> None:
    data = simulate(model, T, LOAD, observe=observe)
    res = fit(_start(model), T, LOAD, data, observe=observe)
    assert res.converged, res.reason
    assert res.status == "converged"
    for name, value in model.as_dict().items():
        assert res.params[name] == pytest.approx(value, rel=1e-8), name
    assert res.r2 == pytest.approx(1.0, abs=1e-12)
    assert res.warnings == []


def test_result_interface() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(_start(KELVIN), T, LOAD, data)
    assert isinstance(res, FitResult)
    assert res.scale == 1.0 and res.iterations > 0 and res.nfev >= res.iterations
    assert res.history[0]["iteration"] == 0 and "cost" in res.history[-1]
    assert res.history[-1]["cost"] <= res.history[0]["cost"]
    d = json.loads(res.to_json())
    for key in ("model", "method", "params", "scale", "converged", "iterations", "rmse", "r2",
                "warnings", "reason", "units"):
        assert key in d
    assert d["units"]["params"]["m"] == "N*s^2/m"
    text = res.report(history=True)
    assert "k0" in text and "N/m" in text and "R^2" in text and "iteration" in text


def test_newton_fd_on_kelvin_with_close_start() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(_start(KELVIN, 1.02), T, LOAD, data, method="newton-fd")
    assert res.converged, res.reason
    for name, value in KELVIN.as_dict().items():
        assert res.params[name] == pytest.approx(value, rel=1e-6)
    assert "epsilon" in res.history[-1]


@pytest.mark.parametrize("model", [KELVIN, MAXWELL, MassSpringDamper(m=2.0, c=3.0, k=40.0)],
                         ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("method", ["lm", "newton-fd"])
def test_scale_symmetry_is_gauged_and_said(model, method) -> None:
    data = 3.0 * simulate(model, T, LOAD)
    res = fit(_start(model, 1.01), T, LOAD, data, scale="free", method=method,
              x0={**_start(model, 1.01).as_dict(), "C": 2.9})
    assert res.converged, res.reason
    assert any("scale symmetry" in w and "gauge C = 1" in w for w in res.warnings)
    assert res.scale == 1.0 and "C" not in res.free
    # On the gauge C = 1 the parameters are the truth divided by 3 ...
    for name, value in model.as_dict().items():
        assert res.params[name] == pytest.approx(value / 3.0, rel=1e-6)
    # ... and the fitted curve still matches the data.
    assert res.rmse <= 1e-8 * np.ptp(data)


def test_no_symmetry_warning_when_c_fixed_or_state_given() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(_start(KELVIN), T, LOAD, data)
    assert not any("symmetry" in w for w in res.warnings)
    x0 = [0.5, 0.0, 0.1]
    data = 2.0 * simulate(KELVIN, T, LOAD, initial_state=x0)
    res = fit(_start(KELVIN, 1.05), T, LOAD, data, scale="free", initial_state=x0)
    assert not any("symmetry" in w for w in res.warnings)
    assert res.converged and res.scale == pytest.approx(2.0, rel=1e-7)
    assert res.params["k0"] == pytest.approx(KELVIN.k0, rel=1e-7)


def test_first_order_scale_is_identifiable() -> None:
    t = np.linspace(0, 10, 501)
    f = np.sin(t) + 2
    data = 1.7 * simulate(FirstOrder(tau=0.8), t, f)
    res = fit(FirstOrder(tau=2.0), t, f, data, scale="free")
    assert res.converged and not res.warnings
    assert res.params["tau"] == pytest.approx(0.8, rel=1e-9)
    assert res.scale == pytest.approx(1.7, rel=1e-9)


def test_offset_is_fitted() -> None:
    data = simulate(KELVIN, T, LOAD) + 12.5
    res = fit(_start(KELVIN), T, LOAD, data, offset=True)
    assert res.converged and res.offset == pytest.approx(12.5, rel=1e-9)
    assert res.params["m"] == pytest.approx(KELVIN.m, rel=1e-8)


def test_log_residual_and_its_checks() -> None:
    data = simulate(KELVIN, T, LOAD, initial_state="equilibrium")
    res = fit(_start(KELVIN), T, LOAD, data, residual="log", initial_state="equilibrium")
    assert res.converged and res.params["k1"] == pytest.approx(KELVIN.k1, rel=1e-8)
    with pytest.raises(ValueError, match="positive data"):
        fit(KELVIN, T, LOAD, data - data.mean(), residual="log", initial_state="equilibrium")
    with pytest.raises(ValueError, match="offset"):
        fit(KELVIN, T, LOAD, data, residual="log", offset=True, initial_state="equilibrium")


def test_divergent_newton_reports_instead_of_raising() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(_start(KELVIN, 30.0), T, LOAD, data, method="newton-fd")
    assert not res.converged
    assert res.status == "failed"
    assert res.reason
    assert res.model is None or np.all(np.isfinite(list(res.params.values())))
    assert "NOT" in res.report() or "not an ordinary" in res.report()


def test_automatic_start_from_the_class() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(Kelvin, T, LOAD, data)
    assert res.converged, res.reason
    for name, value in KELVIN.as_dict().items():
        assert res.params[name] == pytest.approx(value, rel=1e-7)


@pytest.mark.parametrize(
    ("t", "load", "disp", "message"),
    [
        (T, LOAD, np.append(LOAD[:-1], np.nan), "displacement: 1 non-finite value"),
        (T, np.append(LOAD[:-1], np.inf), LOAD, "load: 1 non-finite value.*inf"),
        (T, LOAD[:-1], LOAD, "load: length 2000 does not match"),
        (T[::-1], LOAD, LOAD, "strictly increasing"),
        (T[:9], LOAD[:9], LOAD[:9], "at least 10"),
        (T, np.full_like(T, 3.0), LOAD, "load: constant"),
    ],
)
def test_bad_input_raises_value_error_naming_the_problem(t, load, disp, message) -> None:
    with pytest.raises(ValueError, match=message):
        fit(KELVIN, t, load, disp)


def test_bad_options_raise() -> None:
    data = simulate(KELVIN, T, LOAD)
    with pytest.raises(ValueError, match="method"):
        fit(KELVIN, T, LOAD, data, method="bfgs")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="scale"):
        fit(KELVIN, T, LOAD, data, scale=-1.0)
    with pytest.raises(ValueError, match="unknown names"):
        fit(KELVIN, T, LOAD, data, x0={"k2": 1.0})
    with pytest.raises(TypeError, match="model instance"):
        fit("kelvin", T, LOAD, data)  # type: ignore[arg-type]


def test_a_trial_point_that_cannot_be_simulated_is_rejected(monkeypatch) -> None:
    from pumpid.problem import Problem

    truth = Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0)
    t = np.linspace(0.0, 20.0, 801)
    load = 10.0 + np.sin(t) + 0.5 * np.sin(2.7 * t)
    data = simulate(truth, t, load)
    original = Problem.output_and_sensitivities
    calls = {"n": 0}

    def flaky(self, theta):
        calls["n"] += 1
        if calls["n"] == 3:
            raise np.linalg.LinAlgError("singular matrix (injected)")
        return original(self, theta)

    monkeypatch.setattr(Problem, "output_and_sensitivities", flaky)
    res = fit(truth.replace(k0=5.0, c1=0.25), t, load, data, multistart=False)
    assert res.converged and calls["n"] > 3
    np.testing.assert_allclose(res.model.values, truth.values, rtol=1e-9)

    calls["n"] = 0

    def broken_start(self, theta):
        calls["n"] += 1
        raise np.linalg.LinAlgError("singular matrix (injected)")

    monkeypatch.setattr(Problem, "output_and_sensitivities", broken_start)
    res = fit(truth, t, load, data, multistart=False)
    assert not res.converged and "solver error" in res.reason
