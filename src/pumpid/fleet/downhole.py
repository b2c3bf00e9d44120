"""Pump quantities in the fleet's results: ``pumpid batch --well-file`` and their trends.

With a well file, each partition of a batch run also computes the downhole (pump) card of
every readable card in one call of :func:`pumpid.rods.diagnose_cards` (the partition's
cards batched, as the fit is) and adds its pump quantities to the card's row, each with its
unit:

``downhole_status``, ``downhole_reason``
    ``computed``, ``invalid-input`` (no unit, no time, a well not in the file, ...) or
    ``failed``, and why. A card whose downhole card cannot be computed keeps its row (the
    fit's columns are unaffected); its pump columns are null and the reason is also added
    to its ``warnings``.
``downhole_well``, ``downhole_method``, ``downhole_damping``, ``downhole_reversed``,
``downhole_notes``
    The well the card was computed with, the method, Gibbs' dimensionless damping factor
    used, whether the card was stored in reverse time order, and everything assumed or
    noticed (`` | ``-separated).
``pump_<name>``, ``pump_<name>_unit``
    For each of :data:`PUMP_QUANTITIES`: the value in the unit of the next column (lengths
    and loads in the card's units, fillage as a fraction, displacement in bbl/d or m3/d and
    intake pressure in psi or kPa by the well file's unit system).

A one-well file applies to every card; otherwise a card is matched to its well by its well
id (:meth:`pumpid.rods.WellFile.for_card`).

The change detector and the fleet report (:mod:`pumpid.fleet.changes`,
:mod:`pumpid.fleet.report`) trend the pump quantities of :data:`TRENDED` by their column
name (``pump_fillage``): a card counts when its downhole card was computed, whatever its
model fit's status.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from pumpid.rods import WellFile, diagnose_cards, read_well_file

from .inputs import BadItem, CardItem

__all__ = ["PUMP_PREFIX", "PUMP_QUANTITIES", "TRENDED", "DownholeSpec", "add_pump_columns",
           "is_pump_quantity", "pump_quantities", "pump_schema", "pump_usable"]

#: Prefix of the pump quantities' columns (and of their names in the change detector).
PUMP_PREFIX = "pump_"
#: The pump quantities of a results row, in column order (:meth:`DownholeResult.quantities`).
PUMP_QUANTITIES = ("gross_stroke", "net_stroke", "fluid_load", "fillage", "upper_load_line",
                   "lower_load_line", "displacement", "intake_pressure")
#: Those trended by default: the load lines are the fluid load's ingredients, and each more
#: quantity tested costs every other some sensitivity (the false-alarm rate is split).
TRENDED = ("fillage", "fluid_load", "net_stroke", "gross_stroke", "displacement",
           "intake_pressure")


@dataclass(frozen=True)
class DownholeSpec:
    """The downhole options of a batch run: the well file and the solver's options.

    Attributes
    ----------
    well_file : str
        Path of the JSON well file.
    wells : WellFile
        Its wells (read and checked once, when the spec is made).
    digest : str
        SHA-256 of the file's bytes: a resumed run must use the same wells.
    damping : float or None
        Gibbs' dimensionless damping factor (None: the default rule of
        :func:`pumpid.rods.diagnose_cards`).
    harmonics : int or None
        Highest harmonic of the Fourier method (None: all the samples resolve).
    """

    well_file: str
    wells: WellFile
    digest: str
    damping: float | None = None
    harmonics: int | None = None

    @classmethod
    def load(cls, well_file: str | os.PathLike[str], *, damping: float | None = None,
             harmonics: int | None = None) -> DownholeSpec:
        """Read the well file and check the options (WellError / ValueError naming them)."""
        if damping is not None and not (np.isfinite(damping) and damping >= 0):
            raise ValueError(f"--damping must be a non-negative number, got {damping}")
        if harmonics is not None and harmonics < 1:
            raise ValueError(f"--harmonics must be at least 1, got {harmonics}")
        path = os.fspath(well_file)
        wells = read_well_file(path)
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        return cls(well_file=path, wells=wells, digest=digest, damping=damping,
                   harmonics=harmonics)

    def to_dict(self) -> dict[str, Any]:
        """The manifest's form."""
        return {"well_file": self.well_file, "sha256": self.digest, "damping": self.damping,
                "harmonics": self.harmonics}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DownholeSpec:
        """The spec of :meth:`to_dict`'s form, the well file read again."""
        return cls.load(str(data["well_file"]), damping=data.get("damping"),
                        harmonics=data.get("harmonics"))


def pump_schema(base: pa.Schema) -> pa.Schema:
    """``base`` with the downhole and pump columns appended (see the module doc)."""
    s, f, b = pa.string(), pa.float64(), pa.bool_()
    extra = [("downhole_status", s), ("downhole_reason", s), ("downhole_well", s),
             ("downhole_method", s), ("downhole_damping", f), ("downhole_reversed", b),
             ("downhole_notes", s)]
    for name in PUMP_QUANTITIES:
        extra += [(f"{PUMP_PREFIX}{name}", f), (f"{PUMP_PREFIX}{name}_unit", s)]
    out = base
    for name, kind in extra:
        out = out.append(pa.field(name, kind))
    return out


def add_pump_columns(items: Sequence[CardItem | BadItem], rows: list[dict[str, Any] | None],
                     spec: DownholeSpec) -> None:
    """Add the pump columns to the rows of one partition, in place.

    The partition's readable cards are diagnosed in one batch; an unreadable item's row is
    left without pump columns (null in the table).

    Parameters
    ----------
    items : sequence of CardItem or BadItem
        The partition, in order.
    rows : list of dict
        Their rows, in the same order.
    spec : DownholeSpec
        The well file and options.
    """
    index = [i for i, item in enumerate(items) if isinstance(item, CardItem)]
    cards = [items[i].card for i in index]  # type: ignore[union-attr]
    if not cards:
        return
    results = diagnose_cards(cards, spec.wells, damping=spec.damping, harmonics=spec.harmonics)
    for i, res in zip(index, results, strict=True):
        row = rows[i]
        if row is None:
            continue
        row.update(res.to_row())
        row["downhole_notes"] = " | ".join(res.notes)
        row["downhole_well"] = res.well.well_id if res.well is not None else None
        if not res.ok:
            row["downhole_damping"] = None
            row["downhole_reversed"] = None
            warning = f"no pump card: {res.reason}"
            row["warnings"] = " | ".join(w for w in (row.get("warnings") or "", warning) if w)


# --------------------------------------------------------------------------- trending
def is_pump_quantity(quantity: str) -> bool:
    """Whether a quantity name of the change detector is a pump quantity's column."""
    return quantity.startswith(PUMP_PREFIX)


def pump_quantities(table: pd.DataFrame) -> list[str]:
    """The pump quantities a results table holds with some value, by column name, in the
    order of :data:`TRENDED`."""
    return [f"{PUMP_PREFIX}{q}" for q in TRENDED
            if f"{PUMP_PREFIX}{q}" in table.columns
            and pd.to_numeric(table[f"{PUMP_PREFIX}{q}"], errors="coerce").notna().any()]


def pump_usable(frame: pd.DataFrame) -> pd.Series:
    """Rows whose pump quantities count: their downhole card was computed."""
    if "downhole_status" not in frame.columns:
        return pd.Series(False, index=frame.index)
    return frame["downhole_status"].eq("computed").fillna(False).astype(bool)
