"""``pumpid reproduce``: the paper's Tables 1-3 beside our runs of each."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from ..result import jsonable
from .common import EXIT_OK

__all__ = ["cmd_reproduce", "register"]


def _fmt(v: Any, digits: int = 13) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    if isinstance(v, bool | int):
        return str(v)
    return f"{v:.{digits}g}"


def cmd_reproduce(args: argparse.Namespace) -> int:
    """The paper's Tables 1-3 beside our runs."""
    from ..paper import PAPER_TABLES, reproduce

    out = {name: reproduce(name) for name in PAPER_TABLES}
    if args.json:
        print(json.dumps(jsonable(out), indent=2, allow_nan=False))
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


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid reproduce``."""
    p = subparsers.add_parser("reproduce", help="the paper's Tables 1-3 beside our runs")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_reproduce)
    return p
