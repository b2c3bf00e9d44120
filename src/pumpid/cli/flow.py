"""The ``pumpid flow`` commands: simulate a reference record, fit a surrogate, study step sizes.

    pumpid flow simulate --K 10 --n 0.4 --rho 1000 --radius 5e-3 --length 1 --dp 2e5 -o run.csv
    pumpid flow fit run.csv [--model first-order|power-law|shear-thinning] [--json] [--out DIR]
    pumpid flow study --K 10 --n 0.4 --rho 1000 --radius 5e-3 --length 1 --dp 1e5 --out DIR

Registered on the main parser by :func:`register` (:func:`add_flow_parser`). Errors are raised
as ``ValueError`` (the main entry point prints them without a traceback and exits with status
2); output problems as :class:`pumpid.report.output.OutputError` (status 4). Files are
written whole or not at all, through :mod:`pumpid.report.output`.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..cards import printable
from ..report.output import OutputError, OutputFolder, atomic_write
from .common import exit_status

__all__ = ["add_flow_parser", "cmd_flow_fit", "cmd_flow_simulate", "cmd_flow_study",
           "register"]

EXIT_OK = 0


class FlowCliError(ValueError):
    """A user-facing error of the flow commands."""


def _parse_fixed(items: list[str] | None) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or []:
        for part in item.split(","):
            if not part.strip():
                continue
            name, sep, value = part.partition("=")
            if not sep:
                raise FlowCliError(f"--fix: expected name=value, got {part!r}")
            try:
                out[name.strip()] = float(value)
            except ValueError:
                raise FlowCliError(f"--fix: {name.strip()} = {value!r} is not a number") from None
    return out


def _parse_steps(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise FlowCliError(f"--steps: {text!r} is not a comma-separated list of numbers") from None
    if len(set(values)) < 2 or any(not (math.isfinite(v) and v > 0) for v in values):
        # 1,1 gave a slope through two points of one abscissa.
        raise FlowCliError("--steps: give at least two different positive factors, e.g. "
                           "0.25,0.5,1,2,4")
    return values


#: The simulator's field names as the options that give them (an error named the class:
#: "PowerLawFluid.K (consistency) must be positive").
_OPTION_OF = {"PowerLawFluid.K": "--K", "PowerLawFluid.n": "--n", "PowerLawFluid.rho": "--rho",
              "Pipe.radius": "--radius", "Pipe.length": "--length"}


def _fluid_pipe(args: argparse.Namespace) -> tuple[Any, Any]:
    from ..flow.pipeflow import Pipe, PowerLawFluid

    try:
        return (PowerLawFluid(K=args.K, n=args.n, rho=args.rho),
                Pipe(args.radius, args.length))
    except ValueError as exc:
        text = str(exc)
        for field, option in _OPTION_OF.items():
            text = text.replace(field, option)
        raise FlowCliError(text) from None


def _fmt(value: Any, digits: int = 8) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:.{digits}g}"


# --------------------------------------------------------------------------- simulate
def cmd_flow_simulate(args: argparse.Namespace) -> int:
    """Simulate the reference pipe flow for a pressure-drop step or history; write t, dp, q."""
    from ..flow import simulate_flow_record
    from ..flow.pipeflow import PipeNumerics, power_law_time_scale

    fluid, pipe = _fluid_pipe(args)
    if (args.dp is None) == (args.dp_file is None):
        raise FlowCliError("give either --dp (a step in Pa) or --dp-file (a t, dp history)")
    if args.dp is not None:
        if not (math.isfinite(args.dp) and args.dp != 0):
            raise FlowCliError("--dp: the pressure-drop step must be a non-zero number (Pa)")
        t_end = (6.0 * power_law_time_scale(args.dp, fluid, pipe) if args.t_end is None
                 else args.t_end)  # 0 given is refused, not taken for "not given"
        if not (t_end > 0):
            raise FlowCliError("--t-end must be positive")
        if args.samples < 10:
            raise FlowCliError("--samples: at least 10")
        t = np.linspace(0.0, t_end, args.samples)
        dp: Any = args.dp
    else:
        history = _read_dp_history(args)
        t, dp = history
    if args.output is not None and Path(args.output).is_dir():
        raise OutputError(f"-o {printable(args.output)}: is a folder; give the name of the "
                          "CSV file to write")
    rec = simulate_flow_record(t, dp, fluid=fluid, pipe=pipe,
                               numerics=PipeNumerics(n_radial=args.n_radial))
    text = rec.to_csv()
    if args.output is None:
        sys.stdout.write(text)
    else:
        atomic_write(args.output, text)
        print(f"wrote {rec.n} samples (t [s], dp [Pa], q [m^3/s]) to "
              f"{printable(args.output)}", file=sys.stderr)
    return EXIT_OK


def _read_dp_history(args: argparse.Namespace) -> tuple[np.ndarray, np.ndarray]:
    """t and dp (Pa) from a CSV with a header (columns t and dp, units as for flow fit)."""
    import csv

    from ..cards import CardError
    from ..flow.records import convert_pressure, seconds_per, split_header

    path = args.dp_file
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    except OSError as exc:
        raise CardError(f"cannot read ({exc.strerror})", path=path) from None
    if len(rows) < 11:
        raise CardError("needs a header and at least 10 samples", path=path)
    header = [split_header(c) for c in rows[0]]
    names = [h[0].lower() for h in header]
    out = []
    for role, col in (("t", args.t_col or "t"), ("dp", args.dp_col or "dp")):
        if col.lower() not in names:
            raise CardError(f"no column {col!r}; columns are {[h[0] for h in header]}",
                            path=path, field=role)
        j = names.index(col.lower())
        try:
            out.append(np.array([float(r[j]) for r in rows[1:]]))
        except (ValueError, IndexError):
            raise CardError("unparsable number", path=path, field=col) from None
    t, dp = out
    j_dp = names.index((args.dp_col or "dp").lower())
    unit = args.dp_unit or header[j_dp][1] or "Pa"
    dp = convert_pressure(dp, unit, "Pa")
    # The header's time unit, as flow fit reads it: 't [ms]' was taken for seconds.
    t = t * seconds_per(header[names.index((args.t_col or "t").lower())][1] or "s",
                        field_name="t", path=path)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(dp))):
        raise CardError("non-finite values", path=path)
    if np.any(np.diff(t) <= 0):
        raise CardError("time must be strictly increasing", path=path, field="t")
    return t, dp


def _write_into(out: str, write: Callable[[Path], object]) -> None:
    """Write a command's files into a staging folder, then move them into ``out`` whole."""
    folder = OutputFolder(out)
    for said in folder.prepare():
        print(f"pumpid: {said}", file=sys.stderr)
    with folder.staging() as stage:
        write(stage)
        for said in folder.commit_files(stage):
            print(f"pumpid: {said}", file=sys.stderr)


# --------------------------------------------------------------------------- fit
def _columns(args: argparse.Namespace) -> dict[str, str] | None:
    cols = {"t": args.t_col, "dp": args.dp_col, "q": args.q_col, "p_in": args.p_in_col,
            "p_out": args.p_out_col}
    cols = {k: v for k, v in cols.items() if v is not None}
    return cols or None


def result_table(result: Any) -> str:
    """A readable summary of a flow fit: parameters with units and errors, R^2, warnings."""
    info = result.application.get("flow", {})
    units = result.param_units()
    stderr = result.extra.get("stderr", {})
    lines = [
        f"pumpid flow fit: {result.model_name} ({info.get('input', 'pressure drop')} in, "
        f"{info.get('output', 'flow rate')} out), method {result.method}",
        f"  record: {info.get('source', '?')}, {result.t.size} samples over "
        f"{result.t[-1] - result.t[0]:.6g} s",
    ]
    lines += [f"  note: {n}" for n in info.get("notes", [])]
    if info.get("initial_state"):
        lines.append(f"  initial state: {info['initial_state']}")
    if info.get("dp_ref"):
        lines.append(f"  pressure reference dp_ref = {info['dp_ref']:g} Pa (gain = steady q/dp "
                     "there)")
    lines.append(f"  status: {result.status} -- {result.reason}")
    lines.append(f"  iterations: {result.iterations}, model simulations: {result.nfev}")
    lines.append("")
    lines.append(f"  {'parameter':<10} {'value':>16}  {'std. error':>12}  unit")
    for name, value in result.params.items():
        fixed = "" if name in result.free else "  (fixed)"
        lines.append(f"  {name:<10} {_fmt(value, 10):>16}  {_fmt(stderr.get(name), 3):>12}  "
                     f"{units.get(name, '')}{fixed}")
    lines.append("")
    lines.append(f"  fit quality: R^2 = {_fmt(result.r2, 8)}, RMSE = {_fmt(result.rmse, 6)} "
                 f"{result.units.position}")
    if result.warnings:
        lines.append("  warnings:")
        lines += [f"  - {w}" for w in result.warnings]
    return "\n".join(lines)


def cmd_flow_fit(args: argparse.Namespace) -> int:
    """Fit a first-order surrogate to a flow record."""
    from ..flow import fit_flow, read_flow_record
    from ..flow.report import write_flow_outputs
    from ..result import jsonable as _jsonable

    rec = read_flow_record(args.file, columns=_columns(args), dp_unit=args.dp_unit,
                           q_unit=args.q_unit, t_unit=args.t_unit)
    state: Any = args.initial_state
    res = fit_flow(rec, args.model, direction=args.direction, method=args.method,
                   initial_state=state, dp_ref=args.dp_ref, fixed=_parse_fixed(args.fix) or None)
    if args.out:
        _write_into(args.out, lambda stage: write_flow_outputs(res, stage))
    if args.json:
        print(json.dumps(_jsonable(res.to_dict()), indent=2, allow_nan=False))
    else:
        print("\n".join(printable(line) for line in result_table(res).splitlines()))
        if args.history:
            print()
            print(res.history_table())
        if args.out:
            print(f"\noutputs written to {args.out}")
    # The exit codes of every command (a poor or undetermined fit exited 3, "failed").
    return exit_status({res.status.key: 1})


# --------------------------------------------------------------------------- study
def cmd_flow_study(args: argparse.Namespace) -> int:
    """Fit the surrogates to start-ups at several step sizes; tau against the step."""
    from ..flow import step_response_study
    from ..flow.report import write_study_outputs
    from ..result import jsonable as _jsonable

    fluid, pipe = _fluid_pipe(args)
    steps = [args.dp * f for f in _parse_steps(args.steps)]
    study = step_response_study(fluid, pipe, steps, window=args.window, samples=args.samples,
                                n_radial=args.n_radial)
    if args.out:
        _write_into(args.out, lambda stage: write_study_outputs(study, stage))
    if args.json:
        print(json.dumps(_jsonable(study.to_dict()), indent=2, allow_nan=False))
    else:
        print(f"pumpid flow study: power-law fluid K = {fluid.K:g} Pa s^n, n = {fluid.n:g}, "
              f"rho = {fluid.rho:g} kg/m^3; pipe R = {pipe.radius:g} m, L = {pipe.length:g} m")
        print(study.table())
        if args.out:
            print(f"\noutputs written to {args.out}")
    return EXIT_OK


# --------------------------------------------------------------------------- parser
def _add_fluid_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--K", type=float, required=True, help="consistency index K [Pa s^n]")
    p.add_argument("--n", type=float, default=1.0, help="flow-behaviour index n [-] (1)")
    p.add_argument("--rho", type=float, required=True, help="density [kg/m^3]")
    p.add_argument("--radius", type=float, required=True, help="pipe radius [m]")
    p.add_argument("--length", type=float, required=True, help="pipe length [m]")
    p.add_argument("--n-radial", type=int, default=200,
                   help="radial cells of the reference simulator (simulate: 200, study: "
                        "120)")


def add_flow_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``flow simulate``, ``flow fit`` and ``flow study`` on the main parser.

    Parameters
    ----------
    subparsers
        The object returned by ``parser.add_subparsers()`` of the ``pumpid`` parser.

    Returns
    -------
    argparse.ArgumentParser
        The ``flow`` parser.
    """
    flow = subparsers.add_parser(
        "flow", help="pressure-drop / flow-rate records: simulate, fit a surrogate, study steps",
        description="First-order surrogates of a viscous (power-law) delivery system.")
    sub = flow.add_subparsers(dest="flow_command", required=True)

    p = sub.add_parser("simulate", help="reference pipe-flow simulation -> CSV t, dp, q (SI)")
    _add_fluid_arguments(p)
    p.add_argument("--dp", type=float, help="pressure-drop step from rest at t = 0 [Pa]")
    p.add_argument("--dp-file", help="CSV with a pressure-drop history (columns t, dp)")
    p.add_argument("--t-col", help="time column of --dp-file (t)")
    p.add_argument("--dp-col", help="pressure-drop column of --dp-file (dp)")
    p.add_argument("--dp-unit", help="pressure unit of --dp-file (Pa)")
    p.add_argument("--t-end", type=float, help="record length for --dp [s] (6 time scales)")
    p.add_argument("--samples", type=int, default=301, help="samples for --dp (301)")
    p.add_argument("-o", "--output", help="output CSV (default: standard output)")
    p.set_defaults(func=cmd_flow_simulate)

    p = sub.add_parser("fit", help="fit a first-order surrogate to a flow record (CSV)")
    p.add_argument("file", help="CSV with a header: time, pressure drop (or p_in, p_out), flow")
    p.add_argument("--model", default="first-order",
                   choices=["first-order", "power-law", "shear-thinning"],
                   help="first-order (tau, gain; default), power-law (+ n, Hammerstein) or "
                        "shear-thinning (+ n, flow-dependent time constant)")
    p.add_argument("--direction", default="dp->q", choices=["dp->q", "q->dp"],
                   help="pressure drop in, flow rate out (default) or the reverse")
    p.add_argument("--method", default="lm", choices=["lm", "newton-fd"],
                   help="lm (default) or newton-fd (the paper's method)")
    p.add_argument("--t-col", help="time column (default t)")
    p.add_argument("--dp-col", help="pressure-drop column (default dp)")
    p.add_argument("--q-col", help="flow-rate column (default q)")
    p.add_argument("--p-in-col", help="inlet-pressure column (dp = p_in - p_out)")
    p.add_argument("--p-out-col", help="outlet-pressure column")
    p.add_argument("--dp-unit", help="pressure unit of the file: Pa (default), kPa, MPa, bar, "
                                     "psi, ...")
    p.add_argument("--q-unit", help="flow-rate unit of the file: m^3/s (default), L/s, L/min, "
                                    "mL/s, m^3/h, gpm")
    p.add_argument("--t-unit", help="time unit of the file: s (default), ms, min, h")
    p.add_argument("--initial-state", default="auto", choices=["auto", "rest", "equilibrium"],
                   help="auto (default): rest when the output starts at zero, else equilibrium")
    p.add_argument("--dp-ref", type=float,
                   help="pressure reference of the power-law models [Pa] (max |dp|)")
    p.add_argument("--fix", action="append", metavar="NAME=VALUE",
                   help="hold a parameter fixed, e.g. --fix n=0.4")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--out", help="write PNGs, result.json and report.html into this folder")
    p.add_argument("--history", action="store_true", help="print the iteration history")
    p.set_defaults(func=cmd_flow_fit)

    p = sub.add_parser("study", help="time constant against the pressure-drop step size")
    _add_fluid_arguments(p)
    p.set_defaults(n_radial=120)
    p.add_argument("--dp", type=float, default=1e5, help="reference step [Pa] (1e5)")
    p.add_argument("--steps", default="0.25,0.5,1,2,4",
                   help="step sizes as factors of --dp (0.25,0.5,1,2,4)")
    p.add_argument("--window", default="common", choices=["common", "scaled"],
                   help="common record length for all steps (default) or scaled to each step")
    p.add_argument("--samples", type=int, default=301, help="samples per record (301)")
    p.add_argument("--json", action="store_true", help="print the study as JSON")
    p.add_argument("--out", help="write tau_vs_step.png, study.csv/json and report.html here")
    p.set_defaults(func=cmd_flow_study)
    return flow


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid flow`` (the same as :func:`add_flow_parser`)."""
    return add_flow_parser(subparsers)
