"""One self-contained HTML page for a ``pumpid downhole`` run.

The page holds the run's options, a table of every card with its pump quantities, and per
card the surface card beside the pump card (a PNG embedded as base64), the pump quantities
with their units and the notes; a card that could not be computed shows why. Every text
from the cards or the well file is HTML-escaped. Figures are drawn as the cards arrive and
only their PNG bytes are kept, so memory stays small; beyond ``max_figures`` cards the page
lists the rest in its table only (and says so).
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

__all__ = ["DownholeReport"]

#: Pump quantities of the page's tables, in order, with their names in words.
_SHOWN = (("gross_stroke", "gross plunger stroke"), ("net_stroke", "net plunger stroke"),
          ("fluid_load", "fluid load"), ("fillage", "pump fillage"),
          ("upper_load_line", "upper load line"), ("lower_load_line", "lower load line"),
          ("displacement", "pump displacement"), ("intake_pressure", "pump intake pressure"))

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 1250px; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em;
     border-bottom: 1px solid #ccc; } h3 { font-size: 1em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; vertical-align: top; }
th { background: #f0f3f7; text-align: left; }
td.num { text-align: right; font-family: ui-monospace, Menlo, Consolas, monospace; }
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
    png: bytes | None = None


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

    def add(self, result: DownholeResult) -> None:
        """Add one card's result (drawn now if computed and within ``max_figures``)."""
        card = result.card
        well = card.well_id if card.well_id is not None else (
            result.well.well_id if result.well is not None else "")
        entry = _Entry(card_id=str(card.card_id), well=str(well or ""),
                       source=str(card.source or ""), status=result.status,
                       reason=result.reason, quantities=result.quantities(),
                       notes=result.notes)
        drawn = sum(e.png is not None for e in self.entries)
        if result.ok and drawn < self.max_figures:
            buf = io.BytesIO()
            draw_cards(result, buf)
            entry.png = buf.getvalue()
            entry.caption = (f"{result.convention} pump load, {result.method} method, "
                             f"damping nu = {result.damping:g}, "
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
        head = ["card", "well", "status"] + [
            f"{dict(_SHOWN)[n]} [{_e(units.get(n, ''))}]" for n in names]
        rows = []
        for k, e in enumerate(self.entries):
            cells = [f'<td><a href="#card-{k}">{_e(e.card_id)}</a></td>', f"<td>{_e(e.well)}</td>",
                     f'<td class="status-{_e(e.status)}">{_e(e.status)}</td>']
            for n in names:
                q = e.quantities.get(n)
                value = None if q is None else q["value"]
                text = _num(value)
                if q is not None and units.get(n) != q["unit"] and text != "n/a":
                    text += f" {q['unit']}"  # another card's unit: said beside the value
                cells.append(f'<td class="num">{_e(text)}</td>')
            rows.append("<tr>" + "".join(cells) + "</tr>")
        return ('<div class="scroll"><table><tr>' + "".join(f"<th>{h}</th>" for h in head)
                + "</tr>" + "".join(rows) + "</table></div>")

    def _card_section(self, k: int, e: _Entry) -> str:
        out = [f'<h2 id="card-{k}">card {_e(e.card_id)}</h2>',
               f'<p class="muted">well {_e(e.well or "(none)")}; from {_e(e.source)}; status '
               f'<span class="status-{_e(e.status)}">{_e(e.status)}</span></p>']
        if e.status != "computed":
            out.append(f"<p>Not computed: {_e(e.reason)}</p>")
        out.append('<div class="card">')
        if e.png is not None:
            data = base64.b64encode(e.png).decode("ascii")
            out.append(f'<figure><img src="data:image/png;base64,{data}" alt="surface card '
                       f'and pump card of card {_e(e.card_id)}"><figcaption>Left: the surface '
                       f"card as measured; right: the pump card ({_e(e.caption)}); dashed: "
                       "the load lines; red: the load transfer point.</figcaption></figure>")
        if e.quantities:
            rows = "".join(
                f'<tr><td>{_e(label)}</td><td class="num">{_e(_num(e.quantities[n]["value"]))}'
                f'</td><td>{_e(e.quantities[n]["unit"])}</td></tr>'
                for n, label in _SHOWN if n in e.quantities)
            out.append("<table><tr><th>pump quantity</th><th>value</th><th>unit</th></tr>"
                       f"{rows}</table>")
        out.append("</div>")
        if e.notes:
            out.append("<h3>Notes</h3><ul class=\"notes\">" + "".join(
                f"<li>{_e(n)}</li>" for n in e.notes) + "</ul>")
        return "\n".join(out)
