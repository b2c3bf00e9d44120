"""Unit conversion for the views across wells (``pumpid.report.units.unit_factor``)."""

from __future__ import annotations

import pytest

from pumpid.report.units import unit_factor, unit_size


def test_the_cards_and_pump_units_convert_exactly() -> None:
    assert unit_factor("lbf", "kN") == pytest.approx(4.4482216152605e-3, rel=1e-15)
    assert unit_factor("ft", "m") == pytest.approx(0.3048, rel=1e-15)
    assert unit_factor("bbl/d", "m3/d") == pytest.approx(0.158987294928, rel=1e-15)
    assert unit_factor("psi", "kPa") == pytest.approx(6.894757293168361, rel=1e-15)
    # Compound units of the models' parameters and derived quantities.
    assert unit_factor("lbf*s^2/in", "N*s^2/m") == pytest.approx(4.4482216152605 / 0.0254)
    assert unit_factor("klbf/ft", "lbf/in") == pytest.approx(1000 / 12)
    assert unit_factor("Hz", "Hz") == unit_factor("fraction", "1") == 1.0
    assert unit_size("lbf*s/in") == (pytest.approx(4.4482216152605 / 0.0254), (-1, 1, 1))


def test_units_of_other_dimensions_or_unknown_do_not_convert() -> None:
    assert unit_factor("lbf", "in") is None
    assert unit_factor("lbf/in", "lbf*s/in") is None
    assert unit_factor("furlongs", "m") is None
    assert unit_factor("Pa/(m^3/s)", "Pa*s/m^3") is None  # brackets: not read
    assert unit_factor("unit not stated", "kN") is None
