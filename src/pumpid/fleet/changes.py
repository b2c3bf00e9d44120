"""Which wells changed, when, and how: persistent shifts in fitted quantities over time.

The input is the fleet results table (one row per fitted card; see :data:`USABLE_STATUSES`
and the column conventions below); the output is one row per detected change.

Method
------
For each well and each quantity (by default every derived quantity ``d_NAME`` of the
table; model parameters ``p_NAME`` on request), the cards whose fit is usable (status
``converged``, ``boundary`` or ``undetermined``; not ``poor-fit``), whose value is finite
and, where the table says so, determined by the data, are put in time order (in the
table's card order when no card of the well has a time; a card without a time in a well
whose other cards have one is counted and set aside, :func:`is_undated_among_dated`). The
analysis scale is the logarithm when every value is positive, so that a change is relative
and a constant coefficient of variation is a constant noise level; otherwise the values
themselves.

1. **Reference.** The first ``min_cards`` cards of a segment set its level and noise: the
   level is their median ``m``; the card-to-card scatter is ``sigma = 1.4826 MAD(diff) /
   sqrt(2)``, the median absolute deviation of successive differences, which a single step
   or a slow drift inside the window barely moves.
2. **Noise per card.** Part of the scatter is each fit's own uncertainty. With ``s_i`` the
   card's reported standard error on the analysis scale (for parameters the larger of the
   ordinary and the autocorrelation-robust one) and ``s_ref`` its median over the
   reference cards, the scatter between cards beyond the fits' errors is
   ``tau² = max(sigma² - s_ref², 0)`` and a card's noise is ``sigma_i = sqrt(tau² + s_i²)``,
   never below ``sigma / 2``. A missing (NaN) standard error counts as ``s_ref``; so a
   poorly determined card weighs less, and NaN errors throughout reduce to ``sigma``.
   Errors wider than the scatter (``s_ref > sigma``: a model error's robust errors, far
   wider than the spread of consecutive cards) only weigh the cards against each other:
   ``sigma_i = sigma s_i / s_ref``, the scatter's scale for a card of the reference's
   error.
3. **Robust two-sided CUSUM.** Each later card gives ``z_i = (y_i - m) / sigma_i``,
   clipped to ``[-clip, clip]`` (Huber's rule: one wild card moves the statistic by at most
   ``clip - reference``), and the upper and lower sums
   ``S+_i = max(0, S+_{i-1} + z_i - reference)``, ``S-_i = max(0, S-_{i-1} - z_i -
   reference)``. An alarm is the first card at which either exceeds the threshold ``h``.
   With the default ``reference = 1`` the scheme is tuned to shifts of about two noise
   scales and more; smaller persistent shifts still accumulate, more slowly.
4. **Threshold.** ``h`` is the ``1 - alpha`` quantile of ``max(S+, S-)`` over a steady
   history, found by simulation (fixed seed, so reproducible) of the whole procedure,
   reference estimation included: Student-t noise with ``tail_dof`` degrees of freedom
   (default 5: heavier tails than Gaussian) with a fraction ``outlier_fraction`` (1 %) of
   cards replaced by outliers of 6-12 noise scales of random sign, over the well's own
   history length rounded up to a grid of lengths (so a longer history gets a higher
   threshold and the false-alarm probability holds whatever the length). ``alpha`` is the
   requested per-well false-alarm probability divided by the number of quantities tested
   (Bonferroni: a steady well raises any alert with probability at most ``false_alarm``;
   correlated quantities make it smaller). Of the simulated maxima the order statistic
   that bounds the quantile from above with 95 % confidence is taken, so the simulation's
   own error does not push the false-alarm rate above the target.
5. **Change point.** The change's first card, not the alarm card: the CUSUM's own estimate
   (the card after the statistic last left zero) is refined by the split that best fits
   two levels (least absolute deviations, weighted by ``1 / sigma_i``) within
   ``min_cards`` cards of it, using cards up to ``min_cards`` after the alarm.
6. **More changes.** The new level's first ``min_cards`` cards (from the change point)
   become the next reference and the search goes on, so a well can have several alerts.
   ``before`` and ``after`` are the medians of the segments on either side (up to the
   neighbouring change points), in the quantity's unit.

Short histories
---------------
A history of ``min_short_cards`` (6) to ``min_cards`` usable cards (a week of daily cards)
has no room for a reference window; it is tested as a whole by the **two-segment test**
(:func:`pumpid.fleet.thresholds.two_segment_statistic`): for every split into two runs of at
least 3 cards, the difference of their medians over its standard error, the scale being the
cards' scatter about their own run's median (never below the median of the fits' standard
errors); the largest over the splits is compared with its ``1 - alpha / 2`` quantile
simulated for that very length under the same steady noise as the CUSUM's
(:func:`pumpid.fleet.thresholds.two_segment_threshold`). Beside it, the **drift test**
(:func:`pumpid.fleet.thresholds.drift_statistic`): the history's Theil-Sen slope over its
standard error, the scale being the cards' scatter about that line, compared with its own
simulated ``1 - alpha / 2`` quantile (:func:`pumpid.fleet.thresholds.drift_threshold`). A
level falling steadily over the history widens the two-segment test's scatter as much as it
parts its medians: on a straight decline of 14 cards that test's statistic is 5.2 however
steep the fall, below its threshold when a pump field's nine quantities share the
false-alarm probability (5.6 with the whole of it, 6.3 with half; a pump's fillage falling from
0.99 to 0.61 over 14 daily cards went unreported). Where both alert, the one further beyond
its threshold names the change (``method`` ``"two-segment"`` or ``"drift"``). A step's first
card is the maximising split of the two-segment statistic and ``before`` / ``after`` the
medians either side; a drift is under way from the history's first card, ``before`` /
``after`` the fitted line's values at its first and last cards and ``change_se`` the slope
over its standard error. The alarm card is the history's last. At most one change per short
history; a step in its first or last two cards cannot be told from an outlier and is not
reported. ``benchmarks/bench_changes.py`` measures the false-alarm rate and power.

Assumptions: levels are piecewise constant between changes with independent card-to-card
noise; in a long history a slow drift shows as a late alert, or several alerts in the same
direction (a short one has the drift test). The first ``min_cards`` cards of a segment (the
reference) cannot themselves hold a change (two changes closer than ``min_cards`` cards are
seen as one); a history shorter than ``min_short_cards`` usable cards is not tested
(:func:`history_coverage` says which).

Column conventions of the results table
---------------------------------------
``well_id``, ``card_id``, ``status`` (required; a row without a well, such as a file that
could not be read, counts under :data:`UNKNOWN_WELL`); ``time`` (datetime, NaT when unknown);
per derived quantity ``d_NAME``, ``d_NAME_se``, ``d_NAME_determined``, ``d_NAME_unit``;
per parameter ``p_NAME``, ``p_NAME_se``, ``p_NAME_se_hac``. Missing optional columns
are treated as unknown (NaT time, NaN standard error, determined, no unit).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .detectors import median_se, robust_sigma, scan_cusum, scan_two_segments
from .downhole import pump_usable
from .events import change_size, events_of, number_events
from .quantities import (
    STATUSES,
    USABLE_STATUSES,
    available_quantities,
    columns_of,
    counted,
    larger_error,
    parameter_unit,
    with_asked,
)
from .thresholds import MIN_SEGMENT, cusum_threshold

__all__ = [
    "ALERT_COLUMNS",
    "SHORT_MIN_CARDS",
    "STATUSES",
    "UNKNOWN_WELL",
    "USABLE_STATUSES",
    "available_quantities",
    "card_counts",
    "cusum_threshold",
    "detect_changes",
    "history_coverage",
    "is_duplicate",
    "is_named",
    "is_undated_among_dated",
    "load_results",
    "summarise_wells",
]

#: The well of rows whose ``well_id`` is missing (files that could not be read).
UNKNOWN_WELL = "(unknown well)"
#: Columns of :func:`detect_changes`' result, in order.
ALERT_COLUMNS = (
    "well_id", "quantity", "unit", "first_card_id", "first_time", "alarm_card_id",
    "alarm_time", "before", "after", "change", "change_rel", "change_se", "direction",
    "kind", "scale", "noise", "first_index", "alarm_index", "delay_cards", "n_before",
    "n_after", "threshold", "order", "method", "event",
)  # fmt: skip
#: Shortest history :func:`detect_changes` tests by default (the two-segment and drift
#: tests).
SHORT_MIN_CARDS = 6

# --------------------------------------------------------------------------- input
def load_results(results: pd.DataFrame | str | os.PathLike[str]) -> pd.DataFrame:
    """Return the results table, reading it when given a Parquet file or dataset folder.

    Parameters
    ----------
    results : pandas.DataFrame or path
        The table, or a Parquet file or folder that :func:`pandas.read_parquet` reads.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    ValueError
        If the ``well_id``, ``card_id`` or ``status`` column is missing.
    """
    table = results if isinstance(results, pd.DataFrame) else pd.read_parquet(results)
    missing = [c for c in ("well_id", "card_id", "status") if c not in table.columns]
    if missing:
        raise ValueError(
            f"the results table lacks the column(s) {', '.join(missing)}; it has "
            f"{', '.join(map(str, table.columns))}"
        )
    if table["well_id"].isna().any():
        # A file that could not be read names no well: its rows are counted, not trended.
        table = table.assign(well_id=table["well_id"].astype(object).where(
            table["well_id"].notna(), UNKNOWN_WELL))
    return table


def is_named(table: pd.DataFrame) -> pd.Series:
    """Rows of a named well: cards without a well id (and unreadable files' rows) are filed
    under :data:`UNKNOWN_WELL`, which may hold several wells: counted, never trended."""
    return table["well_id"].astype(str) != UNKNOWN_WELL


def is_undated_among_dated(table: pd.DataFrame) -> pd.Series:
    """Rows without a time in a well whose other cards have one: a time order cannot place
    them, and the table's order put them last, so that one became the well's latest value
    and its alarm card (fillage 0.99 shown as latest where the newest dated card said
    0.66). They are counted, not trended; a well whose cards all lack a time keeps the
    table's order."""
    if "time" not in table.columns:
        return pd.Series(False, index=table.index)
    undated = pd.to_datetime(table["time"], utc=True).isna()
    dated_well = (~undated).groupby(table["well_id"].astype(str)).transform("any")
    return undated & dated_well & is_named(table)


def card_counts(table: pd.DataFrame) -> dict[str, int]:
    """What a run's table holds, counted once for every output that says it: ``cards``
    (repeats set aside), ``repeats``, ``wells`` (named ones), ``unnamed`` (cards filed
    under :data:`UNKNOWN_WELL`, not trended) and ``undated`` (cards without a time in a
    well whose other cards have one, not trended)."""
    table = load_results(table)
    repeats = is_duplicate(table)
    kept = table[~repeats]
    named = is_named(kept)
    return {"cards": len(kept), "repeats": int(repeats.sum()),
            "wells": int(kept.loc[named, "well_id"].nunique()),
            "unnamed": int((~named).sum()),
            "undated": int(is_undated_among_dated(kept).sum())}


def is_duplicate(table: pd.DataFrame) -> pd.Series:
    """Rows that repeat an earlier card exactly (``duplicate_of`` set by ``pumpid batch``):
    counted once, so left out of trends, change detection and counts."""
    if "duplicate_of" not in table.columns:
        return pd.Series(False, index=table.index)
    dup = table["duplicate_of"]
    return dup.notna() & (dup.astype(str) != "")


@dataclass(frozen=True)
class _Usable:
    """The usable rows of a table, each well's in its order, with per-well bounds."""

    frame: pd.DataFrame
    wells: tuple[str, ...]
    bounds: NDArray[np.int64]
    order: tuple[str, ...]  # "time" or "card order", per well
    card_id: NDArray[np.object_]
    time: NDArray[np.datetime64]  # UTC, NaT where unknown


def _prepare(frame: pd.DataFrame) -> _Usable:
    """Usable rows, sorted by well, then by time, or by table order for a well none of
    whose cards has a time (an undated card of a dated well is set aside:
    :func:`is_undated_among_dated`)."""
    # A card's pump quantities count when its downhole card was computed, whatever its fit.
    # Cards without a well id may come from several wells: one history of them would
    # trend and test a mixture, so they are counted, not trended.
    rows = frame[(frame["status"].isin(USABLE_STATUSES) | pump_usable(frame))
                 & ~is_duplicate(frame) & is_named(frame) & ~is_undated_among_dated(frame)]
    well = rows["well_id"].astype(str).to_numpy()
    if "time" in rows.columns:
        time = pd.to_datetime(rows["time"], utc=True).dt.tz_localize(None)
        time = time.astype("datetime64[ns]").to_numpy()
    else:
        time = np.full(len(rows), np.datetime64("NaT"), dtype="datetime64[ns]")
    missing = pd.Series(np.isnat(time)).groupby(well).transform("any").to_numpy()
    key = np.where(missing, 0, time.astype(np.int64))
    idx = np.lexsort((np.arange(len(rows)), key, well))
    well, missing = well[idx], missing[idx]
    wells, starts = np.unique(well, return_index=True)
    bounds = np.append(starts, len(well)).astype(np.int64)
    sorted_rows = rows.iloc[idx]
    return _Usable(
        frame=sorted_rows,
        wells=tuple(str(w) for w in wells),
        bounds=bounds,
        order=tuple("card order" if missing[b] else "time" for b in starts),
        card_id=sorted_rows["card_id"].astype(str).to_numpy(dtype=object),
        time=time[idx],
    )


def _quantity(
    usable: _Usable, q: str
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], list[str], str]:
    """One quantity over the usable rows: values, standard errors, which rows count, the
    unit of each well, and the kind (derived or parameter)."""
    frame = usable.frame
    cols = columns_of(q)
    values = pd.to_numeric(frame[cols.value], errors="coerce").to_numpy(dtype=float)
    keep = counted(frame, q, values)
    se = larger_error(frame, q)
    n_wells = len(usable.wells)
    code = np.repeat(np.arange(n_wells), np.diff(usable.bounds))
    units = [""] * n_wells
    # A parameter's unit comes from the model (parameter_unit), as before tables stated it.
    if not cols.unit_from_model and cols.unit in frame.columns:
        stated = frame[cols.unit].to_numpy(dtype=object)
        # A well's unit is the one most of its kept values state; a well with no kept value
        # (every card left the quantity undetermined) still has the unit its rows state,
        # which does not depend on whether the value is known.
        for has in (pd.notna(stated), keep & pd.notna(stated)):
            if has.any():
                counts = pd.DataFrame({"w": code[has],
                                       "u": stated[has].astype(str)}).value_counts()
                major = counts.reset_index().drop_duplicates("w")  # sorted by count
                for w, u in zip(major["w"], major["u"], strict=True):
                    units[int(w)] = u
        has = keep & pd.notna(stated)
        if has.any():
            # Values in another unit cannot be compared with these: leave them out (a row
            # that states no unit is taken to share the well's).
            well_unit = np.array(units, dtype=object)[code]
            keep &= ~pd.notna(stated) | (stated.astype(str) == well_unit)
    elif cols.unit_from_model:
        units = [parameter_unit(frame.iloc[usable.bounds[i]:usable.bounds[i + 1]], q)
                 for i in range(n_wells)]  # fmt: skip
    return values, se, keep, units, cols.kind


# --------------------------------------------------------------------------- public API
def detect_changes(
    table: pd.DataFrame | str | os.PathLike[str],
    quantities: Sequence[str] | None = None,
    *,
    min_cards: int = 30,
    false_alarm: float = 0.01,
    parameters: bool = False,
    reference: float = 1.0,
    clip: float = 3.0,
    tail_dof: float = 5.0,
    outlier_fraction: float = 0.01,
    min_short_cards: int = SHORT_MIN_CARDS,
    asked: Sequence[str] | None = None,
) -> pd.DataFrame:
    """Find persistent shifts in each well's fitted quantities (see the module docstring).

    Parameters
    ----------
    table : pandas.DataFrame or path
        The results table (one row per card), or a Parquet file or folder holding it.
    quantities : sequence of str, optional
        Derived quantities by name (``"stiffness"`` for column ``d_stiffness``) and/or
        parameters by column name (``"p_k0"``). Default: every derived quantity in the
        table, plus every parameter when ``parameters`` is true.
    min_cards : int, default 30
        Cards in each reference window of the CUSUM, which tests histories of more than
        ``min_cards`` usable cards of a quantity; changes closer than this are seen as one.
    min_short_cards : int, default 6
        Shortest history tested: histories of ``min_short_cards`` to ``min_cards`` cards are
        tested as a whole by the two-segment and drift tests (at most one change each).
    false_alarm : float, default 0.01
        Probability that a steady well raises any alert over its history (split evenly
        over the quantities tested).
    parameters : bool, default False
        With ``quantities=None``, also test the model parameters.
    reference, clip : float, default 1 and 3
        The CUSUM's reference value and clipping level, in noise scales.
    tail_dof, outlier_fraction : float, default 5 and 0.01
        The steady-well noise the threshold is calibrated for (Student t and outliers).
    asked : sequence of str, optional
        Quantities the user named (default: ``quantities``): their values that fits call
        an echo of the stroke are trended too (:func:`~pumpid.fleet.quantities.with_asked`);
        the others' are not.

    Returns
    -------
    pandas.DataFrame
        One row per change, columns :data:`ALERT_COLUMNS`: ``well_id``, ``quantity``,
        ``unit``, ``first_card_id`` and ``first_time`` (the change's first card),
        ``alarm_card_id`` and ``alarm_time`` (the card at which the CUSUM crossed),
        ``before`` and ``after`` (medians of the segments, in ``unit``; for a drift the
        fitted line's values at the history's first and last cards), ``change``
        (``after - before``, in ``unit``), ``change_rel`` (``change / before``),
        ``change_se`` (``change`` over its standard error; signed), ``direction``
        (``"up"``/``"down"``), ``kind`` (``"derived"``/``"parameter"``), ``scale``
        (``"log"``/``"linear"``), ``noise`` (card-to-card noise in the reference: relative
        on the log scale, in ``unit`` otherwise), ``first_index``/``alarm_index``
        (positions among the well's usable cards of that quantity), ``delay_cards``,
        ``n_before``/``n_after`` (cards in the segments; 0 and the history's cards for a
        drift), ``threshold`` (``h``, in noise scales) and ``order`` (``"time"`` or
        ``"card order"``), ``method`` (``"cusum"``, ``"two-segment"`` or ``"drift"``: a
        short history's steady rise or fall), ``event`` (alerts of one well over
        overlapping cards share it: one change seen in several quantities; see
        :func:`pumpid.fleet.events.number_events`). Sorted by well, quantity and first card.

    Raises
    ------
    ValueError
        If a required column is missing, a requested quantity is not in the table, or an
        option is out of range.
    """
    frame = load_results(table)
    if not 0 < false_alarm < 1:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm}")
    if isinstance(min_cards, bool) or not isinstance(min_cards, int) or min_cards < 5:
        raise ValueError(f"min_cards must be an integer >= 5, got {min_cards!r}")
    if (isinstance(min_short_cards, bool) or not isinstance(min_short_cards, int)
            or min_short_cards < 2 * MIN_SEGMENT):
        raise ValueError(f"min_short_cards must be an integer >= {2 * MIN_SEGMENT}, got "
                         f"{min_short_cards!r}")
    if not (reference >= 0 and clip > reference):
        raise ValueError("need reference >= 0 and clip > reference")
    names = list(quantities) if quantities is not None else available_quantities(
        frame, parameters=parameters)  # fmt: skip
    for q in names:
        if columns_of(q).value not in frame.columns:
            raise ValueError(
                f"no column {columns_of(q).value!r} for quantity {q!r}; the table has "
                f"{', '.join(available_quantities(frame, parameters=True)) or 'none'}"
                + (f" (a derived quantity is named without its column's d_: {q[2:]})"
                   if q.startswith("d_") and columns_of(q[2:]).value in frame.columns else "")
            )
    frame = with_asked(frame, asked if asked is not None else quantities or ())
    rows: list[dict[str, Any]] = []
    if not names or frame.empty:
        return pd.DataFrame(columns=list(ALERT_COLUMNS))
    alpha = false_alarm / len(names)
    usable = _prepare(frame)
    for q in names:
        values, se, keep, units, kind = _quantity(usable, q)
        for i, well in enumerate(usable.wells):
            part = slice(usable.bounds[i], usable.bounds[i + 1])
            k = keep[part]
            if k.sum() < min_short_cards:
                continue
            rows.extend(_series_alerts(
                values[part][k], se[part][k], usable.card_id[part][k], usable.time[part][k],
                well=well, quantity=q, unit=units[i], kind=kind, order=usable.order[i],
                min_cards=min_cards, alpha=alpha, reference=reference, clip=clip,
                tail_dof=tail_dof, outlier_fraction=outlier_fraction,
            ))
    out = pd.DataFrame(rows, columns=list(ALERT_COLUMNS))
    out = out.sort_values(["well_id", "quantity", "first_index"], kind="stable")
    for col in ("first_time", "alarm_time"):
        out[col] = pd.to_datetime(out[col], utc=True).astype("datetime64[ns, UTC]")
    out = out.reset_index(drop=True)
    out["event"] = number_events(out)
    return out


def _series_alerts(
    values: NDArray[np.float64], se: NDArray[np.float64], ids: NDArray[np.object_],
    times: NDArray[np.datetime64], *, well: str, quantity: str, unit: str, kind: str,
    order: str, min_cards: int, alpha: float, reference: float, clip: float, tail_dof: float,
    outlier_fraction: float,
) -> list[dict[str, Any]]:
    """The alerts of one well's series of one quantity (values in time order)."""
    q = quantity
    log = bool(np.all(values > 0))
    y = np.log(values) if log else values
    s = se / values if log else se
    if values.size > min_cards:
        changes, _ = scan_cusum(y, s, min_cards=min_cards, alpha=alpha, reference=reference,
                           clip=clip, tail_dof=tail_dof, outlier_fraction=outlier_fraction)
        method = "cusum"
    else:
        changes = scan_two_segments(y, s, alpha=alpha, tail_dof=tail_dof,
                                outlier_fraction=outlier_fraction)
        method = "two-segment"
    bounds = [0] + [c.first for c in changes] + [values.size]
    scatter = robust_sigma(y)
    scatter = scatter if math.isfinite(scatter) and scatter > 0 else math.inf
    out = []
    for j, ch in enumerate(changes):
        part_b, part_a = slice(bounds[j], bounds[j + 1]), slice(bounds[j + 1], bounds[j + 2])
        seg_b, seg_a = values[part_b], values[part_a]
        if ch.line is not None:
            # A drift: the fitted line's ends, over the whole history.
            ends = ch.line[0] + ch.line[1] * np.array([0.0, values.size - 1.0])
            before, after = (float(v) for v in (np.exp(ends) if log else ends))
            change = after - before
            change_se = ch.size
            # on a linear scale the line's start may lie near zero or below it
            rel = (change / before if log else
                   change / abs(before) if abs(before) > ch.noise else math.nan)
        else:
            before, after = float(np.median(seg_b)), float(np.median(seg_a))
            change = after - before
            # The well's card-to-card scatter over its whole history (robust to the step
            # itself), in the values' unit on either side: the split's own scale varies
            # with the split (30 times between two lengths of one history).
            noise_b, noise_a = ((scatter * abs(before), scatter * abs(after)) if log
                                else (scatter, scatter))
            se_change = math.hypot(median_se(seg_b, se[part_b], noise_b),
                                   median_se(seg_a, se[part_a], noise_a))
            change_se = (change / se_change if se_change > 0
                         else math.copysign(math.inf, change))
            rel = change / before if before != 0 else math.nan
        out.append({
            "well_id": well, "quantity": q, "unit": unit,
            "first_card_id": ids[ch.first], "first_time": times[ch.first],
            "alarm_card_id": ids[ch.alarm], "alarm_time": times[ch.alarm],
            "before": before, "after": after, "change": change,
            "change_rel": rel,
            "change_se": change_se,
            "direction": ch.direction, "kind": kind, "scale": "log" if log else "linear",
            "noise": ch.noise, "first_index": ch.first, "alarm_index": ch.alarm,
            "delay_cards": ch.alarm - ch.first, "n_before": int(seg_b.size),
            "n_after": int(seg_a.size), "threshold": ch.threshold, "order": order,
            "method": "drift" if ch.drift else method,
        })  # fmt: skip
    return out


def history_coverage(
    table: pd.DataFrame | str | os.PathLike[str],
    quantities: Sequence[str] | None = None,
    *,
    min_cards: int = 30,
    min_short_cards: int = SHORT_MIN_CARDS,
) -> pd.DataFrame:
    """How each well's history of each quantity is tested by :func:`detect_changes`.

    Parameters
    ----------
    table : pandas.DataFrame or path
        The results table.
    quantities : sequence of str, optional
        As for :func:`detect_changes` (default: every derived quantity).
    min_cards, min_short_cards : int
        As for :func:`detect_changes`.

    Returns
    -------
    pandas.DataFrame
        ``well_id``, ``quantity``, ``cards`` (usable cards of the quantity, duplicates not
        counted) and ``method``: ``"cusum"`` (more than ``min_cards``), ``"two-segment"``
        (``min_short_cards`` to ``min_cards``) or ``"too short"``; every well with a usable
        card, per quantity.
    """
    frame = load_results(table)
    names = list(quantities) if quantities is not None else available_quantities(frame)
    names = [q for q in names if columns_of(q).value in frame.columns]
    rows: list[dict[str, Any]] = []
    if not frame.empty and names:
        usable = _prepare(frame)
        for q in names:
            _, _, keep, _, _ = _quantity(usable, q)
            for i, well in enumerate(usable.wells):
                n = int(keep[usable.bounds[i]:usable.bounds[i + 1]].sum())
                method = ("cusum" if n > min_cards else "two-segment" if n >= min_short_cards
                          else "too short")
                rows.append({"well_id": well, "quantity": q, "cards": n, "method": method})
    return pd.DataFrame(rows, columns=["well_id", "quantity", "cards", "method"])


def summarise_wells(
    table: pd.DataFrame | str | os.PathLike[str],
    alerts: pd.DataFrame | None = None,
    quantities: Sequence[str] | None = None,
) -> pd.DataFrame:
    """One row per well: cards, statuses, alerts and the latest value of each quantity.

    Parameters
    ----------
    table : pandas.DataFrame or path
        The results table.
    alerts : pandas.DataFrame, optional
        :func:`detect_changes`' result (none: no alert columns filled).
    quantities : sequence of str, optional
        Quantities whose latest values to give (default: every derived quantity).

    Returns
    -------
    pandas.DataFrame
        ``well_id``, ``cards`` (rows; a card repeating an earlier one exactly is counted
        once), ``n_<status>`` for each of :data:`STATUSES` (and ``n_other`` for any other
        or missing status), ``usable``, ``duplicates`` (repeats set aside), ``first_time``,
        ``last_time``, ``alerts``, ``changes`` (the alerts' events: a change seen in
        several quantities counts once), ``alerted_quantities`` (comma-separated),
        ``max_abs_change_se``, ``largest_change`` (a phrase with quantity, size and unit,
        relative and in standard errors, signed),
        and per quantity ``latest_<name>``, ``latest_<name>_unit`` (its last usable,
        determined value) and ``latest_<name>_time``. Wells with alerts come first, by
        decreasing ``max_abs_change_se``, then the others by ``well_id``.
    """
    frame = load_results(table)
    names = list(quantities) if quantities is not None else available_quantities(frame)
    names = [q for q in names if columns_of(q).value in frame.columns]
    alerts = alerts if alerts is not None else pd.DataFrame(columns=list(ALERT_COLUMNS))
    if frame.empty:
        return pd.DataFrame(columns=["well_id", "cards"])
    repeats = is_duplicate(frame)
    n_repeats = repeats.groupby(frame["well_id"].astype(str)).sum()
    frame = frame[~repeats]
    well = frame["well_id"].astype(str)
    status = frame["status"].where(frame["status"].isin(STATUSES), "other")
    out = pd.crosstab(well, status).reindex(columns=[*STATUSES, "other"], fill_value=0)
    out.columns = ["n_" + str(c).replace("-", "_") for c in out.columns]
    out.insert(0, "cards", out.sum(axis=1))
    out.insert(len(out.columns), "usable", out[[f"n_{st.replace('-', '_')}"
                                                for st in USABLE_STATUSES]].sum(axis=1))
    out["duplicates"] = n_repeats.reindex(out.index, fill_value=0).astype(int)
    if "time" in frame.columns:
        times = pd.to_datetime(frame["time"], utc=True).groupby(well)
        out["first_time"], out["last_time"] = times.min(), times.max()
    else:
        out["first_time"] = out["last_time"] = pd.NaT
    mine = alerts.assign(_w=alerts["well_id"].astype(str), _size=change_size(alerts),
                         _event=events_of(alerts))
    by_well = mine.groupby("_w")
    out["alerts"] = by_well.size().reindex(out.index, fill_value=0).astype(int)
    out["changes"] = by_well["_event"].nunique().reindex(out.index, fill_value=0).astype(int)
    out["alerted_quantities"] = by_well["quantity"].agg(
        lambda s: ", ".join(dict.fromkeys(s.astype(str)))).reindex(out.index, fill_value="")
    out["max_abs_change_se"] = by_well["_size"].max().reindex(out.index)
    top = mine.sort_values("_size", ascending=False, kind="stable").drop_duplicates("_w")
    phrases = {
        r["_w"]: (f"{r['quantity']} {r['before']:.4g} -> {r['after']:.4g} {r['unit']} "
                  f"({r['change_rel']:+.1%}, {float(r['change_se']):+.3g} standard errors) "
                  f"from card {r['first_card_id']}"
                  f"{', a steady drift' if r['method'] == 'drift' else ''}")
        for _, r in top.iterrows()
    }
    out["largest_change"] = [phrases.get(w, "") for w in out.index]
    usable = _prepare(frame)
    code = np.repeat(np.arange(len(usable.wells)), np.diff(usable.bounds))
    for q in names:
        values, _, keep, units, _ = _quantity(usable, q)
        last = pd.DataFrame({"w": code[keep], "v": values[keep], "t": usable.time[keep]})
        last = last.groupby("w").tail(1).set_index("w")
        ids = pd.Index(usable.wells)
        latest = pd.Series(last["v"].to_numpy(), index=ids[last.index.to_numpy()])
        when = pd.Series(last["t"].to_numpy(), index=ids[last.index.to_numpy()])
        out[f"latest_{q}"] = latest.reindex(out.index)
        out[f"latest_{q}_unit"] = pd.Series(units, index=ids).reindex(out.index).fillna("")
        out[f"latest_{q}_time"] = pd.to_datetime(when.reindex(out.index), utc=True)
    out = out.reset_index(names="well_id")
    out["_has"] = out["alerts"] > 0
    # The cards without a well id last: "(unknown well)" sorted among the named wells.
    out["_unknown"] = out["well_id"].astype(str) == UNKNOWN_WELL
    out = out.sort_values(["_has", "_unknown", "max_abs_change_se", "well_id"],
                          ascending=[False, True, False, True], na_position="last",
                          kind="stable")
    return out.drop(columns=["_has", "_unknown"]).reset_index(drop=True)
