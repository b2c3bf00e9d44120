"""Command-line interface: a thin shell over the public Python API.

    pumpid fit FILE [FILE ...] [--spm X | --period S] [--model kelvin] [--out DIR]
               [--json | --brief | --verbose]
    pumpid demo [--out DIR]
    pumpid reproduce [--json]
    pumpid simulate --model kelvin -p k0=4 -p m=1 -p c1=0.2 -p k1=4 LOAD.csv [-o OUT.csv]
    pumpid flow simulate|fit|study ...
    pumpid downhole FILE [FILE ...] --well WELL.json [--json] [--out DIR]

Each command lives in its own module with a ``register(subparsers)`` function; adding a
command is one line in :func:`build_parser`. :func:`main` turns every failure into one line
on standard error and an exit code (see :mod:`pumpid.cli.common`): no traceback reaches
the user, whatever the input, the options or the output path.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from .. import interrupts
from ..engine import compiled
from ..report.output import OutputError
from ..version import __version__
from . import batch, demo, downhole, fit, flow, report, reproduce, simulate
from .common import (
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OUTPUT,
    EXIT_PIPE,
    EXIT_USAGE,
    WarningCounter,
    check_paths,
    compile_notice,
    err,
)

__all__ = ["build_parser", "main"]

_EPILOG = """exit status: 0 every card fitted; 1 internal error (a bug); 2 bad options or input,
nothing fitted; 3 some cards not fitted; 4 outputs could not be written; 5 every card
fitted, some poorly (R^2 below --min-r2: status poor-fit); 6 every card fitted, but on
some the data determine no parameter (status undetermined); 130 interrupted (Ctrl-C,
results so far kept); 141 output pipe closed"""


#: The commands that fit (and so may compile the main job on a fresh install).
_FITTING = ("fit", "batch", "demo", "reproduce")


def _compiled_for(args: argparse.Namespace) -> tuple[str, ...]:
    """The compiled functions a command will call (what its compile notice checks)."""
    if args.command == "downhole":
        return compiled.PUMP_JOB if downhole.identifies(args)[0] else ()
    if args.command not in _FITTING:
        return ()
    if args.command == "batch":
        identify, pump_only = batch.pump_run(args)
        if identify:
            return compiled.PUMP_JOB if pump_only else compiled.MAIN_JOB + compiled.PUMP_JOB
    return compiled.MAIN_JOB


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``pumpid`` command."""
    parser = argparse.ArgumentParser(
        prog="pumpid", epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Identify small physical models from load/displacement data.")
    parser.add_argument("--version", action="version", version=f"pumpid {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    fit.register(sub)
    demo.register(sub)
    reproduce.register(sub)
    simulate.register(sub)
    flow.register(sub)
    batch.register(sub)
    report.register(sub)
    downhole.register(sub)
    return parser


def _negative_values(argv: Sequence[str]) -> list[str]:
    """``--opt -1e5`` as ``--opt=-1e5``: argparse reads a negative number in exponent
    notation (or ``-inf``) after an option as another option ("expected one argument")."""
    out: list[str] = []
    for token in argv:
        prev = out[-1] if out else ""
        if (token.startswith("-") and prev.startswith("-") and "=" not in prev
                and prev not in ("-", "--")):
            try:
                float(token)
            except ValueError:
                pass
            else:
                out[-1] = f"{prev}={token}"
                continue
        out.append(token)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pumpid`` command; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(_negative_values(sys.argv[1:] if argv is None else argv))
    except SystemExit as exc:
        # argparse has printed the usage and the problem (or the help, or the version).
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    except KeyboardInterrupt:
        err("interrupted (Ctrl-C)")
        return EXIT_INTERRUPTED
    names = _compiled_for(args)
    if names:
        compile_notice(names=names)
    counter = WarningCounter()
    try:
        with counter.active(), interrupts.recorded():
            check_paths(args)
            code = int(args.func(args))
    except OutputError as exc:
        err(f"error: {exc}")
        return EXIT_OUTPUT
    except (ValueError, TypeError) as exc:
        # Validation errors of the options and the API (CardError and CliError are
        # ValueErrors) carry messages naming the file, line or field.
        err(f"error: {exc}")
        return EXIT_USAGE
    except FileNotFoundError as exc:
        # Not every FileNotFoundError names its file (pyarrow's do not): then its words.
        err(f"error: {exc.filename}: no such file" if exc.filename else f"error: {exc}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        err("interrupted (Ctrl-C)")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_PIPE
    except MemoryError:
        err("error: out of memory (fit fewer or shorter records at a time)")
        return EXIT_INTERNAL
    except Exception as exc:
        if os.environ.get("PUMPID_DEBUG"):
            raise
        err(f"internal error: {type(exc).__name__}: {exc} (a bug in pumpid; rerun with "
            "PUMPID_DEBUG=1 for the traceback and please report it)")
        return EXIT_INTERNAL
    if getattr(args, "verbose", False):
        note = counter.summary()
        if note:
            err(note)
    return code


def _quiet_stdout() -> None:
    """After a closed pipe, send what Python flushes at exit nowhere (no second error)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
