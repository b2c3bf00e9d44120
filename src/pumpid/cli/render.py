"""What ``pumpid fit`` prints: one short block per card, one line per card, or JSON.

Three printers share one interface (``start``, ``file``, ``row``, ``finish``) so that the
command streams: each card is printed as soon as it is fitted and nothing is kept.

* :class:`TextPrinter` (default): the run's assumptions once, each file's notes once, then
  per card its status, fit quality, parameters with units and standard errors, derived
  quantities and warnings; ``verbose=True`` gives each card's full report instead.
* :class:`LinePrinter` (``--brief``): one tab-separated line per card.
* :class:`JsonPrinter` (``--json``): always one object ``{"cards": [...], "summary":
  {...}}``, whatever the number of cards; each element has at least ``status``, ``reason``
  and ``card`` (``{"id", "source", ...}``); a fitted card's element is its
  :meth:`~pumpid.FitResult.to_dict` plus ``output`` (where its files are, or null). The
  elements are written as the cards are fitted; an interrupted run still closes the
  document (``summary.interrupted`` is true).

Every piece of text that comes from a file (card ids, notes, reasons) is shown with
control characters escaped (:func:`pumpid.cards.printable`), so a hostile card id cannot
reach the terminal raw.
"""

from __future__ import annotations

import collections
import json
import math
import sys
import textwrap
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, TextIO

from ..cards import Card, printable
from ..inference.serial import widening
from ..report.units import model_param_units, unit_text
from ..result import FitResult, Prediction, jsonable, model_choice_text
from ..result.fit import beyond_text
from .common import fmt, plural

__all__ = ["JsonPrinter", "LinePrinter", "Row", "RunInfo", "TextPrinter", "first_sentence"]

_WIDTH = 100


@dataclass
class Row:
    """One card's outcome as the command prints it.

    ``result`` is None when the card could not be fitted at all (invalid input, an
    unreadable file, an internal error); ``status`` and ``reason`` then say why.
    """

    card_id: str | None
    source: str | None
    status: str
    reason: str
    result: FitResult | None = None
    card: Card | None = None
    warnings: list[str] = field(default_factory=list)
    prediction: Prediction | None = None
    output: str | None = None
    #: The well a card refused by its reader names (its result's card says it otherwise).
    well_id: str | None = None

    @property
    def fitted(self) -> bool:
        """A usable answer: converged, or a boundary (limiting-model) solution."""
        return self.status in ("converged", "boundary")


@dataclass(frozen=True)
class RunInfo:
    """What holds for every card of the run, said once."""

    model: str
    title: str
    observe: str | None
    observe_meaning: str | None
    method: str
    assumptions: tuple[str, ...]
    out: str | None


def first_sentence(text: str) -> str:
    """The first sentence of a warning (the rest is in ``--verbose`` and the report)."""
    for i, ch in enumerate(text):
        if ch == "." and i + 1 < len(text) and text[i + 1] == " " and i > 20:
            return text[: i + 1]
    return text


def _wrap(text: str, indent: str = "  ") -> list[str]:
    return textwrap.wrap(text, width=_WIDTH, initial_indent=indent,
                         subsequent_indent=indent + "  ", break_long_words=False,
                         break_on_hyphens=False) or [indent]


def _wrap_items(items: Sequence[str], prefix: str = "", indent: str = "  ") -> list[str]:
    """Comma-separated items, wrapped between items only (a value keeps its error and unit)."""
    glue = "\u00a0"  # a space the wrapper does not break at
    text = prefix + ", ".join(item.replace(" ", glue) for item in items)
    return [line.replace(glue, " ") for line in _wrap(text, indent)]


def _id(row: Row) -> str:
    return printable(row.card_id) if row.card_id else "(unnamed card)"


def _quality(res: FitResult) -> str:
    return (f"R^2 = {fmt(res.r2, 6)}{beyond_text(res, short=True)}, RMSE = {fmt(res.rmse, 4)} "
            f"{unit_text(res.units.position)}")


def _bounds(res: FitResult) -> dict[str, str]:
    if res.boundary is None:
        return {}
    return {b.name: b.direction for b in res.boundary.limits}


def _valued(name: str, value: float, se: float | None, unit: str, undetermined: bool) -> str:
    """``name = value ± error unit`` with the "(not determined)" flag where it applies."""
    err_txt = f" ± {fmt(se, 2)}" if se is not None and math.isfinite(se) and se > 0 else ""
    flag = " (not determined)" if undetermined else ""
    return f"{name} = {fmt(value, 5)}{err_txt} {unit}{flag}".replace("  ", " ")


def _params(res: FitResult, *, errors: bool = True) -> list[str]:
    units = res.param_units()
    se = res.stderr if errors else {}
    undetermined = set(res.determined.get("not_determined", []) or [])
    at_bound = _bounds(res)
    out = []
    for name, value in res.params.items():
        if name in at_bound:
            out.append(f"{name} -> {at_bound[name]} (ran to a bound)")
            continue
        out.append(_valued(name, value, se.get(name), unit_text(units.get(name, "")),
                           name in undetermined))
    # The scale and the offset are flagged like the parameters: an offset of -1e8 ± 4e13 m
    # went unmarked where the JSON listed it as not determined.
    if "C" in res.free or "D" in res.free:
        out.append(_valued("C", res.scale, se.get("C"), "", "C" in undetermined).rstrip())
    if "offset" in res.free:
        out.append(_valued("offset", res.offset, se.get("offset"),
                           unit_text(res.units.position), "offset" in undetermined))
    return out


def _prediction_scores(pred: Prediction, res: FitResult) -> str:
    """A prediction's R^2 beside its card's fundamental alone, and its RMSE."""
    alone = (f" (the card's fundamental alone: {fmt(pred.r2_fundamental, 6)})"
             if math.isfinite(pred.r2_fundamental) else "")
    return (f"R^2 = {fmt(pred.r2, 6)}{alone}, RMSE = {fmt(pred.rmse, 4)} "
            f"{unit_text(res.units.position)}")


def _robust_note(res: FitResult) -> str | None:
    """Which errors the ± are, where they are not the independent-noise ones (the run's
    header says that the card says so)."""
    if res.errors_shown != "robust" or res.uncertainty is None:
        return None
    lag1 = (res.uncertainty.whiteness or {}).get("lag1_autocorrelation")
    # two decimals, as the warning beside it gives them ("lag-1 1" read as exactly 1)
    said = f" (lag-1 {lag1:.2f})" if lag1 is not None else ""
    times = widening(res.uncertainty)
    wider = f"; assuming independence, {times} smaller" if times else ""
    if not res.serial_test.get("found", True):
        return (f"± robust: {res.t.size} samples, too few to test the residuals' "
                f"independence{said}{wider}")
    return f"± robust: residuals serially correlated{said}{wider}"


def _derived(res: FitResult) -> list[str]:
    out = []
    for d in res.derived.values():
        unit = "" if d.unit in ("1", "-", "") else f" {unit_text(d.unit)}"
        # The HTML and --joint mark an echo; this line printed it as the well's.
        flag = (" (not determined)" if not d.determined
                else "" if d.well_property else " (an echo of the stroke, not the well's)")
        out.append(f"{d.name.replace('_', ' ')} = {fmt(d.value, 4)}{unit}{flag}")
    return out


def _reason(row: Row) -> str:
    return printable(row.reason) if row.reason else "no reason was given"


def _card_warnings(row: Row) -> list[str]:
    data = list(row.card.warnings) if row.card is not None else []
    fit = list(row.result.warnings) if row.result is not None else []
    return [*(f"data: {w}" for w in data), *fit, *row.warnings]


class TextPrinter:
    """Readable output: the assumptions once, then a short block per card."""

    def __init__(self, stream: TextIO | None = None, *, verbose: bool = False,
                 history: bool = False) -> None:
        self.stream = stream or sys.stdout
        self.verbose = verbose
        self.history = history
        self._file_notes: set[str] = set()

    def _print(self, *lines: str) -> None:
        for line in lines:
            print(line, file=self.stream)
        self.stream.flush()

    def start(self, info: RunInfo) -> None:
        """The run's model and assumptions."""
        observed = f", observed output {info.observe}" if info.observe else ""
        self._print(f"pumpid fit: {info.model} model{observed}, {info.method} solver")
        if info.observe_meaning:
            self._print(f"  {info.observe}: {info.observe_meaning}")
        for text in info.assumptions:
            self._print(*_wrap(text))

    def file(self, path: str, cards: Sequence[Card]) -> None:
        """A file's notes that hold for all its cards, once."""
        notes = _shared_notes(cards)
        self._file_notes = set(notes)
        what = plural(len(cards), "card")
        self._print("", f"{printable(path)}: {what}")
        if not self.verbose:
            for note in notes:
                self._print(*_wrap(f"note: {printable(note)}"))

    def file_failed(self, path: str, reason: str) -> None:
        """A file that could not be read at all."""
        self._print("", f"{printable(path)}: not read: {printable(reason)}")

    def row(self, row: Row) -> None:
        """One card's block."""
        res = row.result
        where = f"   [{printable(row.source)}]" if row.source else ""
        if res is None:
            self._print(f"{_id(row)}  {row.status}: {_reason(row)}{where}")
            for w in row.warnings:
                self._print(*_wrap(f"warning: {printable(w)}"))
            return
        if self.verbose:
            self._verbose(row, res, where)
            return
        lines = [f"{_id(row)}  {row.status}  {_quality(res)}{where}"]
        if not row.fitted:
            lines += _wrap(f"why: {_reason(row)}")
        if res.model is not None:
            params = _params(res)
            lines += _wrap_items(params)
            robust = _robust_note(res)
            if robust and any(" ± " in p for p in params):  # says what the ± shown are
                lines += _wrap(robust)
            derived = _derived(res)
            if derived:
                lines += _wrap_items(derived, "derived: ")
        if res.boundary is not None and res.boundary.reduced is not None:
            red = res.boundary.reduced
            units = model_param_units(red.model, res.units) or dict(red.units)
            params = [f"{n} = {fmt(v, 5)} {unit_text(units.get(n, ''))}".rstrip()
                      for n, v in red.params.items()]
            lines += _wrap_items([*params, f"R^2 = {fmt(red.r2, 6)}"],
                                 f"limiting model {red.model}"
                                 f"{f' ({red.limit})' if red.limit else ''}: ")
        said = (f"reduced model {res.boundary.reduced.model}"
                if res.boundary is not None and res.boundary.reduced is not None else None)
        for w in _card_warnings(row):
            if said is None or not w.startswith(said):  # the limiting model's line says it
                lines += _wrap(f"warning: {printable(first_sentence(w))}")
        notes = [n for n in (row.card.notes if row.card is not None else ())
                 if n not in self._file_notes]
        lines += [ln for n in notes for ln in _wrap(f"note: {printable(n)}")]
        if row.prediction is not None:
            lines += _wrap(f"prediction of card {printable(row.prediction.card)}: "
                           f"{_prediction_scores(row.prediction, res)}")
        choice = res.application.get("model_choice")
        if choice:
            lines += ["  " + ln for ln in model_choice_text(choice).splitlines()]
        if row.output:
            lines.append(f"  outputs: {printable(row.output)}")
        self._print(*lines)

    def _verbose(self, row: Row, res: FitResult, where: str) -> None:
        lines = [f"card {_id(row)}{where}"]
        notes = row.card.notes if row.card is not None else ()
        lines += [f"  note: {printable(n)}" for n in notes]
        if row.card is not None:
            lines += [f"  data warning: {printable(w)}" for w in row.card.warnings]
        lines.append(printable_block(res.report(history=self.history)))
        for w in row.warnings:
            lines.append(f"  - {printable(w)}")
        if row.prediction is not None:
            lines.append(f"  prediction of card {printable(row.prediction.card)}: "
                         f"{_prediction_scores(row.prediction, res)}")
        if row.output:
            lines.append(f"  outputs: {printable(row.output)}")
        lines.append("")
        self._print(*lines)

    def finish(self, counts: collections.Counter[str], *, interrupted: bool,
               out: str | None, index: str | None) -> None:
        """The run's summary line."""
        total = sum(counts.values())
        parts = ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
        line = f"{plural(total, 'card')}: {parts or 'none'}"
        if interrupted:
            line += " (interrupted)"
        self._print("", line)
        if out:
            self._print(f"outputs in {printable(out)}"
                        + (f" (index of folders: {printable(index)})" if index else ""))


def printable_block(text: str) -> str:
    """A multi-line text with each line's control characters escaped."""
    return "\n".join(printable(line) for line in text.splitlines())


def _shared_notes(cards: Sequence[Card]) -> list[str]:
    if not cards:
        return []
    shared = list(cards[0].notes)
    for card in cards[1:]:
        mine = set(card.notes)
        shared = [n for n in shared if n in mine]
    return shared


class LinePrinter:
    """One tab-separated line per card: id, status, R^2, RMSE, parameters, warning count."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stdout

    def _print(self, line: str) -> None:
        print(line, file=self.stream, flush=True)

    def start(self, info: RunInfo) -> None:
        """The model and assumptions as ``#`` lines."""
        observed = f", observed output {info.observe}" if info.observe else ""
        self._print(f"# pumpid fit: {info.model} model{observed}, {info.method} solver")
        for text in info.assumptions:
            self._print(f"# {text}")

    def file(self, path: str, cards: Sequence[Card]) -> None:
        """Nothing: every line names its source."""

    def file_failed(self, path: str, reason: str) -> None:
        """An unreadable file is a line of its own."""
        self._print("\t".join([printable(path), "invalid-input", f"reason={printable(reason)}"]))

    def row(self, row: Row) -> None:
        """The card's line."""
        fields = [_id(row), row.status]
        res = row.result
        if res is not None:
            fields += [f"R^2={fmt(res.r2, 6)}",
                       f"RMSE={fmt(res.rmse, 4)} {unit_text(res.units.position)}",
                       *([f"beyond_fundamental={fmt(res.r2_beyond, 4)}"]
                         if math.isfinite(res.r2_beyond) else [])]
            if res.application.get("model_choice"):
                fields.append(f"model={res.model_name}/{res.observe}")
            if res.model is not None:
                fields += [p.replace(" = ", "=", 1) for p in _params(res, errors=False)]
            fields.append(f"warnings={len(_card_warnings(row))}")
        if not row.fitted:
            fields.append(f"reason={_reason(row)}")
        if row.source:
            fields.append(f"source={printable(row.source)}")
        if row.output:
            fields.append(f"output={printable(row.output)}")
        self._print("\t".join(f.replace("\t", " ") for f in fields))

    def finish(self, counts: collections.Counter[str], *, interrupted: bool,
               out: str | None, index: str | None) -> None:
        """A ``#`` summary line."""
        parts = ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
        self._print(f"# {plural(sum(counts.values()), 'card')}: {parts or 'none'}"
                    + (" (interrupted)" if interrupted else ""))


class JsonPrinter:
    """``{"cards": [...], "summary": {...}}`` written element by element."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stdout
        self._count = 0
        self._info: RunInfo | None = None

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()

    def start(self, info: RunInfo) -> None:
        """Open the document."""
        self._info = info
        self._write('{"cards": [')

    def file(self, path: str, cards: Sequence[Card]) -> None:
        """Nothing: every element names its source."""

    def _element(self, obj: dict[str, Any]) -> None:
        text = json.dumps(jsonable(obj), indent=2, allow_nan=False)
        self._write(("," if self._count else "") + "\n" + _indent(text))
        self._count += 1

    def file_failed(self, path: str, reason: str) -> None:
        """An unreadable file as an element."""
        self._element({"status": "invalid-input", "reason": reason,
                       "card": {"id": None, "source": path}, "output": None})

    def row(self, row: Row) -> None:
        """One card's element."""
        if row.result is not None:
            obj = row.result.to_dict()
            obj["status"] = row.status
        else:
            obj = {"model": self._info.model if self._info else None, "status": row.status,
                   "converged": False, "reason": row.reason,
                   "card": {"id": row.card_id, "well": row.well_id, "source": row.source}}
        if row.card is not None and row.card.warnings:
            obj["data_warnings"] = list(row.card.warnings)
        if row.warnings:
            obj["warnings"] = [*obj.get("warnings", []), *row.warnings]
        if row.prediction is not None:
            obj["prediction"] = row.prediction.to_dict()
        obj["output"] = row.output
        self._element(obj)

    def finish(self, counts: collections.Counter[str], *, interrupted: bool,
               out: str | None, index: str | None) -> None:
        """Close the document with the summary."""
        summary = {"cards": sum(counts.values()), "status": dict(sorted(counts.items())),
                   "interrupted": interrupted, "output": out, "index": index}
        if self._info is not None:
            summary["model"] = self._info.model
            summary["assumptions"] = list(self._info.assumptions)
        text = json.dumps(jsonable(summary), indent=2, allow_nan=False)
        self._write(("\n" if self._count else "") + '], "summary": ' + text + "}\n")


def _indent(text: str) -> str:
    return "\n".join("  " + line for line in text.splitlines())


def describe_counts(rows: Iterable[Row]) -> collections.Counter[str]:
    """Cards per status."""
    return collections.Counter(r.status for r in rows)
