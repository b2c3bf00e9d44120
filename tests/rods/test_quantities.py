"""Pump quantities measured on known pump cards, with their units."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pumpid.rods import Tubing, measure_pump_card

from .strings import three_tapers


def ideal_card(fillage: float, n: int = 400, stroke: float = 2.0, fo: float = 20000.0):
    """A plunger moving as a cosine; full load up, released at ``fillage`` on the way down."""
    phase = np.arange(n) / n
    y = stroke / 2 * (1 - np.cos(2 * np.pi * phase))
    rising = phase < 0.5
    h = y / stroke
    load = np.where(rising, fo * np.clip(h / 0.02, 0, 1),
                    fo * np.clip((h - fillage) / 0.02 + 1, 0, 1))
    return y, load


@pytest.mark.parametrize("fillage", [1.0, 0.8, 0.5, 0.35])
def test_fillage_and_fluid_load_of_ideal_cards(fillage: float) -> None:
    well = three_tapers()
    y, load = ideal_card(fillage)
    m = measure_pump_card(y, load, well, spm=8.0)
    assert m.gross_stroke == pytest.approx(2.0, rel=1e-4)
    assert m.fluid_load == pytest.approx(20000.0)
    assert m.upper_load == pytest.approx(20000.0) and m.lower_load == pytest.approx(0.0)
    # The load crosses its middle 1 % of the stroke below the liquid (half the ramp).
    assert m.fillage == pytest.approx(min(fillage, 1.0) - 0.01, abs=0.003)
    assert m.net_stroke == pytest.approx(m.fillage * m.gross_stroke)
    assert m.displacement == pytest.approx(well.pump.area * m.net_stroke * 8.0 * 1440)
    pressure = 1000 * 9.80665 * well.pump.depth
    assert m.intake_pressure == pytest.approx(pressure - 20000.0 / well.pump.area)


def test_free_tubing_stretch_shortens_the_net_stroke() -> None:
    well = three_tapers()
    free = dataclasses.replace(well, tubing=Tubing(anchored=False, outer_diameter=0.0603,
                                                   inner_diameter=0.0503))
    y, load = ideal_card(1.0)
    anchored = measure_pump_card(y, load, well, 8.0)
    loose = measure_pump_card(y, load, free, 8.0)
    stretch = 20000.0 * well.pump.depth / (free.tubing.modulus * free.tubing.area)
    assert loose.net_stroke == pytest.approx(anchored.net_stroke - stretch)
    assert any("tubing's stretch" in n for n in loose.notes)


def test_without_fluid_or_speed_the_quantities_say_so() -> None:
    well = three_tapers(fluid=None)
    y, load = ideal_card(0.8)
    m = measure_pump_card(y, load, well, None)
    assert m.intake_pressure is None and m.displacement is None
    assert any("no fluid data" in n for n in m.notes)
    assert any("no pumping speed" in n for n in m.notes)
    with pytest.raises(ValueError, match="does not move"):
        measure_pump_card(np.zeros(10), load[:10], well, 8.0)


def test_quantities_carry_units_of_card_and_well_file() -> None:
    from pumpid.rods import diagnose_card

    from .strings import card, surface_motion

    well = three_tapers()
    s = surface_motion()
    load = 30000 + 9000 * np.sin(2 * np.pi * np.arange(200) / 200)
    us = diagnose_card(card(s, load, 8.0), well).quantities()
    assert us["gross_stroke"]["unit"] == "in" and us["fluid_load"]["unit"] == "lbf"
    assert us["displacement"]["unit"] == "bbl/d" and us["intake_pressure"]["unit"] == "psi"
    assert us["fillage"]["unit"] == "fraction" and 0 <= us["fillage"]["value"] <= 1
    metric = diagnose_card(card(s, load, 8.0, metric=True), well)
    q = metric.quantities()
    assert q["gross_stroke"]["unit"] == "m" and q["fluid_load"]["unit"] == "kN"
    assert q["gross_stroke"]["value"] == pytest.approx(us["gross_stroke"]["value"] * 0.0254)
    assert any("converted" in n for n in metric.notes)
    row = metric.to_row()
    assert row["pump_fluid_load_unit"] == "kN" and row["downhole_status"] == "computed"


def test_a_coarse_card_measures_its_lines_from_the_nearest_samples() -> None:
    # Four samples a stroke: no downstroke sample lies in the lower line's band (5-30 % of
    # the stroke), so the line is the median of the three downstroke samples nearest the
    # band's middle; a batch measures each card as alone.
    from pumpid.rods import measure_pump_cards

    well = three_tapers()
    y = 1 - np.cos(2 * np.pi * np.arange(4) / 4)
    load = np.array([900.0, 20000.0, 19000.0, 300.0])
    m = measure_pump_card(y, load, well, 8.0)
    h = (y - y.min()) / np.ptp(y)
    top = int(np.argmax(y))
    down = [i % 4 for i in range(top, 5)]
    nearest = sorted(down, key=lambda i: abs(h[i] - 0.175))[:3]
    assert not any(0.05 <= h[i] <= 0.3 for i in down)
    assert m.lower_load == pytest.approx(np.median(load[nearest]))
    assert m.upper_load == pytest.approx(np.median(load[[i for i in range(top + 1)
                                                         if 0.4 <= h[i] <= 0.9]]))
    other = load[::-1].copy()
    both = measure_pump_cards(np.array([y, y]), np.array([load, other]), [well, well],
                              [8.0, 8.0])
    assert both == [m, measure_pump_card(y, other, well, 8.0)]
