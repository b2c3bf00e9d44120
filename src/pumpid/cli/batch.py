"""``pumpid batch``: fit every card of files and folders into one results table.

    pumpid batch INPUT... --out RESULTS [--resume] [--csv [PATH]]
                 [--engine local|processes|dask] [--scheduler ADDRESS] [--workers N]
                 [--model kelvin] [--observe u] [--spm X] [--load-unit lbf] ... [--quiet]
                 [--well-file WELLS.json [--no-identify | --pump-only]]

A thin shell over :func:`pumpid.fleet.batch.run_batch`; the results folder is described
in :mod:`pumpid.fleet.store`, the inputs in :mod:`pumpid.fleet.inputs`.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

from ..cards import printable
from ..models import MODELS, model_class
from ..report.output import OutputError
from .common import (
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OUTPUT,
    EXIT_USAGE,
    CliError,
    add_fit_options,
    batch_exit,
    check_fit_options,
    columns_option,
    err_block,
    rate_option,
)

__all__ = ["cmd_batch", "pump_run", "register"]



def _specs(args: argparse.Namespace) -> tuple[Any, Any]:
    """The fit and read options: those given, over the resumed run's (or the defaults)."""
    from ..fleet.batch import FitSpec
    from ..fleet.inputs import ReadOptions
    from ..fleet.store import ResultsStore

    earlier = ResultsStore.options_of(args.out) if args.resume else None
    fit = (FitSpec.from_dict(earlier.get("fit", {})) if earlier else FitSpec()).to_dict()
    read = (ReadOptions.from_dict(earlier.get("read", {})) if earlier
            else ReadOptions()).to_dict()
    columns = columns_option(args.columns, t=args.t_col, load=args.load_col,
                             position=args.position_col)
    if columns:
        read["columns"] = columns
    for key in ("format", "position_unit", "load_unit", "spm", "period", "encoding",
                "well_id"):
        if getattr(args, key) is not None:
            read[key] = getattr(args, key)
    if args.split_strokes:
        read["split_strokes"] = True
    for key in ("model", "offset"):
        if getattr(args, key) is not None:
            fit[key] = getattr(args, key)
    auto = fit["model"] == "auto"
    if auto and (args.observe or args.x0):
        raise CliError("--model auto compares the structures and their observed outputs "
                       "itself: give neither --observe nor --x0")
    try:
        cls = model_class("kelvin" if auto else fit["model"])
    except ValueError as exc:
        raise CliError(str(exc)) from None
    # The options given are checked as pumpid fit checks them (a resumed run's own options
    # were checked when it started).
    checked = check_fit_options(cls, observe=args.observe, scale=args.scale,
                                min_r2=args.min_r2, max_nfev=args.max_nfev, x0=args.x0,
                                initial_state=args.initial_state)
    if "initial_state" in checked:
        fit["initial_state"] = checked["initial_state"]
    if "x0" in checked:
        fit["x0"] = checked["x0"]
    options = dict(fit["options"])
    for key in ("integrator", "residual", "method"):
        if getattr(args, key) is not None:
            options[key] = getattr(args, key)
    if options.get("method") == "newton-fd" and "max_nfev" in checked:
        raise CliError("--max-nfev limits the lm method; newton-fd runs its own iteration limit")
    options.update({k: checked[k] for k in ("observe", "scale", "min_r2", "max_nfev")
                    if k in checked})
    fit["options"] = options
    return FitSpec.from_dict(fit), ReadOptions.from_dict(read)


def _csv_path(args: argparse.Namespace) -> Path | None:
    if args.csv is None:
        return None
    if args.csv is True:
        folder = Path(os.path.normpath(args.out))
        return folder.with_name(folder.name + ".csv")
    return Path(args.csv)


def _downhole(args: argparse.Namespace) -> Any:
    """The pump quantities' options (pumpid.fleet.downhole), or None."""
    if args.well_file is None:
        if (args.damping is not None or args.harmonics is not None or args.no_identify
                or args.pump_only):
            given = [flag for flag, on in (("--damping", args.damping is not None),
                                           ("--harmonics", args.harmonics is not None),
                                           ("--no-identify", args.no_identify),
                                           ("--pump-only", args.pump_only)) if on]
            if getattr(args, "resume", False):
                # The run's own well file and downhole options are used: "need --well-file"
                # was said to a run that has one.
                raise ValueError(f"{', '.join(given)}: a resumed run keeps its own downhole "
                                 "options (its well file, or none); to change them, write a "
                                 "new run to another folder")
            raise ValueError("--damping, --harmonics, --no-identify and --pump-only need "
                             "--well-file")
        return None
    from ..fleet.downhole import DownholeSpec
    return DownholeSpec.load(args.well_file, damping=args.damping, harmonics=args.harmonics,
                             identify=not args.no_identify, lumped=not args.pump_only)


def _check_csv(path: Path | None) -> None:
    """Refuse a ``--csv`` path that cannot be written, before any card is fitted (exit 4).

    The CSV is written last, after all the fitting: a folder of that name, or a place no
    file can be created in, would otherwise end a long run with an error and no summary.
    """
    if path is None:
        return
    where = printable(str(path))
    if path.is_dir():
        raise OutputError(f"--csv {where}: is a folder; give the name of the CSV file to "
                          "write (or --csv alone: RESULTS.csv beside the results folder)")
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise OutputError(f"--csv {where}: {printable(str(parent))} is not a folder")
    if parent == path.parent:
        try:
            tempfile.TemporaryFile(dir=parent).close()
        except OSError as exc:
            raise OutputError(f"--csv {where}: cannot write in {printable(str(parent))} "
                              f"({exc.strerror or exc})") from None
    elif not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"--csv {where}: cannot create folders in {printable(str(parent))}")


def pump_run(args: argparse.Namespace) -> tuple[bool, bool]:
    """Whether the run asked for identifies pumps, and whether without the lumped fit
    (``--pump-only``): from the options, or for a resume without ``--well-file`` from the
    run's own manifest."""
    if args.well_file is None and args.resume:
        from ..fleet.downhole import DownholeSpec
        from ..fleet.store import ResultsStore

        try:
            earlier = (ResultsStore.options_of(args.out) or {}).get("downhole")
        except (OSError, ValueError):
            return False, False  # not a run's folder: the run says so
        if not earlier:
            return False, False
        identify, lumped = DownholeSpec.modes(earlier)
        return identify, identify and not lumped
    identify = args.well_file is not None and not args.no_identify
    return identify, identify and bool(args.pump_only)


def _engine(args: argparse.Namespace) -> str:
    """The engine asked for, else the default: worker processes when the run identifies
    pumps, this process's threads otherwise.

    About a third of an identification is Python that holds the interpreter's lock, so two
    threads of one process do not make two cores' work on it; on 1,024 cards of the demo's
    pump field (``benchmarks/bench_pump_batch.py``), worker processes fitted 111.5 cards/s
    against 74.6 on threads with ``--pump-only``, 44.9 against 29.8 with the lumped fits;
    the demo's 64 cards (MSD fits and pumps) took 2.9-3.1 s against 3.4-3.5 s. A lumped
    fit's compiled passes release the lock and use the threads. Where worker processes
    cannot run (a container without shared memory), the default stays local.
    """
    from ..fleet.engines import processes_available

    if args.engine is not None:
        return str(args.engine)
    identify, _ = pump_run(args)
    return "processes" if identify and processes_available() else "local"


def cmd_batch(args: argparse.Namespace) -> int:
    """Run ``pumpid batch``; print the summary; exit as ``pumpid fit`` does.

    0 every card fitted; 2 bad options or a refused results folder, or no card could be
    fitted (every one invalid); 3 some cards failed or were invalid; 4 ``--csv`` cannot be
    written, or ``--out`` is a file; 5 every card fitted, some poorly; 6 some undetermined;
    130 interrupted; 1 the engine failed.
    """
    from ..fleet.batch import run_batch
    from ..fleet.engines import EngineError
    from ..fleet.progress import make_progress
    from ..fleet.store import ResultsFolderError

    if not args.input and not args.resume:
        raise ValueError("give at least one INPUT file or folder (or --resume to continue "
                         "the run in --out with its own inputs)")
    fit, read = _specs(args)
    rate_option(args.spm, args.period)
    csv = _csv_path(args)
    _check_csv(csv)
    downhole = _downhole(args)
    if downhole is not None and not downhole.lumped:
        from ..fleet.batch import FitSpec

        # --model is asked of itself: at its default value it leaves the spec unchanged,
        # and "--pump-only --model kelvin" ran as if it had been left out.
        if fit.to_dict() != FitSpec().to_dict() or args.model is not None:
            raise ValueError("--pump-only fits no lumped model: leave out the lumped fit's "
                             "options (--model, --observe, --x0, ...)")
    mode = "quiet" if args.quiet else args.progress
    progress = make_progress(mode, interval=args.progress_interval)
    try:
        summary = run_batch(args.input, args.out, fit=fit, read=read,
                            engine=_engine(args),
                            scheduler=args.scheduler, workers=args.workers, resume=args.resume,
                            partition_size=args.partition_size, progress=progress,
                            csv=csv, downhole=downhole)
    except ResultsFolderError as exc:
        # Its differences are a list, one per line: printed as lines, not as escapes.
        err_block(f"error: {exc}")
        # A file where the folder goes cannot be written, as for pumpid fit --out (4); a
        # folder of another run or of other files is refused (2).
        return EXIT_OUTPUT if Path(args.out).is_file() else EXIT_USAGE
    except EngineError as exc:
        print(f"pumpid: error: {exc}", file=sys.stderr)
        print("pumpid: the partitions written so far are kept; continue with --resume",
              file=sys.stderr)
        return EXIT_INTERNAL
    print(summary.text())
    if summary.interrupted:
        sys.stdout.flush()
        sys.stderr.flush()
        if any(t.name.startswith("pumpid-fit") and t.is_alive() for t in threading.enumerate()):
            # A fit dropped at a second Ctrl-C cannot be stopped inside its thread; its
            # results would be discarded anyway, and everything written is complete.
            os._exit(EXIT_INTERRUPTED)
        return EXIT_INTERRUPTED
    return batch_exit(summary.statuses, None if summary.pump_only else summary.pump_statuses)


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid batch`` to the ``pumpid`` command's subparsers."""
    from ..fleet.defaults import IDENTIFY_PARTITION_SIZE, PARTITION_SIZE

    p = subparsers.add_parser(
        "batch", help="fit every card of files and folders into one results table",
        description="Fit every card of the inputs (files, or folders searched recursively "
                    "for card files) and write one row per card into a Parquet results "
                    "folder, partition by partition; resumable with --resume.")
    p.add_argument("input", nargs="*", metavar="INPUT",
                   help="card files (any format pumpid reads, Parquet long layout included) "
                        "or folders")
    p.add_argument("--out", required=True, metavar="RESULTS",
                   help="results folder (new or empty; with --resume the run to continue)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in RESULTS: only unfinished partitions are fitted "
                        "(refused if the inputs or options differ; INPUT may be left out)")
    p.add_argument("--csv", nargs="?", const=True, metavar="PATH",
                   help="also write the table as CSV (default path: RESULTS.csv beside the "
                        "folder)")
    run = p.add_argument_group("engine")
    run.add_argument("--engine", choices=["local", "processes", "dask"],
                     help="local: this process on every core; processes: a worker process "
                          "per core (faster where much of a fit is Python, as when "
                          "--well-file identifies pumps); dask: dask.distributed (pip "
                          "install \"pumpid[fleet]\"). Default: processes when --well-file "
                          "identifies pumps, else local")
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="with --engine dask: a running scheduler (else a LocalCluster)")
    run.add_argument("--workers", type=int,
                     help="local: threads; processes and dask LocalCluster: worker "
                          "processes (default: one per core)")
    run.add_argument("--partition-size", type=int, metavar="N",
                     help=f"cards per partition and results file (default {PARTITION_SIZE}; "
                          f"{IDENTIFY_PARTITION_SIZE} when --well-file identifies pumps)")
    run.add_argument("--quiet", action="store_true", help="no progress display")
    run.add_argument("--progress", default="auto", choices=["auto", "bar", "lines"],
                     help="a bar on a terminal, plain lines otherwise (default auto)")
    run.add_argument("--progress-interval", type=float, default=10.0, metavar="S",
                     help="seconds between plain progress lines (default 10)")
    rd = p.add_argument_group("reading")
    rd.add_argument("--format", help="force a format for files that are not Parquet: csv, "
                                     "scada, json, whitespace, ts")
    rd.add_argument("--spm", type=float, help="strokes per minute (cards without time)")
    rd.add_argument("--period", type=float, help="stroke period in s (cards without time)")
    rd.add_argument("--load-unit", help="load unit of the files: lbf, klbf, N, kN, kgf")
    rd.add_argument("--position-unit", help="position unit of the files: in, ft, m")
    rd.add_argument("--encoding", help="text encoding of the files (default: detected)")
    rd.add_argument("--well-id", metavar="ID",
                    help="the well of every card of the inputs (over their own; for files "
                         "of one well without a well column)")
    rd.add_argument("--columns", metavar="ROLE=COL[,...]",
                    help="column roles, e.g. position=1,load=0 (names or 0-based indices; "
                         "t=- reads no time column)")
    rd.add_argument("--t-col", help="time column (name, or index for tables without header): "
                         "seconds, or ISO 8601 date/time stamps such as 2024-05-01 10:00:00.25")
    rd.add_argument("--load-col", help="load column")
    rd.add_argument("--position-col", help="position column")
    rd.add_argument("--split-strokes", action="store_true",
                    help="split multi-stroke time records into strokes (ids CARD#0, ...)")
    ft = p.add_argument_group(
        "fitting (as pumpid fit; with --resume, options not given are the run's own)")
    add_fit_options(ft, sorted(MODELS))
    dh = p.add_argument_group("pump quantities (the pump identified from each card, and its "
                              "downhole card)")
    dh.add_argument("--well-file", metavar="WELLS.json",
                    help="well file (as pumpid downhole --well): add the pump quantities, "
                         "identified with their errors, as columns; one well applies to "
                         "every card, several are matched by well id (with --resume: the "
                         "run's own if not given)")
    dh.add_argument("--damping", type=float, metavar="NU",
                    help="Gibbs' dimensionless damping factor, held in the identification "
                         "(default: identified from each card; with --no-identify, "
                         "pumpid downhole's rule)")
    dh.add_argument("--no-identify", action="store_true",
                    help="do not identify the pump from each card (about 0.02-0.03 s a "
                         "card): the diagnostic pump card's quantities only")
    dh.add_argument("--pump-only", action="store_true",
                    help="fit no lumped model: the pump's identification is each card's "
                         "fit (its status, R^2 and evaluations in the fit's columns); more "
                         "than twice the cards a second")
    dh.add_argument("--harmonics", type=int, metavar="N",
                    help="highest harmonic of the Fourier method (default: all)")
    p.set_defaults(func=cmd_batch)
    return p
