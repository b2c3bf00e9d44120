"""One self-contained HTML page for a ``pumpid downhole`` run.

The page holds the run's options, a table of every card with its pump quantities, and per
card the surface card beside the pump card (a PNG embedded as base64), the pump quantities
with their units and the notes; a card that could not be computed shows why.

Where the pump was also identified (the rod string and valve pump fitted to the surface
card), the caller gives that as plain data (``extra``: the quantities with their errors, the
damping and its rule, the fit's R^2 and residual autocorrelation, the identification's status,
parameters, identifiability and warnings) with its own figure; this layer knows no pump model.

Every text from the cards or the well file is HTML-escaped. Figures are drawn as the cards
arrive and only their PNG bytes are kept, so memory stays small; beyond ``max_figures`` cards
the page lists the rest in its table only (and says so).
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .diagnose import DownholeResult
from .figure import draw_cards

__all__ = ["DownholeReport", "quantity_mark"]

#: Pump quantities of the page's tables, in order, with their names in words.
_SHOWN = (("gross_stroke", "gross plunger stroke"), ("net_stroke", "net plunger stroke"),
          ("fluid_load", "fluid load"), ("fillage", "pump fillage"),
          ("upper_load_line", "upper load line"), ("lower_load_line", "lower load line"),
          ("displacement", "pump displacement"), ("intake_pressure", "pump intake pressure"))

#: The all-cards table's shorter headers (the page's width held all but its last two
#: columns).
_SHORT = {"gross_stroke": "gross stroke", "net_stroke": "net stroke", "fillage": "fillage",
          "upper_load_line": "upper line", "lower_load_line": "lower line",
          "displacement": "displace&shy;ment", "intake_pressure": "intake pressure"}

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 1250px; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em;
     border-bottom: 1px solid #ccc; } h3 { font-size: 1em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; vertical-align: top; }
th { background: #f0f3f7; text-align: left; }
td.num { text-align: right; font-family: ui-monospace, Menlo, Consolas, monospace;
         white-space: nowrap; }
.status-computed { color: #176a2c; font-weight: bold; }
.status-invalid-input, .status-failed { color: #b00020; font-weight: bold; }
figure { margin: 0.8em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
.card { display: flex; flex-wrap: wrap; gap: 1.5em; align-items: flex-start; }
.muted { color: #666; } ul.notes { font-size: 0.9em; color: #444; }
div.scroll { overflow-x: auto; }
"""


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(value: Any) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{float(value):.4g}"


@dataclass
class _Entry:
    card_id: str
    well: str
    source: str
    status: str
    reason: str
    quantities: dict[str, dict[str, Any]]
    notes: tuple[str, ...]
    caption: str = ""
    convention: str = "effective"
    png: bytes | None = None
    extra: Mapping[str, Any] | None = None
    diagnostic: dict[str, dict[str, Any]] = field(default_factory=dict)


@dataclass
class DownholeReport:
    """The HTML page of a run, built card by card.

    Parameters
    ----------
    info : mapping
        The run's options in words (method, damping and its rule, harmonics, load
        convention, well file), shown at the top.
    max_figures : int
        Cards drawn at most (the others are in the table only).
    """

    info: Mapping[str, Any]
    max_figures: int = 200
    entries: list[_Entry] = field(default_factory=list)

    def add(self, result: DownholeResult, extra: Mapping[str, Any] | None = None,
            png: bytes | None = None) -> None:
        """Add one card's result (drawn if computed and within ``max_figures``).

        Parameters
        ----------
        result : DownholeResult
            The diagnostic pump card shown.
        extra : mapping, optional
            The identification as plain data: ``pump`` (each quantity ``{"value", "stderr",
            "unit"}``, the ones shown), ``damping`` (``{"value", "stderr", "unit", "rule"}``),
            ``r2``, ``residual_autocorrelation``, ``identification`` (``status``, ``reason``,
            ``used``, ``parameters``, ``agreement``, ``consistency``, ``energy``,
            ``identifiability``, ``warnings``, ``notes``, or None when not run) and
            ``skipped`` (why not run).
        png : bytes, optional
            The card's figure, already drawn; else the surface card beside the pump card is
            drawn here.
        """
        card = result.card
        well = card.well_id if card.well_id is not None else (
            result.well.well_id if result.well is not None else "")
        quantities = result.quantities()
        if extra is not None and extra.get("pump"):
            quantities = {**quantities, **extra["pump"]}
        entry = _Entry(card_id=str(card.card_id), well=str(well or ""),
                       source=str(card.source or ""), status=result.status,
                       reason=result.reason, quantities=quantities,
                       notes=result.notes, extra=extra, diagnostic=result.quantities(),
                       convention=str(result.convention or "effective"))
        drawn = sum(e.png is not None for e in self.entries)
        if result.ok and drawn < self.max_figures:
            if png is None:
                buf = io.BytesIO()
                draw_cards(result, buf)
                png = buf.getvalue()
            entry.png = png
            entry.caption = (f"{result.convention} pump load, {result.method} method, "
                             f"damping nu = {result.damping:.4g}, "
                             f"{'reversed time order, ' if result.reversed else ''}"
                             f"well {result.well.well_id if result.well else '?'}")
        self.entries.append(entry)

    def html(self) -> str:
        """The page."""
        counts: dict[str, int] = {}
        for e in self.entries:
            counts[e.status] = counts.get(e.status, 0) + 1
        drawn = sum(e.png is not None for e in self.entries)
        parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
                 "<title>pumpid downhole report</title>", f"<style>{_CSS}</style>",
                 "</head><body>", "<h1>pumpid downhole: pump cards and pump quantities</h1>"]
        # Gibbs' factor has no unit: said, so the bare number is not taken for one.
        shown = {k: (f"{v} (Gibbs' dimensionless factor nu)" if k == "damping" else v)
                 for k, v in self.info.items()}
        parts.append("<table>" + "".join(
            f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in shown.items())
            + f"<tr><th>cards</th><td>{len(self.entries)} (" + ", ".join(
                f"{_e(s)} {n}" for s, n in sorted(counts.items())) + ")</td></tr></table>")
        parts.append("<h2>All cards</h2>")
        parts.append(self._summary_table())
        if drawn < sum(e.status == "computed" for e in self.entries):
            parts.append(f'<p class="muted">The first {drawn} computed cards are drawn '
                         "below; the others are in the table above only.</p>")
        for k, e in enumerate(self.entries):
            parts.append(self._card_section(k, e))
        parts.append("</body></html>")
        return "\n".join(parts) + "\n"

    def _summary_table(self) -> str:
        units: dict[str, str] = {}
        for e in self.entries:
            for name, q in e.quantities.items():
                units.setdefault(name, str(q["unit"]))
        names = [n for n, _ in _SHOWN if n in units] or [n for n, _ in _SHOWN]
        fits = any(e.extra is not None and e.extra.get("identification") for e in self.entries)
        head = ["card", "well", "status"] + (
            ["identification", "R&sup2;", "damping nu"] if fits else []) + [
            f"{_SHORT.get(n, dict(_SHOWN)[n])} [{_e(units.get(n, ''))}]" for n in names]
        rows = []
        for k, e in enumerate(self.entries):
            cells = [f'<td><a href="#card-{k}">{_e(e.card_id)}</a></td>', f"<td>{_e(e.well)}</td>",
                     f'<td class="status-{_e(e.status)}">{_e(e.status)}</td>']
            if fits:
                extra = e.extra or {}
                ident = extra.get("identification") or {}
                damping = extra.get("damping") or {}
                # Marked as the card's own table marks it (the fitted damping's word).
                fitted_nu = (ident.get("parameters") or {}).get("damping") or {}
                nu = {**damping, "determined": fitted_nu.get("determined")
                      if damping.get("stderr") is not None else None}
                cells += [f"<td>{_e(ident.get('status', 'not run'))}</td>",
                          f'<td class="num">{_e(_num(extra.get("r2")))}</td>',
                          f'<td class="num">{_stacked(nu)}</td>']
            for n in names:
                q = e.quantities.get(n)
                # Another card's unit is said beside the value.
                other = (q["unit"] if q is not None and units.get(n) != q["unit"]
                         and _num(q.get("value")) != "n/a" else "")
                cells.append(f'<td class="num">{"n/a" if q is None else _stacked(q, other)}'
                             "</td>")
            rows.append("<tr>" + "".join(cells) + "</tr>")
        return ('<div class="scroll"><table><tr>' + "".join(f"<th>{h}</th>" for h in head)
                + "</tr>" + "".join(rows) + "</table></div>")

    def _card_section(self, k: int, e: _Entry) -> str:
        out = [f'<h2 id="card-{k}">card {_e(e.card_id)}</h2>',
               f'<p class="muted">well {_e(e.well or "(none)")}; from {_e(e.source)}; status '
               f'<span class="status-{_e(e.status)}">{_e(e.status)}</span></p>']
        if e.status != "computed":
            out.append(f"<p>Not computed: {_e(e.reason)}</p>")
        extra = e.extra or {}
        ident = extra.get("identification") or {}
        fitted = "parameters" in ident
        if e.status == "computed":
            out.append(_identification_said(extra, ident))
        if e.png is not None:
            data = base64.b64encode(e.png).decode("ascii")
            if fitted:
                caption = ("Top left: the surface card as measured (black) and as the fitted "
                           "rod string and pump predict it (orange, dashed); top right: "
                           "fitted minus measured load over the stroke; bottom left: the "
                           f"diagnostic pump card ({_e(e.caption)}), dashed: its load lines; "
                           + ("bottom right: the identified pump card (green) over the "
                              "diagnostic one (faint blue)" if e.convention == "effective" else
                              "bottom right: the identified pump card (green), in effective "
                              "loads and alone: the diagnostic card is in "
                              f"{_e(e.convention)} loads")
                           + (", red: the identified load transfer point." if ident.get("used")
                              else "."))
            else:
                caption = (f"Left: the surface card as measured; right: the pump card "
                           f"({_e(e.caption)}); dashed: the load lines; red: the load "
                           "transfer point.")
            out.append(f'<figure><img src="data:image/png;base64,{data}" alt="surface card '
                       f'and pump card of card {_e(e.card_id)}"><figcaption>{caption}'
                       "</figcaption></figure>")
        out.append('<div class="card">')
        if e.quantities:
            out.append(self._quantity_table(e, extra))
        if fitted:
            out.append(_parameter_table(ident))
        out.append("</div>")
        for title, key in (("What the card cannot tell", "identifiability"),
                           ("Warnings of the identification", "warnings")):
            if ident.get(key):
                out.append(f'<h3>{title}</h3><ul class="notes">' + "".join(
                    f"<li>{_e(n)}</li>" for n in ident[key]) + "</ul>")
        notes = list(dict.fromkeys([*e.notes, *(ident.get("notes") or [])]))
        if notes:
            out.append("<h3>Notes</h3><ul class=\"notes\">" + "".join(
                f"<li>{_e(n)}</li>" for n in notes) + "</ul>")
        return "\n".join(out)

    @staticmethod
    def _quantity_table(e: _Entry, extra: Mapping[str, Any]) -> str:
        ident = extra.get("identification") or {}
        fitted = bool(ident.get("pump"))
        if not fitted:
            rows = "".join(
                f'<tr><td>{_e(label)}</td><td class="num">{_e(_pm(e.quantities[n]))}</td>'
                f'<td>{_e(e.quantities[n]["unit"])}</td></tr>'
                for n, label in _SHOWN if n in e.quantities)
            damping = extra.get("damping")
            if damping:
                rows += (f'<tr><td>damping nu (Gibbs)</td><td class="num">{_e(_pm(damping))}'
                         "</td><td>dimensionless</td></tr>")
            return ("<table><tr><th>pump quantity</th><th>value</th><th>unit</th></tr>"
                    f"{rows}</table>")
        # Both cards side by side; the column the outputs use is marked.
        used = bool(ident.get("used"))
        mark = ' <span class="muted">(used)</span>'
        head = ("<tr><th>pump quantity</th><th>identified &plusmn; standard error"
                f"{mark if used else ''}</th><th>diagnostic pump card"
                f"{'' if used else mark}</th><th>unit</th></tr>")
        rows = []
        for n, label in _SHOWN:
            d = e.diagnostic.get(n)
            q = ident["pump"].get(n)
            if d is None and q is None:
                continue
            unit = (q or d or {}).get("unit", "")
            rows.append(f'<tr><td>{_e(label)}</td><td class="num">'
                        f'{_e("" if q is None else _pm(q))}</td><td class="num">'
                        f'{_e(_num(None if d is None else d["value"]))}</td>'
                        f"<td>{_e(unit)}</td></tr>")
        fitted_nu = (ident.get("parameters") or {}).get("damping") or {}
        nu = (extra.get("damping") or {}).get("value")
        rows.append(f'<tr><td>damping nu (Gibbs)</td><td class="num">{_e(_pm(fitted_nu))}</td>'
                    f'<td class="num">{_e(_num(nu))}</td><td>dimensionless</td></tr>')
        return f"<table>{head}{''.join(rows)}</table>"


def _unit_words(unit: Any) -> str:
    """A unit as the page's other tables write it: a model's "1" is "dimensionless" there
    (one page said both of the damping)."""
    return "dimensionless" if unit in ("1", "-") else str(unit or "")


def quantity_mark(q: Mapping[str, Any]) -> str:
    """The word beside a quantity the fit does not determine ("" where it does): a full
    pump's fillage is held, not measured."""
    if q.get("held"):
        return "(held: a full pump)"
    return "(not determined)" if q.get("determined") is False else ""


def _pm_parts(q: Mapping[str, Any]) -> list[str]:
    """A quantity's value, its standard error (where it has one) and its mark."""
    parts = [_num(q.get("value"))]
    se = q.get("stderr")
    if parts[0] != "n/a" and se is not None and math.isfinite(float(se)):
        parts.append(f"\u00b1 {float(se):.2g}")
    mark = quantity_mark(q)
    return [*parts, mark] if mark else parts


def _pm(q: Mapping[str, Any]) -> str:
    """``value +- standard error`` (the error left out when there is none), and its mark."""
    return " ".join(_pm_parts(q))


def _stacked(q: Mapping[str, Any], unit: str = "") -> str:
    """A table cell (HTML): the value, its error and its mark on lines of their own, and
    ``unit`` after them: at one line a cell, the all-cards table ran past the page and its
    last columns (displacement, intake pressure) went unseen."""
    parts = _pm_parts(q)
    if unit:
        parts[-1] += f" {unit}"
    return "<br>".join(_e(p).replace("(not determined)", "(not<br>determined)")
                       for p in parts)


def _identification_said(extra: Mapping[str, Any], ident: Mapping[str, Any]) -> str:
    """The identification's outcome in one paragraph: status, R^2, residual autocorrelation,
    damping and its rule, agreement with the diagnostic card, the energy balance."""
    damping = extra.get("damping") or {}
    rule = f"damping nu = {_pm(damping)} ({damping.get('rule', '')})" if damping else ""
    if not ident:
        why = extra.get("skipped") or "not run"
        return f"<p>Pump not identified ({_e(why)}); {_e(rule)}.</p>"
    words = [f"identification <b>{_e(ident.get('status'))}</b>"]
    if not ident.get("used"):
        words.append(f"not used ({_e(ident.get('reason'))}): the outputs give the diagnostic "
                     "pump card's quantities, without errors")
    if extra.get("r2") is not None:
        words.append(f"surface-load fit R&sup2; {_e(_num(extra['r2']))}, residual lag-1 "
                     f"autocorrelation {_e(_num(extra.get('residual_autocorrelation')))}")
    words.append(_e(rule))
    agreement = ident.get("agreement")
    if agreement is not None:
        consistency = ident.get("consistency")
        solvers = ("" if consistency is None else
                   "; the fitted pump card and the diagnostic of the fitted surface load by "
                   f"{_e(f'{100 * consistency:.2f}')} % (the two solvers' own difference: the "
                   "rest is the surface residual carried down the string)")
        words.append(f"fitted and diagnostic pump cards differ by RMS "
                     f"{_e(f'{100 * agreement:.2f}')} % of the load range (after a constant)"
                     + solvers)
    energy = ident.get("energy") or {}
    if energy.get("surface_work") is not None and energy.get("pump_work") is not None:
        loss = energy.get("string_loss")
        measured = energy.get("measured_loss")
        unit = _e(energy.get("unit", ""))
        # The share lost is of the fitted surface card's work (the model's own balance),
        # printed beside it; an identification not used comes after the diagnostic card's
        # balance, which the outputs use (its 69 % led where the card used loses 5.5 %).
        fitted = (f"the fitted surface card {_e(_num(energy.get('fitted_surface_work')))}, "
                  f"the identified pump card {_e(_num(energy['pump_work']))} {unit}"
                  + ("" if loss is None else f": {100 * loss:.1f} % lost in the string"))
        down = energy.get("diagnostic_pump_work")
        diagnostic = ("" if measured is None or down is None else
                      f"the measured surface card {_e(_num(energy['surface_work']))}, the "
                      f"diagnostic pump card {_e(_num(down))} {unit}: "
                      f"{100 * measured:.1f} % lost in the string")
        parts = [fitted, diagnostic] if ident.get("used") else [diagnostic, fitted]
        words.append("work per stroke: " + "; ".join(x for x in parts if x)
                     + ("" if ident.get("used") else " (the identification, not used)"))
    return "<p>" + "; ".join(words) + ".</p>"


def _parameter_table(ident: Mapping[str, Any]) -> str:
    rows = "".join(
        # The table's own column says whether it is determined.
        f'<tr><td>{_e(name)}</td><td class="num">{_e(_pm({**p, "determined": None}))}</td>'
        f'<td>{_e(_unit_words(p.get("unit")))}</td>'
        f"<td>{'yes' if p.get('determined') else 'no'}</td></tr>"
        for name, p in (ident.get("parameters") or {}).items())
    return ("<table><tr><th>fitted parameter</th><th>value &plusmn; standard error</th>"
            f"<th>unit</th><th>determined</th></tr>{rows}</table>")
