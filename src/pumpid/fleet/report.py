"""The fleet report: one self-contained HTML page on many wells' fits over time.

:func:`write_fleet_report` writes ``report.html`` (figures embedded as base64 PNG, inline
style sheet, no script, nothing loaded from elsewhere), the PNGs themselves, ``alerts.csv``
(one row per detected change, as :func:`pumpid.fleet.changes.detect_changes` returns it)
and ``wells.csv`` (one row per well, :func:`pumpid.fleet.changes.summarise_wells`).

The page shows, in order: the run summary (wells, cards and their statuses, the period
covered, the quantities and the detection settings); the alerts, largest first; the wells
table (alerted wells first, then by size of change in standard errors) with status counts
and the latest value of each quantity; each quantity's distribution across wells; and
per-well trends with +-2 standard-error bands and the change points marked. For fleets of
thousands of wells the trends are drawn for the alerted wells (up to a limit) and a random
sample of steady ones, and the page says how many of each; the wells table on the page is
limited in the same way, ``wells.csv`` has them all. Every number is printed with its name
and unit; text from the table (ids, warnings) is escaped.
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
import re
from collections.abc import Iterable, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pumpid.report.spreadsheet import to_csv

from .changes import (
    SHORT_MIN_CARDS,
    UNKNOWN_WELL,
    detect_changes,
    history_coverage,
    is_duplicate,
    is_named,
    is_undated_among_dated,
    load_results,
    summarise_wells,
)
from .events import count_events, ordered_by_event
from .figures import (
    MIN_WELLS_HISTOGRAM,
    column_unit,
    count_words,
    distribution_figure,
    per_well_median,
    quantity_values,
    status_figure,
    unit_mix,
    unit_text,
    well_figure,
)
from .quantities import STATUSES, USABLE_STATUSES, available_quantities, echo_count, with_asked

__all__ = ["write_fleet_report"]

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 2em auto;
       max-width: 100em; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
h3 { font-size: 1.05em; margin-bottom: 0.2em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.45em; text-align: left; vertical-align: top;
         overflow-wrap: break-word; }
th { background: #f2f2f2; font-size: 0.95em; }
td.num { text-align: right; font-family: ui-monospace, Menlo, Consolas, monospace; }
tr.alert td:first-child { border-left: 4px solid #b00020; }
.up { color: #b00020; font-weight: bold; }
.down { color: #1f4fa0; font-weight: bold; }
.muted { color: #666; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figure.wide img { width: 100%; }
div.grid { display: grid; grid-template-columns: repeat(auto-fit, minmax(34em, 1fr));
           gap: 0 1.5em; }
figcaption { color: #555; font-size: 0.92em; }
footer { margin-top: 2em; color: #777; font-size: 0.85em; }
div.scroll { overflow-x: auto; max-width: 100%; }
"""

_DPI = 96
#: An underscore and a zero-width space (where a browser may break a long name).
_WRAP_AFTER_UNDERSCORE = "_\u200b"


# --------------------------------------------------------------------------- formatting
def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(value: Any, digits: int = 4) -> str:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return "n/a"
    if not math.isfinite(x):
        return "n/a" if math.isnan(x) else ("+inf" if x > 0 else "-inf")
    return f"{x:.{digits}g}"


def _with_unit(value: Any, unit: Any, digits: int = 4) -> str:
    text = _num(value, digits)
    if text == "n/a":
        return text
    u = unit_text(unit)
    return f"{text} ({u})" if u == "dimensionless" else f"{text} {u}"


def _when(value: Any) -> str:
    if value is None or value is pd.NaT or (isinstance(value, float) and math.isnan(value)):
        return "time unknown"
    try:
        ts = pd.Timestamp(value)
    except (TypeError, ValueError):
        return str(value)
    if ts is pd.NaT:
        return "time unknown"
    return ts.strftime("%Y-%m-%d %H:%M UTC")


def _table(headers: Sequence[str], rows: Iterable[Sequence[str]], *, num_cols: Iterable[int] = (),
           row_classes: Sequence[str] | None = None) -> str:
    num = set(num_cols)
    out = ["<table>", "<thead><tr>", *(f"<th>{_e(h)}</th>" for h in headers), "</tr></thead>",
           "<tbody>"]  # fmt: skip
    for i, row in enumerate(rows):
        cls = f' class="{_e(row_classes[i])}"' if row_classes and row_classes[i] else ""
        cells = "".join(
            f'<td class="num">{_e(c)}</td>' if j in num else f"<td>{_e(c)}</td>"
            for j, c in enumerate(row)
        )
        out.append(f"<tr{cls}>{cells}</tr>")
    out.append("</tbody></table>")
    return '<div class="scroll">' + "\n".join(out) + "</div>"


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI, bbox_inches="tight")
    return buf.getvalue()


def _figure_html(data: bytes, alt: str, caption: str, *, wide: bool = False) -> str:
    """A figure; ``wide`` ones are drawn across the page's width (their PNG is made for it)."""
    b64 = base64.b64encode(data).decode("ascii")
    cls = ' class="wide"' if wide else ""
    return (f'<figure{cls}><img src="data:image/png;base64,{b64}" alt="{_e(alt)}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _safe_name(text: str, taken: set[str]) -> str:
    base = re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("._") or "well"
    name, k = base, 1
    while name in taken:
        k += 1
        name = f"{base}_{k}"
    taken.add(name)
    return name


def _version() -> str:
    try:
        return metadata.version("pumpid")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


# --------------------------------------------------------------------------- sections
#: How each way of testing a well reads in the report, by :func:`history_coverage`'s method:
#: the short-history method is two tests (it read "two-segment" alone), and a well "too
#: short" may have 30 cards, too few of them usable.
_TESTED = {"cusum": "CUSUM", "two-segment": "two-segment and drift",
           "too short": "too few usable cards"}


def _well_tests(coverage: pd.DataFrame) -> pd.Series:
    """How each well was tested: by its longest history over the quantities."""
    rank = {"cusum": 0, "two-segment": 1, "too short": 2}
    if coverage.empty:
        return pd.Series(dtype=object)
    best = coverage.assign(_r=coverage["method"].map(rank)).sort_values("_r", kind="stable")
    return best.drop_duplicates("well_id").set_index("well_id")["method"]


def _coverage_rows(coverage: pd.DataFrame, min_cards: int,
                   min_short: int) -> list[tuple[str, str]]:
    """Summary rows: how many wells each method tested, and which were too short."""
    tests = _well_tests(coverage)
    short = sorted(tests[tests == "too short"].index.astype(str))
    rows = [("wells tested",
             f"{count_words((tests == 'cusum').sum(), 'well')} by the CUSUM (more than "
             f"{min_cards} usable cards of a quantity), "
             f"{count_words((tests == 'two-segment').sum(), 'well')} by the two-segment and "
             f"drift tests ({min_short} to {min_cards} cards)")]
    if short:
        shown = ", ".join(short[:30]) + (f" and {len(short) - 30} more" if len(short) > 30
                                         else "")
        rows.append((f"wells too short to test (fewer than {min_short} usable cards of "
                     "every quantity)", f"{count_words(len(short), 'well')}: {shown}"))
    return rows


def _no_value(frame: pd.DataFrame, quantity: str) -> str:
    """Why a quantity has nothing to trend, in words: "no usable value" was said of pumps
    identified on cards without a well id, where the missing id is the reason."""
    if quantity_values(frame, quantity)[2].any():
        return "usable values only on cards without a well id"
    echoes = echo_count(frame, quantity)
    if echoes:
        # A quantity "with no usable value" whose 66 determined values were all echoes
        # gave no hint of them, nor of how to see them.
        return (f"{count_words(echoes, 'value')}, all echoes of the stroke, not the well's "
                f"(name it to trend them: --quantity {quantity}, Python asked=)")
    return "no usable value in any well"


def _summary_section(frame: pd.DataFrame, named: pd.DataFrame, alerts: pd.DataFrame,
                     quantities: Sequence[str], units: dict[str, str], settings: str,
                     empty: Sequence[str], coverage_rows: Sequence[tuple[str, str]] = (),
                     asked: bool = False) -> str:
    status = frame["status"].where(frame["status"].isin(STATUSES), "other")
    counts = status.value_counts().reindex([*STATUSES, "other"], fill_value=0)
    n = len(frame)
    times = pd.to_datetime(frame["time"], utc=True) if "time" in frame.columns else None
    span = "no card times in the table"
    if times is not None and times.notna().any():
        span = f"{_when(times.min())} to {_when(times.max())}"
    no_well = len(frame) - len(named)
    undated_rows = is_undated_among_dated(named)
    undated = int(undated_rows.sum())
    rows = [
        ("wells", count_words(named["well_id"].nunique(), "well")),
        ("cards", count_words(n, "card")),
        *(((f"cards without a well id (filed under {UNKNOWN_WELL}, with any unreadable "
             "input's rows)", count_words(no_well, "card")),)
          if no_well else ()),
        *((("cards without a time in wells whose other cards have one (not trended: a "
             "time order cannot place them)", count_words(undated, "card")),)
          if undated else ()),
        (f"cards used for trends ({', '.join(USABLE_STATUSES)}, with a well id"
         f"{' and a time where their well has one' if undated else ''})",
         count_words(int((named["status"].isin(USABLE_STATUSES) & ~undated_rows).sum()),
                     "card")),
        *((f"status {st}", f"{count_words(counts[st], 'card')} ({counts[st] / max(n, 1):.1%})")
          for st in counts.index if counts[st] or st in STATUSES),
        ("cards without a time",
         count_words(times.isna().sum() if times is not None else n, "card")),
        *((("pump identifications (the status the pump quantities count by)",
             _status_counts(frame["identify_status"])),) if "identify_status" in frame.columns
          else ()),
        ("period covered", span),
        # Each is trended where it has usable values; "quantities trended" listed some
        # marked "(not trended)".
        ("quantities asked for" if asked else "quantities", ", ".join(
            f"{q} [{unit_text(units[q])}]" + (f" ({_no_value(frame, q)}: not trended)"
                                             if q in empty else "")
            for q in quantities) or "none"),
        ("alerts", _alert_count(alerts)),
        *coverage_rows,
        ("detection", settings),
    ]
    return _table(("item", "value"), rows)


def _alert_count(alerts: pd.DataFrame) -> str:
    """``9 alerts in 2 wells: 2 changes, ...``: one leak read as five alerts."""
    text = (f"{count_words(len(alerts), 'alert')} in "
            f"{count_words(alerts['well_id'].nunique(), 'well')}")
    events = count_events(alerts)
    if events < len(alerts):
        text += (f": {count_words(events, 'change')} (the alerts of a well over the same "
                 "cards are one change seen in several quantities)")
    return text


def _alerts_section(alerts: pd.DataFrame, tests: pd.Series, unnamed: bool) -> str:
    if alerts.empty:
        tested = int((tests != "too short").sum())
        if not tests.size and unnamed:
            return (f"<p>No well was tested for changes: the cards carry no well id "
                    f"(they are filed under {UNKNOWN_WELL}, whose cards may come from "
                    "several wells, and are not trended; give the wells' ids to trend "
                    "them: a well column, or <code>--well-id ID</code> for the files of "
                    "one well).</p>")
        if not tested:
            return ("<p>No well was tested for changes: no well has enough usable cards of "
                    "a quantity (see the run summary).</p>")
        short = int((tests == "too short").sum())
        rest = (f"; {count_words(short, 'well')} with too few usable cards to test" if short
                else "")
        which = "the well" if tested == 1 else f"the {tested} wells"
        return f"<p>No persistent change was found in {which} tested{rest}.</p>"
    rows, classes = [], []
    for _, a in ordered_by_event(alerts).iterrows():
        unit = a["unit"]
        rows.append([
            str(int(a["event"])), str(a["well_id"]), str(a["quantity"]),
            f"{a['first_card_id']} ({_when(a['first_time'])})",
            # A short history is tested whole (every method but the CUSUM), at the report:
            # its newest card is no detector's delay ("3 cards later" was read as one).
            (f"{a['alarm_card_id']} (its newest usable card: the history is tested whole)"
             if a["method"] != "cusum" else
             f"{a['alarm_card_id']} ({count_words(a['delay_cards'], 'card')} later)"),
            f"{_with_unit(a['before'], unit)} → {_with_unit(a['after'], unit)}"
            + (" (fitted line, first card → last)" if a["method"] == "drift" else ""),
            # The sign gives the direction (a column of its own made the table too wide
            # once the change numbers came in).
            f"{_with_unit(a['change'], unit)} ({float(a['change_rel']):+.1%}"
            f"{', a steady drift' if a['method'] == 'drift' else ''})",
            _num(a["change_se"], 3),
            f"{int(a['n_before'])} / {int(a['n_after'])}",
        ])  # fmt: skip
        classes.append("alert")
    headers = ("change", "well", "quantity", "first changed card (its time)", "alarm card",
               "median before → after", "change (relative)", "size (standard errors)",
               "cards before / after")
    return _table(headers, rows, num_cols=(0, 5, 6, 7), row_classes=classes)


def _status_counts(statuses: pd.Series) -> str:
    """``converged 14, undetermined 2`` (most first; none: "none")."""
    counts = statuses.dropna().astype(str).value_counts()
    return ", ".join(f"{k} {int(v)}" for k, v in counts.items()) or "none"


def _identifications(frame: pd.DataFrame) -> dict[str, str] | None:
    """Each well's pump identification statuses in words, where the run identified pumps:
    the wells table gave only the lumped fits' statuses, and an undetermined pump's fluid
    load (11.97 +- 58.5 kN) read as its latest value like any other."""
    if "identify_status" not in frame.columns:
        return None
    wells = frame["well_id"].astype("string").fillna(UNKNOWN_WELL)
    return {str(w): _status_counts(group) for w, group in frame["identify_status"].groupby(
        wells.to_numpy(), sort=False)}


def _wells_section(summary: pd.DataFrame, quantities: Sequence[str], units: dict[str, str],
                   limit: int) -> str:
    shown = summary.head(limit)
    # Columns that would be empty in every listed well are left out, and said: a pump
    # field's 9 quantities and 6 statuses made the table scroll sideways at 1400 px.
    statuses = [st for st in STATUSES if shown["n_" + st.replace("-", "_")].sum() > 0]
    latest = [q for q in quantities
              if f"latest_{q}" in shown
              and np.isfinite(pd.to_numeric(shown[f"latest_{q}"], errors="coerce")).any()]
    # Counts and units go in the headers, so that every column fits a normal window; a
    # zero-width space after each underscore lets a quantity's name wrap there.
    pumps = "pump_identifications" in shown.columns
    # Beside the pumps' statuses, the lumped fits' are said to be theirs (P004's "converged
    # 0, undetermined 16" read as its pump's, which converged 16 times).
    shown_statuses = [f"{st} (lumped fit)" if pumps else st for st in statuses]
    headers = ["well", "cards", *shown_statuses, *(["pump identifications"] if pumps else []),
               "alerts", "tested by", "largest change",
               *(f"latest {q.replace('_', _WRAP_AFTER_UNDERSCORE)} "
                 f"[{unit_text(units.get(q, ''))}]" for q in latest)]
    rows, classes = [], []
    for _, w in shown.iterrows():
        cells = [str(w["well_id"]), str(int(w["cards"]))]
        cells += [str(int(w["n_" + st.replace("-", "_")])) for st in statuses]
        if pumps:
            cells.append(str(w["pump_identifications"]) or "none")
        changes = int(w.get("changes", w["alerts"]))
        cells.append(str(int(w["alerts"])) + (f" ({count_words(changes, 'change')})"
                                              if changes < w["alerts"] else ""))
        cells.append(str(w.get("tested", "")))
        # The phrase carries the change's signed size (the absolute one only ranks).
        cells.append(str(w["largest_change"]) if w["alerts"] else "none")
        for q in latest:
            unit = w.get(f"latest_{q}_unit", "")
            same = unit_text(unit) == unit_text(units.get(q, ""))
            value = w.get(f"latest_{q}")
            cell = _num(value) if same else _with_unit(value, unit)
            # A latest value older than the well's last card says its date: it read as
            # current while 13 later cards had none.
            when, last = w.get(f"latest_{q}_time"), w.get("last_time")
            if pd.notna(when) and pd.notna(last) and when < last and _num(value) != "n/a":
                cell += f" (of {pd.Timestamp(when):%Y-%m-%d %H:%M})"
            cells.append(cell)
        rows.append(cells)
        classes.append("alert" if w["alerts"] else "")
    note = ""
    if len(summary) > limit:
        note = (f"<p class=\"muted\">The first {limit} of {len(summary)} wells are listed "
                "(alerted wells first); wells.csv lists them all.</p>")
    left = [st for st in STATUSES if st not in statuses]
    empty = [q for q in quantities if q not in latest]
    if left or empty:
        said = []
        if left:
            said.append(f"no card of these wells has status {', '.join(left)} (the run "
                        "summary counts every status)")
        if empty:
            said.append(f"no latest usable value of {', '.join(empty)} in these wells")
        note += (f"<p class=\"muted\">Columns left out: {'; '.join(said)}; wells.csv has "
                 "them all.</p>")
    # Right-aligned: the cards, the statuses' counts, the alerts and the latest values.
    alerts_col = 2 + len(statuses) + (1 if pumps else 0)
    num = [*range(1, 2 + len(statuses)), alerts_col]
    return note + _table(headers, rows, num_cols=[*num, *range(len(headers) - len(latest),
                                                               len(headers))],
                         row_classes=classes)


def _drawn_words(drawn_alerted: Sequence[str], alerted: Sequence[str],
                 drawn_steady: Sequence[str], steady: Sequence[str], seed: int) -> str:
    """Which wells the trends show, in words that fit one well as well as thousands."""
    parts = []
    # "1 well without an alert: it." read as a broken sentence: the count goes into words
    # that stand for one well as well as for thousands.
    if alerted:
        n, k = len(alerted), len(drawn_alerted)
        if k == n:
            parts.append("the well with an alert" if n == 1 else "both wells with an alert"
                         if n == 2 else f"all {n} wells with an alert")
        else:
            parts.append(f"the one of the {n} wells with an alert with the largest change"
                          if k == 1 else
                         f"the {k} of the {n} wells with an alert with the largest changes")
    if steady:
        n, k = len(steady), len(drawn_steady)
        if k == n:
            parts.append("the well without an alert" if n == 1 else
                         "both wells without an alert" if n == 2 else
                         f"all {n} wells without an alert")
        elif k == 0:
            parts.append("not the well without an alert" if n == 1 else
                         f"none of the {n} wells without an alert")
        else:
            parts.append(f"{k} of the {n} wells without an alert for comparison, picked at "
                         f"random (seed {seed}), the wells the detector tested first")
    if not parts:
        return "No well has a usable card to draw."
    return "Drawn: " + "; ".join(parts) + "."


# --------------------------------------------------------------------------- entry point
def write_fleet_report(
    results: pd.DataFrame | str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    alerts: pd.DataFrame | None = None,
    quantities: Sequence[str] | None = None,
    asked: Sequence[str] | None = None,
    max_wells_plotted: int = 24,
    steady_sample: int = 6,
    max_wells_listed: int = 500,
    seed: int = 0,
    **detect_options: Any,
) -> dict[str, Path]:
    """Write the fleet report (HTML, PNGs, alerts.csv, wells.csv) for a results table.

    Parameters
    ----------
    results : pandas.DataFrame or path
        The results table, or a Parquet file or folder holding it.
    out_dir : str or path
        Output folder (created).
    alerts : pandas.DataFrame, optional
        Changes found by :func:`pumpid.fleet.changes.detect_changes`; computed here (with
        ``quantities`` and ``detect_options``) when not given.
    quantities : sequence of str, optional
        Quantities to show (default: every derived quantity of the table).
    asked : sequence of str, optional
        Quantities the user named (default: ``quantities``): their values that fits call
        an echo of the stroke are counted, trended and drawn too; the others' are not.
    max_wells_plotted : int, default 24
        Most alerted wells drawn (the largest changes first).
    steady_sample : int, default 6
        Wells without alerts drawn for comparison, picked at random with ``seed``.
    max_wells_listed : int, default 500
        Most wells in the page's wells table (alerted wells first); ``wells.csv`` has all.
    seed : int, default 0
        For the sample of steady wells.
    **detect_options
        Passed to :func:`~pumpid.fleet.changes.detect_changes` when ``alerts`` is None.

    Returns
    -------
    dict of str to Path
        ``"report"`` (report.html), ``"alerts"`` (alerts.csv), ``"wells"`` (wells.csv) and
        one entry per PNG, keyed by its file name without ``.png``.

    Raises
    ------
    ValueError
        If the table lacks ``well_id``, ``card_id`` or ``status``, or a quantity is unknown.
    """
    asked = asked if asked is not None else quantities or ()
    whole = with_asked(load_results(results), asked)
    # A card exported twice counts once: its repeats are set aside before anything is
    # counted, trended or tested, and the summary says how many.
    repeats = is_duplicate(whole)
    n_repeats = int(repeats.sum())
    frame = whole[~repeats]
    named = frame[is_named(frame)]
    out = Path(os.fspath(out_dir))
    out.mkdir(parents=True, exist_ok=True)
    names = list(quantities) if quantities is not None else available_quantities(frame)
    min_cards = int(detect_options.get("min_cards", 30))
    min_short = int(detect_options.get("min_short_cards", SHORT_MIN_CARDS))
    given = alerts is not None
    if alerts is None:
        # The quantities asked for count their echoes of the stroke (with_asked above), in
        # the detection as in the views; the default leaves echoes out.
        alerts = detect_changes(frame, quantities, asked=asked, **detect_options)
    if not given or detect_options:
        # Alerts a caller found with these same options (the command line prints them
        # before the CSV neutralises their text) are described as if found here.
        settings = (f"per-well false-alarm probability "
                    f"{detect_options.get('false_alarm', 0.01):.1%}; robust two-sided CUSUM "
                    f"with reference windows of {min_cards} cards for histories of more than "
                    f"{min_cards} cards; the two-segment and drift tests for {min_short} to "
                    f"{min_cards}")
    else:
        settings = "alerts given by the caller"
    coverage = history_coverage(frame, names, min_cards=min_cards, min_short_cards=min_short)
    # The repeats are counted per well by the summary itself (it sets them aside too).
    summary = summarise_wells(whole, alerts, names)
    tests = _well_tests(coverage)
    summary["tested"] = [_TESTED.get(tests.get(w, ""), "not tested (no well id)"
                                     if w == UNKNOWN_WELL else "no usable card")
                         for w in summary["well_id"].astype(str)]
    identified = _identifications(frame)
    if identified is not None:
        summary["pump_identifications"] = [
            identified.get(str(w), "") for w in summary["well_id"].astype(str)]
    units = {q: column_unit(frame, summary, q) for q in names}
    files: dict[str, Path] = {}
    alerts_path = out / "alerts.csv"
    # Text a spreadsheet would evaluate (an id "=...") is neutralised in the CSV files.
    to_csv(alerts, alerts_path, date_format="%Y-%m-%dT%H:%M:%S%z")
    files["alerts"] = alerts_path
    wells_path = out / "wells.csv"
    to_csv(summary, wells_path, date_format="%Y-%m-%dT%H:%M:%S%z")
    files["wells"] = wells_path

    def save(fig: Figure, name: str) -> bytes:
        data = _png(fig)
        path = out / f"{name}.png"
        path.write_bytes(data)
        files[name] = path
        return data

    status = frame["status"].where(frame["status"].isin(STATUSES), "other")
    counts = status.value_counts().reindex([*STATUSES, "other"], fill_value=0)
    parts: list[str] = []
    parts.append("<section id=\"summary\"><h2>Run summary</h2>")
    repeat_rows = [("duplicate cards set aside (exact repeats of an earlier card of the "
                    "same well, counted once)", count_words(n_repeats, "card"))]
    # Quantities with no usable value in any well: named so in the summary, left out of
    # the trends (a third of each pump well's figure was three panels saying "no card of
    # the well determined this quantity").
    empty = [q for q in names if not quantity_values(named, q)[2].any()]
    parts.append(_summary_section(frame, named, alerts, names, units, settings, empty,
                                  [*repeat_rows, *_coverage_rows(coverage, min_cards,
                                                                 min_short)],
                                  asked=bool(asked) and set(names) <= set(asked)))
    pumps = ("" if identified is None else
             " These are the lumped model's statuses; the pump quantities count by the pump "
             "identification's, given in the summary and the wells table.")
    parts.append(_figure_html(save(status_figure(counts), "status"), "status of every card",
                              f"Cards by fit status. Only {', '.join(USABLE_STATUSES)} "
                              "cards of named wells enter the trends; the others are counted "
                              f"here.{pumps}"))
    parts.append("</section>")

    parts.append("<section id=\"alerts\"><h2>Alerts</h2>")
    parts.append("<p>Each row is a persistent shift in one quantity of one well: the first "
                 "card of the new level (the estimated change point), the card at which the "
                 "detector raised the alarm (a short history's tests judge it whole: their "
                 "alarm is its newest usable card), the medians before and after, and the size of "
                 "the change in units of its standard error. The alerts of a well over the "
                 "same cards are one change seen in several quantities (a leak lowers the "
                 "fluid load and raises the intake pressure): they share a number, the "
                 "largest change first.</p>")
    parts.append(_alerts_section(alerts, tests,
                                 len(named) < len(frame)))
    parts.append("</section>")

    parts.append("<section id=\"wells\"><h2>Wells</h2>")
    parts.append("<p>Wells with alerts first (largest change in standard errors first), "
                 "then the others by name; the number of cards of each fit status, the "
                 "alerts, and the latest usable value of each quantity.</p>")
    parts.append(_wells_section(summary, names, units, max_wells_listed))
    parts.append("</section>")

    alerted = set(alerts["well_id"].astype(str))
    parts.append("<section id=\"distributions\"><h2>Quantities across wells</h2>")
    # The quantities without a value in one paragraph above the grid: as grid cells of
    # their own they left half-empty rows beside the figures.
    figures, missing = [], []
    taken: set[str] = set()
    for q in names:
        fig = distribution_figure(named, q, units[q], alerted)
        if fig is None:
            missing.append(f"{_e(q)}: {_no_value(frame, q)}")
            continue
        name = _safe_name(f"distribution_{q}", taken)
        # The view the figure drew: wells whose unit cannot be converted are not in it.
        few = len(per_well_median(named, q, units[q])) < MIN_WELLS_HISTOGRAM
        caption = (f"{q} [{unit_text(units[q])}] of each well's cards, well by well (too "
                   f"few wells for a histogram); red: wells with an alert." if few else
                   f"Distribution across wells of each well's median {q} "
                   f"[{unit_text(units[q])}]; triangles mark wells with an alert.")
        converted, left = unit_mix(named, q, units[q])
        if converted:
            caption += (f" Values stated in {', '.join(converted)} are converted to "
                        f"{unit_text(units[q])}.")
        if left:
            caption += (f" {count_words(left, 'card')} in a unit that cannot be converted "
                        "to it are left out.")
        figures.append(_figure_html(save(fig, name), f"distribution of {q}", caption))
    if missing:
        parts.append(f"<p>{'; '.join(missing)}.</p>")
    parts.append("<div class=\"grid\">" + "".join(figures) + "</div></section>")

    # Which wells to draw: the alerted ones by decreasing size, then a random few steady.
    ranked = summary[summary["alerts"] > 0]["well_id"].astype(str).tolist()
    drawn_alerted = ranked[:max_wells_plotted]
    # Steady wells worth drawing have at least one usable card.
    usable_wells = named.loc[named["status"].isin(USABLE_STATUSES), "well_id"].astype(str)
    steady = sorted(set(usable_wells) - alerted)
    rng = np.random.default_rng(seed)
    k = min(steady_sample, len(steady))
    # Wells the detector tested first: a comparison drawn from wells with too few usable
    # cards showed mostly empty panels while tested wells went undrawn.
    tested = [w for w in steady if tests.get(w, "too short") != "too short"]
    first = sorted(rng.choice(tested, size=min(k, len(tested)), replace=False).tolist()) \
        if tested else []
    rest = [w for w in steady if w not in tested]
    more = (sorted(rng.choice(rest, size=k - len(first), replace=False).tolist())
            if k > len(first) else [])
    drawn_steady = sorted([*first, *more])
    drawn_names = [q for q in names if q not in empty] or names
    parts.append("<section id=\"trends\"><h2>Trends per well</h2>")
    # The panels described only where some are drawn (a page without one described them).
    panels = ("" if not (drawn_alerted or drawn_steady) else
              " Each panel shows one quantity over the well's cards with a band of ± 2 "
              "standard errors (the axis is scaled to the values; a band running beyond "
              "it is cut and marked by a triangle at the edge); dashed lines mark the "
              "first card of each change; crosses at the bottom mark cards whose fit "
              "failed or whose input was invalid. A card whose fit left a quantity "
              "undetermined (or has no error for it: a full pump's held fillage) has no "
              "point (or no band) in its panel; a line joins cards at most three usual spacings "
              "apart."
              + (f" Quantities no well has a usable value of are not drawn: "
                 f"{', '.join(empty)}." if empty else ""))
    parts.append(f"<p>{_drawn_words(drawn_alerted, ranked, drawn_steady, steady, seed)}"
                 f"{panels}</p>")
    groups = {str(w): g for w, g in frame.groupby(frame["well_id"].astype(str))}
    for well in [*drawn_alerted, *drawn_steady]:
        fig = well_figure(groups[well], drawn_names, units, alerts, well)
        name = _safe_name(f"well_{well}", taken)
        n_alerts = int((alerts["well_id"].astype(str) == well).sum())
        # "(without an alert: 0 alerts)" said it twice.
        said = count_words(n_alerts, "alert") if n_alerts else "no alert"
        parts.append(f"<h3>Well {_e(well)} ({_e(said)})</h3>")
        parts.append(_figure_html(save(fig, name), f"trends of well {well}",
                                  f"Well {well}: quantities over time, value ± 2 SE.",
                                  wide=True))
    parts.append("</section>")

    body = "\n".join(parts)
    n_wells = named["well_id"].nunique()
    events = count_events(alerts)
    headline = (f"{count_words(n_wells, 'well')}, {count_words(len(frame), 'card')}, "
                f"{count_words(len(alerts), 'alert')}"
                + (f" ({count_words(events, 'change')})" if events < len(alerts) else ""))
    page = f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>pumpid fleet report</title>
<style>{_CSS}</style>
</head>
<body>
<h1>pumpid fleet report</h1>
<p class="muted">Which wells changed, when, and how: {headline}.</p>
{body}
<footer>Made by pumpid {_e(_version())}. Change detection: see
pumpid.fleet.changes for the method and its assumptions.</footer>
</body>
</html>
"""
    report = out / "report.html"
    report.write_text(page, encoding="utf-8")
    files["report"] = report
    return files
