"""``pumpid simulate``: a model's displacement for a load record (CSV with t and load)."""

from __future__ import annotations

import argparse
import codecs
import csv
import io
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..cards import TIME_UNITS, CardError, interpret_name, normalize_time_unit, printable
from ..models import MODELS, model_class
from ..report.output import OutputError, atomic_write
from .common import EXIT_OK, CliError, initial_state_option, model_option, parse_assignments

__all__ = ["cmd_simulate", "read_text", "register"]

_BOMS = ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
         (codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"),
         (codecs.BOM_UTF16_BE, "utf-16"))


def read_text(path: str, encoding: str | None = None) -> str:
    """A text file's content: ``encoding`` if given, else by its byte-order mark, else UTF-8.

    Raises
    ------
    CliError
        Naming the file: unreadable, an unknown encoding, or bytes that are not text in it.
    """
    where = printable(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise CliError(f"{where}: cannot read ({exc.strerror or exc})") from None
    if encoding is None:
        encoding = next((name for bom, name in _BOMS if data.startswith(bom)), "utf-8")
    try:
        return data.decode(encoding)
    except LookupError:
        raise CliError(f"--encoding {printable(encoding)!r}: not a known text encoding") \
            from None
    except UnicodeDecodeError as exc:
        raise CliError(f"{where}: not {encoding} text (byte 0x{data[exc.start]:02x} at byte "
                       f"{exc.start}); give its encoding with --encoding (e.g. latin-1, "
                       "utf-16)") from None


def _read_table(path: str, wanted: dict[str, str | None], encoding: str | None
                ) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The columns of roles ``t`` and ``load``: by the name given, else ``t``/``load``, else
    the column whose name says its role as ``pumpid fit`` reads it (``t_s``, ``load_lbf``,
    ``Time [ms]``). Returns the values by role and the header names used."""
    where = printable(path)
    text = read_text(path, encoding)
    rows = [r for r in csv.reader(io.StringIO(text, newline="")) if r and any(c.strip()
                                                                              for c in r)]
    if not rows:
        raise CliError(f"{where}: empty file")
    header = [h.strip() for h in rows[0]]
    out: dict[str, np.ndarray] = {}
    used: dict[str, str] = {}
    for role, given in wanted.items():
        name = given
        if name is None:
            by_role = [h for h in header if interpret_name(h)[0] == role]
            if role not in header and len(by_role) > 1:
                # Two loads (load_kN, load_lbf): taking the first would choose a unit.
                flag = "--t-col" if role == "t" else "--load-col"
                raise CliError(f"{where}: columns {', '.join(map(repr, by_role))} all read as "
                               f"{'time' if role == 't' else 'load'}; name one with {flag}")
            name = role if role in header else (by_role[0] if by_role else role)
        if name not in header:
            flag = "--t-col" if role == "t" else "--load-col"
            raise CliError(f"{where}: no column {printable(name)!r}; columns are "
                           f"{', '.join(printable(h) for h in header)} (name it with {flag})")
        j = header.index(name)
        values = []
        for lineno, row in enumerate(rows[1:], start=2):
            try:
                values.append(float(row[j]))
            except (ValueError, IndexError):
                cell = printable(row[j]) if j < len(row) else "(missing)"
                raise CliError(f"{where}, line {lineno}, column {printable(name)!r}: "
                               f"{cell!r} is not a number") from None
        arr = np.array(values)
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise CliError(f"{where}, line {int(bad[0]) + 2}, column {printable(name)!r}: "
                           "not a finite number")
        out[role] = arr
        used[role] = name
    if used.get("t") == used.get("load"):
        raise CliError(f"{where}: --t-col and --load-col name the same column "
                       f"{printable(used['t'])!r}")
    return out, used


def _seconds(path: str, name: str) -> float:
    """Seconds per unit of a time column named with its unit (``t_ms``), 1 otherwise."""
    unit = interpret_name(name)[2]
    if unit is None:
        return 1.0
    try:
        return TIME_UNITS[normalize_time_unit(unit)]
    except CardError as exc:
        raise CliError(f"{printable(path)}: time column {printable(name)!r}: {exc}") from None


def _check_finite(path: str, t: np.ndarray, y: np.ndarray) -> None:
    """Refuse to write a displacement that is not a number everywhere (CliError, exit 2).

    Parameters far outside floating point (``k0=1e308``, ``m=1e-320``), an output scale
    that overflows, or time steps too small to divide by all give infinities or NaNs in
    floating point; a file of them would read as a simulation.
    """
    bad = np.flatnonzero(~np.isfinite(y))
    if bad.size:
        i = int(bad[0])
        raise CliError(
            f"{printable(path)}: the simulated displacement is not a finite number from "
            f"line {i + 2} (t = {float(t[i]):.6g} s; {bad.size} of {y.size} samples): the "
            "parameters, the scale or the time steps are outside what floating point can "
            "compute (check -p, --scale and the time column); nothing was written")


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate a model's displacement for a load record; CSV t, load, displacement."""
    from ..engine.simulate import simulate

    cls = model_class(args.model)
    params = parse_assignments(args.param, "--param")
    model = model_option(cls, params, "--param",
                         f"{cls.__name__} needs {', '.join(cls.param_names())}")
    if args.observe is not None and args.observe not in cls.outputs:
        raise CliError(f"--observe {printable(args.observe)!r}: {cls.__name__} can observe "
                       f"{', '.join(cls.outputs)}")
    if args.output and Path(args.output).is_dir():
        raise OutputError(f"-o {printable(args.output)}: is a folder; give the name of the CSV "
                          "file to write")
    if not (0 < args.scale < np.inf):
        raise CliError(f"--scale {args.scale:g}: the output scale must be a positive finite "
                       "number")
    data, used = _read_table(args.file, {"t": args.t_col, "load": args.load_col},
                             args.encoding)
    # Time in seconds, as everywhere; the file's own unit converted at the edge.
    t, load = data["t"] * _seconds(args.file, used["t"]), data["load"]
    state = initial_state_option(args.initial_state) or "rest"
    try:
        y = simulate(model, t, load, observe=args.observe, initial_state=state,
                     integrator=args.integrator, scale=args.scale)
    except ValueError as exc:
        raise CliError(f"{printable(args.file)}: {exc}") from None
    _check_finite(args.file, t, y)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    # The load keeps its column's name (and so its unit); the time is in seconds.
    writer.writerow(["t_s", used["load"], "displacement"])
    for row in zip(t, load, y, strict=True):
        writer.writerow([repr(float(v)) for v in row])
    if args.output:
        atomic_write(args.output, buf.getvalue())
    else:
        sys.stdout.write(buf.getvalue())
    return EXIT_OK


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid simulate``."""
    p = subparsers.add_parser("simulate", help="simulate a model for a load record (CSV t, load)")
    p.add_argument("file", help="CSV with a header holding time and load columns")
    p.add_argument("--model", default="kelvin", choices=sorted(MODELS))
    p.add_argument("-p", "--param", action="append", metavar="NAME=VALUE",
                   help="model parameter (repeat, or comma-separate)")
    p.add_argument("--t-col", help="time column (default t, else the column named as time, "
                                    "e.g. t_s or time_ms, read in its unit)")
    p.add_argument("--load-col", help="load column (default load, else the column named as "
                                      "load, e.g. load_lbf)")
    p.add_argument("--encoding", help="text encoding of the file (default: UTF-8, or as its "
                                      "byte-order mark says)")
    p.add_argument("--observe")
    p.add_argument("--initial-state", help="rest (default), equilibrium, periodic or numbers")
    p.add_argument("--integrator", default="exact", choices=["exact", "euler"])
    p.add_argument("--scale", type=float, default=1.0, help="output scale C (default 1)")
    p.add_argument("-o", "--output", help="output CSV (default: standard output); written "
                                          "whole or not at all")
    p.set_defaults(func=cmd_simulate)
    return p
