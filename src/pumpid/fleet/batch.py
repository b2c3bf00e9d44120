"""Fit every card of a dataset into one results table: :func:`run_batch`.

The run reads the inputs in a fixed order (:mod:`pumpid.fleet.inputs`), cuts the stream of
cards into partitions of ``partition_size`` cards, has an engine fit each partition
(:mod:`pumpid.fleet.engines`: :func:`fit_partition` with :func:`pumpid.fit`) and
writes each partition's rows as one Parquet file of the results folder
(:mod:`pumpid.fleet.store`) as soon as it is back. One row per input card, in input order:
the columns of :meth:`pumpid.FitResult.to_row` plus ``file``, ``item``, ``partition`` and
``duplicate_of`` (the id of the earlier card of the run whose data this card repeats
exactly: the same card exported twice, e.g. as a "Full" and a "Current" card; such a card
is fitted like any other and set aside by the change detection and the report);
a card that could not be read or validated is a row of status ``invalid-input`` with the
reason, and a file that could not be read at all is one such row named after the file,
with the well and card time the file states (:mod:`pumpid.fleet.inputs`), if it states them.

Resuming (``resume=True``) rebuilds the same partitions from the same inputs (the manifest
checks that they are the same), skips those already written (after checking that each
holds the cards it should) and fits the others, so no row is lost or written twice. An
interrupt (Ctrl-C) stops the reading, lets the partitions being fitted finish and be
written, and ends the run as interrupted; a second one drops them (they are redone on
resume).

Memory stays flat in the number of cards: only the partitions in flight (two on the local
engine, twice the worker threads on Dask) and the file being read are held, plus the ids
seen so far (to keep them unique) and the summary's counts.
"""

from __future__ import annotations

import hashlib
import os
import time
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from pumpid import interrupts
from pumpid.pump import PumpSystem
from pumpid.pump.runner import FitSpec, fit_cards_each
from pumpid.report.spreadsheet import to_csv as spreadsheet_csv
from pumpid.result import CardInfo
from pumpid.result.table import fit_row, identity_of, unfitted_row
from pumpid.version import __version__

from .defaults import IDENTIFY_PARTITION_SIZE, PARTITION_SIZE
from .downhole import DownholeSpec, add_pump_columns, pump_schema
from .engines import Engine, EngineError, make_engine
from .inputs import BadItem, CardItem, InputFile, ReadOptions, find_inputs, iter_items
from .progress import Progress, QuietProgress
from .store import ResultsFolderError, ResultsStore, results_schema, to_frame
from .summary import BatchSummary, reason_kind

__all__ = ["BatchSummary", "FitSpec", "fit_partition", "reason_kind", "run_batch",
           "unlisted_inputs"]

# --------------------------------------------------------------------------- the task
def _utc(value: Any) -> pd.Timestamp | None:
    """A card time as an aware UTC timestamp (naive: UTC), None when unknown or unreadable."""
    if value is None:
        return None
    try:
        stamp = pd.Timestamp(value)
    except (TypeError, ValueError, OverflowError):
        return None
    if stamp is pd.NaT:
        return None
    return stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")


def _fit_card_row(item: CardItem, result: Any, reason: str, status: str | None, model: str,
                  observe: str | None) -> dict[str, Any]:
    """A readable card's row: its fit's, or (``result`` None) the row of a card without one."""
    card = item.card
    if result is not None:
        return _card_row(item, fit_row(result))
    return _card_row(item, unfitted_row(
        None, model=model, observe=observe, status=status or "invalid-input", reason=reason,
        n_samples=card.n, position_unit=card.position_unit, load_unit=card.load_unit))


def _card_row(item: CardItem, row: dict[str, Any]) -> dict[str, Any]:
    """``row`` with the card's identity, time and reading warnings."""
    card = item.card
    meta = card.metadata
    stamp = meta.get("time", meta.get("timestamp"))
    time_value = _utc(stamp)
    warnings = [w for w in (row.get("warnings") or "").split(" | ") if w]
    warnings += [w for w in card.warnings if w not in warnings]
    if stamp is not None and time_value is None:
        warnings.append(f"card time {stamp!r} is not a date and time: left out")
    # The batch's identity of the card: the reader's id and source, the file, the UTC time.
    row.update(identity_of(CardInfo(id=item.card_id, well=card.well_id, source=item.source),
                           file=item.file, time=time_value))
    row["warnings"] = " | ".join(warnings)
    return row


def _bad_row(item: BadItem, model: str, observe: str | None) -> dict[str, Any]:
    row = unfitted_row(CardInfo(id=item.card_id, well=item.well_id, source=item.source),
                       model=model, observe=observe, status="invalid-input",
                       reason=item.reason)
    row.update(file=item.file, time=_utc(item.time))
    return row


def fit_partition(items: Sequence[CardItem | BadItem], spec: FitSpec, threads: int,
                  partition: int, first_item: int,
                  downhole: DownholeSpec | None = None) -> list[dict[str, Any]]:
    """Rows of one partition: its cards fitted in one batch, its unreadable items as
    ``invalid-input`` rows; the task an engine runs.

    Parameters
    ----------
    items : sequence of CardItem or BadItem
        The partition, in input order.
    spec : FitSpec
        What to fit.
    threads : int
        Threads for :func:`pumpid.fit`.
    partition, first_item : int
        The partition's index and the run-wide index of its first item.
    downhole : DownholeSpec, optional
        Also add the pump quantities (:mod:`pumpid.fleet.downhole`).

    Returns
    -------
    list of dict
        One row per item, in order, with the columns of :func:`results_schema`.
    """
    cls = spec.model_class()
    rows: list[dict[str, Any] | None] = [None] * len(items)
    idx = [i for i, item in enumerate(items) if isinstance(item, CardItem)]
    pump_only = downhole is not None and not downhole.lumped
    model, observe = ((PumpSystem.name, PumpSystem.output) if pump_only else
                      (cls.__name__, spec.options.get("observe") or cls.default_output))
    for i, item in enumerate(items):
        if not isinstance(item, CardItem):
            rows[i] = _bad_row(item, model, observe)
    if pump_only:
        # The identification fills the fit's columns (pumpid.fleet.downhole).
        for i in idx:
            rows[i] = _fit_card_row(items[i], None,  # type: ignore[arg-type]
                                    "the pump was not identified", "failed", model, observe)
    else:
        outcomes = fit_cards_each([items[i].card for i in idx],  # type: ignore[union-attr]
                                  spec, workers=threads)
        for i, got in zip(idx, outcomes, strict=True):
            status = None if got.result is not None else got.status
            rows[i] = _fit_card_row(items[i], got.result, got.reason,  # type: ignore[arg-type]
                                    status, model, observe)
    if downhole is not None:  # the pump quantities (pumpid.fleet.downhole)
        add_pump_columns(items, rows, downhole, threads=threads)
    out: list[dict[str, Any]] = []
    for i, row in enumerate(rows):
        assert row is not None
        row["item"] = first_item + i
        row["partition"] = partition
        out.append(row)
    return out


# --------------------------------------------------------------------------- the run
def _partitions(items: Iterator[CardItem | BadItem],
                size: int) -> Iterator[tuple[int, int, list[CardItem | BadItem]]]:
    """(index, first item's index, items) of consecutive partitions of ``size`` items."""
    chunk: list[CardItem | BadItem] = []
    k = start = 0
    for item in items:
        chunk.append(item)
        if len(chunk) == size:
            yield k, start, chunk
            k, start, chunk = k + 1, start + size, []
    if chunk:
        yield k, start, chunk


def _data_key(card: Any) -> bytes:
    """What makes two cards the same card: the well, the samples, the time axis and the
    units (not the id, the source or the card time: an export names a copy differently and
    stamps it seconds later)."""
    h = hashlib.blake2b(digest_size=16)
    for part in (card.well_id, card.position_unit, card.load_unit, card.spm, card.period,
                 card.periodic, card.position.size):
        h.update(repr(part).encode("utf-8", "backslashreplace") + b"\x00")
    for arr in (card.position, card.load, card.t):
        h.update(b"-" if arr is None else np.ascontiguousarray(arr, dtype=float).tobytes())
    return h.digest()


class _Duplicates:
    """Finds exact repeats of earlier cards of the run, in input order.

    Memory: one 16-byte digest per distinct card (the run keeps every id already), and the
    pending flags of the partitions in flight.
    """

    def __init__(self) -> None:
        self.first: dict[bytes, str] = {}
        self.of: dict[int, str] = {}  # run-wide item index -> the id it repeats

    def scan(self, items: Iterator[CardItem | BadItem]) -> Iterator[CardItem | BadItem]:
        for index, item in enumerate(items):
            if isinstance(item, CardItem):
                key = _data_key(item.card)
                earlier = self.first.setdefault(key, item.card_id)
                if earlier != item.card_id:
                    self.of[index] = earlier
            yield item

    def mark(self, rows: list[dict[str, Any]]) -> None:
        """Fill ``duplicate_of`` of a partition's rows (and forget their flags)."""
        for row in rows:
            row["duplicate_of"] = self.of.pop(int(row["item"]), None)

    def forget(self, first: int, count: int) -> None:
        """Drop the flags of a partition written by an earlier run."""
        for i in range(first, first + count):
            self.of.pop(i, None)


def _files_for(inputs: Sequence[str | os.PathLike[str]], out: Path, resume: bool,
               exclude: Sequence[str | os.PathLike[str]]) -> list[InputFile]:
    if inputs:
        files = find_inputs(inputs, exclude=[out, *exclude])
        if resume and (out / "_manifest.json").exists():
            # The names of the first run stay (the inputs may be typed differently now).
            names = {f["path"]: f["name"] for f in ResultsStore.files_of(out)}
            files = [InputFile(names.get(f.path, f.name), f.path, f.size, f.mtime_ns)
                     for f in files]
        return files
    if not resume:
        raise ValueError("no inputs given")
    out_files = []
    for f in ResultsStore.files_of(out):
        try:
            now = InputFile.of(f["name"], Path(f["path"]))
        except OSError:
            now = InputFile(f["name"], f["path"], -1, -1)
        out_files.append(now)
    return out_files


def unlisted_inputs(out: Path, exclude: Sequence[str | os.PathLike[str]] = ()) -> list[str]:
    """Files in a run's input folders that its manifest does not list (found by searching
    the folders again), for a resume without inputs to name: a file added to a folder was
    resumed without a word. Empty where the run recorded no inputs or they are gone.

    Parameters
    ----------
    out : Path
        The results folder.
    exclude : sequence of path
        Files and folders that are never inputs (the run's own ``--csv``).

    Returns
    -------
    list of str
        The files' names as found under the run's inputs.
    """
    given = ResultsStore.inputs_of(out)
    if not (given and all(Path(p).exists() for p in given)):
        return []
    known = {f["path"] for f in ResultsStore.files_of(out)}
    return [f.name for f in find_inputs(given, exclude=[out, *exclude]) if f.path not in known]


def run_batch(
    inputs: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    fit: FitSpec | None = None,
    read: ReadOptions | None = None,
    engine: str = "local",
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    partition_size: int | None = None,
    progress: Progress | None = None,
    csv: str | os.PathLike[str] | None = None,
    downhole: DownholeSpec | None = None,
) -> BatchSummary:
    """Fit every card of ``inputs`` into the results folder ``out`` (see the module doc).

    Parameters
    ----------
    inputs : sequence of path
        Files and folders (searched recursively, see :func:`~pumpid.fleet.inputs.find_inputs`).
        May be empty with ``resume``: the inputs are then the manifest's.
    out : path
        The results folder: new or empty, or (``resume``) a run to continue.
    fit : FitSpec, optional
        Model and fit options (default: Kelvin with the automatic start; when resuming,
        the run's own).
    read : ReadOptions, optional
        Reader options (units, SPM, format, columns, ...; default: none, or when resuming
        the run's own).
    engine : {"local", "processes", "dask"}
        See :mod:`pumpid.fleet.engines`; ``scheduler`` and ``workers`` go to it.
    resume : bool
        Continue the run in ``out`` (refused if its inputs or options differ).
    partition_size : int, optional
        Cards per partition (and per results file); default 256 (32 when ``downhole``
        identifies each pump), or the run's own when resuming.
    progress : Progress, optional
        A display from :func:`~pumpid.fleet.progress.make_progress` (default: none).
    csv : path, optional
        Also write the whole table as CSV here, when the run completes.
    downhole : DownholeSpec, optional
        Add the pump quantities of each card (:mod:`pumpid.fleet.downhole`); when
        resuming, the run's own if not given.

    Returns
    -------
    BatchSummary
        ``interrupted`` is true when a Ctrl-C stopped the run.

    Raises
    ------
    ResultsFolderError
        If ``out`` holds another run (or anything else), or its inputs/options differ.
    ValueError
        For unknown options, a model that cannot observe what is asked, no inputs.
    FileNotFoundError
        For an input that does not exist.
    EngineError
        If the engine cannot start or loses a task.
    """
    folder = Path(os.fspath(out))
    earlier = ResultsStore.options_of(folder) if resume else None
    if earlier is not None:
        fit = fit or FitSpec.from_dict(earlier.get("fit", {}))
        read = read or ReadOptions.from_dict(earlier.get("read", {}))
        partition_size = partition_size or earlier.get("partition_size")
        if downhole is None and earlier.get("downhole"):
            downhole = DownholeSpec.from_dict(earlier["downhole"])
    fit = fit or FitSpec()
    read = read or ReadOptions()
    if partition_size is None:
        partition_size = (IDENTIFY_PARTITION_SIZE if downhole is not None and downhole.identify
                          else PARTITION_SIZE)
    progress = progress or QuietProgress()
    fit.check()
    if isinstance(partition_size, bool) or not isinstance(partition_size, int) \
            or partition_size < 1:
        raise ValueError(f"partition_size must be a whole number >= 1, got {partition_size!r}")
    files = _files_for(inputs, folder, resume, [csv] if csv else [])
    if resume and not inputs:
        # Said, not refused: the run's own files may sit in its input folders (a --csv
        # written there), and they are no inputs of it.
        more = unlisted_inputs(folder, [csv] if csv else [])
        if more:
            shown = ", ".join(more[:5]) + (f" and {len(more) - 5} more" if len(more) > 5
                                           else "")
            text = (f"{len(more)} file(s) in the run's input folders are not in the run "
                    f"({shown}): resumed without them; name the inputs to include them in a "
                    "new run")
            progress.note(text)
            warnings.warn(text, UserWarning, stacklevel=2)
    pump_only = downhole is not None and not downhole.lumped
    schema = results_schema(() if pump_only else fit.model_classes())
    if downhole is not None:
        schema = pump_schema(schema, identify=downhole.identify)
    # Every column of the run's table: a run written with other columns (an earlier pumpid
    # of the same version number) is not resumed into one table with this one's (its
    # parts' pump_fluid_load and this run's would mean two things, its new columns dropped).
    manifest = {"pumpid": __version__, "table": list(schema.names),
                "inputs": [os.fspath(i) for i in inputs],
                # Absolute, for a resume without inputs to search the same folders again.
                "input_paths": ([str(Path(os.fspath(i)).resolve()) for i in inputs] if inputs
                                else ResultsStore.inputs_of(folder) if resume else []),
                "files": [f.to_dict() for f in files],
                "options": {"read": read.to_dict(), "fit": fit.to_dict(),
                            "partition_size": partition_size}}
    if downhole is not None:
        manifest["options"]["downhole"] = downhole.to_dict()
    # Refuse a folder before starting an engine, and start the engine before writing.
    ResultsStore.check(folder, manifest, resume=resume)
    runner = make_engine(engine, scheduler=scheduler, workers=workers)
    try:
        store = (ResultsStore.resume if resume else ResultsStore.create)(folder, manifest)
    except BaseException:
        runner.close()
        raise
    summary = BatchSummary(results=folder, pump_only=pump_only)
    summary.engine = runner.description
    started = time.monotonic()
    progress.start(sum(max(f.size, 0) for f in files), runner.description)

    def on_file(file: InputFile, items: list[CardItem | BadItem]) -> None:
        progress.file_read(max(file.size, 0), len(items))
        if len(items) == 1 and isinstance(items[0], BadItem) and items[0].whole_file:
            summary.unreadable.append((file.name, items[0].reason))

    pending: dict[Any, tuple[int, int]] = {}
    n_parts = 0
    duplicates = _Duplicates()
    try:
        try:
            stream = duplicates.scan(iter_items(files, read, on_file=on_file))
            for k, first, items in _partitions(stream, partition_size):
                n_parts = k + 1
                interrupts.check()
                if _already_written(store, k, items, summary, progress, schema):
                    duplicates.forget(first, len(items))
                    continue
                while len(pending) >= runner.capacity:
                    interrupts.check()
                    _collect(runner, pending, store, schema, summary, progress, 0.5,
                             duplicates)
                handle = runner.submit(fit_partition, items, fit, runner.threads, k, first,
                                       downhole)
                pending[handle] = (k, len(items))
                del items
            progress.all_read()
            while pending:
                interrupts.check()
                _collect(runner, pending, store, schema, summary, progress, 0.5, duplicates)
        except KeyboardInterrupt:
            summary.interrupted = True
            _wind_down(runner, pending, store, schema, summary, progress, duplicates)
    finally:
        runner.close()
        summary.elapsed = time.monotonic() - started
        summary.close()
        progress.close()
    if summary.interrupted:
        store.write_summary(summary.text())
        return summary
    store.finish(partitions=n_parts, rows=summary.cards, summary=summary.text())
    if csv:
        write_csv(store, n_parts, Path(os.fspath(csv)))
    return summary


def _already_written(store: ResultsStore, k: int, items: list[CardItem | BadItem],
                     summary: BatchSummary, progress: Progress, schema: pa.Schema) -> bool:
    """Whether partition ``k`` was written by an earlier run (checked to hold these cards)."""
    info = store.part_info(k)
    if info is None:
        return False
    want = (len(items), items[0].card_id, items[-1].card_id)
    if (info.rows, info.first, info.last) != want:
        raise ResultsFolderError(
            f"{store.part_path(k)} holds {info.rows} rows from {info.first!r} to {info.last!r}, "
            f"but the inputs give partition {k} as {want[0]} cards from {want[1]!r} to "
            f"{want[2]!r}; the folder is not from these inputs")
    counted = ["card_id", "status", "reason", "nfev", "n_samples", "duplicate_of"]
    summary.add(store.read_part(k, counted + [c for c in ("identify_status", "identify_reason")
                                              if c in schema.names]))
    summary.skipped += info.rows
    progress.advance(info.rows, skipped=True)
    return True


def _collect(runner: Engine, pending: dict[Any, tuple[int, int]], store: ResultsStore,
             schema: pa.Schema, summary: BatchSummary, progress: Progress,
             timeout: float, duplicates: _Duplicates) -> None:
    """Write the partitions that have come back (waiting up to ``timeout`` s for one)."""
    for handle in runner.wait(list(pending), timeout):
        k, n = pending.pop(handle)
        rows = runner.result(handle)
        duplicates.mark(rows)
        table = store.write_part(k, rows, schema)
        summary.add(table)
        summary.fitted += n
        progress.advance(n)
    progress.tick()


def _wind_down(runner: Engine, pending: dict[Any, tuple[int, int]], store: ResultsStore,
               schema: pa.Schema, summary: BatchSummary, progress: Progress,
               duplicates: _Duplicates) -> None:
    """After a Ctrl-C: drop what has not started, finish and write what is being fitted;
    a second Ctrl-C drops those too."""
    waiting = [h for h in pending if not _running(h)]
    runner.cancel(waiting)
    for h in waiting:
        pending.pop(h, None)
        summary.discarded += 1
    if pending:
        progress.note(f"stopping: finishing the {len(pending)} partition(s) being fitted "
                      "(Ctrl-C again to drop them)")
    try:
        while pending:
            try:
                _collect(runner, pending, store, schema, summary, progress, 0.5, duplicates)
            except EngineError:
                break  # workers stopped by the same Ctrl-C: what they had is dropped
    except KeyboardInterrupt:
        pass
    runner.cancel(list(pending))
    summary.discarded += len(pending)
    pending.clear()


def _running(handle: Any) -> bool:
    status = getattr(handle, "status", None)  # dask
    if isinstance(status, str):
        return status not in ("pending",)
    running = getattr(handle, "running", None)  # concurrent.futures
    return bool(running()) if callable(running) else True


def write_csv(store: ResultsStore, partitions: int, path: Path) -> Path:
    """Write the results as one CSV file, part by part (flat memory), atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            for k in range(partitions):
                # Parquet keeps the raw text; the CSV is for spreadsheets (see neutralise).
                spreadsheet_csv(to_frame(store.read_part(k)), fh, header=(k == 0),
                                date_format="%Y-%m-%dT%H:%M:%SZ")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
