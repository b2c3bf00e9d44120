"""The pump identified from the surface card (:func:`pumpid.pump.identify_cards`).

Cards are made by the predictive solver at 60 elements (the fit's model marches 30), with
noise, so the model is not fitted to its own output."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pumpid.cards import Card
from pumpid.pump import PumpSystem, SurfaceCard, identify_card, identify_cards, solver_difference
from pumpid.rods import PumpModel, measure_pump_card, predict_surface

from ..rods.strings import LBF, card, surface_motion, three_tapers

SPM = 8.0
NU = 0.1
# liquid fraction admitted, intake ratio: full pump, fluid pound, gas interference
CASES = {"full": (1.0, 0.01), "pound-70": (0.7, 0.01), "pound-50": (0.5, 0.01),
         "gas": (0.7, 0.3)}


@pytest.fixture(scope="module")
def made():
    well = three_tapers()
    s = surface_motion(n=200, period=60 / SPM)
    fill = np.array([v[0] for v in CASES.values()])
    ratio = np.array([v[1] for v in CASES.values()])
    fluid = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=fluid, fillage=fill, intake_ratio=ratio, transfer=0.05)
    pred = predict_surface(well, np.repeat(s[None], len(CASES), 0), 60 / SPM, pump, nu=NU,
                           tol=1e-9, elements=60)
    rng = np.random.default_rng(7)
    cards = []
    for i, name in enumerate(CASES):
        load = pred.surface_load[i] + well.buoyant_weight()
        load = load + 0.01 * np.ptp(load) * rng.standard_normal(load.size)
        cards.append(card(s, load, SPM, name))
    fits = identify_cards(cards, well)
    return well, pred, fluid, fits


@pytest.mark.parametrize("index,name", list(enumerate(CASES)))
def test_each_case_is_identified(made, index: int, name: str) -> None:
    well, pred, fluid, fits = made
    got = fits[index]
    assert got.ok and got.status == "converged", got.reason
    assert got.fit.r2 > 0.99
    truth = measure_pump_card(pred.pump_position[index], pred.pump_load[index], well, SPM)
    q = got.quantities()
    assert q["fluid_load"]["unit"] == "lbf" and q["fillage"]["unit"] == "fraction"
    assert q["fluid_load"]["value"] == pytest.approx(fluid / LBF, rel=0.02)
    assert abs(q["fillage"]["value"] - truth.fillage) < 0.02
    for entry in q.values():  # a full pump's fillage is held: no error
        assert entry["held"] or (entry["stderr"] is not None and entry["stderr"] >= 0)
    damping = got.damping()
    assert damping["value"] == pytest.approx(NU, rel=0.1)
    assert damping["stderr"] > 0 and "identified from the card" in damping["rule"]
    # The diagnostic card is computed with the identified damping and agrees with the
    # fitted pump card.
    assert got.downhole.ok and got.downhole.damping == damping["value"]
    assert got.agreement < 0.02
    # The two solvers on one surface card (the fitted one): within 1 % of the load range.
    assert got.consistency < 0.01


def test_the_two_solvers_converge_to_each_other(made) -> None:
    # The predictive march's pump card against the diagnostic card of the march's own
    # surface load: the difference is the march's elements, so it about halves as they
    # double (measured 0.76, 0.39, 0.20 % of the load range at 30, 60, 120 elements on
    # this 50 % pound).
    got = made[3][2]
    values = np.array(list(got.fit.params.values()))
    differences, previous = [], got.model
    for elements in (30, 60, 120):
        model = PumpSystem(got.model.surface, elements=elements, tol=1e-7)
        model.start_from(previous)
        differences.append(solver_difference(model, values))
        previous = model
    assert differences[0] < 0.01 and differences[2] < 0.003
    assert differences[0] > 1.6 * differences[1] > 2.56 * differences[2]


def test_full_pump_is_said_and_its_gas_parameter_held(made) -> None:
    _well, _pred, _fluid, fits = made
    full = fits[0]
    assert full.full_pump
    assert full.fit.params["liquid_fraction"] == 1.0
    assert "intake_ratio" not in full.fit.free
    assert any("full pump" in n for n in full.notes)
    assert fits[1].full_pump is False
    # Its fillage is the hold, not a measurement: it read "1 +- 9.9e-06", determined.
    fillage = full.quantities()["fillage"]
    assert fillage["held"] and fillage["stderr"] is None and not fillage["determined"]
    assert not fits[1].quantities()["fillage"]["held"]


def test_json_form_has_each_quantity_with_error_and_the_fit(made) -> None:
    got = made[3][2].to_dict()
    assert got["status"] == "converged"
    assert set(got["pump"]) == {"fluid_load", "fillage", "gross_stroke", "net_stroke",
                                "displacement", "intake_pressure"}
    assert set(got["pump"]["fillage"]) == {"value", "stderr", "unit", "determined", "held"}
    assert 0.99 < got["r2"] <= 1 and got["residual_autocorrelation"] is not None
    assert got["energy"]["unit"] == "lbf*in" and got["energy"]["loss_unit"] == "fraction"
    assert 0 < got["energy"]["string_loss"] < 1


def test_damping_held_when_given(made) -> None:
    well, _pred, _fluid, _fits = made
    c = card(surface_motion(n=200, period=60 / SPM), made[1].surface_load[1]
             + well.buoyant_weight(), SPM)
    got = identify_card(c, well, damping=0.2)
    assert got.ok
    assert got.fit.params["damping"] == 0.2 and "damping" not in got.fit.free
    assert got.damping()["rule"].startswith("given")
    assert got.downhole.damping == 0.2


def test_reversed_card_is_turned_round(made) -> None:
    well, _pred, _fluid, fits = made
    forward = fits[2]
    c = forward.card
    back = Card(position=c.position[::-1], load=c.load[::-1], position_unit="in",
                load_unit="lbf", card_id="back").with_spm(SPM)
    got = identify_card(back, well)
    assert got.ok and SurfaceCard.of(back, well).reversed
    assert any("reverse" in n for n in got.notes)
    assert got.quantities()["fillage"]["value"] == pytest.approx(
        forward.quantities()["fillage"]["value"], abs=0.02)
    # Works and checks are taken in time order whichever way the file runs.
    for key in ("surface_work", "diagnostic_pump_work", "measured_loss", "string_loss"):
        assert got.energy()[key] == pytest.approx(forward.energy()[key], rel=0.02), key
    assert got.consistency < 0.01


@pytest.mark.parametrize("index", range(len(CASES)))
def test_the_damping_loses_the_energy_the_measured_card_loses(made, index: int) -> None:
    # The fitted string's loss (fitted surface work against the fitted pump card's) and
    # the measured card's (its work against the diagnostic pump card's at the identified
    # damping) agree: 0.1-0.6 points apart on these cards (0.0-0.6 on the benchmark's).
    energy = made[3][index].energy()
    assert energy["diagnostic_pump_work"] > 0
    assert 0.1 < energy["measured_loss"] < 0.9
    assert abs(energy["measured_loss"] - energy["string_loss"]) < 0.01


def test_bad_cards_are_rows_not_errors(made) -> None:
    well = made[0]
    no_unit = Card(position=np.linspace(0, 1, 50), load=np.ones(50)).with_spm(SPM)
    no_time = Card(position=np.linspace(0, 1, 50), load=np.ones(50), position_unit="in",
                   load_unit="lbf")
    got = identify_cards([no_unit, no_time], well)
    assert [g.status for g in got] == ["invalid-input", "invalid-input"]
    assert "unit" in got[0].reason and "--spm" in got[1].reason
    assert got[0].to_dict() == {"status": "invalid-input", "reason": got[0].reason}
    with pytest.raises(ValueError, match="damping"):
        identify_cards([no_unit], well, damping=-1.0)


def test_model_sensitivities_match_central_differences(made) -> None:
    well = made[0]
    c = made[3][1].card
    model = PumpSystem(SurfaceCard.of(c, well))
    fitted = np.array(list(made[3][1].fit.params.values()))
    # The second sensitivities, a step away, start their perturbed marches from the first
    # ones' state slopes: they must be as good.
    model.simulate(fitted * np.array([0.97, 1.05, 0.98, 1.0, 1.04, 1.0]), None, True)
    values = fitted
    _, jac = model.simulate(values, None, True)
    for j in range(5):
        h = 1e-4 * values[j]
        up, down = values.copy(), values.copy()
        up[j] += h
        down[j] -= h
        ref = (model.simulate(up, None, False)[0] - model.simulate(down, None, False)[0]) / (
            2 * h)
        scale = max(float(np.max(np.abs(ref))), 1e-12)
        assert np.max(np.abs(jac[:, j] - ref)) < 2e-2 * scale, j
    assert np.all(jac[:, 5] == 1.0)
    with pytest.raises(ValueError, match="outside"):
        bad = values.copy()
        bad[3] = 1.5
        model.simulate(bad, None, False)


def test_damping_error_belongs_to_the_fitted_value_only(made) -> None:
    well, pred, _fluid, _fits = made
    s = surface_motion(n=200, period=60 / SPM)
    # A full-pump card reversed and shifted half a stroke: no pump fits it well.
    load = np.roll((pred.surface_load[0] + well.buoyant_weight())[::-1], -60)
    got = identify_card(card(s, load, SPM), well)
    assert got.ok and got.status == "poor-fit"
    assert got.damping()["value"] != got.fit.params["damping"]
    assert got.damping()["stderr"] is None
    assert got.damping()["rule"].startswith("default rule")
    held = identify_card(made[3][1].card, well, damping=0.15)
    assert held.damping() == {"value": 0.15, "stderr": None, "unit": held.damping()["unit"],
                              "rule": "given: nu = 0.15"}


def test_a_full_pump_without_a_periodic_stroke_keeps_the_free_fit(made, monkeypatch) -> None:
    # The full-pump refit starts from the free fit with the liquid fraction at 1; where the
    # march finds no periodic stroke there, the free fit stands (it used to fail the card).
    from pumpid.pump.system import START_DAMPING

    well, _pred, _fluid, fits = made
    original = PumpSystem.simulate

    def no_full_pump(self, values, data, sensitivities):
        if float(values[2]) == 1.0 and float(values[1]) not in START_DAMPING:
            raise ArithmeticError("the march reaches no periodic stroke")
        return original(self, values, data, sensitivities)

    monkeypatch.setattr(PumpSystem, "simulate", no_full_pump)
    got = identify_card(fits[0].card, well)
    assert got.ok and got.status == "converged", got.reason
    assert not got.full_pump and 0.98 <= got.fit.params["liquid_fraction"] < 1.0



def _same_answer(got, direct) -> None:
    """Every free parameter within a fifth of its standard error of the direct fit's."""
    assert set(got.fit.free) == set(direct.free)
    for name in direct.free:
        se = direct.uncertainty.stderr[name]
        assert abs(got.fit.params[name] - direct.params[name]) < 0.2 * se, name


@pytest.mark.parametrize("index", [1, 3])
def test_the_answer_is_the_model_s_own_optimum(made, index: int) -> None:
    # The solver searches on a march of half the elements, then fits the model's march
    # from there: the answer is that march's optimum, as when fitted directly. (Fitting the
    # coarse march plus the fine one's defect instead missed by up to 1.1 standard errors.)
    from pumpid import fit
    from pumpid.pump.identify import SOLVER

    well, _pred, _fluid, fits = made
    surface = SurfaceCard.of(fits[index].card, well)
    direct = fit(PumpSystem(surface), surface, solver=SOLVER)
    assert fits[index].model.elements == 30
    _same_answer(fits[index], direct)


def test_no_stroke_from_rest_at_the_search_s_answer_searches_the_model(made,
                                                                        monkeypatch) -> None:
    # Where the model's march finds no periodic stroke at the search's answer (from the
    # search's stroke, nor from rest), the search runs again on the model's march itself:
    # same answer, no failure.
    from pumpid import fit
    from pumpid.pump.identify import SOLVER

    well, _pred, _fluid, fits = made
    original = PumpSystem.run
    failed = []

    def first_fails(self, values, warm=None, tol=None):
        if self.elements == 30 and not failed:
            failed.append(values)
            raise ArithmeticError("the march reaches no periodic stroke")
        return original(self, values, warm, tol)

    monkeypatch.setattr(PumpSystem, "run", first_fails)
    got = identify_card(fits[1].card, well)
    assert failed and got.status == "converged"
    assert got.model.elements == 30 and got.fit.derived["fillage"].value > 0
    monkeypatch.undo()
    surface = SurfaceCard.of(fits[1].card, well)
    _same_answer(got, fit(PumpSystem(surface), surface, solver=SOLVER))


def test_a_full_pump_whose_free_search_crawls_is_the_full_pump_fitted_directly() -> None:
    # With little noise a full pump's free search sits at liquid fraction 1, where the
    # intake ratio moves nothing, and crawls; the search's budget cuts it short, the
    # full-pump fit takes over, and the answer is the model's own full-pump optimum.
    from pumpid import FitOptions, fit
    from pumpid.pump.identify import SEARCH_SOLVER, SOLVER
    from pumpid.pump.system import START_INTAKE_RATIO

    assert SEARCH_SOLVER.max_evaluations is not None
    well = three_tapers()
    s = surface_motion(n=200, period=60 / SPM)
    fluid = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=fluid, fillage=1.0, intake_ratio=0.01, transfer=0.05)
    pred = predict_surface(well, s, 60 / SPM, pump, nu=NU, tol=1e-9, elements=60)
    load = pred.surface_load[0] + well.buoyant_weight()
    load = load + 0.002 * np.ptp(load) * np.random.default_rng(8).standard_normal(load.size)
    c = card(s, load, SPM)
    got = identify_card(c, well)
    assert got.status == "converged" and got.full_pump
    surface = SurfaceCard.of(c, well)
    held = {"liquid_fraction": 1.0, "intake_ratio": START_INTAKE_RATIO}
    direct = fit(PumpSystem(surface), surface, options=FitOptions(fixed=held), solver=SOLVER)
    _same_answer(got, direct)


def test_a_card_the_coarse_march_cannot_start_is_searched_on_the_model(made,
                                                                       monkeypatch) -> None:
    # Where no start reaches a periodic stroke of the search's 15-element march, the search
    # runs on the model's own march: same answer, no failure.
    from pumpid import fit
    from pumpid.pump.identify import SOLVER

    well, _pred, _fluid, fits = made
    original = PumpSystem.start

    def coarse_fails(self, data):
        if self.elements != 30:
            raise ValueError("no start reaches a periodic stroke")
        return original(self, data)

    monkeypatch.setattr(PumpSystem, "start", coarse_fails)
    got = identify_card(fits[1].card, well)
    assert got.status == "converged" and got.model.elements == 30
    monkeypatch.undo()
    surface = SurfaceCard.of(fits[1].card, well)
    _same_answer(got, fit(PumpSystem(surface), surface, solver=SOLVER))


@pytest.mark.parametrize("index", range(len(CASES)))
def test_the_quantities_errors_are_the_delta_method_over_the_fit(made, index: int) -> None:
    # The pump quantities' errors come from the fit's own sensitivity strokes where the
    # fit ended (forward differences); they are the delta method over the parameters'
    # covariance, whose slopes central differences of the fitted model give independently.
    got = made[3][index]
    model, fit = got.model, got.fit
    names = model.param_names()
    values = np.array([fit.params[n] for n in names])
    # The independent-noise errors against the independent-noise covariance (the errors
    # shown may be the robust ones: the same delta method over the robust covariance).
    names_cov = list(fit.uncertainty.names)
    grad = np.zeros((len(names_cov), 2))
    for a, name in enumerate(names_cov):
        j = names.index(name)
        if name == "load_offset":
            continue
        step = 1e-4 * values[j]
        up, down = values.copy(), values.copy()
        up[j] += step
        down[j] -= step
        if up[j] > model.parameters[j].upper:
            up[j] = values[j]
            step /= 2
        q_up, q_down = model.quantities(up), model.quantities(down)
        grad[a] = (q_up - q_down)[[0, 1]] / (up[j] - down[j])
    white = np.array(fit.uncertainty.covariance_white)
    expected = np.sqrt(np.einsum("ai,ab,bi->i", grad, white, grad))
    for k, q in enumerate(("fillage", "gross_stroke")):
        if q == "fillage" and got.full_pump:  # held with the liquid fraction: no error
            assert math.isnan(fit.derived[q].stderr_white) and not fit.derived[q].determined
            continue
        assert fit.derived[q].stderr_white == pytest.approx(expected[k], rel=0.05)


def test_evaluations_count_every_fit_of_the_identification(made, monkeypatch) -> None:
    import pumpid.pump.identify as identify_module

    well, _pred, _fluid, fits = made
    spent: list[int] = []
    real_fit = identify_module.fit

    def counted(*args, **kwargs):
        res = real_fit(*args, **kwargs)
        spent.append(res.nfev)
        return res

    monkeypatch.setattr(identify_module, "fit", counted)
    got = identify_card(fits[1].card, well)
    assert len(spent) >= 2  # the search, then the final fit
    assert got.evaluations == sum(spent) > got.fit.nfev
    assert got.to_dict()["evaluations"] == got.evaluations


def test_the_solvers_check_is_made_when_asked_and_once(made, monkeypatch) -> None:
    import pumpid.pump.identify as identify_module

    well, _pred, _fluid, fits = made
    calls: list[int] = []
    real = identify_module.solver_difference

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(identify_module, "solver_difference", counted)
    got = identify_card(fits[2].card, well)
    assert calls == []  # a batch that never asks does not pay for it
    first = got.consistency
    assert 0 < first < 0.01 and got.consistency == first and len(calls) == 1
    assert got.to_dict()["consistency"] == first and len(calls) == 1


def test_the_pump_card_shown_is_the_finer_marchs_and_agrees_with_the_diagnostic() -> None:
    # A fast, lightly damped 50 % pound: the sharp pickup the fit's 30-element march rounds
    # most. Drawn by twice the elements, the card is within 1 % of the load range of the
    # diagnostic card of the same surface load; the fit's own march is not.
    well = three_tapers()
    spm, n = 9.75, 173
    s = surface_motion(n=n, period=60 / spm)
    fluid = 0.75 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=fluid, fillage=0.5, intake_ratio=0.01, transfer=0.068)
    pred = predict_surface(well, s, 60 / spm, pump, nu=0.08, tol=1e-9, elements=120,
                           max_cycles=300)
    load = pred.surface_load[0] + well.buoyant_weight()
    load = load + 0.01 * np.ptp(load) * np.random.default_rng(3).standard_normal(n)
    got = identify_card(card(s, load, spm, "sharp"), well)
    assert got.ok and got.status == "converged", got.reason
    values = np.array(list(got.fit.params.values()))
    fine = got.fine
    assert fine is not None and fine.elements == 2 * got.model.elements
    pos, pump_load = fine.pump_card(values)
    shown = got.pump_card()
    assert shown is not None
    np.testing.assert_allclose(shown[0], pos / fine.surface.position_factor, atol=1e-9)
    np.testing.assert_allclose(shown[1], pump_load / fine.surface.load_factor, rtol=1e-6)
    coarse = solver_difference(got.model, values)
    print(f"solvers apart: {100 * coarse:.2f} % at {got.model.elements} elements, "
          f"{100 * got.consistency:.2f} % at {fine.elements}")
    assert got.consistency < 0.01 < coarse
    assert got.consistency < 0.7 * coarse


def test_a_pump_card_no_march_can_draw_is_none_and_its_checks_nan(made, monkeypatch) -> None:
    import dataclasses
    import math

    _well, _pred, _fluid, fits = made
    fresh = dataclasses.replace(fits[1])  # nothing worked out yet

    def no_stroke(self, values, tol=None, warm=None):
        raise ArithmeticError("no periodic stroke")

    monkeypatch.setattr(PumpSystem, "pump_card", no_stroke)
    assert fresh.ok and fresh.pump_card() is None
    assert math.isnan(fresh.agreement) and math.isnan(fresh.consistency)
    out = fresh.to_dict()
    assert out["agreement"] is None and out["consistency"] is None
    assert out["energy"]["pump_work"] is None and out["energy"]["surface_work"] > 0
    assert out["pump"]["fillage"]["value"] is not None  # the quantities stand


def test_the_pump_s_errors_do_not_depend_on_the_card_s_first_sample() -> None:
    # A stroke repeats: the rod string's model is a periodic one, and its errors' serial
    # statistics run around the stroke. The same card started at other samples gives the
    # same quantities and errors (they had moved 0.3-0.4 % with the start on this card,
    # tens of per cent on short ones).
    well = three_tapers()
    s = surface_motion(n=200, period=60 / SPM)
    fluid = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=fluid, fillage=np.array([0.7]), intake_ratio=np.array([0.01]),
                     transfer=0.05)
    pred = predict_surface(well, s[None], 60 / SPM, pump, nu=NU, tol=1e-9, elements=60)
    load = pred.surface_load[0] + well.buoyant_weight()
    rng = np.random.default_rng(3)
    noise = np.zeros(load.size)
    for i in range(1, 3 * load.size):  # AR(1) of rho 0.9 taken round the stroke
        noise[i % load.size] = 0.9 * noise[(i - 1) % load.size] + rng.standard_normal()
    load = load + 0.01 * np.ptp(load) * noise / noise.std()
    base = identify_card(card(s, load, SPM, "start 0"), well)
    assert base.ok and base.fit.errors_shown == "robust"
    for shift in (37, 111):
        turned = identify_card(card(np.roll(s, -shift), np.roll(load, -shift), SPM,
                                    f"start {shift}"), well)
        assert turned.status == base.status
        for name, entry in base.quantities().items():
            other = turned.quantities()[name]
            assert other["value"] == pytest.approx(entry["value"], rel=1e-4), name
            if entry["stderr"] is not None:
                assert other["stderr"] == pytest.approx(entry["stderr"], rel=1e-3), name
