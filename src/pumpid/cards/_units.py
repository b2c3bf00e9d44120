"""Position, load and time units used by dynamometer cards.

All factors are exact by definition (1 in = 0.0254 m, 1 lbf = 4.4482216152605 N,
1 kgf = 9.80665 N), so converting back and forth loses nothing but rounding.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._errors import CardError

__all__ = [
    "BARREL_M3",
    "LOAD_UNITS",
    "POSITION_UNITS",
    "PSI_PA",
    "TIME_UNITS",
    "convert_load",
    "convert_position",
    "load_factor",
    "normalize_load_unit",
    "normalize_position_unit",
    "normalize_time_unit",
    "position_factor",
]

_LBF_N = 4.4482216152605
#: One pound-force per square inch in pascals, and one oil barrel in cubic metres (exact by
#: definition): the US well files' pressures and the pump's displacement.
PSI_PA = _LBF_N / 0.0254**2
BARREL_M3 = 0.158987294928

#: Canonical position units and their size in metres.
POSITION_UNITS: Mapping[str, float] = MappingProxyType(
    {"in": 0.0254, "ft": 0.3048, "m": 1.0, "cm": 0.01, "mm": 0.001}
)

#: Canonical load units and their size in newtons.
LOAD_UNITS: Mapping[str, float] = MappingProxyType(
    {
        "lbf": _LBF_N,
        "klbf": 1000.0 * _LBF_N,
        "N": 1.0,
        "daN": 10.0,
        "kN": 1000.0,
        "kgf": 9.80665,
    }
)

#: Canonical time units and their size in seconds (time is always stored in seconds).
TIME_UNITS: Mapping[str, float] = MappingProxyType(
    {"s": 1.0, "ms": 0.001, "min": 60.0, "h": 3600.0}
)

# Spellings accepted on input, lower-cased, mapped to the canonical name.
_POSITION_ALIASES = {
    "in": "in", "inch": "in", "inches": "in", '"': "in", "in.": "in",
    "ft": "ft", "foot": "ft", "feet": "ft", "'": "ft",
    "m": "m", "metre": "m", "metres": "m", "meter": "m", "meters": "m",
    "cm": "cm", "centimetre": "cm", "centimetres": "cm", "centimeter": "cm", "centimeters": "cm",
    "mm": "mm", "millimetre": "mm", "millimetres": "mm", "millimeter": "mm", "millimeters": "mm",
}  # fmt: skip
_LOAD_ALIASES = {
    "lbf": "lbf", "lb": "lbf", "lbs": "lbf", "lb-f": "lbf", "lbs-f": "lbf", "pound": "lbf",
    "pounds": "lbf", "pound-force": "lbf", "pounds-force": "lbf",
    "klbf": "klbf", "klb": "klbf", "klbs": "klbf", "kip": "klbf", "kips": "klbf",
    "kilopound": "klbf", "kilopounds": "klbf",
    "n": "N", "newton": "N", "newtons": "N",
    "dan": "daN", "decanewton": "daN", "decanewtons": "daN",
    "kn": "kN", "kilonewton": "kN", "kilonewtons": "kN",
    "kgf": "kgf", "kg-f": "kgf", "kp": "kgf", "kilopond": "kgf", "kilogram-force": "kgf",
}  # fmt: skip
_TIME_ALIASES = {
    "s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s",
    "ms": "ms", "msec": "ms", "millisecond": "ms", "milliseconds": "ms",
    "min": "min", "minute": "min", "minutes": "min",
    "h": "h", "hr": "h", "hour": "h", "hours": "h",
}  # fmt: skip


def _normalize(
    unit: object, aliases: Mapping[str, str], known: Mapping[str, float], kind: str, field: str
) -> str:
    if not isinstance(unit, str):
        raise CardError(
            f"{kind} unit must be a string, got {type(unit).__name__}; known: {', '.join(known)}",
            field=field,
        )
    key = unit.strip().lower()
    if key in aliases:
        return aliases[key]
    extra = sorted(a for a in aliases if a not in {k.lower() for k in known} and a.isalpha())
    raise CardError(
        f"unknown {kind} unit {unit!r}; known units: {', '.join(known)} "
        f"(also accepted: {', '.join(extra)})",
        field=field,
    )


def normalize_position_unit(unit: str, *, field: str = "position_unit") -> str:
    """Return the canonical name of a position unit.

    Parameters
    ----------
    unit : str
        Any accepted spelling, case-insensitive (``"in"``, ``"inches"``, ``"feet"``,
        ``"metres"``, ``"mm"`` ...).
    field : str, optional
        Name reported in the error when the unit is unknown.

    Returns
    -------
    str
        One of the keys of :data:`POSITION_UNITS`.

    Raises
    ------
    CardError
        If the unit is not known; the message lists the known units.
    """
    return _normalize(unit, _POSITION_ALIASES, POSITION_UNITS, "position", field)


def normalize_load_unit(unit: str, *, field: str = "load_unit") -> str:
    """Return the canonical name of a load unit (one of :data:`LOAD_UNITS`).

    Parameters
    ----------
    unit : str
        Any accepted spelling, case-insensitive (``"lbf"``, ``"lb"``, ``"kip"``, ``"kN"``,
        ``"kgf"`` ...).
    field : str, optional
        Name reported in the error when the unit is unknown.

    Raises
    ------
    CardError
        If the unit is not known; the message lists the known units.
    """
    return _normalize(unit, _LOAD_ALIASES, LOAD_UNITS, "load", field)


def normalize_time_unit(unit: str, *, field: str = "time_unit") -> str:
    """Return the canonical name of a time unit (one of :data:`TIME_UNITS`).

    Raises
    ------
    CardError
        If the unit is not known.
    """
    return _normalize(unit, _TIME_ALIASES, TIME_UNITS, "time", field)


def is_unit_spelling(token: str) -> bool:
    """Tell whether ``token`` is an accepted spelling of any position, load or time unit."""
    key = token.strip().lower()
    return key in _POSITION_ALIASES or key in _LOAD_ALIASES or key in _TIME_ALIASES


def position_factor(from_unit: str, to_unit: str) -> float:
    """Multiplier taking positions in ``from_unit`` to ``to_unit``."""
    a = POSITION_UNITS[normalize_position_unit(from_unit)]
    b = POSITION_UNITS[normalize_position_unit(to_unit)]
    return a / b


def load_factor(from_unit: str, to_unit: str) -> float:
    """Multiplier taking loads in ``from_unit`` to ``to_unit``."""
    a = LOAD_UNITS[normalize_load_unit(from_unit)]
    b = LOAD_UNITS[normalize_load_unit(to_unit)]
    return a / b


def convert_position(values: ArrayLike, from_unit: str, to_unit: str) -> NDArray[np.float64]:
    """Convert positions between units.

    Parameters
    ----------
    values : array_like
        Positions in ``from_unit``.
    from_unit, to_unit : str
        Any accepted spellings (see :func:`normalize_position_unit`).

    Returns
    -------
    numpy.ndarray
        Float array in ``to_unit``.

    Raises
    ------
    CardError
        If either unit is unknown.

    Examples
    --------
    >>> float(convert_position([1.0], "ft", "in")[0])
    12.0
    """
    return np.asarray(values, dtype=float) * position_factor(from_unit, to_unit)


def convert_load(values: ArrayLike, from_unit: str, to_unit: str) -> NDArray[np.float64]:
    """Convert loads between units (see :func:`convert_position`).

    Examples
    --------
    >>> float(convert_load([1.0], "kgf", "N")[0])
    9.80665
    """
    return np.asarray(values, dtype=float) * load_factor(from_unit, to_unit)
