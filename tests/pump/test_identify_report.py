"""The identified card's figure (:func:`pumpid.pump.identify_report.draw_identified`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pumpid.pump import PumpSystem, identify_card
from pumpid.pump.identify_report import DownholeCard, draw_identified

from ..rods.strings import card, pound_70

SPM = 8.0


@pytest.fixture(scope="module")
def fitted():
    well, s, pred, _fluid = pound_70(160, SPM)
    load = pred.surface_load[0] + well.buoyant_weight()
    load = load + 0.01 * np.ptp(load) * np.random.default_rng(5).standard_normal(load.size)
    return identify_card(card(s, load, SPM, "pound"), well)


def test_the_figure_is_drawn_with_the_identified_pump_card(fitted, tmp_path) -> None:
    path = tmp_path / "card.png"
    draw_identified(DownholeCard.of(fitted.downhole, fitted), path)
    assert path.stat().st_size > 10_000


def test_the_figure_is_drawn_when_no_march_can_draw_the_pump_card(fitted, tmp_path,
                                                                    monkeypatch) -> None:
    def no_stroke(self, values, tol=None, warm=None):
        raise ArithmeticError("no periodic stroke")

    monkeypatch.setattr(PumpSystem, "pump_card", no_stroke)
    fresh = dataclasses.replace(fitted)  # nothing drawn yet
    shown = DownholeCard.of(fresh.downhole, fresh)
    assert fresh.pump_card() is None and "pump_card" not in shown.to_dict()["identification"]
    path = tmp_path / "card.png"
    draw_identified(shown, path)
    assert path.stat().st_size > 10_000
