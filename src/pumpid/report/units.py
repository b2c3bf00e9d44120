"""Units as reports show them (a light module: the terminal output needs it without
matplotlib)."""

from __future__ import annotations

from ..models import model_class
from ..result import Units

__all__ = ["UNSTATED_UNITS", "model_param_units", "unit_text"]


#: What :func:`pumpid.fit` records for a card as the unit of a card whose file states none.
UNSTATED_UNITS = ("load-unit", "position-unit")


def unit_text(unit: str) -> str:
    """A unit for display: the placeholder of a unit the data did not state reads so."""
    return "unit not stated" if unit in UNSTATED_UNITS else unit


def model_param_units(model: str, units: Units) -> dict[str, str]:
    """Units of a model's parameters (by the model's name) in the data's units.

    For the limiting model of a boundary fit, whose stored units may be those of a fit
    made without the card's units; empty when the name is not a known model.
    """
    try:
        cls = model_class(model)
    except ValueError:
        return {}
    return {p.name: p.unit_for(units.load, units.position) for p in cls.param_info()}
