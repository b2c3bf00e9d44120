"""``pumpid fit``: fit a model to every card of one or more files, streaming.

    pumpid fit CARD_FILE [CARD_FILE ...] [--spm X | --period S] [--model kelvin]
               [--out DIR] [--json | --brief | --verbose]

Cards are fitted one at a time through :func:`pumpid.fit` (the verb ``pumpid batch`` uses,
so both give the same answers) and each card's result is
printed, its files written and its row indexed as soon as it is done: an interrupt keeps
every finished card, and a reader of the output (``| head``) sees each card at once. Nothing
is kept afterwards, so memory does not grow with the number of cards. A card that cannot be
fitted is a row with status ``invalid-input`` or ``failed`` and the reason; a file that
cannot be read is such a row too. Neither stops the others.

Output folder (``--out DIR``): a run of exactly one card writes its files (figures,
``result.json``, ``report.html``) directly into ``DIR``; otherwise every card gets a folder
``DIR/<card id, made safe and unique>/`` and ``DIR/results.csv`` lists the folders with the
cards' ids, sources, statuses and parameters. Every file and folder appears whole or not at
all (see :mod:`pumpid.report.output`).
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import csv
import dataclasses
import os
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import interrupts
from ..cards import Card, CardError, printable, split_strokes
from ..job import FitOptions, LevenbergMarquardt, PaperNewton, fit
from ..models import MODELS, Model, model_class
from ..pump.runner import FitSpec, fit_cards_each
from ..report.output import FILE_MODE, OutputError, OutputFolder, UniqueNames
from ..report.spreadsheet import LINE_END, neutralise_row
from ..report.units import unit_text
from ..result import FitResult
from .common import (
    EXIT_INTERRUPTED,
    EXIT_OUTPUT,
    CliError,
    add_card_options,
    add_fit_options,
    check_fit_options,
    columns_option,
    err,
    exit_status,
    parquet_cards,
    plural,
    rate_option,
)
from .render import JsonPrinter, LinePrinter, Row, RunInfo, TextPrinter, printable_block
from .select import missing_rows, selected

__all__ = ["cmd_fit", "register"]

#: Names the run writes itself into an output folder of per-card folders.
INDEX_NAME = "results.csv"


# --------------------------------------------------------------------------- setup
@dataclass
class FitSetup:
    """The command's options, checked once before any card is read."""

    cls: type[Model]
    model: Model | type[Model]
    #: --model auto: each card's structure chosen by evidence (pumpid.pump.choose_model).
    auto: bool
    initial_state: Any
    offset: str
    options: dict[str, Any]
    x0_extras: dict[str, float] | None
    history: bool
    read: dict[str, Any] = field(default_factory=dict)

    @property
    def spec(self) -> FitSpec:
        """The card runner's spec (the one ``pumpid batch`` fits with)."""
        x0 = None
        if isinstance(self.model, Model):
            x0 = {**self.model.as_dict(), **(self.x0_extras or {})}
        state = self.initial_state
        return FitSpec(model="auto" if self.auto else self.cls.key, x0=x0,
                       initial_state=tuple(state) if isinstance(state, list) else state,
                       offset=self.offset, options=dict(self.options))

    def fit_options(self, card: Card) -> FitOptions:
        """What the fit of this card means (:meth:`FitOptions.for_cards` with the options)."""
        spec = self.spec
        return spec.fit_options(spec.offset_for(card))

    def solver(self) -> LevenbergMarquardt | PaperNewton:
        """The solver object of ``--method``, ``--tol`` and ``--max-nfev``."""
        return self.spec.solver()


#: What ``pumpid fit`` fits with where an option is not given.
_DEFAULTS = {"model": "kelvin", "method": "lm", "integrator": "exact", "residual": "linear",
             "offset": "auto"}


def _setup(args: argparse.Namespace) -> FitSetup:
    for key, value in _DEFAULTS.items():
        if getattr(args, key, None) is None:
            setattr(args, key, value)
    if args.method == "newton-fd" and args.max_nfev is not None:
        raise CliError("--max-nfev limits the lm method; newton-fd runs its own iteration limit")
    auto = args.model == "auto"
    if auto and (args.observe or args.x0):
        raise CliError("--model auto compares the structures and their observed outputs "
                       "itself: give neither --observe nor --x0")
    if auto and args.method != "lm":
        raise CliError("--model auto uses the lm method")
    cls = model_class("kelvin" if auto else args.model)
    checked = check_fit_options(cls, observe=args.observe, scale=args.scale,
                                min_r2=args.min_r2, max_nfev=args.max_nfev, x0=args.x0,
                                x0_extras=("C", "D", "offset"),
                                initial_state=args.initial_state)
    opts: dict[str, Any] = {"method": args.method, "integrator": args.integrator,
                            "residual": args.residual}
    opts.update({k: checked[k] for k in ("observe", "scale", "min_r2", "max_nfev")
                 if k in checked})
    model: Model | type[Model] = cls
    extras: dict[str, float] | None = None
    if "x0" in checked:
        x0 = checked["x0"]
        model = cls(**{n: x0[n] for n in cls.param_names()})
        extras = {k: v for k, v in x0.items() if k in ("C", "D", "offset")} or None
    rate_option(args.spm, args.period)
    columns = columns_option(args.columns, t=args.t_col, load=args.load_col,
                             position=args.position_col)
    read = {"format": args.format, "position_unit": args.position_unit,
            "load_unit": args.load_unit, "spm": args.spm, "period": args.period,
            "columns": columns, "encoding": args.encoding, "well_id": args.well_id}
    return FitSetup(cls=cls, model=model, auto=auto,
                    initial_state=checked.get("initial_state"),
                    offset=args.offset, options=opts, x0_extras=extras, history=args.history,
                    read=read)


def _run_info(setup: FitSetup, out: str | None) -> RunInfo:
    cls = setup.cls
    if setup.auto:
        from ..pump.choose import CANDIDATES

        names = ", ".join(f"{m} ({o})" for m, o in CANDIDATES)
        base = _run_info(dataclasses.replace(setup, auto=False), out)
        return dataclasses.replace(
            base, model="auto", title=f"chosen per card by BIC among {names}", observe=None,
            observe_meaning=None)
    observe = setup.options.get("observe") or cls.default_output or None
    state = ("a single-stroke card is one period of a periodic motion"
             if setup.initial_state is None else
             f"every card starts from the initial state {setup.initial_state}")
    offset = {"auto": ", with a fitted position offset (its zero is arbitrary); longer "
                      "records start from rest" if setup.initial_state is None else "",
              "yes": "; a position offset is fitted for every card",
              "no": "; no position offset is fitted"}[setup.offset]
    assumptions = [f"assumptions: {state}{offset}; ± is one standard error: robust to "
                   "serial correlation on a card whose residuals are serially correlated or "
                   "too few to test (the card says so), else assuming independent residuals "
                   "(--verbose: both, all diagnostics)"]
    return RunInfo(model=cls.__name__, title=cls.title, observe=observe,
                   observe_meaning=cls.outputs.get(observe) if observe else None,
                   method=setup.options.get("method", "lm"), assumptions=tuple(assumptions),
                   out=out)


# --------------------------------------------------------------------------- reading
def _read_file(path: str, setup: FitSetup) -> tuple[list[Card], list[CardError]]:
    """Every card of a file, each on its own: the good cards, and an error per broken card
    (a CardError is raised only when the whole file cannot be read)."""
    from ..cards import read_cards_and_errors

    got = parquet_cards(path, **{k: setup.read[k] for k in (
        "position_unit", "load_unit", "spm", "period", "well_id")})
    if got is not None:
        return got
    read = read_cards_and_errors(path, **setup.read)
    return read.cards, read.errors


# --------------------------------------------------------------------------- fitting
def fit_one(card: Card, setup: FitSetup) -> tuple[FitResult | None, str, str]:
    """Fit one card: ``(result or None, status, reason)``.

    Through the card runner ``pumpid batch`` uses (:func:`pumpid.pump.runner.fit_cards_each`),
    so both give the same answers and rows. One card at a time: fitting cards in batches of
    64 gave the same answers and took no less time (32 Kelvin cards of 60 samples on 2
    cores: 4.99 s batched, 4.92 s one by one), while it held every card of a batch back from
    the output until the last was fitted.
    """
    got = fit_cards_each([card], setup.spec, workers=1)[0]
    return got.result, got.status, got.reason


def _one_at_a_time(cards: list[Card]) -> Iterator[Card]:
    """Consume the list card by card (the list lets go of each card once it is fitted)."""
    cards.reverse()
    while cards:
        yield cards.pop()


# --------------------------------------------------------------------------- outputs
class _Index:
    """``results.csv`` of a run of per-card folders, written as the cards complete.

    Rows go to a hidden temporary file in the output folder, renamed to ``results.csv`` at
    the end (also of an interrupted run): the index is never seen half-written.
    """

    _BASE = ("folder", "card_id", "well_id", "time", "source", "status", "reason")

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        fd, self._tmp = tempfile.mkstemp(prefix=".pumpid-results.", suffix=".tmp", dir=folder)
        self._fh = os.fdopen(fd, "w", newline="", encoding="utf-8")
        self._writer: csv.DictWriter[str] | None = None
        self._waiting: list[dict[str, Any]] = []

    def add(self, row: Row) -> None:
        rec: dict[str, Any] = {"folder": row.output and Path(row.output).name,
                               "card_id": row.card_id, "source": row.source,
                               "status": row.status, "reason": row.reason}
        if row.result is not None:
            rec.update({k: v for k, v in row.result.to_row().items() if k not in rec})
            rec["status"] = row.status
        if self._writer is None and row.result is None:
            self._waiting.append(rec)
            return
        if self._writer is None:
            names = list(dict.fromkeys([*self._BASE, *rec]))
            self._writer = csv.DictWriter(self._fh, fieldnames=names, extrasaction="ignore",
                                          lineterminator=LINE_END)
            self._writer.writeheader()
            for waiting in self._waiting:
                self._writer.writerow(neutralise_row(waiting))
            self._waiting.clear()
        self._writer.writerow(neutralise_row(rec))
        self._fh.flush()

    def close(self) -> Path:
        if self._writer is None:
            self._writer = csv.DictWriter(self._fh, fieldnames=list(self._BASE),
                                          extrasaction="ignore", lineterminator=LINE_END)
            self._writer.writeheader()
            for waiting in self._waiting:
                self._writer.writerow(neutralise_row(waiting))
        self._fh.close()
        target = self.folder / INDEX_NAME
        os.chmod(self._tmp, FILE_MODE)
        os.replace(self._tmp, target)
        return target

    def discard(self) -> None:
        with contextlib.suppress(OSError):
            self._fh.close()
            os.unlink(self._tmp)


class RunOutputs:
    """The ``--out`` folder of one run: one card's files directly, or a folder per card."""

    def __init__(self, path: str) -> None:
        self.folder = OutputFolder(path)
        self.names = UniqueNames(reserved=[INDEX_NAME])
        self.direct: bool | None = None
        self.index: _Index | None = None
        self.failed = 0
        self.replaced: list[str] = []

    def prepare(self) -> None:
        for said in self.folder.prepare():
            err(said)

    def layout(self, direct: bool) -> None:
        """Decide once: files directly in the folder (one card) or a folder per card."""
        if self.direct is None:
            self.direct = direct
            if not direct:
                try:
                    self.index = _Index(self.folder.path)
                except OSError as exc:
                    raise OutputError(f"{printable(str(self.folder.path))}: cannot write "
                                      f"({exc.strerror or exc})") from None

    def write(self, row: Row) -> None:
        """Write a fitted card's files; on failure the row says so (its result is kept)."""
        from ..report import write_outputs

        res = row.result
        if res is None:
            if self.index is not None:
                self.index.add(row)
            return
        notes = list(row.card.notes) if row.card is not None else []
        try:
            with self.folder.staging() as stage:
                write_outputs(res, stage, notes=notes, prediction=row.prediction)
                if self.direct:
                    said = self.folder.commit_files(stage)
                    row.output = str(self.folder.path)
                else:
                    name = self.names.claim(row.card_id or "card")
                    if self.folder.commit_folder(stage, name):
                        self.replaced.append(name)
                    said = []
                    row.output = str(self.folder.path / name)
            for s in said:
                err(s)
        except MemoryError:
            raise
        except OutputError as exc:
            interrupts.check()
            self.failed += 1
            row.warnings.append(f"outputs not written: {exc} (the result is printed here)")
        except Exception as exc:
            # A Ctrl-C that a library turned into another error while the files were being
            # written is the interrupt, not a failure of this card's outputs: the card is
            # then not counted as finished (it was, indexed without its folder).
            interrupts.check()
            self.failed += 1
            row.warnings.append(f"outputs not written: making the figures or report failed "
                                f"({type(exc).__name__}: {exc}); the result is printed here")
        if self.index is not None:
            self.index.add(row)

    def finish(self) -> str | None:
        """Put the index in place; its path, or None for a one-card run."""
        self.folder.discard_staged()
        if self.replaced:
            shown = ", ".join(printable(n) for n in self.replaced[:5])
            more = f" and {len(self.replaced) - 5} more" if len(self.replaced) > 5 else ""
            err(f"replaced {plural(len(self.replaced), 'card folder')} of an earlier run in "
                f"{printable(str(self.folder.path))}: {shown}{more}")
        if self.index is None:
            return None
        try:
            return str(self.index.close())
        except OSError as exc:
            self.failed += 1
            err(f"{printable(str(self.folder.path))}: the index {INDEX_NAME} could not be "
                f"written ({exc.strerror or exc})")
            self.index.discard()
            return None


# --------------------------------------------------------------------------- prediction
class _Predictor:
    """``--predict``: the card to predict with every fit (another file, or an id)."""

    def __init__(self, target: str | None, setup: FitSetup) -> None:
        self.target = target
        self.card: Card | None = None
        if target is not None and Path(target).is_file():
            from ..cards import read_cards

            try:
                self.card = read_cards(target, spm=setup.read["spm"],
                                       period=setup.read["period"],
                                       encoding=setup.read["encoding"])[0]
            except CardError as exc:
                raise CliError(f"--predict: {exc}") from None
        self.in_file: Card | None = None

    def use_file(self, cards: Sequence[Card], strokes: bool = False) -> None:
        """The target among a file's cards (when it is an id), or among their strokes with
        ``--split-strokes`` (an id RECORD#k)."""
        if self.target is None or self.card is not None:
            return
        self.in_file = next((c for c in cards if c.card_id == self.target), None)
        if self.in_file is None and strokes:
            record = self.target.rpartition("#")[0]
            for card in cards:
                if card.card_id != record:
                    continue
                try:
                    pieces = split_strokes(card)
                except CardError:
                    continue
                self.in_file = next((c for c in pieces if c.card_id == self.target), None)

    def predict(self, row: Row) -> None:
        if self.target is None or row.result is None or row.result.model is None:
            return
        other = self.card or self.in_file
        if other is None:
            row.warnings.append(f"no prediction: no card {printable(self.target)!r} in this "
                                "file and no such file")
            return
        from ..pump import predict_card

        try:
            row.prediction = predict_card(row.result, other)
        except MemoryError:
            raise
        except Exception as exc:
            row.warnings.append(f"prediction of card {printable(other.card_id)} failed: {exc}")


# --------------------------------------------------------------------------- the command
def _printer(args: argparse.Namespace) -> TextPrinter | LinePrinter | JsonPrinter:
    if args.json:
        return JsonPrinter()
    if args.brief:
        return LinePrinter()
    return TextPrinter(verbose=args.verbose or args.history, history=args.history)


def _row(card: Card, outcome: tuple[FitResult | None, str, str]) -> Row:
    res, status, reason = outcome
    return Row(card_id=card.card_id, source=card.source, status=status, reason=reason,
               result=res, card=card)


def _inputs(args: argparse.Namespace, setup: FitSetup,
            predictor: _Predictor) -> Iterator[tuple[str, list[Card] | CardError, list[Row]]]:
    """Each file with its cards to fit and rows for cards refused before fitting, or the
    error that made it unreadable. With a single file, its problems are the run's: raised."""
    single = len(args.files) == 1
    answered: set[str] = set()
    for path in args.files:
        try:
            cards, errors = _read_file(path, setup)
            if single and not cards and errors and not args.json:
                raise errors[0]  # nothing of the only file can be fitted: the run's error
        except CardError as exc:
            # --json always gives its document: a script that fits one file a call got an
            # empty output when that file could not be read.
            if single and not args.json:
                raise
            yield path, exc, []
            continue
        predictor.use_file(cards, strokes=args.split_strokes)
        if single and args.predict and predictor.card is None and predictor.in_file is None:
            raise CliError(f"--predict: no card {printable(args.predict)!r} in "
                           f"{printable(path)} and no such file")
        chosen, refused, got = selected(cards, path, args, errors, report_missing=single)
        answered |= got
        del cards, errors
        if single and args.card is not None and not chosen and refused:
            raise CliError(f"{printable(path)}: {refused[0].reason}")
        yield path, chosen, refused
    # Over several files, an id is missing only when no file has it (each file that lacked
    # one gave a row of its own, and two cards of two files ran with two such rows).
    missing = [w for w in dict.fromkeys(args.card or ()) if w not in answered]
    if missing and not single:
        files = ", ".join(args.files)
        yield files, [], missing_rows(set(), missing, f"in any of the {len(args.files)} files",
                                      files)


def _joint_document(joint: FitResult, cards: Sequence[Card]) -> dict[str, Any]:
    """``--joint --json``: the ``{"cards": [...], "summary": {...}}`` every ``--json`` has.

    Each card's element holds what the joint fit says of it (its level and offset, R^2, RMSE
    and its own fit's parameters); the summary holds the joint fit itself
    (``summary["joint"]``, the result's JSON form).
    """
    part = joint.application["joint"]["cards"]
    elements = [{"status": joint.status.key, "reason": joint.reason,
                 "card": {"id": card.card_id, "source": card.source},
                 **{k: v for k, v in own.items() if k != "card"}, "output": None}
                for card, own in zip(cards, part, strict=True)]
    summary = {"cards": len(cards), "status": {joint.status.key: len(cards)},
               "interrupted": False, "output": None, "index": None,
               "model": joint.model_name, "joint": joint.to_dict()}
    return {"cards": elements, "summary": summary}


def _joint_text(joint: FitResult) -> str:
    """The joint fit's report and a line per card."""
    pos = joint.units.position
    lines = [joint.report(), "", "  per card: level (position at its mean load), offset (at "
             "zero load), R^2, RMSE, and the card's own fit:"]
    units = joint.param_units()
    for c in joint.application["joint"]["cards"]:
        # As a card's own fit flags its offset (at zero load) where the static stiffness is
        # not determined.
        loose = "" if c.get("offset_determined", True) else " (not determined)"
        own = ", ".join(f"{k} = {v:.4g} {unit_text(units.get(k, ''))}".rstrip()
                        for k, v in c["single"].items())
        lines.append(f"  {c['card']}: level = {c['level']:.6g} {pos}, offset = "
                     f"{c['offset']:.6g} {pos}{loose}, R^2 = {c['r2']:.6f}, RMSE = "
                     f"{c['rmse']:.4g} {pos}; alone: RMSE = {c['rmse_alone']:.4g} {pos}, "
                     f"{own}")
    return "\n".join(lines)


def _cmd_joint(args: argparse.Namespace, setup: FitSetup) -> int:
    """--joint: one parameter set for every card of the files (``FitOptions(joint=True)``)."""
    if setup.auto or setup.x0_extras is not None or args.out or args.predict or args.brief:
        # --brief's line per card has no place for one fit of several cards: it was ignored.
        raise CliError("--joint takes one model (not auto), no --x0, --out, --predict or "
                       "--brief")
    cards: list[Card] = []
    for path, read, refused in _inputs(args, setup, _Predictor(None, setup)):
        if isinstance(read, CardError):
            raise CliError(str(read))
        if refused:
            raise CliError(f"{printable(path)}: {refused[0].reason}")
        cards.extend(read)
    try:
        joint = fit(setup.cls, cards, options=setup.fit_options(cards[0]).replace(
            joint=True, offset=True), solver=setup.solver())
    except (ValueError, TypeError) as exc:
        raise CliError(str(exc)) from None
    assert isinstance(joint, FitResult)
    if args.json:
        import json

        from ..result import jsonable

        print(json.dumps(jsonable(_joint_document(joint, cards)), indent=2, allow_nan=False))
    else:
        print(printable_block(_joint_text(joint)))
    return exit_status({joint.status.key: 1})


def cmd_fit(args: argparse.Namespace) -> int:
    """Fit every card of the files; print each as it is done; say how it went."""
    setup = _setup(args)
    if args.joint:
        return _cmd_joint(args, setup)
    predictor = _Predictor(args.predict, setup)
    outputs = RunOutputs(args.out) if args.out else None
    if outputs is not None:
        outputs.prepare()
    inputs = _inputs(args, setup, predictor)
    # A single file is read before anything is printed: if it cannot be, that is the error.
    first = next(inputs, None) if len(args.files) == 1 else None
    printer = _printer(args)
    counts: collections.Counter[str] = collections.Counter()
    interrupted = False
    index_path: str | None = None
    printer.start(_run_info(setup, args.out))
    try:
        for path, cards, refused in ([first] if first is not None else inputs):
            if isinstance(cards, CardError):
                counts["invalid-input"] += 1
                printer.file_failed(path, str(cards))
                if outputs is not None:
                    outputs.layout(False)
                    outputs.write(Row(card_id=None, source=path, status="invalid-input",
                                      reason=str(cards)))
                continue
            if outputs is not None:
                outputs.layout(len(args.files) == 1 and len(cards) + len(refused) == 1)
            printer.file(path, cards)
            for row in refused:
                counts[row.status] += 1
                if outputs is not None:
                    outputs.write(row)
                printer.row(row)
            for card in _one_at_a_time(cards):
                interrupts.check()
                row = _row(card, fit_one(card, setup))
                # A Ctrl-C swallowed during the fit (a library's cleanup) ends the run here:
                # the card is not counted as finished.
                interrupts.check()
                del card
                predictor.predict(row)
                if outputs is not None:
                    outputs.write(row)
                counts[row.status] += 1
                printer.row(row)
                del row
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if outputs is not None:
            index_path = outputs.finish()
        printer.finish(counts, interrupted=interrupted, out=args.out, index=index_path)
    if interrupted:
        done = sum(counts.values())
        err(f"interrupted (Ctrl-C) after {plural(done, 'card')}; "
            + ("the results finished so far are above" if done else "no card was finished")
            + (f" and in {printable(args.out)}" if args.out and done else ""))
        return EXIT_INTERRUPTED
    if outputs is not None and outputs.failed:
        their = "its result is" if outputs.failed == 1 else "their results are"
        err(f"the outputs of {plural(outputs.failed, 'card')} could not be written to "
            f"{printable(args.out)}; {their} printed above")
        return EXIT_OUTPUT
    return exit_status(counts)


# --------------------------------------------------------------------------- parser
def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid fit`` to the command's subparsers."""
    p = subparsers.add_parser(
        "fit", help="fit a model to every card of one or more files",
        description="Fit a model to every card of the files. Each card is printed as soon "
                    "as it is fitted; a card or file that cannot be fitted is reported and "
                    "the others go on. Exit status: 0 all fitted, 2 bad options or nothing "
                    "readable, 3 some cards not fitted, 4 outputs not written, 5 every card "
                    "fitted but some poorly (R^2 below --min-r2), 6 every card fitted but some "
                    "determine no parameter, 130 interrupted.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="card files (CSV/TSV, SCADA export, JSON, table, .ts)")
    add_card_options(p)
    p.add_argument("--joint", action="store_true",
                   help="one parameter set for all the cards (strokes of one well), each "
                        "card with its own offset; prints the joint fit (no --out, "
                        "--predict, --x0 or --model auto with it)")
    add_fit_options(p, sorted(MODELS))
    p.add_argument("--predict", metavar="CARD_OR_FILE",
                   help="predict another card (an id in the same file, or a file) with each fit")
    p.add_argument("--out", help="write figures, result.json and report.html here (one card), "
                                 "or a folder per card and results.csv (several)")
    view = p.add_mutually_exclusive_group()
    view.add_argument("--json", action="store_true",
                      help='print {"cards": [...], "summary": {...}} (always this shape)')
    view.add_argument("--brief", action="store_true",
                      help="one tab-separated line per card")
    view.add_argument("--verbose", action="store_true",
                      help="each card's full report (uncertainty, correlations, diagnostics)")
    p.add_argument("--history", action="store_true",
                   help="print each card's full report with its iteration history (fits the "
                        "cards one by one)")
    p.set_defaults(func=cmd_fit, verbose=False)
    return p
