"""The system model of the surface card (:class:`pumpid.pump.PumpSystem`): the options the
identification's two stages use."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid.pump import PumpSystem, SurfaceCard

from ..rods.strings import INCH, LBF, card, pound_70

SPM = 8.0


@pytest.fixture(scope="module")
def pound():
    well, s, pred, fluid = pound_70(200, SPM)
    surface = SurfaceCard.of(card(s, pred.surface_load[0] + well.buoyant_weight(), SPM), well)
    # fluid load (lbf), damping, liquid fraction, intake ratio, transfer (in), offset (lbf)
    values = np.array([fluid / LBF, 0.1, 0.7, 0.01, 0.05 / INCH, 0.0])
    return surface, values, pred


def test_a_search_model_measures_nothing(pound) -> None:
    surface, v, _pred = pound
    assert PumpSystem(surface, 15, derive=False).derived(v, None, False, []) == {}
    assert set(PumpSystem(surface, 15).derived(v, None, False, [])) == {
        "fillage", "gross_stroke", "net_stroke", "displacement", "intake_pressure"}


def test_the_march_converges_to_the_string_it_stands_for(pound) -> None:
    # The search's march (15 elements) is further from the 60-element card than the
    # model's (30), and a looser stopping tolerance changes the load by far less than that.
    surface, v, pred = pound
    truth = pred.surface_load[0] / LBF
    span = float(np.ptp(truth))
    err = {}
    for e in (15, 30):
        m = PumpSystem(surface, e)
        err[e] = np.sqrt(np.mean((m.run(v).out[0] / LBF - truth) ** 2)) / span
    assert err[30] < err[15] < 0.02
    loose = PumpSystem(surface, 30, tol=1e-7).run(v)
    assert loose.cycles < PumpSystem(surface, 30).run(v).cycles
    diff = np.sqrt(np.mean((loose.out[0] / LBF - PumpSystem(surface, 30).run(v).out[0] / LBF)
                           ** 2)) / span
    assert diff < 1e-6 and diff < 1e-3 * err[30]


def test_a_stroke_marched_once_is_not_marched_again_for_its_offset(pound) -> None:
    # The solver evaluates each start after the start has marched it, with the offset
    # levelled and the positive parameters back from its log scale (a few bits off).
    surface, v, _pred = pound
    m = PumpSystem(surface, 15, derive=False)
    m.simulate(v, None, False)
    again = v.copy()
    again[:5] = np.exp(np.log(v[:5]))
    again[5] = 123.0
    assert m.run(again) is m.run(v)
    # A step the solver or a difference takes is another stroke.
    moved = v.copy()
    moved[0] *= 1 + 1e-9
    assert m.run(moved) is not m.run(v)


def test_a_fluid_pound_repeats_one_stroke_from_any_start(pound) -> None:
    # At these values (a fluid pound identified from a noisy copy of this 70 % card), a
    # march that let the pump's spring run past the valve's opening within a step repeated
    # two strokes 1 % of the load range apart: one from rest, another from the stroke of a
    # nearby intake ratio.
    surface, _v, _pred = pound
    v = np.array([4598.711866873145, 0.09836013101889125, 0.701299829855772,
                  0.008854605885099622, 2.079381322614736, 0.0])
    m = PumpSystem(surface, 30)
    near = v.copy()
    near[3] *= 1.1  # the intake ratio
    strokes = [m.run(v, warm, 1e-12).out[0] for warm in (None, m.run(near, None, 1e-12))]
    assert np.max(np.abs(strokes[0] - strokes[1])) < 1e-8 * np.ptp(strokes[0])


def test_a_full_pump_s_intake_ratio_moves_nothing(pound) -> None:
    # Without gas (a liquid fraction of 1) the barrel's load is the liquid's spring alone,
    # whatever the intake ratio: its derivative is zero, not the march's rounding.
    surface, v, _pred = pound
    full = v.copy()
    full[2] = 1.0
    m = PumpSystem(surface, 15, derive=False)
    _load, jac = m.simulate(full, None, True)
    assert np.all(jac[:, 3] == 0.0)
    assert np.all(np.abs(jac[:, [0, 1, 2, 4]]).max(axis=0) > 0)
    # With gas it does move the card.
    _load, jac = m.simulate(v, None, True)
    assert np.abs(jac[:, 3]).max() > 0


def test_a_held_parameter_s_sensitivity_is_not_marched(pound, monkeypatch) -> None:
    # A fit that holds a parameter never reads its column: the march it would cost is
    # saved, and the other columns are the same.
    from pumpid.rods.predict import StringGrid

    surface, v, _pred = pound
    marches = []
    march = StringGrid.march

    def counted(self, *args, **kwargs):
        marches.append(1)
        return march(self, *args, **kwargs)

    monkeypatch.setattr(StringGrid, "march", counted)
    free = PumpSystem(surface, 15, derive=False)
    _load, jac_free = free.simulate(v, None, True)
    n_free = len(marches)
    held = PumpSystem(surface, 15, derive=False)
    held.hold(frozenset({"liquid_fraction", "transfer"}))
    marches.clear()
    _load, jac = held.simulate(v, None, True)
    assert len(marches) == n_free - 2
    assert np.all(jac[:, [2, 4]] == 0.0)
    np.testing.assert_array_equal(jac[:, [0, 1, 3, 5]], jac_free[:, [0, 1, 3, 5]])
