"""Pump quantities in the fleet's results: ``pumpid batch --well-file`` and their trends.

With a well file, each partition of a batch run also works out the pump of every readable
card and adds it to the card's row. By default the pump is **identified** from the card
(:func:`pumpid.pump.identify_cards`: the rod string and a valve pump fitted to the whole
surface card, damping included); with ``identify=False`` (``--no-identify``) only the
diagnostic pump card is computed (:func:`pumpid.rods.diagnose_cards`, the partition's cards
batched), at the given damping or the default rule, as before identification existed.

Columns in both modes:

``downhole_status``, ``downhole_reason``
    ``computed``, ``invalid-input`` (no unit, no time, a well not in the file, ...) or
    ``failed``, and why, for the diagnostic pump card. A card whose pump cannot be worked
    out keeps its row (the fit's columns are unaffected); its pump columns are null and
    the reason is also added to its ``warnings``.
``downhole_well``, ``downhole_method``, ``downhole_damping``, ``downhole_reversed``,
``downhole_notes``
    The well the card was computed with, the method, Gibbs' dimensionless damping factor
    of the diagnostic pump card, whether the card was stored in reverse time order, and
    everything assumed or noticed (`` | ``-separated).
``pump_<name>``, ``pump_<name>_unit``
    For each of :data:`PUMP_QUANTITIES`: the value in the unit of the next column (lengths
    and loads in the card's units, fillage as a fraction, displacement in bbl/d or m3/d and
    intake pressure in psi or kPa by the well file's unit system). Without identification,
    measured on the diagnostic pump card; with it, see below.

Columns added by the identification:

``identify_status``, ``identify_reason``
    The system model fit's status (``converged``, ``boundary``, ``poor-fit``, ...,
    ``failed``, ``invalid-input``) and why. A card whose identification failed (status
    ``failed`` or ``invalid-input``) keeps its row: its identified columns are null, the
    reason is added to its ``warnings``, and its diagnostic columns are computed at the
    default (or given) damping.
``pump_<name>``, ``pump_<name>_se``
    For each of :data:`IDENTIFIED`: the identified value and its standard error (the
    autocorrelation-robust one where the residuals are serially correlated), in the unit
    of ``pump_<name>_unit``. The load lines (``pump_upper_load_line``,
    ``pump_lower_load_line``) are the diagnostic card's ingredients of the fluid load and
    have no identified counterpart: null.
``downhole_<name>``
    For each of :data:`PUMP_QUANTITIES`: the value measured on the diagnostic pump card
    computed at ``downhole_damping`` (the identified damping when the identification
    succeeded), in the unit of ``pump_<name>_unit``.
``pump_damping``, ``pump_damping_se``, ``pump_damping_rule``
    Gibbs' dimensionless damping factor identified (or held at ``--damping``), its
    standard error, and in words which damping the diagnostic card used and why.
``pump_r2``, ``pump_residual_rho``
    The surface-load fit's R^2 and its residuals' lag-1 autocorrelation.

With ``lumped=False`` (``--pump-only``) no lumped model is fitted: the row's fit columns
are the identification's (``model`` is ``rod string and pump``, ``observe`` the
polished-rod load; ``status``, ``reason``, ``r2``, ``rmse``, ``cost`` those of
``identify_status``'s fit, ``nfev`` the identification's model evaluations, its searches'
included) and the table has no ``p_`` or ``d_`` columns. The lumped fit is
most of a card's time beside the identification: leaving it out more than doubles the
cards a second.

A one-well file applies to every card; otherwise a card is matched to its well by its well
id (:meth:`pumpid.rods.WellFile.for_card`).

The change detector and the fleet report (:mod:`pumpid.fleet.changes`,
:mod:`pumpid.fleet.report`) trend the pump quantities of :data:`TRENDED` by their column
name (``pump_fillage``), with their standard errors where the table has them: a card
counts when its pump was identified (status in :data:`IDENTIFIED_USABLE`), or without
identification when its downhole card was computed, whatever its model fit's status.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from pumpid.engine.threads import run_chunks
from pumpid.pump import PumpFit, PumpSystem, identify_cards
from pumpid.pump.identify import SHOWN
from pumpid.pump.identify_report import DownholeCard
from pumpid.rods import DownholeResult, WellFile, diagnose_cards, read_well_file

from .inputs import BadItem, CardItem

__all__ = ["IDENTIFIED", "IDENTIFIED_USABLE", "PUMP_PREFIX", "PUMP_QUANTITIES", "TRENDED",
           "DownholeSpec", "add_pump_columns", "is_pump_quantity", "pump_quantities",
           "pump_schema", "pump_usable"]

#: Prefix of the pump quantities' columns (and of their names in the change detector).
PUMP_PREFIX = "pump_"
#: The pump quantities of a results row, in column order (:meth:`DownholeResult.quantities`).
PUMP_QUANTITIES = ("gross_stroke", "net_stroke", "fluid_load", "fillage", "upper_load_line",
                   "lower_load_line", "displacement", "intake_pressure")
#: Those the identification gives with a standard error (:meth:`PumpFit.quantities`).
IDENTIFIED = tuple(q for q in PUMP_QUANTITIES if q in SHOWN)
#: Identification statuses whose fit's own figures are written (R^2, residual
#: autocorrelation, damping); its quantities are the row's where it is used (converged or
#: boundary, as pumpid downhole uses it), else the diagnostic card's are, not trended.
IDENTIFIED_USABLE = ("converged", "boundary", "undetermined", "poor-fit")
#: Those trended by default: the load lines are the fluid load's ingredients, and each more
#: quantity tested costs every other some sensitivity (the false-alarm rate is split).
TRENDED = ("fillage", "fluid_load", "net_stroke", "gross_stroke", "displacement",
           "intake_pressure")
#: Cards per identification task: small, so that the threads share a partition evenly (a
#: card costs a fraction of a second, the task's own cost is negligible).
_IDENTIFY_CHUNK = 4


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
        Gibbs' dimensionless damping factor (None: identified from each card, or without
        identification the default rule of :func:`pumpid.rods.diagnose_cards`); with
        identification it is held in the fit.
    harmonics : int or None
        Highest harmonic of the Fourier method (None: all the samples resolve).
    identify : bool
        Identify each card's pump (:func:`pumpid.pump.identify_cards`); False: the
        diagnostic pump card only.
    lumped : bool
        Also fit the lumped model to each card (the row's fit columns, as without a well
        file). False (``--pump-only``): the pump's identification is the row's fit (see
        :func:`add_pump_columns`); needs ``identify``.
    """

    well_file: str
    wells: WellFile
    digest: str
    damping: float | None = None
    harmonics: int | None = None
    identify: bool = True
    lumped: bool = True

    @classmethod
    def load(cls, well_file: str | os.PathLike[str], *, damping: float | None = None,
             harmonics: int | None = None, identify: bool = True,
             lumped: bool = True) -> DownholeSpec:
        """Read the well file and check the options (WellError / ValueError naming them)."""
        if not lumped and not identify:
            raise ValueError("--pump-only makes the pump's identification each card's fit: "
                             "it cannot go with --no-identify")
        if damping is not None and not (np.isfinite(damping) and damping >= 0):
            raise ValueError(f"--damping must be a non-negative number, got {damping}")
        if identify and damping == 0:
            # The predictive model reaches its periodic state only through some damping.
            raise ValueError("--damping 0 (undamped) cannot be held in the identification: "
                             "give a positive NU, or --no-identify for the diagnostic pump "
                             "card alone")
        if harmonics is not None and harmonics < 1:
            raise ValueError(f"--harmonics must be at least 1, got {harmonics}")
        path = os.fspath(well_file)
        wells = read_well_file(path)
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        return cls(well_file=path, wells=wells, digest=digest, damping=damping,
                   harmonics=harmonics, identify=bool(identify), lumped=bool(lumped))

    def to_dict(self) -> dict[str, Any]:
        """The manifest's form."""
        return {"well_file": self.well_file, "sha256": self.digest, "damping": self.damping,
                "harmonics": self.harmonics, "identify": self.identify,
                "lumped": self.lumped}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DownholeSpec:
        """The spec of :meth:`to_dict`'s form, the well file read again."""
        identify, lumped = cls.modes(data)
        return cls.load(str(data["well_file"]), damping=data.get("damping"),
                        harmonics=data.get("harmonics"), identify=identify, lumped=lumped)

    @staticmethod
    def modes(data: Mapping[str, Any]) -> tuple[bool, bool]:
        """``identify`` and ``lumped`` of :meth:`to_dict`'s form, without reading the well
        file: a manifest that does not say ``identify`` is from before identification
        (diagnostic only); one that does not say ``lumped`` fitted the lumped model too."""
        return bool(data.get("identify", False)), bool(data.get("lumped", True))


def pump_schema(base: pa.Schema, identify: bool = False) -> pa.Schema:
    """``base`` with the downhole and pump columns appended (see the module doc); with
    ``identify``, the identification's columns too."""
    s, f, b = pa.string(), pa.float64(), pa.bool_()
    extra = [("downhole_status", s), ("downhole_reason", s), ("downhole_well", s),
             ("downhole_method", s), ("downhole_damping", f), ("downhole_reversed", b),
             ("downhole_notes", s)]
    for name in PUMP_QUANTITIES:
        extra += [(f"{PUMP_PREFIX}{name}", f), (f"{PUMP_PREFIX}{name}_unit", s)]
        if identify and name in IDENTIFIED:
            extra += [(f"{PUMP_PREFIX}{name}_se", f), (f"{PUMP_PREFIX}{name}_determined", b)]
    if identify:
        extra += [(f"downhole_{name}", f) for name in PUMP_QUANTITIES]
        extra += [("identify_status", s), ("identify_reason", s), ("pump_damping", f),
                  ("pump_damping_se", f), ("pump_damping_rule", s), ("pump_r2", f),
                  ("pump_residual_rho", f)]
    out = base
    for name, kind in extra:
        out = out.append(pa.field(name, kind))
    return out


def add_pump_columns(items: Sequence[CardItem | BadItem], rows: list[dict[str, Any] | None],
                     spec: DownholeSpec, threads: int = 1) -> None:
    """Add the pump columns to the rows of one partition, in place.

    Without identification the partition's readable cards are diagnosed in one batch; with
    it each is identified (on ``threads`` threads) and the diagnostic pump card is the one
    at its identified damping. An unreadable item's row is left without pump columns (null
    in the table).

    Parameters
    ----------
    items : sequence of CardItem or BadItem
        The partition, in order.
    rows : list of dict
        Their rows, in the same order.
    spec : DownholeSpec
        The well file and options.
    threads : int
        Threads for the identification.
    """
    index = [i for i, item in enumerate(items) if isinstance(item, CardItem)]
    cards = [items[i].card for i in index]  # type: ignore[union-attr]
    if not cards:
        return
    fits: list[PumpFit | None] = [None] * len(cards)
    if spec.identify:
        def work(a: int, b: int) -> None:
            fits[a:b] = identify_cards(cards[a:b], spec.wells, damping=spec.damping,
                                       harmonics=spec.harmonics)

        run_chunks(work, len(cards), workers=threads, chunk=_IDENTIFY_CHUNK)
    # The diagnostic pump card: the identification's own (at its damping), else computed
    # here at the given damping or the default rule, in one batch.
    missing = [k for k, f in enumerate(fits) if f is None or f.downhole is None]
    down: list[DownholeResult | None] = [None if f is None else f.downhole for f in fits]
    if missing:
        fresh = diagnose_cards([cards[k] for k in missing], spec.wells, damping=spec.damping,
                               harmonics=spec.harmonics)
        for k, res in zip(missing, fresh, strict=True):
            down[k] = res
    for k, i in enumerate(index):
        row = rows[i]
        res = down[k]
        if row is None or res is None:
            continue
        _diagnostic_columns(row, res, spec.identify)
        if spec.identify:
            _identified_columns(row, fits[k], res)
        if not spec.lumped:
            _fit_columns(row, fits[k])


def _add_warning(row: dict[str, Any], warning: str) -> None:
    row["warnings"] = " | ".join(w for w in (row.get("warnings") or "", warning) if w)


def _diagnostic_columns(row: dict[str, Any], res: DownholeResult, identify: bool) -> None:
    row.update(res.to_row())
    row["downhole_notes"] = " | ".join(res.notes)
    row["downhole_well"] = res.well.well_id if res.well is not None else None
    if not res.ok:
        row["downhole_damping"] = None
        row["downhole_reversed"] = None
        _add_warning(row, f"no pump card: {res.reason}")
    if identify:
        # The diagnostic's values keep their own columns; pump_<name> is the identified.
        for name in PUMP_QUANTITIES:
            row[f"downhole_{name}"] = row.pop(f"{PUMP_PREFIX}{name}", None)


def _finite(value: Any) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _identified_columns(row: dict[str, Any], fit: PumpFit | None,
                        diagnostic: DownholeResult) -> None:
    if fit is None:  # not reached: every readable card is identified
        return
    row["identify_status"] = fit.status
    row["identify_reason"] = fit.reason
    usable = fit.ok and fit.status in IDENTIFIED_USABLE
    # The pump's quantities as pumpid downhole gives them (one meaning for pump_<q> in both
    # tables): the identification's where it is used, else the diagnostic card's, without
    # an error. The same fj1 card's fluid load read 2.69 klbf here (an undetermined
    # identification's) and 7.32 klbf in pumpid downhole's table.
    shown = DownholeCard.of(diagnostic, fit)
    pump = shown.pump()
    for name in PUMP_QUANTITIES:
        entry = pump.get(name)
        row[f"{PUMP_PREFIX}{name}"] = None if entry is None else _finite(entry["value"])
        if entry is not None:
            row[f"{PUMP_PREFIX}{name}_unit"] = entry["unit"]
        if name in IDENTIFIED:
            row[f"{PUMP_PREFIX}{name}_se"] = None if entry is None else _finite(
                entry["stderr"])
            # Trended only where the identification is used and determines it, as the
            # lumped fits' quantities are; a full pump's held fillage is the model the
            # card chose (the pump is full) and counts. A diagnostic card's value shown
            # instead is not trended: it is drawn at another damping than the identified
            # cards' beside it (fj2's fluid load 24.2 kN at the default against 20.7).
            row[f"{PUMP_PREFIX}{name}_determined"] = None if entry is None else bool(
                shown.identified and (entry.get("determined") or entry.get("held")))
    damping = shown.damping()
    row["pump_damping_rule"] = damping["rule"] or None
    if not usable:
        for key in ("pump_damping", "pump_damping_se", "pump_r2", "pump_residual_rho"):
            row[key] = None
        _add_warning(row, f"pump not identified ({fit.status}): {fit.reason}")
        return
    assert fit.fit is not None
    white = fit.fit.whiteness
    # The damping the row's quantities were made with (the identified one, with its error,
    # where the identification is used; else the diagnostic card's): a poor fit's fluid
    # load of 3174 lbf had sat beside the default rule's 0.05.
    row["pump_damping"] = _finite(damping["value"])
    row["pump_damping_se"] = _finite(damping["stderr"])
    row["pump_r2"] = _finite(fit.fit.r2)
    row["pump_residual_rho"] = None if white is None else _finite(
        white.get("lag1_autocorrelation"))
    if fit.notes:
        row["downhole_notes"] = " | ".join(
            n for n in (row.get("downhole_notes") or "", *fit.notes) if n)


def _fit_columns(row: dict[str, Any], fit: PumpFit | None) -> None:
    """``--pump-only``: the identification is the row's fit (status, reason, R^2, ...)."""
    if fit is None:  # not reached: every readable card is identified
        return
    row.update(model=PumpSystem.name, observe=PumpSystem.output, status=fit.status,
               reason=fit.reason)
    if fit.fit is not None:
        row.update(r2=_finite(fit.fit.r2), rmse=_finite(fit.fit.rmse),
                   cost=_finite(fit.fit.cost), nfev=fit.evaluations)


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
    """Rows whose pump quantities count: their pump was identified (a run with
    identification), or their downhole card was computed (one without)."""
    if "identify_status" in frame.columns:
        return frame["identify_status"].isin(IDENTIFIED_USABLE).fillna(False).astype(bool)
    if "downhole_status" not in frame.columns:
        return pd.Series(False, index=frame.index)
    return frame["downhole_status"].eq("computed").fillna(False).astype(bool)
