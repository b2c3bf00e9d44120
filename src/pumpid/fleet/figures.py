"""The fleet report's figures: distributions across wells, trends per well, statuses.

Matplotlib figures (never pyplot), made by :mod:`pumpid.fleet.report` and embedded in its
page; also the formatting of units and counts that figures and page share.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from pumpid.cards import printable
from pumpid.report.units import unit_factor
from pumpid.report.words import plural

from .quantities import USABLE_STATUSES, columns_of, counted, larger_error

__all__ = [
    "MIN_WELLS_HISTOGRAM",
    "STATUS_COLOURS",
    "column_unit",
    "count_words",
    "distribution_figure",
    "few_wells_figure",
    "label",
    "padded_limits",
    "per_well_median",
    "quantity_values",
    "status_figure",
    "unit_mix",
    "unit_text",
    "well_figure",
]

#: Colour of each fit status in the figures.
STATUS_COLOURS = {"converged": "#176a2c", "boundary": "#c98a00", "poor-fit": "#9a5b00",
                  "failed": "#b00020", "invalid-input": "#6b2d8c", "other": "#777777"}  # fmt: skip


def unit_text(unit: Any) -> str:
    """A unit for display. A missing unit is said to be missing, never taken for
    "dimensionless", which only ``-`` and ``1`` (as the models state it) mean."""
    u = "" if unit is None or (isinstance(unit, float) and math.isnan(unit)) else str(unit)
    if u == "":
        return "unit not stated"
    return "dimensionless" if u in ("-", "1") else u


def label(text: Any) -> str:
    """A name from the files as figure text: control characters escaped (they have no
    glyph) and ``$`` escaped (matplotlib would read ``$...$`` as mathematics)."""
    return printable(str(text)).replace("$", r"\$")


def count_words(n: Any, word: str) -> str:
    """``"1 card"``, ``"3 cards"`` for a count that may be a numpy or pandas integer."""
    return plural(int(n), word)


# --------------------------------------------------------------------------- data helpers
def column_unit(frame: pd.DataFrame, summary: pd.DataFrame, quantity: str) -> str:
    """The unit of a quantity: the one most rows of the table state in its unit column
    (whether or not their value is determined: a quantity no card determined still has its
    unit), else the one most wells' latest values have (parameters: from the model)."""
    stated = pd.Series(dtype=object)
    cols = columns_of(quantity)
    if not cols.unit_from_model and cols.unit in frame.columns:
        stated = frame[cols.unit].dropna().astype(str)
    if not len(stated) and f"latest_{quantity}_unit" in summary.columns:
        stated = summary[f"latest_{quantity}_unit"].dropna().astype(str)
    stated = stated[stated != ""]
    return str(stated.mode().iloc[0]) if len(stated) else ""


def quantity_values(frame: pd.DataFrame, quantity: str, unit: str | None = None
                    ) -> tuple[pd.Series, pd.Series, pd.Series]:
    """Value, standard error and a usable mask of one quantity over rows of ``frame``.

    With ``unit``, values a row states in another unit are converted to it
    (:func:`pumpid.report.units.unit_factor`), and rows whose unit cannot be are not
    usable: one axis across wells, each in its controller's units, had plotted lbf, klbf
    and kN as one. A row that states no unit is taken to be in ``unit``, as the change
    detection takes it to share its well's.

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of a results table.
    quantity : str
        A derived quantity's name, ``p_<name>`` or ``pump_<name>``.
    unit : str, optional
        The unit to give the values in.

    Returns
    -------
    value, se : pandas.Series
    usable : pandas.Series of bool
    """
    cols = columns_of(quantity)
    value = pd.to_numeric(frame[cols.value], errors="coerce")
    se = pd.Series(larger_error(frame, quantity), index=frame.index)
    if unit and cols.unit in frame.columns:
        stated = frame[cols.unit]
        factors = {u: unit_factor(str(u), unit) for u in stated.dropna().unique()}
        factor = stated.map(lambda u: 1.0 if pd.isna(u) else factors[u])
        factor = pd.to_numeric(factor, errors="coerce")  # None (not convertible): NaN
        value, se = value * factor, se * factor
    # The change detection's rows (pumpid.fleet.quantities.counted): the plots show what
    # it trends.
    ok = pd.Series(counted(frame, quantity, value.to_numpy(dtype=float)), index=frame.index)
    return value, se, ok


def _by_well(frame: pd.DataFrame, value: pd.Series, ok: pd.Series) -> Any:
    # Grouped by position, not by index label: a results table read from several
    # partitions may repeat index labels, which label alignment would mix across wells.
    keep = np.asarray(ok, dtype=bool)
    pairs = pd.DataFrame({"well": frame["well_id"].astype(str).to_numpy()[keep],
                          "value": value.to_numpy(dtype=float)[keep]})
    return pairs.groupby("well")["value"]


def unit_mix(frame: pd.DataFrame, quantity: str, unit: str) -> tuple[list[str], int]:
    """The other units a quantity's usable values are stated in that were converted to
    ``unit`` for a view across wells, and how many values were left out because their unit
    could not be.

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of a results table.
    quantity : str
        As for :func:`quantity_values`.
    unit : str
        The views' unit.

    Returns
    -------
    converted : list of str
    left_out : int
    """
    own = columns_of(quantity).unit
    if not unit or own not in frame.columns:
        return [], 0
    _, _, ok = quantity_values(frame, quantity)
    stated = frame.loc[np.asarray(ok, dtype=bool), own].dropna().astype(str)
    others = sorted(set(stated) - {unit})
    converted = [u for u in others if unit_factor(u, unit) is not None]
    left = int(stated.isin([u for u in others if u not in converted]).sum())
    return converted, left


def per_well_median(frame: pd.DataFrame, quantity: str, unit: str | None = None) -> pd.Series:
    """Each well's median of a quantity's usable values, in ``unit`` where given."""
    value, _, ok = quantity_values(frame, quantity, unit)
    return _by_well(frame, value, ok).median()


# --------------------------------------------------------------------------- figures
#: Fewest wells whose values a histogram is drawn for; fewer are drawn one by one.
MIN_WELLS_HISTOGRAM = 5


#: Fewest cards whose middle half (quartiles) is drawn.
_MIN_QUARTILES = 4


def padded_limits(lo: float, hi: float, log: bool = False) -> tuple[float, float]:
    """Axis limits around the values ``lo..hi``, with a margin; a single value gets a
    margin of 1 % of its size (a flat series is not stretched over an arbitrary range)."""
    if log:
        a, b = padded_limits(math.log(lo), math.log(hi))
        return math.exp(a), math.exp(b)
    span = hi - lo
    if not span > 0:
        span = 0.02 * abs(hi) if hi != 0 else 1.0
    return lo - 0.08 * span, hi + 0.08 * span


def few_wells_figure(frame: pd.DataFrame, quantity: str, unit: str,
                      alerted: set[str]) -> Figure | None:
    """Each well's cards of one quantity as a row: the median, the middle half and the
    range, for fields of too few wells for a histogram."""
    value, _, ok = quantity_values(frame, quantity, unit)
    groups = _by_well(frame, value, ok)
    if not len(groups):
        return None
    wells = sorted(groups.groups)
    fig = Figure(figsize=(6.4, 0.8 + 0.45 * len(wells)))
    ax = fig.subplots()
    few = False
    for row, well in enumerate(wells):
        v = groups.get_group(well).to_numpy(dtype=float)
        q = np.quantile(v, [0.0, 0.25, 0.5, 0.75, 1.0])
        colour = "#b00020" if well in alerted else "#08519c"
        ax.hlines(row, q[0], q[4], color=colour, lw=1)
        if v.size < _MIN_QUARTILES:
            # A "middle half" of two or three cards is an interpolation between them: the
            # cards themselves are drawn instead.
            few = True
            ax.plot(v, np.full(v.size, row), "|", color=colour, ms=10, mew=2)
        else:
            ax.hlines(row, q[1], q[3], color=colour, lw=5, alpha=0.5)
        ax.plot([q[2]], [row], "o", color=colour, ms=6)
    names = [f"{label(w)} ({count_words(groups.get_group(w).size, 'card')})" for w in wells]
    ax.set_yticks(range(len(wells)), names, fontsize=8)
    ax.set_ylim(-0.6, len(wells) - 0.4)
    allv = value[ok].to_numpy(dtype=float)
    ax.set_xlim(*padded_limits(float(allv.min()), float(allv.max())))
    ax.set_xlabel(f"{quantity} of each card [{unit_text(unit)}]: median (dot), middle "
                  "half (bar), range (line)"
                  + (f"; each card (tick) where a well has fewer than {_MIN_QUARTILES}"
                     if few else ""), fontsize=8)
    ax.tick_params(labelsize=8)
    ax.grid(alpha=0.3, axis="x")
    ax.set_title(f"{quantity} in {count_words(len(wells), 'well')}"
                 + (" (red: with an alert)" if alerted & set(wells) else ""), fontsize=10)
    return fig


def distribution_figure(frame: pd.DataFrame, quantity: str, unit: str,
                         alerted: set[str]) -> Figure | None:
    med = per_well_median(frame, quantity, unit)
    if med.empty:
        return None
    if len(med) < MIN_WELLS_HISTOGRAM:
        return few_wells_figure(frame, quantity, unit, alerted)
    fig = Figure(figsize=(6.4, 3.2))
    ax = fig.subplots()
    values = med.to_numpy(dtype=float)
    # A log axis only pays when the values span an order of magnitude; below that it only
    # squeezes the ticks.
    positive = bool(np.all(values > 0)) and values.max() >= 10 * values.min()
    bins: Any = int(np.clip(np.ceil(2 * np.sqrt(len(values))), 5, 30))
    if positive:
        bins = np.geomspace(values.min(), values.max(), bins + 1)
        ax.set_xscale("log")
    ax.hist(values, bins=bins, color="#8fb3d9", edgecolor="#4a6f96")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    marked = med[med.index.isin(alerted)]
    if len(marked):
        ax.plot(marked.to_numpy(), np.zeros(len(marked)), "v", color="#b00020", ms=8,
                clip_on=False, label=f"wells with an alert ({len(marked)})")
        # beside the axes, where it cannot hide a bar
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.set_xlabel(f"{quantity}: median over each well's cards [{unit_text(unit)}]")
    ax.set_ylabel("wells")
    ax.set_title(f"{quantity} across {len(med)} wells", fontsize=10)
    return fig


def _as_float(x: pd.Series) -> np.ndarray:
    if np.issubdtype(x.dtype, np.datetime64):
        return x.to_numpy().astype("datetime64[ns]").astype(np.int64).astype(float)
    return x.to_numpy(dtype=float)


def _segments(x: pd.Series, every: pd.Series) -> np.ndarray:
    """A run number per point of ``x`` that changes across gaps far longer than the usual
    spacing of the well's cards (``every``), so that bands and lines do not pretend to know
    the quantity where no card was read or where the cards left it undetermined."""
    step = np.diff(np.sort(_as_float(every)))
    typical = float(np.median(step[step > 0])) if np.any(step > 0) else 0.0
    if len(x) < 2 or typical <= 0:
        return np.zeros(len(x), dtype=int)
    return np.concatenate([[0], np.cumsum(np.diff(_as_float(x)) > 3.0 * typical)])


def _band(v: pd.Series, s: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """Limits of value +- 2 SE. A positive quantity gets them on the log scale (as the
    change detector judges it), so the band never crosses zero."""
    vv = v.to_numpy(dtype=float)
    ss = np.where(np.isfinite(s.to_numpy(dtype=float)), s.to_numpy(dtype=float), 0.0)
    if len(vv) and np.all(vv > 0):
        factor = np.exp(2.0 * ss / vv)
        return vv / factor, vv * factor
    return vv - 2.0 * ss, vv + 2.0 * ss


def well_figure(group: pd.DataFrame, quantities: Sequence[str], units: dict[str, str],
                 alerts: pd.DataFrame, well: str) -> Figure:
    rows = len(quantities)
    # As wide as the page's figures are shown (about 1350 px at 96 dpi), so that text is
    # drawn at its size rather than scaled.
    fig = Figure(figsize=(14.0, 2.0 * rows + 0.8))
    axes = np.atleast_1d(fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0])
    # The time axis as the change detector orders the well: by time when every usable card
    # has one; a failed or invalid card without a time then cannot be placed and is left out.
    timed = ("time" in group.columns and group["time"].notna().any()
             and group.loc[group["status"].isin(USABLE_STATUSES), "time"].notna().all())
    ordered = (group[group["time"].notna()].sort_values("time", kind="stable") if timed
               else group)
    x_all = (pd.to_datetime(ordered["time"], utc=True).dt.tz_localize(None) if timed
             else pd.Series(np.arange(len(ordered)), index=ordered.index))
    bad = ordered["status"].isin(("failed", "invalid-input")).to_numpy()
    for ax, q in zip(axes, quantities, strict=True):
        value, se, ok = quantity_values(ordered, q)
        x, v, s = x_all[ok], value[ok], se[ok]
        band_lo = band_hi = np.empty(0)
        if len(v):
            band_lo, band_hi = _band(v, s)
            lo, hi = band_lo, band_hi
            run = _segments(x, x_all)
            for k in np.unique(run):
                on = run == k
                if on.sum() > 1:
                    ax.fill_between(x[on], lo[on], hi[on], color="#c6dbef", linewidth=0,
                                    label="value ± 2 SE")
                else:  # a band needs two cards; a lone card gets its interval as a bar
                    ax.vlines(x[on], lo[on], hi[on], color="#c6dbef", lw=3,
                              label="value ± 2 SE")
                ax.plot(x[on], v[on], ".-", color="#08519c", ms=3, lw=0.6,
                        label="value of a card")
        if bad.any():
            # at the foot of the panel, whatever the quantity's range
            ax.plot(x_all[bad], np.full(int(bad.sum()), 0.02), "x", color="#b00020", ms=5,
                    transform=ax.get_xaxis_transform(), clip_on=False,
                    label="failed / invalid card")
        mine = alerts[(alerts["well_id"].astype(str) == well) & (alerts["quantity"] == q)]
        ids = ordered["card_id"].astype(str)
        for _, a in mine.iterrows():
            key = ids == str(a["first_card_id"])
            if not key.any():
                continue
            xc = x_all[key].iloc[0]
            ax.axvline(xc, color="#b00020", lw=1.2, ls="--",
                       label="first card of a change" if _ == mine.index[0] else None)
            # On a white box: the after-change values sit at the top of the axis too. To a
            # tenth of a per cent, as the alerts' text: an alerted 0.3 % read "+0%".
            ax.annotate(f"{a['change_rel']:+.1%}", (xc, 0.98), xycoords=("data", "axes fraction"),
                        xytext=(4, -10), textcoords="offset points", color="#b00020",
                        fontsize=8, fontweight="bold",
                        bbox={"boxstyle": "round,pad=0.15", "facecolor": "white",
                              "edgecolor": "none", "alpha": 0.85})
            # The levels the alert compares, over the cards they come from: a step's medians
            # either side; a drift's line, straight in card order on the analysis scale, so
            # drawn through each card (geometric on a log scale, whatever the cards' times).
            xs, fi = x.to_numpy(), int(a["first_index"])
            if a.get("method") == "drift" and 0 <= fi < xs.size:
                last = min(int(a["alarm_index"]), xs.size - 1)
                share = np.arange(last - fi + 1) / max(last - fi, 1)
                before, after = float(a["before"]), float(a["after"])
                line = (before * (after / before) ** share if a["scale"] == "log"
                        else before + (after - before) * share)
                ax.plot(xs[fi:last + 1], line, color="#e6550d", lw=1.5,
                        label="steady drift (fitted line)")
            elif 0 <= fi < xs.size:
                lo = xs[max(fi - int(a["n_before"]), 0)]
                hi = xs[min(fi + int(a["n_after"]) - 1, xs.size - 1)]
                ax.hlines(a["before"], lo, xc, color="#e6550d", lw=1.5,
                          label="median before / after")
                ax.hlines(a["after"], xc, hi, color="#e6550d", lw=1.5)
        if len(v):
            _value_axis(ax, x, v.to_numpy(dtype=float), band_lo, band_hi, mine)
        else:  # say so, rather than leave an empty panel to be read as missing data
            ax.set_yticks([])
            ax.text(0.5, 0.5, "no card of the well determined this quantity",
                    transform=ax.transAxes, ha="center", va="center", color="#666666",
                    fontsize=9)
        ax.set_ylabel(f"{q}\n[{unit_text(units.get(q, ''))}]", fontsize=8)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    handles: dict[str, Any] = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    # The legend above the panels, right of the title: below them it would sit on the
    # time axis' label.
    top = 1.0 - 0.45 / fig.get_figheight()
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower right", ncols=6,
               fontsize=8, frameon=False, bbox_to_anchor=(0.99, top))
    if len(x_all) > 1 and x_all.max() > x_all.min():
        # Over every card of the well: scaled to the plotted points, the axis ended at the
        # last card with a value, and the cards after it (none determined it) went unseen.
        first, last = x_all.min(), x_all.max()
        margin = 0.02 * (last - first)
        axes[-1].set_xlim(first - margin, last + margin)
    axes[-1].set_xlabel("card time (UTC)" if timed else "card number (no times in the table)")
    if not timed:  # a card number is whole (one card's axis read -0.04 ... 0.04)
        axes[-1].xaxis.set_major_locator(MaxNLocator(integer=True))
    fig.suptitle(f"well {label(well)}", fontsize=10, x=0.01, y=top + 0.1 / fig.get_figheight(),
                 ha="left", va="bottom")
    fig.autofmt_xdate()
    fig.subplots_adjust(top=top, bottom=0.9 / fig.get_figheight())
    return fig


def _value_axis(ax: Any, x: pd.Series, v: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                alerts: pd.DataFrame) -> None:
    """Scale the value axis to the values (and the medians of any change), not to the
    +-2 SE bands: a band may widen the axis by a quarter of the values' range on either side
    at most (so the values fill at least two thirds of it); what runs
    beyond is clipped and marked by a triangle at the axis edge. Values without a range
    (one card) get their band whole."""
    marks = [*v, *pd.to_numeric(alerts["before"], errors="coerce").dropna(),
             *pd.to_numeric(alerts["after"], errors="coerce").dropna()]
    a, b = padded_limits(float(np.min(marks)), float(np.max(marks)))
    # At least 2 % of the values' size: a steady full pump's fillage (0.98825-0.98950)
    # filled its panel as a steep zigzag beside a well whose fillage fell by a quarter.
    least = 0.02 * float(np.max(np.abs(marks)))
    if 0 < b - a < least:
        a, b = 0.5 * (a + b - least), 0.5 * (a + b + least)
    finite_lo, finite_hi = lo[np.isfinite(lo)], hi[np.isfinite(hi)]
    if np.ptp(marks) > 0 or not (finite_lo.size and finite_hi.size):
        half = 0.25 * (b - a)
        bottom = max(a - half, float(finite_lo.min())) if finite_lo.size else a
        top = min(b + half, float(finite_hi.max())) if finite_hi.size else b
    else:
        # One value (a single card, or cards that agree): the axis had only a margin of
        # 1 % of it, and a band a thousand times wider was clipped to that margin, read
        # as a narrow interval. The band is then drawn whole.
        bottom, top = padded_limits(float(finite_lo.min()), float(finite_hi.max()))
    bottom, top = min(bottom, a), max(top, b)
    ax.set_ylim(bottom, top)
    for beyond, edge, marker in ((hi > top, 1.0, "^"), (lo < bottom, 0.0, "v")):
        if beyond.any():
            ax.plot(x[beyond], np.full(int(beyond.sum()), edge), marker, color="#6baed6",
                    ms=4, transform=ax.get_xaxis_transform(), clip_on=False,
                    label="± 2 SE beyond the axis")


def status_figure(counts: pd.Series) -> Figure:
    fig = Figure(figsize=(7.5, 1.1))
    ax = fig.subplots()
    left = 0.0
    total = float(counts.sum())
    for st, n in counts.items():
        if n == 0:
            continue
        ax.barh([0], [n], left=left, color=STATUS_COLOURS.get(str(st), "#777777"),
                label=f"{st}: {count_words(n, 'card')}")
        left += n
    ax.set_xlim(0, max(total, 1))
    # Cards come whole: no ticks at 0.5 of one.
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_yticks([])
    ax.set_xlabel("cards")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.9), ncols=3, fontsize=8,
              frameon=False)
    ax.set_title("fit status of every card", fontsize=10)
    return fig


