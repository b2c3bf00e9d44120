"""One quantity of a results table: its columns, and which rows count for it.

The change detection (:mod:`.changes`) and the report's figures (:mod:`.figures`) trend the
same values: a card counts for a quantity when its fit (or, for a pump quantity, its pump)
is usable, the value is finite, the card determines it and the fit does not call it an echo
of the stroke. The rule lives here once; each had kept its own copy, and a fix made in one
(an older table's infinite parameter errors read as not determined) had to be made in the
other by hand.

Column conventions: a derived quantity ``NAME`` is the column ``d_NAME``, a parameter
``p_NAME``, a pump quantity ``pump_NAME`` (:mod:`.downhole`); beside each value, ``_se``
(and ``_se_hac`` for a parameter), ``_determined``, ``_unit`` and ``_well_property``
(derived quantities that can echo the stroke). Missing optional columns are read as unknown;
a flag column's missing entries as its default (not determined; a property of the well).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pumpid.models import model_class

from .downhole import is_pump_quantity, pump_quantities, pump_usable

__all__ = [
    "STATUSES",
    "USABLE_STATUSES",
    "QuantityColumns",
    "available_quantities",
    "columns_of",
    "counted",
    "echo_count",
    "flag",
    "larger_error",
    "parameter_unit",
    "with_asked",
]

#: Every status a results row can have.
STATUSES = ("converged", "boundary", "undetermined", "poor-fit", "failed", "invalid-input")
#: Statuses whose values are trended (the others are counted only). Not ``poor-fit``: its
#: reason tells the user to check the record before using the numbers, and a card at
#: R^2 0.24 that did not close had been a field well's latest natural frequency.
USABLE_STATUSES = ("converged", "boundary", "undetermined")
#: Column suffixes beside a value (never a quantity of their own).
_SUFFIXES = ("_se", "_se_hac", "_se_white", "_determined", "_well_property", "_unit")


@dataclass(frozen=True)
class QuantityColumns:
    """Where one quantity lives in a results table.

    Attributes
    ----------
    value : str
        The value's column.
    errors : tuple of str
        Its standard errors' columns (the larger one is used).
    determined : str
        The column saying whether the card determines it.
    unit : str
        The column stating its unit (a parameter's too; a well's unit for a parameter is
        the model's instead, :attr:`unit_from_model`).
    kind : str
        ``"derived"``, ``"parameter"`` or ``"pump"``.
    """

    value: str
    errors: tuple[str, ...]
    determined: str
    unit: str
    kind: str

    @property
    def unit_from_model(self) -> bool:
        """Whether a well's unit for the quantity is the model's (a parameter's, from the
        model and the table's units, :func:`parameter_unit`) rather than its unit column's,
        which then only converts a row's value."""
        return self.kind == "parameter"


def columns_of(quantity: str) -> QuantityColumns:
    """The columns of a quantity named as :func:`available_quantities` names it.

    Parameters
    ----------
    quantity : str
        A derived quantity's name, ``p_<name>`` or ``pump_<name>``.

    Returns
    -------
    QuantityColumns
    """
    if is_pump_quantity(quantity):
        # The identification's standard error and whether it determines the value (both
        # absent without it: the scatter alone, every computed card).
        return QuantityColumns(quantity, (f"{quantity}_se",), f"{quantity}_determined",
                               f"{quantity}_unit", "pump")
    if quantity.startswith("p_"):
        return QuantityColumns(quantity, (f"{quantity}_se", f"{quantity}_se_hac"),
                               f"{quantity}_determined", f"{quantity}_unit", "parameter")
    col = f"d_{quantity}"
    return QuantityColumns(col, (f"{col}_se",), f"{col}_determined", f"{col}_unit",
                           "derived")


def available_quantities(table: pd.DataFrame, *, parameters: bool = False) -> list[str]:
    """Names of the quantities a table holds: derived ones, then (optionally) parameters,
    then pump quantities.

    Derived quantity ``NAME`` is the column ``d_NAME``; parameter ``NAME`` is listed as
    ``p_NAME`` (its column name), so the two kinds cannot collide.

    Parameters
    ----------
    table : pandas.DataFrame
        A results table.
    parameters : bool, default False
        Also list the model parameters.

    Returns
    -------
    list of str
    """
    derived = [
        c[2:] for c in table.columns
        if isinstance(c, str) and c.startswith("d_") and not c.endswith(_SUFFIXES)
    ]  # fmt: skip
    params = [
        c for c in table.columns
        if parameters and isinstance(c, str) and c.startswith("p_") and not c.endswith(_SUFFIXES)
    ]  # fmt: skip
    return derived + params + pump_quantities(table)


def larger_error(frame: pd.DataFrame, quantity: str) -> NDArray[np.float64]:
    """Each row's standard error of a quantity: the larger of its error columns (NaN where
    none is known; a negative entry is read as unknown).

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of a results table.
    quantity : str
        As for :func:`columns_of`.

    Returns
    -------
    numpy.ndarray
    """
    se = np.full(len(frame), np.nan)
    for c in columns_of(quantity).errors:
        if c in frame.columns:
            other = pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float)
            se = np.fmax(se, np.where(other >= 0, other, np.nan))
    return se


def counted(frame: pd.DataFrame, quantity: str, values: NDArray[np.float64]
            ) -> NDArray[np.bool_]:
    """Which rows' values of a quantity are trended.

    A row counts when its value is finite; its fit's status is usable (a pump quantity:
    its pump was identified, or its downhole card computed); the card determines the value
    (a table written before parameters had their own verdict: the parameter's error is
    finite; an alert on c1 had been sized at "-68.8 standard errors" from cards whose own
    errors were all infinite); and the fit does not call the value an echo of the stroke
    (a stroke frequency drawn as the well's resonance contradicted the card's own warning),
    unless the user named the quantity (:func:`with_asked` drops that verdict).

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of a results table.
    quantity : str
        As for :func:`columns_of`.
    values : numpy.ndarray
        The quantity's values on those rows (converted to another unit where the caller
        needs it; NaN where that cannot be).

    Returns
    -------
    numpy.ndarray of bool
    """
    cols = columns_of(quantity)
    keep = np.isfinite(np.asarray(values, dtype=float))
    usable = pump_usable(frame) if cols.kind == "pump" else frame["status"].isin(
        USABLE_STATUSES)
    keep &= usable.to_numpy(dtype=bool)
    if cols.determined in frame.columns:
        keep &= flag(frame[cols.determined], default=False)
    elif cols.kind == "parameter" and cols.errors[0] in frame.columns:
        shown = pd.to_numeric(frame[cols.errors[0]], errors="coerce").to_numpy(dtype=float)
        keep &= np.isfinite(shown)
    prop = f"{cols.value}_well_property"
    if prop in frame.columns:
        keep &= flag(frame[prop], default=True)
    return keep


def with_asked(frame: pd.DataFrame, asked: Sequence[str]) -> pd.DataFrame:
    """The table as counted for quantities the user named: their values that fits call an
    echo of the stroke count too, in every view of a report as in its change detection.

    Parameters
    ----------
    frame : pandas.DataFrame
        A results table.
    asked : sequence of str
        The quantities named (as for :func:`columns_of`).

    Returns
    -------
    pandas.DataFrame
        ``frame`` without those quantities' ``<column>_well_property`` verdicts (the same
        object where it has none of them).

    Raises
    ------
    ValueError
        If a quantity asked for is not in the table (a name mistyped was ignored).
    """
    unknown = [q for q in asked if columns_of(q).value not in frame.columns]
    if unknown:
        raise ValueError(f"asked for {', '.join(map(repr, unknown))}, not in the table; it has "
                         f"{', '.join(available_quantities(frame, parameters=True)) or 'none'}")
    drop = [f"{columns_of(q).value}_well_property" for q in asked]
    drop = [c for c in drop if c in frame.columns]
    return frame.drop(columns=drop) if drop else frame


def echo_count(frame: pd.DataFrame, quantity: str) -> int:
    """How many of a quantity's values count only because the user named it: those its fits
    call an echo of the stroke (an alert on them may follow the pumping speed).

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of a results table, as the fits wrote them (not :func:`with_asked`'s).
    quantity : str
        As for :func:`columns_of`.

    Returns
    -------
    int
    """
    cols = columns_of(quantity)
    if cols.value not in frame.columns:
        return 0
    values = pd.to_numeric(frame[cols.value], errors="coerce").to_numpy(dtype=float)
    named = counted(with_asked(frame, [quantity]), quantity, values)
    return int((named & ~counted(frame, quantity, values)).sum())


def flag(column: pd.Series, *, default: bool) -> NDArray[np.bool_]:
    """A flag column as booleans, its missing entries ``default``.

    A table written to Parquet holds booleans (or nulls); one read back from CSV may hold
    their text, where ``astype(bool)`` read "False" as True (any non-empty string), and
    filling a float column of NaN with False is deprecated in pandas.

    Parameters
    ----------
    column : pandas.Series
        The flag column.
    default : bool
        What a missing or unreadable entry means.

    Returns
    -------
    numpy.ndarray of bool
    """
    if column.dtype == object or pd.api.types.is_string_dtype(column.dtype):
        text = column.astype("string").str.strip().str.lower()
        out = np.full(len(column), default)
        out[text.isin(("true", "1", "1.0")).fillna(False).to_numpy(dtype=bool)] = True
        out[text.isin(("false", "0", "0.0")).fillna(False).to_numpy(dtype=bool)] = False
        return out
    values = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)
    return np.where(np.isnan(values), default, values != 0.0)


def parameter_unit(frame: pd.DataFrame, quantity: str) -> str:
    """A parameter's unit from the model's own description, when the table allows it.

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of a results table (their ``model``, ``load_unit`` and ``position_unit``).
    quantity : str
        ``p_<name>``.

    Returns
    -------
    str
        The unit, or ``"model units"`` where the rows do not say one model and its units.
    """
    name = quantity[2:]
    try:
        models = frame["model"].dropna().unique()
        if len(models) != 1:
            return "model units"
        info = {p.name: p for p in model_class(str(models[0])).param_info()}[name]
        load = str(frame["load_unit"].dropna().iloc[0])
        position = str(frame["position_unit"].dropna().iloc[0])
        return info.unit_for(load, position)
    except (KeyError, IndexError, ValueError, AttributeError):
        # No model column, several models, unknown units, or a model class without unit
        # descriptions: say so rather than guess.
        return "model units"
