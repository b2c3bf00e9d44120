"""Command-line interface: a thin shell over the public Python API.

    pumpid fit CARD [--spm X | --period S] [--model kelvin] [--out DIR] [--json]
    pumpid demo [--out DIR]
    pumpid reproduce [--json]
    pumpid simulate --model kelvin -p k0=4 -p m=1 -p c1=0.2 -p k1=4 LOAD.csv [-o OUT.csv]
    pumpid flow simulate|fit ...
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..models import MODELS, model_class
from ..result import FitResult
from ..result import jsonable as _jsonable
from . import batch as batch_cli
from . import report as report_cli
from .flow import add_flow_parser

EXIT_OK, EXIT_USAGE, EXIT_NOT_CONVERGED = 0, 2, 3


class CliError(Exception):
    """A user-facing error: printed without a traceback, exit status 2."""


# --------------------------------------------------------------------------- helpers
def _parse_assignments(items: Sequence[str] | None, what: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or []:
        for part in item.split(","):
            if not part.strip():
                continue
            if "=" not in part:
                raise CliError(f"{what}: expected name=value, got {part!r}")
            name, value = part.split("=", 1)
            try:
                out[name.strip()] = float(value)
            except ValueError:
                raise CliError(f"{what}: {name.strip()} = {value!r} is not a number") from None
    return out


def _initial_state(text: str | None) -> Any:
    if text is None:
        return None
    if text in ("rest", "equilibrium", "periodic"):
        return text
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise CliError(
            f"--initial-state: {text!r} is neither rest, equilibrium, periodic nor a list "
            "of numbers"
        ) from None


def _print_json(obj: Any) -> None:
    print(json.dumps(_jsonable(obj), indent=2, allow_nan=False))


def _columns(args: argparse.Namespace) -> dict[str, Any] | None:
    cols = {k: getattr(args, f"{k}_col") for k in ("t", "load", "position")}
    cols = {k: v for k, v in cols.items() if v is not None}
    if not cols:
        return None
    out: dict[str, Any] = {}
    for key, value in cols.items():
        out[key] = int(value) if value.isdigit() else value
    return out


# --------------------------------------------------------------------------- fit
def _read(args: argparse.Namespace) -> list[Any]:
    from ..cards import read_cards

    cards = read_cards(
        args.file, format=args.format, position_unit=args.position_unit,
        load_unit=args.load_unit, spm=args.spm, period=args.period, columns=_columns(args),
    )
    if args.split_strokes:
        from ..cards import split_strokes

        cards = [stroke for card in cards for stroke in split_strokes(card)]
    if args.card:
        chosen = [c for c in cards if c.card_id == args.card]
        if not chosen:
            ids = ", ".join(c.card_id for c in cards[:20])
            raise CliError(f"{args.file}: no card {args.card!r}; cards are: {ids}")
        return chosen
    return cards


def _fit_options(args: argparse.Namespace) -> dict[str, Any]:
    opts: dict[str, Any] = {"method": args.method, "integrator": args.integrator,
                            "residual": args.residual}
    if args.observe:
        opts["observe"] = args.observe
    if args.scale is not None:
        opts["scale"] = args.scale if args.scale == "free" else float(args.scale)
    if args.x0:
        opts["x0"] = _parse_assignments(args.x0, "--x0")
    return opts


def _fit_one(card: Any, args: argparse.Namespace) -> FitResult:
    from ..pump import fit_card

    cls = model_class(args.model)
    opts = _fit_options(args)
    model: Any = cls
    if "x0" in opts:
        x0 = opts.pop("x0")
        missing = [n for n in cls.param_names() if n not in x0]
        if missing:
            raise CliError(f"--x0: give all of {cls.param_names()} (missing {missing})")
        model = cls(**{n: x0[n] for n in cls.param_names()})
        extra = {k: v for k, v in x0.items() if k in ("C", "D", "offset")}
        if extra:
            opts["x0"] = {**{n: x0[n] for n in cls.param_names()}, **extra}
    offset: bool | float
    if args.offset == "auto":
        offset = bool(card.periodic)
    else:
        offset = args.offset == "yes"
    return fit_card(card, model, initial_state=_initial_state(args.initial_state),
                    offset=offset, **opts)


def cmd_fit(args: argparse.Namespace) -> int:
    """Fit every card of a file (or the one chosen with --card)."""
    cards = _read(args)
    results = []
    for card in cards:
        res = _fit_one(card, args)
        pred = None
        if args.predict:
            pred = _prediction_for(res, args)
        results.append((card, res, pred))
        if args.out:
            from ..report import write_outputs

            out_dir = Path(args.out)
            if len(cards) > 1:
                out_dir = out_dir / _safe(card.card_id or "card")
            write_outputs(res, out_dir, notes=list(card.notes), prediction=pred)
    if args.json:
        dicts = [r.to_dict() for _c, r, _p in results]
        _print_json(dicts[0] if len(dicts) == 1 else {"cards": dicts})
    else:
        for card, res, pred in results:
            print(f"card {card.card_id or '(unnamed)'} from {card.source}")
            for note in card.notes:
                print(f"  note: {note}")
            print(res.report(history=args.history))
            if pred is not None:
                print(f"  prediction of card {pred['card']}: R^2 = {pred['r2']:.6g}, "
                      f"RMSE = {pred['rmse']:.4g} {res.units.position}")
            print()
        if args.out:
            print(f"outputs written to {args.out}")
    return EXIT_OK if all(r.converged or r.status == "boundary" for _c, r, _p in results) \
        else EXIT_NOT_CONVERGED


def _prediction_for(res: FitResult, args: argparse.Namespace) -> dict[str, Any]:
    from ..cards import read_cards
    from ..pump import predict_card

    target = args.predict
    if Path(target).is_file():
        others = read_cards(target, spm=args.spm, period=args.period)
        other = others[0]
    else:
        all_cards = read_cards(args.file, format=args.format, spm=args.spm, period=args.period,
                               position_unit=args.position_unit, load_unit=args.load_unit,
                               columns=_columns(args))
        matches = [c for c in all_cards if c.card_id == target]
        if not matches:
            raise CliError(f"--predict: no card {target!r} in {args.file} and no such file")
        other = matches[0]
    return predict_card(res, other)


def _safe(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name) or "card"


# --------------------------------------------------------------------------- demo
def cmd_demo(args: argparse.Namespace) -> int:
    """Fit the bundled example card and write the report."""
    from importlib import resources

    from ..cards import read_cards
    from ..pump import fit_card, predict_card
    from ..report import write_outputs

    ref = resources.files("pumpid") / "data" / "example_cards.csv"
    with resources.as_file(ref) as path:
        cards = read_cards(path)
    first, second = cards[0], cards[1]
    res = fit_card(first, "kelvin", observe="u")
    pred = predict_card(res, second)
    out = Path(args.out)
    paths = write_outputs(res, out, notes=list(first.notes), prediction=pred)
    print(f"pumpid demo: the bundled example well (synthetic, made by "
          f"scripts/make_example_cards.py), card {first.card_id}")
    print(res.report())
    print(f"\n  prediction of the next stroke ({second.card_id}) with these parameters: "
          f"R^2 = {pred['r2']:.6g}, RMSE = {pred['rmse']:.4g} {res.units.position}")
    print(f"\nreport: {paths.get('report', out / 'report.html')}")
    return EXIT_OK


# --------------------------------------------------------------------------- reproduce
def _fmt(v: Any, digits: int = 13) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}g}"


def cmd_reproduce(args: argparse.Namespace) -> int:
    """The paper's Tables 1-3 beside our runs."""
    from ..paper import PAPER_TABLES, reproduce

    out = {name: reproduce(name) for name in PAPER_TABLES}
    if args.json:
        _print_json(out)
        return EXIT_OK
    titles = {
        "table1": "Table 1: first order, tau = 5, linear residual, C free",
        "table2": "Table 2: first order, tau = 6, log residual, D = ln C free",
        "table3": "Table 3: mass-spring-dashpot m = 9.88, c = 4.94, k = 247, C free",
    }
    units = {"tau": "s", "C": "-", "D": "-", "m": "N s^2/m", "c": "N s/m", "k": "N/m"}
    for name, runs in out.items():
        print(titles[name])
        keys = [k for k in runs["paper"] if k not in ("truth", "iterations", "epsilon")]
        cols = ["paper", "paper_mode", "exact", "default"]
        header = f"  {'quantity':<12}" + "".join(f"{c:>22}" for c in cols)
        print(header)
        for key in [*keys, "iterations"]:
            row = f"  {key + ' [' + units.get(key, '-') + ']' if key != 'iterations' else key:<12}"
            for c in cols:
                row += f"{_fmt(runs[c].get(key)):>22}"
            print(row)
        print(f"  {'truth':<12}" + "  ".join(f"{k} = {v} {units.get(k, '')}"
                                              for k, v in runs["paper"]["truth"].items()))
        print("  paper_mode = the paper's newton-fd on explicit Euler (dt = 0.01); exact = "
              "newton-fd on the exact discretization; default = lm, exact")
        if name == "table3":
            fp = runs["paper_method_from_paper_start"]
            fd = runs["default_from_paper_start"]
            print(f"  from the paper's own start (its first printed row): newton-fd "
                  f"{'converged' if fp['converged'] else 'did not converge'} with our forcing; "
                  f"lm converged={fd['converged']} to m = {_fmt(fd['m'])} N s^2/m, "
                  f"c = {_fmt(fd['c'])} N s/m, k = {_fmt(fd['k'])} N/m")
        print()
    return EXIT_OK


# --------------------------------------------------------------------------- simulate
def _read_table(path: str, names: Sequence[str]) -> dict[str, np.ndarray]:
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise CliError(f"{path}: cannot read ({exc.strerror})") from None
    if not rows:
        raise CliError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    out: dict[str, np.ndarray] = {}
    for name in names:
        if name not in header:
            raise CliError(f"{path}: no column {name!r}; columns are {header}")
        j = header.index(name)
        values = []
        for lineno, row in enumerate(rows[1:], start=2):
            if not row:
                continue
            try:
                values.append(float(row[j]))
            except (ValueError, IndexError):
                raise CliError(f"{path}, line {lineno}, column {name!r}: not a number") from None
        out[name] = np.array(values)
    return out


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate a model's displacement for a load record."""
    from ..engine.simulate import simulate

    cls = model_class(args.model)
    params = _parse_assignments(args.param, "--param")
    missing = [n for n in cls.param_names() if n not in params]
    if missing:
        raise CliError(f"--param: {cls.__name__} needs {cls.param_names()} (missing {missing})")
    model = cls(**{n: params[n] for n in cls.param_names()})
    data = _read_table(args.file, [args.t_col or "t", args.load_col or "load"])
    t, load = data[args.t_col or "t"], data[args.load_col or "load"]
    state = _initial_state(args.initial_state) or "rest"
    y = simulate(model, t, load, observe=args.observe, initial_state=state,
                 integrator=args.integrator, scale=args.scale)
    out = open(args.output, "w", newline="", encoding="utf-8") if args.output else sys.stdout
    try:
        writer = csv.writer(out)
        writer.writerow(["t", "load", "displacement"])
        for row in zip(t, load, y, strict=True):
            writer.writerow([repr(float(v)) for v in row])
    finally:
        if args.output:
            out.close()
    return EXIT_OK


# --------------------------------------------------------------------------- parser
def _add_fit_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", default="kelvin", choices=sorted(MODELS),
                   help="model to fit (default kelvin)")
    p.add_argument("--method", default="lm", choices=["lm", "newton-fd"],
                   help="lm (default: exact sensitivities) or newton-fd (the paper's method)")
    p.add_argument("--integrator", default="exact", choices=["exact", "euler"])
    p.add_argument("--residual", default="linear", choices=["linear", "log"])
    p.add_argument("--observe", help="observed state (Kelvin: u2, the paper's, or u)")
    p.add_argument("--scale", help="output scale C: a number (default 1) or 'free'")
    p.add_argument("--initial-state",
                   help="rest, equilibrium, periodic, or the state as numbers (default: "
                        "periodic for a single-stroke card, else rest)")
    p.add_argument("--offset", default="auto", choices=["auto", "yes", "no"],
                   help="fit a position offset (auto: yes for single-stroke cards)")
    p.add_argument("--x0", action="append", metavar="NAME=VALUE[,...]",
                   help="starting guess (default: automatic start)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``pumpid`` command."""
    parser = argparse.ArgumentParser(
        prog="pumpid", description="Identify small physical models from load/displacement data.")
    parser.add_argument("--version", action="version", version=f"pumpid {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("fit", help="fit a model to a card or a time-series record")
    p.add_argument("file", help="card file (CSV/TSV, SCADA export, JSON, table, .ts)")
    p.add_argument("--spm", type=float, help="strokes per minute (cards without time)")
    p.add_argument("--period", type=float, help="stroke period in s (cards without time)")
    p.add_argument("--format", help="force a format: csv, scada, json, whitespace, ts")
    p.add_argument("--card", help="fit only this card id")
    p.add_argument("--split-strokes", action="store_true",
                   help="split multi-stroke time records at position minima; fit each stroke "
                        "as one period (ids CARD#0, CARD#1, ...)")
    p.add_argument("--t-col", help="time column (name, or index for tables without header)")
    p.add_argument("--load-col", help="load column")
    p.add_argument("--position-col", "--displacement-col", dest="position_col",
                   help="position/displacement column")
    p.add_argument("--load-unit", help="load unit of the file: lbf, klbf, N, kN, kgf")
    p.add_argument("--position-unit", help="position unit of the file: in, ft, m")
    _add_fit_arguments(p)
    p.add_argument("--predict", metavar="CARD_OR_FILE",
                   help="predict another card (an id in the same file, or a file) with the fit")
    p.add_argument("--out", help="write PNGs, result.json and report.html into this folder")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--history", action="store_true", help="print the iteration history")
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("demo", help="fit the bundled example card and write a report")
    p.add_argument("--out", default="demo-output", help="output folder (default demo-output)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("reproduce", help="the paper's Tables 1-3 beside our runs")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_reproduce)

    p = sub.add_parser("simulate", help="simulate a model for a load record (CSV t, load)")
    p.add_argument("file", help="CSV with a header holding time and load columns")
    p.add_argument("--model", default="kelvin", choices=sorted(MODELS))
    p.add_argument("-p", "--param", action="append", metavar="NAME=VALUE",
                   help="model parameter (repeat, or comma-separate)")
    p.add_argument("--t-col", help="time column (default t)")
    p.add_argument("--load-col", help="load column (default load)")
    p.add_argument("--observe")
    p.add_argument("--initial-state", help="rest (default), equilibrium, periodic or numbers")
    p.add_argument("--integrator", default="exact", choices=["exact", "euler"])
    p.add_argument("--scale", type=float, default=1.0, help="output scale C (default 1)")
    p.add_argument("-o", "--output", help="output CSV (default: standard output)")
    p.set_defaults(func=cmd_simulate)

    add_flow_parser(sub)
    batch_cli.register(sub)
    report_cli.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pumpid`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except CliError as exc:
        print(f"pumpid: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except (ValueError, TypeError) as exc:
        # Validation errors of the API (CardError is a ValueError) carry readable messages.
        print(f"pumpid: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except FileNotFoundError as exc:
        print(f"pumpid: error: {exc.filename}: no such file", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
