"""The main job through ``pumpid.fit``: one record and many (a batch) -- recovery, both
solvers, scale symmetry and gauge, failures, bad input, and the batch agreeing with
card-by-card fits."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pumpid
import pumpid.cards
import pumpid.result.table
from pumpid import (
    FirstOrder,
    FitBatch,
    FitOptions,
    FitResult,
    Kelvin,
    LevenbergMarquardt,
    MassSpringDamper,
    Maxwell,
    PaperNewton,
    fit,
    simulate,
)

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
    res = fit(_start(model), (T, LOAD, data), options=FitOptions(observe=observe))
    assert res.converged, res.reason
    assert res.status == "converged"
    for name, value in model.as_dict().items():
        assert res.params[name] == pytest.approx(value, rel=1e-8), name
    assert res.r2 == pytest.approx(1.0, abs=1e-12)
    assert not res.warnings


def test_result_interface() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(_start(KELVIN), (T, LOAD, data))
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
    res = fit(_start(KELVIN, 1.02), (T, LOAD, data), solver=PaperNewton())
    assert res.converged, res.reason
    for name, value in KELVIN.as_dict().items():
        assert res.params[name] == pytest.approx(value, rel=1e-6)
    assert "epsilon" in res.history[-1]


@pytest.mark.parametrize("model", [KELVIN, MAXWELL, MassSpringDamper(m=2.0, c=3.0, k=40.0)],
                         ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("solver", [LevenbergMarquardt(), PaperNewton()],
                         ids=["lm", "newton-fd"])
def test_scale_symmetry_is_gauged_and_said(model, solver) -> None:
    data = 3.0 * simulate(model, T, LOAD)
    res = fit(_start(model, 1.01), (T, LOAD, data), options=FitOptions(scale="free"),
              solver=solver, x0={**_start(model, 1.01).as_dict(), "C": 2.9})
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
    res = fit(_start(KELVIN), (T, LOAD, data))
    assert not any("symmetry" in w for w in res.warnings)
    x0 = [0.5, 0.0, 0.1]
    data = 2.0 * simulate(KELVIN, T, LOAD, initial_state=x0)
    res = fit(_start(KELVIN, 1.05), (T, LOAD, data),
              options=FitOptions(scale="free", initial_state=x0))
    assert not any("symmetry" in w for w in res.warnings)
    assert res.converged and res.scale == pytest.approx(2.0, rel=1e-7)
    assert res.params["k0"] == pytest.approx(KELVIN.k0, rel=1e-7)


def test_first_order_scale_is_identifiable() -> None:
    t = np.linspace(0, 10, 501)
    f = np.sin(t) + 2
    data = 1.7 * simulate(FirstOrder(tau=0.8), t, f)
    res = fit(FirstOrder(tau=2.0), (t, f, data), options=FitOptions(scale="free"))
    assert res.converged and not res.warnings
    assert res.params["tau"] == pytest.approx(0.8, rel=1e-9)
    assert res.scale == pytest.approx(1.7, rel=1e-9)


def test_offset_is_fitted() -> None:
    data = simulate(KELVIN, T, LOAD) + 12.5
    res = fit(_start(KELVIN), (T, LOAD, data), options=FitOptions(offset=True))
    assert res.converged and res.offset == pytest.approx(12.5, rel=1e-9)
    assert res.params["m"] == pytest.approx(KELVIN.m, rel=1e-8)


def test_log_residual_and_its_checks() -> None:
    data = simulate(KELVIN, T, LOAD, initial_state="equilibrium")
    log = FitOptions(residual="log", initial_state="equilibrium")
    res = fit(_start(KELVIN), (T, LOAD, data), options=log)
    assert res.converged and res.params["k1"] == pytest.approx(KELVIN.k1, rel=1e-8)
    with pytest.raises(ValueError, match="positive data"):
        fit(KELVIN, (T, LOAD, data - data.mean()), options=log)
    with pytest.raises(ValueError, match="offset"):
        fit(KELVIN, (T, LOAD, data), options=log.replace(offset=True))


def test_divergent_newton_reports_instead_of_raising() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(_start(KELVIN, 30.0), (T, LOAD, data), solver=PaperNewton())
    assert not res.converged
    assert res.status == "failed"
    assert res.reason
    assert res.model is None or np.all(np.isfinite(list(res.params.values())))
    assert "NOT" in res.report() or "not an ordinary" in res.report()


def test_automatic_start_from_the_class() -> None:
    data = simulate(KELVIN, T, LOAD)
    res = fit(Kelvin, (T, LOAD, data))
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
        fit(KELVIN, (t, load, disp))


def test_bad_options_raise() -> None:
    data = simulate(KELVIN, T, LOAD)
    with pytest.raises(TypeError, match="solver"):
        fit(KELVIN, (T, LOAD, data), solver="bfgs")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="scale"):
        fit(KELVIN, (T, LOAD, data), options=FitOptions(scale=-1.0))
    with pytest.raises(ValueError, match="unknown names"):
        fit(KELVIN, (T, LOAD, data), x0={"k2": 1.0})
    with pytest.raises(TypeError, match="model instance"):
        fit(3.0, (T, LOAD, data))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown model 'kelvn'"):
        fit("kelvn", (T, LOAD, data))


def test_a_start_the_model_cannot_simulate_fails_with_a_reason() -> None:
    # Explicit Euler with a step far beyond its stability limit: the response overflows at
    # the start, the fit reports it instead of raising.
    t = np.linspace(0.0, 20.0, 801)
    load = 10.0 + np.sin(t) + 0.5 * np.sin(2.7 * t)
    data = simulate(Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0), t, load)
    with np.errstate(all="ignore"):
        res = fit(Kelvin(k0=4e6, m=1e-6, c1=0.2, k1=4.0), (t, load, data),
                  options=FitOptions(integrator="euler", multistart=False))
    assert not res.converged and res.status == "failed"
    assert "not finite at the starting point" in res.reason


# --------------------------------------------------------------------------- many cards
PERIOD = 7.5
T_CARD = np.linspace(0.0, PERIOD, 300, endpoint=False)
BASE = np.array([8000.0, 40.0, 900.0, 5000.0])
STARTS = np.array([1.3, 1 / 1.3, 1.3, 1 / 1.3])


def card_load(seed: int) -> np.ndarray:
    """A pumping-card-like load: fluid load picked up and released, plus a ripple."""
    rng = np.random.default_rng(seed)
    phase = T_CARD / PERIOD
    on = 0.5 * (1 + np.tanh((phase - 0.08 - 0.05 * rng.random()) / 0.03))
    off = 0.5 * (1 + np.tanh((phase - 0.55 - 0.05 * rng.random()) / 0.04))
    ripple = 300 * np.sin(2 * np.pi * 3 * phase + rng.random())
    return 5000 + 4000 * on * (1 - off) + ripple + 500 * np.sin(2 * np.pi * phase)


def make_cards(cls, n_cards, initial_state="rest", offset=0.0, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    theta = BASE * np.exp(0.25 * rng.standard_normal((n_cards, BASE.size)))
    loads = np.array([card_load(seed * 1000 + i) for i in range(n_cards)])
    disp = np.array([simulate(cls.from_values(th), T_CARD, f, initial_state=initial_state)
                     for th, f in zip(theta, loads, strict=True)]) + offset
    disp += noise * np.ptp(disp, axis=1, keepdims=True) * rng.standard_normal(disp.shape)
    return theta, loads, disp


CASES = [(Kelvin, "rest", False, 0.0), (Maxwell, "rest", False, 0.01),
         (Kelvin, "periodic", True, 0.0), (Kelvin, "periodic", True, 0.01)]


@pytest.mark.parametrize(("cls", "state", "offset", "noise"), CASES)
@pytest.mark.parametrize("start", ["guess", "auto"])
def test_the_batch_is_the_single_fit_card_by_card(cls, state, offset, noise, start) -> None:
    theta, loads, disp = make_cards(cls, 6, state, offset=0.02 if offset else 0.0,
                                    noise=noise, seed=1)
    x0 = theta * STARTS if start == "guess" else None
    options = FitOptions(initial_state=state, offset=offset)
    batch = fit(cls, (T_CARD, loads, disp), options=options, x0=x0)
    assert isinstance(batch, FitBatch) and len(batch) == 6
    for i in range(6):
        model = cls.from_values(x0[i]) if x0 is not None else cls
        ref = fit(model, (T_CARD, loads[i], disp[i]), options=options)
        one = batch.result(i)
        # The same engine on the same numbers: identical answers, not merely close ones.
        assert one.status == ref.status and one.reason == ref.reason
        assert dict(one.params) == dict(ref.params) and one.offset == ref.offset
        assert one.cost == ref.cost and one.nfev == ref.nfev
        assert one.stderr_hac == ref.stderr_hac and one.warnings == ref.warnings
        if noise == 0.0:
            assert one.converged, one.reason
            np.testing.assert_allclose(one.model.values, theta[i], rtol=1e-8)


def test_threads_do_not_change_answers() -> None:
    theta, loads, disp = make_cards(Kelvin, 7, noise=0.005, seed=3)
    x0 = theta * STARTS
    one = fit(Kelvin, (T_CARD, loads, disp), x0=x0, workers=1)
    two = fit(Kelvin, (T_CARD, loads, disp), x0=x0, workers=2)
    np.testing.assert_array_equal(one.theta, two.theta)
    assert one.status == two.status
    np.testing.assert_array_equal(one.nfev, two.nfev)


def test_free_scale_uses_the_gauge_and_records() -> None:
    theta, loads, disp = make_cards(Kelvin, 3, seed=5)
    res = fit(Kelvin, (T_CARD, loads, disp), options=FitOptions(scale="free"),
              x0=theta * STARTS)
    assert np.all(res.scale == 1.0)
    assert all(any("gauge C = 1" in w for w in r.warnings) for r in res.results)
    rows = res.to_frame()
    assert len(rows) == 3 and rows["status"][0] == "converged" and "p_k0" in rows
    assert list(rows.columns) == [n for n, _ in pumpid.result.table.columns(Kelvin)]
    # Every number of the table has its unit: the parameters' beside them (they had none).
    first = res.result(0)
    assert [rows[f"p_{n}_unit"][0] for n in Kelvin.param_names()] == [
        first.param_units()[n] for n in Kelvin.param_names()]
    assert "offset" not in first.free and np.isnan(rows["offset_se"][0])
    example = pumpid.__path__[0] + "/data/example_cards.csv"
    card = pumpid.fit(Kelvin, pumpid.cards.read_cards(example)[0]).to_row()
    assert card["offset_se"] > 0 and card["p_m_unit"] == "lbf*s^2/in"
    assert res.result(2).params["m"] == pytest.approx(theta[2, 1], rel=1e-9)
    assert "converged 3" in res.summary()


def test_cards_of_different_lengths_and_times() -> None:
    theta, loads, disp = make_cards(Kelvin, 3, seed=9)
    t_rows = [T_CARD, T_CARD[::2], T_CARD * 1.5]
    f_rows = [loads[0], loads[1][::2], loads[2]]
    d_rows = [disp[0], simulate(Kelvin.from_values(theta[1]), T_CARD[::2], loads[1][::2]),
              simulate(Kelvin.from_values(theta[2]), T_CARD * 1.5, loads[2])]
    res = fit(Kelvin, (t_rows, f_rows, d_rows), x0=theta * STARTS)
    assert res.converged.all(), res.summary()
    np.testing.assert_allclose(res.theta, theta, rtol=1e-7)


def test_a_bad_card_is_a_failed_row_not_the_end_of_the_batch() -> None:
    theta, loads, disp = make_cards(Kelvin, 5, seed=7)
    bad = disp.copy()
    bad[2, 10] = np.nan
    bad[4] = 1.0  # constant
    res = fit(Kelvin, (T_CARD, loads, bad), x0=theta * STARTS)
    assert [s.value for s in res.status] == ["converged", "converged", "invalid-input",
                                              "converged", "invalid-input"]
    assert "non-finite" in res.invalid[2] and "constant" in res.invalid[4]
    assert np.isnan(res.theta[2]).all() and np.isnan(res.r2[4])
    np.testing.assert_allclose(res.theta[[0, 1, 3]], theta[[0, 1, 3]], rtol=1e-7)
    with pytest.raises(ValueError, match="card 2 is not valid"):
        res.result(2)
    rows = res.to_frame()
    assert rows["status"][2] == "invalid-input" and "non-finite" in rows["reason"][2]
    assert np.isnan(rows["p_k0"][2]) and rows["p_k0"][0] == pytest.approx(theta[0, 0])


def test_bad_options_of_a_batch_raise() -> None:
    _, loads, disp = make_cards(Kelvin, 4, seed=7)
    with pytest.raises(ValueError, match="cards"):
        fit(Kelvin, (T_CARD, loads[:3], disp))
    with pytest.raises(ValueError, match="x0"):
        fit(Kelvin, (T_CARD, loads, disp), x0=np.ones((3, 4)))
    with pytest.raises(ValueError, match="x0"):
        fit(Kelvin, (T_CARD, loads, disp), x0=-np.ones(4))
    with pytest.raises(ValueError, match="cannot observe"):
        fit(Kelvin, (T_CARD, loads, disp), options=FitOptions(observe="F0"))
    with pytest.raises(TypeError, match="model"):
        fit(3.0, (T_CARD, loads, disp))  # type: ignore[arg-type]


# --------------------------------------------------------------------------- quality gate
def _unrelated_record() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A load record and a 'displacement' that has nothing to do with it (white noise)."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 7.5, 300)
    load = 5000.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5)
    return t, load, 10.0 + rng.standard_normal(t.size)


def test_a_fit_below_the_quality_threshold_is_poor_fit_with_a_warning() -> None:
    t, load, d = _unrelated_record()
    res = pumpid.fit(pumpid.Kelvin, (t, load, d), options=FitOptions(offset=True))
    assert res.status is pumpid.Status.POOR_FIT
    assert res.r2 < pumpid.job.MIN_R2
    assert any(w.startswith("poor fit: R^2 = ") and "0.95" in w for w in res.warnings)
    assert "poor fit" in res.reason and "verdict: " in res.reason
    # Each replaced verdict said once and by whom ("verdict: converged: converged: ..." read
    # as garbled; an undetermined status is the gate's, not the solver's).
    for key in ("converged", "boundary", "undetermined"):
        assert f"{key}: {key}:" not in res.reason
    assert "the solver's own verdict: undetermined" not in res.reason
    assert "poor-fit" in res.report() and res.to_dict()["status"] == "poor-fit"
    # The numbers are kept: the gate judges the answer, it does not discard it.
    assert all(np.isfinite(v) for v in res.params.values())


def test_the_quality_threshold_is_configurable_and_changes_nothing_else() -> None:
    t, load, d = _unrelated_record()
    gated = pumpid.fit(pumpid.Kelvin, (t, load, d), options=FitOptions(offset=True))
    # The gate open: the lowest threshold FitOptions takes (it takes finite numbers only).
    lowest = -np.finfo(float).max
    open_gate = pumpid.fit(pumpid.Kelvin, (t, load, d),
                           options=FitOptions(offset=True, min_r2=lowest))
    assert open_gate.status in (pumpid.Status.CONVERGED, pumpid.Status.BOUNDARY)
    assert open_gate.params == gated.params and open_gate.cost == gated.cost
    with pytest.raises(ValueError, match="min_r2"):
        pumpid.fit(pumpid.Kelvin, (t, load, d), options=FitOptions(min_r2=1.5))


def test_a_good_fit_passes_the_quality_gate() -> None:
    t = np.linspace(0.0, 7.5, 300)
    load = 5000.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5)
    truth = pumpid.Kelvin(k0=5200.0, m=20.0, c1=900.0, k1=5200.0)
    d = pumpid.simulate(truth, t, load, observe="u")
    res = pumpid.fit(pumpid.Kelvin, (t, load, d), options=FitOptions(observe="u"))
    assert res.status is not pumpid.Status.POOR_FIT and res.r2 > 0.999


def test_the_quality_gate_prints_an_r2_that_differs_from_its_threshold() -> None:
    # "R^2 = 0.995 is below the quality threshold 0.995": 0.994994 rounded to 4 digits.
    import dataclasses

    from pumpid.job.assemble import quality_gate

    t, load, d = _unrelated_record()
    res = pumpid.fit(pumpid.Kelvin, (t, load, d), options=FitOptions(offset=True, min_r2=0.0))
    res = dataclasses.replace(res, r2=0.994994)
    said = quality_gate(res, 0.995).warnings[-1]
    assert said.startswith("poor fit: R^2 = 0.99499 is below the quality threshold 0.995")
