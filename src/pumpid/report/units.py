"""Units as reports show them (a light module: the terminal output needs it without
matplotlib)."""

from __future__ import annotations

import math
import re

from ..cards import BARREL_M3, LOAD_UNITS, POSITION_UNITS, PSI_PA, TIME_UNITS
from ..models import model_class
from ..result import Units

__all__ = ["UNSTATED_UNITS", "model_param_units", "unit_factor", "unit_size", "unit_text"]


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


# Sizes in SI of the units a card's quantities are stated in, with their dimension as powers
# of (length, force, time). Written out here rather than taken from a units library: the
# set is small and closed (the cards' own units and the pump quantities'), and a library
# would be a dependency of every report for a few dozen names.
_BASE: dict[str, tuple[float, tuple[int, int, int]]] = {
    **{u: (f, (1, 0, 0)) for u, f in POSITION_UNITS.items()},
    **{u: (f, (0, 1, 0)) for u, f in LOAD_UNITS.items()},
    **{u: (f, (0, 0, 1)) for u, f in TIME_UNITS.items()},
    "d": (86400.0, (0, 0, 1)),
    "Hz": (1.0, (0, 0, -1)),
    "bbl": (BARREL_M3, (3, 0, 0)),
    "Pa": (1.0, (-2, 1, 0)),
    "kPa": (1e3, (-2, 1, 0)),
    "MPa": (1e6, (-2, 1, 0)),
    "bar": (1e5, (-2, 1, 0)),
    "psi": (PSI_PA, (-2, 1, 0)),
    "1": (1.0, (0, 0, 0)),
    "-": (1.0, (0, 0, 0)),
    "fraction": (1.0, (0, 0, 0)),
    "dimensionless": (1.0, (0, 0, 0)),
}
_TOKEN = re.compile(r"^([A-Za-z]+|1|-)(?:\^?(-?\d+))?$")


def unit_size(unit: str) -> tuple[float, tuple[int, int, int]] | None:
    """A unit's size in SI (m, N, s) and its dimension as powers of length, force and
    time: ``"lbf*s^2/in"`` is (175.1, (-1, 1, 2)).

    Parameters
    ----------
    unit : str
        Products and quotients of the cards' units, ``d``, ``Hz``, ``bbl``, pressures and
        ``m3``-style powers.

    Returns
    -------
    tuple or None
        (size, dimension); None for anything else (a unit in brackets, a name not known).
    """
    text = str(unit).strip()
    if not text or "(" in text:
        return None
    size, dims = 1.0, [0, 0, 0]
    for k, part in enumerate(text.split("/")):
        for token in part.split("*"):
            match = _TOKEN.match(token.strip())
            if match is None or match.group(1) not in _BASE:
                return None
            base, dim = _BASE[match.group(1)]
            power = int(match.group(2) or 1) * (1 if k == 0 else -1)
            try:
                size *= base**power
            except OverflowError:  # "lbf^1000": no unit a card states
                return None
            dims = [d + power * e for d, e in zip(dims, dim, strict=True)]
    return size, (dims[0], dims[1], dims[2])


def unit_factor(from_unit: str, to_unit: str) -> float | None:
    """What a value in ``from_unit`` is multiplied by to be in ``to_unit``.

    Parameters
    ----------
    from_unit, to_unit : str

    Returns
    -------
    float or None
        1 for the same unit; None when either is not known (:func:`unit_size`) or their
        dimensions differ.
    """
    if str(from_unit) == str(to_unit):
        return 1.0
    a, b = unit_size(from_unit), unit_size(to_unit)
    if a is None or b is None or a[1] != b[1] or not (b[0] > 0 and math.isfinite(a[0])):
        return None
    return a[0] / b[0]
