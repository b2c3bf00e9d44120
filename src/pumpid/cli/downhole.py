"""``pumpid downhole``: the pump card and pump quantities of every surface card.

    pumpid downhole CARD_FILE [CARD_FILE ...] --well WELL.json [--spm X | --period S]
                    [--damping NU] [--no-identify] [--harmonics N] [--method fourier|fd]
                    [--convention effective|true] [--json] [--out DIR]

The card options are those of ``pumpid fit``. Cards are diagnosed in chunks through the
batched API (:func:`pumpid.rods.diagnose_cards`); then, unless ``--no-identify`` (or
``--damping 0``), each card's pump is identified by fitting the rod string and valve pump to
the surface card (:func:`pumpid.pump.identify_cards`), and the card is printed as soon as it
is done (:class:`pumpid.pump.identify_report.DownholeCard` joins the two). A card that cannot
be computed is a row with its status and reason; it does not stop the others.

Output folder (``--out DIR``): one card writes ``downhole.json``, ``pump_card.csv`` and
``cards.png`` (surface card beside pump card) directly into ``DIR``; several cards get a
folder each and ``DIR/downhole.csv`` lists them with their pump quantities. ``DIR/report.html``
is one self-contained page for the run (:class:`pumpid.rods.report.DownholeReport`).
"""

from __future__ import annotations

import argparse
import collections
import csv
import io
import json
import math
import sys
from collections.abc import Iterator
from typing import Any, TextIO

from .. import interrupts
from ..cards import Card, CardError, printable
from ..pump import PumpFit, identify_cards
from ..pump.identify_report import DownholeCard, draw_identified
from ..report.output import OutputError, OutputFolder, UniqueNames, atomic_write
from ..report.spreadsheet import LINE_END, neutralise_row
from ..result import jsonable
from ..rods import DEFAULT_DAMPING, REVERSED_NOTE, WellFile, diagnose_cards, read_well_file
from ..rods.report import DownholeReport
from .common import (
    EXIT_INTERRUPTED,
    EXIT_OUTPUT,
    CliError,
    add_card_options,
    columns_option,
    err,
    exit_status,
    fmt,
    parquet_cards,
    rate_option,
)
from .select import selected

__all__ = ["cmd_downhole", "identifies", "register"]

#: Cards computed in one call of the batched API.
CHUNK_CARDS = 256
INDEX_NAME = "downhole.csv"
REPORT_NAME = "report.html"
#: Why ``--damping 0`` identifies nothing, said in the run's header and each card's notes.
UNDAMPED = ("--damping 0: the undamped diagnostic pump card only; the pump is not "
            "identified, since the predictive model of the rod string needs some damping "
            "(give --damping NU > 0 to hold it in the identification, or leave --damping out "
            "to identify it)")


def identifies(args: argparse.Namespace) -> tuple[bool, str]:
    """Whether the pump is identified, and why not."""
    if args.no_identify:
        return False, "--no-identify: the diagnostic pump card only"
    if args.damping == 0:
        return False, UNDAMPED
    return True, ""


def _options(args: argparse.Namespace) -> dict[str, Any]:
    if args.damping is not None and not (math.isfinite(args.damping) and args.damping >= 0):
        raise CliError(f"--damping {args.damping:g}: Gibbs' damping factor is a number >= 0 "
                       "(0: undamped)")
    if args.harmonics is not None and args.harmonics < 1:
        raise CliError(f"--harmonics {args.harmonics}: give at least 1")
    if args.harmonics is not None and args.method != "fourier":
        raise CliError("--harmonics applies to --method fourier only")
    return {"damping": args.damping, "harmonics": args.harmonics, "method": args.method,
            "convention": args.convention}


def _read(path: str, args: argparse.Namespace) -> list[Card]:
    from ..cards import read_cards

    columns = columns_option(args.columns, t=args.t_col, load=args.load_col,
                             position=args.position_col)
    got = parquet_cards(path, position_unit=args.position_unit, load_unit=args.load_unit,
                        spm=args.spm, period=args.period, well_id=args.well_id)
    if got is not None:
        cards, errors = got
        if errors:  # as the text readers: a bad card stops the file
            raise errors[0]
    else:
        cards = read_cards(path, format=args.format, position_unit=args.position_unit,
                           load_unit=args.load_unit, spm=args.spm, period=args.period,
                           columns=columns, encoding=args.encoding, well_id=args.well_id)
    if args.card is None and not args.split_strokes:
        return cards
    # As pumpid fit chooses them: a stroke's id RECORD#k after its record is split (it
    # chose nothing here, while the shared help promised it).
    chosen, refused, _answered = selected(cards, path, args, report_missing=False)
    if refused:  # a record that does not split, or no such stroke: named with the file
        reason = refused[0].reason
        raise CardError(reason) if printable(path) in reason else CardError(reason, path=path)
    return chosen


def _chunks(cards: list[Card]) -> Iterator[list[Card]]:
    for start in range(0, len(cards), CHUNK_CARDS):
        yield cards[start:start + CHUNK_CARDS]


# --------------------------------------------------------------------------- printing
class _Text:
    """One block per card: its pump quantities with errors and units, damping, R^2, notes."""

    def __init__(self, stream: TextIO | None = None, verbose: bool = False) -> None:
        self.stream = stream or sys.stdout
        self.verbose = verbose

    def start(self, info: dict[str, Any]) -> None:
        damping = info["damping"]
        damping = damping if isinstance(damping, str) else f"nu = {fmt(damping)}"
        print(f"downhole cards: {info['method']} method, damping {damping}"
              f" ({info['damping_rule']}), harmonics {info['harmonics']}, "
              f"{info['convention']} loads; wells from {printable(info['well_file'])}",
              file=self.stream)
        print(f"pump identification: {info['identification']}", file=self.stream)

    def row(self, res: DownholeCard) -> None:
        for line in res.text():
            print(line, file=self.stream)
        # The reader's warnings (position and load that look swapped gave a 29.6 m plunger
        # stroke without a word); its notes with the others below.
        # A card the rod string read reversed says so in its note (REVERSED_NOTE): the
        # reader's warning beside it repeated the fact and spoke of a lumped fit this command
        # does not run.
        reversed_read = REVERSED_NOTE in res.downhole.notes
        for warning in res.downhole.card.warnings:
            if reversed_read and "turns the wrong way" in warning:
                continue
            print(f"  warning: {printable(warning)}", file=self.stream)
        if not res.downhole.ok:
            return
        # The reader's notes too: those that change how the card reads (padding dropped)
        # pass the filter below, the rest only under --verbose.
        notes = [*res.downhole.card.notes, *res.downhole.notes]
        if res.fitted and res.fit is not None:
            notes += list(res.fit.notes)
        if not self.verbose:  # the notes that change how the card reads
            notes = [n for n in notes if any(w in n for w in _ALWAYS_SAID)]
        notes = list(dict.fromkeys(notes))
        for note in notes:
            print(f"  note: {printable(note)}", file=self.stream)

    def file_failed(self, path: str, reason: str) -> None:
        print(f"{printable(path)}: invalid-input: {printable(reason)}", file=self.stream)

    def finish(self, counts: collections.Counter[str], summary: dict[str, Any]) -> None:
        done = ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
        print(f"{sum(counts.values())} card(s): {done}", file=self.stream)
        ident = summary.get("identified")
        if ident:
            said = ", ".join(f"{n} {k}" for k, n in sorted(ident.items()))
            print(f"pump identification: {said}", file=self.stream)


#: Words of the notes printed without --verbose: a card read in reverse, a quantity beside
#: the card that cannot be physical as it stands (an intake pressure of -830 psi was printed
#: with its note only under --verbose; a card with no fluid load), and what a printed
#: quantity assumes or leaves out (the intake pressure with no tubing-head pressure in the
#: well file, or none without a fluid; the pump card computed at the rods' bottom, short of
#: the pump; a net stroke not corrected for a free tubing's stretch; a loop that does not
#: close; fewer harmonics than asked); a card in other units than its well file (the text
#: mixed in/lbf with m3/d and kPa without a word), or of another well, or lighter than the
#: rods; the reader's padding dropped (a fifth of a card's samples, said under --verbose
#: only).
_ALWAYS_SAID = ("reverse", "intake pressure is negative", "tubing-head pressure taken as 0",
                "the pump card is computed at the bottom of the rods",
                "converted, results in the card's units", "has no fluid load",
                "no fluid entry", "not corrected for tubing stretch",
                "less the free tubing's stretch", "padding dropped",
                "differs from the well file's", "the loop does not close",
                "below the rods' weight", "harmonics asked", "taken as anchored",
                "replace those of", "replaces that of", "listed from the bottom")


class _Json:
    """``{"cards": [...], "summary": {...}}`` written element by element."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stdout
        self.count = 0

    def start(self, info: dict[str, Any]) -> None:
        self.stream.write('{"cards": [')

    def _element(self, obj: dict[str, Any]) -> None:
        text = json.dumps(jsonable(obj), allow_nan=False)
        self.stream.write(("," if self.count else "") + "\n  " + text)
        self.stream.flush()
        self.count += 1

    def row(self, res: DownholeCard) -> None:
        self._element(res.to_dict())

    def file_failed(self, path: str, reason: str) -> None:
        self._element({"status": "invalid-input", "reason": reason,
                       "card": {"id": None, "well": None, "source": path},
                       "downhole": None, "pump": None, "damping": None, "r2": None,
                       "residual_autocorrelation": None, "identification": None})

    def finish(self, counts: collections.Counter[str], summary: dict[str, Any]) -> None:
        text = json.dumps(jsonable(summary), indent=2, allow_nan=False)
        self.stream.write(("\n" if self.count else "") + '], "summary": ' + text + "}\n")
        self.stream.flush()


# --------------------------------------------------------------------------- outputs
def _pump_csv(res: DownholeCard) -> str:
    """The card's samples: surface and diagnostic pump card, and where the pump was fitted
    the fitted surface load and the identified pump card, in the file's sample order."""
    down = res.downhole
    card = down.card
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    pu, lu = card.position_unit, card.load_unit
    head = [f"surface_position_{pu}", f"surface_load_{lu}", f"pump_position_{pu}",
            f"pump_load_{lu}"]
    assert down.pump_position is not None and down.pump_load is not None
    columns = [card.position, card.load, down.pump_position, down.pump_load]
    ident = res.identification()
    if ident is not None and "pump_card" in ident:
        # The identified card's loads are effective ones, whatever the diagnostic's.
        effective = "" if down.convention == "effective" else "effective_"
        head += [f"fitted_surface_load_{lu}", f"identified_pump_position_{pu}",
                 f"identified_{effective}pump_load_{lu}"]
        columns += [ident["surface_fit"]["load"], ident["pump_card"]["position"],
                    ident["pump_card"]["load"]]
    w.writerow(head)
    for row in zip(*columns, strict=True):
        w.writerow([f"{v:.10g}" for v in row])
    return buf.getvalue()


class _Outputs:
    """The ``--out`` folder: one card's files directly, or a folder per card and an index."""

    def __init__(self, path: str, info: dict[str, Any]) -> None:
        self.folder = OutputFolder(path)
        self.names = UniqueNames(reserved=[INDEX_NAME, REPORT_NAME])
        self.report = DownholeReport({k.replace("_", " "): v for k, v in info.items()})
        self.rows: list[dict[str, Any]] = []
        self.direct = False
        self.failed = 0

    def prepare(self, direct: bool) -> None:
        self.direct = direct
        for said in self.folder.prepare():
            err(said)

    def write(self, res: DownholeCard) -> None:
        down = res.downhole
        record: dict[str, Any] = {"folder": None, "card_id": down.card.card_id,
                                  "well_id": down.well.well_id if down.well else None,
                                  "source": down.card.source, **res.to_row()}
        png: bytes | None = None
        if down.ok:
            try:
                with self.folder.staging() as stage:
                    (stage / "downhole.json").write_text(
                        json.dumps(jsonable(res.to_dict()), indent=1, allow_nan=False) + "\n",
                        encoding="utf-8")
                    (stage / "pump_card.csv").write_text(_pump_csv(res), encoding="utf-8")
                    figure = io.BytesIO()
                    draw_identified(res, figure)
                    png = figure.getvalue()
                    (stage / "cards.png").write_bytes(png)
                    if self.direct:
                        said = self.folder.commit_files(stage)
                    else:
                        name = self.names.claim(down.card.card_id or "card")
                        said = self.folder.commit_folder(stage, name)
                        record["folder"] = name
                for s in said:
                    err(s)
            except MemoryError:
                raise
            except (OutputError, OSError, ValueError) as exc:
                self.failed += 1
                err(f"card {printable(down.card.card_id)}: outputs not written ({exc})")
        self.rows.append(record)
        self.report.add(down, extra=_report_extra(res), png=png)

    def finish(self) -> None:
        self.folder.discard_staged()
        try:  # one page for the run: surface and pump cards, quantities, notes
            atomic_write(self.folder.path / REPORT_NAME, self.report.html())
        except (OutputError, OSError) as exc:
            self.failed += 1
            err(f"{REPORT_NAME} not written ({exc})")
        if self.direct:
            return
        names = list(dict.fromkeys(k for r in self.rows for k in r))
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=names, lineterminator=LINE_END)
        w.writeheader()
        w.writerows(neutralise_row(r) for r in self.rows)
        try:
            atomic_write(self.folder.path / INDEX_NAME, buf.getvalue())
        except (OutputError, OSError) as exc:
            self.failed += 1
            err(f"{INDEX_NAME} not written ({exc})")


def _report_extra(res: DownholeCard) -> dict[str, Any] | None:
    """What the report shows of the identification, as plain data (the report's layer knows
    no pump model)."""
    if not res.downhole.ok:
        return None
    ident = res.identification()
    return {"pump": res.pump(), "damping": res.damping(), "r2": res.r2(),
            "residual_autocorrelation": res.residual_autocorrelation(),
            "identification": None if ident is None else {
                k: ident.get(k) for k in ("status", "reason", "used", "parameters",
                                          "agreement", "consistency", "energy",
                                          "identifiability",
                                          "warnings", "notes", "pump")},
            "skipped": res.skipped}


def _cards(chunk: list[Card], wells: WellFile, opts: dict[str, Any], identify: bool,
           skipped: str) -> Iterator[DownholeCard]:
    """Each card of a chunk: diagnosed with the others, then identified one by one (so each
    is printed as soon as it is done)."""
    for res in diagnose_cards(chunk, wells, **opts):
        if not identify or not res.ok or res.well is None:
            yield DownholeCard.of(res, None, skipped if res.ok else "")
            continue
        interrupts.check()
        try:
            fit = identify_cards([res.card], res.well, damping=opts["damping"],
                                 harmonics=opts["harmonics"], method=opts["method"],
                                 convention=opts["convention"])[0]
        except (MemoryError, KeyboardInterrupt):
            raise
        except Exception as exc:
            # A bug in one card's identification must not stop a field's run: the card
            # keeps its diagnostic and says what broke.
            fit = PumpFit(card=res.card, status="failed", well=res.well,
                          reason=f"the identification stopped with an internal error "
                                 f"({type(exc).__name__}: {exc}); a bug in pumpid, please "
                                 "report it with the card")
        yield DownholeCard.of(res, fit)


# --------------------------------------------------------------------------- the command
def _inputs(args: argparse.Namespace) -> Iterator[tuple[str, list[Card] | CardError]]:
    single = len(args.files) == 1
    for path in args.files:
        try:
            cards = _read(path, args)
        except CardError as exc:
            # --json always gives its document (a script reading one file a call got an
            # empty output when that file could not be read).
            if single and not args.json:
                raise
            yield path, exc
            continue
        if single and not cards and args.card is not None:
            raise CliError(f"{printable(path)}: no card "
                           + " or ".join(repr(printable(c)) for c in args.card))
        yield path, cards


def cmd_downhole(args: argparse.Namespace) -> int:
    """Compute every card's downhole card; print each; say how it went."""
    opts = _options(args)
    rate_option(args.spm, args.period)
    wells: WellFile = read_well_file(args.well)
    inputs = list(_inputs(args))
    total = sum(len(c) for _p, c in inputs if isinstance(c, list))
    printer: _Text | _Json = _Json() if args.json else _Text(verbose=args.verbose)
    identify, skipped = identifies(args)
    if args.damping is not None:
        damping: float | str = args.damping
        rule = ("given, held in the identification" if identify else "given")
    elif identify:
        damping = "identified per card"
        rule = (f"from each card's identification; where the pump is not identified the "
                f"default rule, nu = {DEFAULT_DAMPING:g}")
    else:
        damping = DEFAULT_DAMPING
        rule = f"default rule: nu = {DEFAULT_DAMPING:g} for every well"
    info = {"method": args.method, "damping": damping, "damping_rule": rule,
            "identification": ("the rod string and valve pump fitted to each surface card"
                               if identify else skipped),
            "harmonics": (args.harmonics or "all the samples resolve")
            if args.method == "fourier" else "n/a",
            "convention": args.convention, "well_file": args.well}
    outputs = _Outputs(args.out, info) if args.out else None
    if outputs is not None:
        outputs.prepare(direct=total == 1 and len(inputs) == 1)
    printer.start(info)
    counts: collections.Counter[str] = collections.Counter()
    outcomes: collections.Counter[str] = collections.Counter()
    identified: collections.Counter[str] = collections.Counter()
    interrupted = False
    try:
        for path, cards in inputs:
            if isinstance(cards, CardError):
                counts["invalid-input"] += 1
                outcomes["invalid-input"] += 1
                printer.file_failed(path, str(cards))
                continue
            for chunk in _chunks(cards):
                interrupts.check()
                for res in _cards(chunk, wells, opts, identify, skipped):
                    counts[res.downhole.status] += 1
                    outcomes[res.outcome] += 1
                    if res.fit is not None:
                        identified[res.fit.status] += 1
                    if outputs is not None:
                        outputs.write(res)
                    printer.row(res)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if outputs is not None:
            outputs.finish()
        summary = {"cards": sum(counts.values()), "status": dict(sorted(counts.items())),
                   "identified": dict(sorted(identified.items())) if identify else None,
                   "interrupted": interrupted, "output": args.out, **info,
                   "load_convention": args.convention}
        printer.finish(counts, summary)
    if interrupted:
        err("interrupted (Ctrl-C); the cards finished so far are above")
        return EXIT_INTERRUPTED
    if outputs is not None and outputs.failed:
        return EXIT_OUTPUT
    # As every command's: each card counts by its identification's status (a card not
    # identified on request counts as fitted), or by its diagnostic's when not computed.
    return exit_status(outcomes)


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid downhole`` to the command's subparsers."""
    p = subparsers.add_parser(
        "downhole", help="pump cards and pump quantities from surface cards (wave equation)",
        description="Compute the downhole (pump) card of every surface card with the damped "
                    "wave equation of the tapered rod string, and its pump quantities "
                    "(gross and net stroke, fluid load, fillage, displacement, intake "
                    "pressure); by default the pump is also identified by fitting the rod "
                    "string and valve pump to the surface card, which gives each quantity "
                    "with its error and chooses the damping. Exit status: 0 all computed "
                    "and identified, 2 bad options or nothing computable, 3 some cards not "
                    "computed or their identification failed, 4 outputs not written, 5 "
                    "some identifications poor (R^2 below 0.95), 6 some undetermined, 130 "
                    "interrupted.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="card files (CSV/TSV, SCADA export, JSON, table, .ts)")
    p.add_argument("--well", required=True, metavar="WELL.json",
                   help="well file: rod tapers, pump, tubing, fluid (see README); one well "
                        "applies to every card, several are matched by the cards' well ids")
    p.add_argument("--damping", type=float, metavar="NU",
                   help="Gibbs' dimensionless damping factor, c = pi NU / (2 sum L_i/a_i), "
                        "held at NU in the identification (default: identified from each "
                        f"card; {DEFAULT_DAMPING:g} where not identified); 0 is undamped and "
                        "gives the diagnostic pump card only")
    p.add_argument("--no-identify", action="store_true",
                   help="the diagnostic pump card only (no fit of the rod string and pump: "
                        "no errors, damping by the default rule or --damping)")
    p.add_argument("--harmonics", type=int, metavar="N",
                   help="highest harmonic of the Fourier method (default: all the card's "
                        "samples resolve; 10-25 smooth the pump card as vendors do)")
    p.add_argument("--method", choices=["fourier", "fd"], default="fourier",
                   help="fourier (Gibbs, default) or fd (finite differences)")
    p.add_argument("--convention", choices=["effective", "true"], default="effective",
                   help="load convention of the downhole loads (default effective)")
    add_card_options(p)
    p.add_argument("--out", help="write downhole.json, pump_card.csv and cards.png here (one "
                                 "card), or a folder per card and downhole.csv (several)")
    view = p.add_mutually_exclusive_group()
    view.add_argument("--json", action="store_true",
                      help='print {"cards": [...], "summary": {...}}')
    view.add_argument("--verbose", action="store_true", help="print every card's notes")
    p.set_defaults(func=cmd_downhole, verbose=False)
    return p

