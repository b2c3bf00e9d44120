"""``pumpid report``: the fleet report of a results table (which wells changed, when, how).

    pumpid report RESULTS --out DIR [--quantity NAME ...] [--parameters]
                  [--false-alarm 0.01] [--min-cards 30]

A thin shell over :func:`pumpid.fleet.report.write_fleet_report` on the table
:func:`pumpid.fleet.read_results` reads (a ``pumpid batch`` results folder, or any Parquet
file or folder in the same layout).
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["cmd_report", "register"]


def cmd_report(args: argparse.Namespace) -> int:
    """Write the fleet report; print where, and the alerts in one line each."""
    import pandas as pd

    from ..fleet.changes import available_quantities
    from ..fleet.report import write_fleet_report
    from ..fleet.store import read_results

    table = read_results(args.results)
    quantities = args.quantity
    if quantities is None and args.parameters:
        quantities = available_quantities(table, parameters=True)
    paths = write_fleet_report(table, args.out, quantities=quantities,
                               false_alarm=args.false_alarm, min_cards=args.min_cards,
                               max_wells_plotted=args.max_wells)
    alerts = pd.read_csv(paths["alerts"])
    wells = table["well_id"].nunique()
    print(f"pumpid report: {len(table)} cards of {wells} wells, {len(alerts)} alert(s) in "
          f"{alerts['well_id'].nunique() if len(alerts) else 0} well(s)")
    for _, a in alerts.iterrows():
        print(f"  well {a['well_id']}: {a['quantity']} {a['before']:.4g} -> {a['after']:.4g} "
              f"{a['unit']} ({a['change_rel']:+.1%}, {a['change_se']:.3g} standard errors) "
              f"from card {a['first_card_id']}")
    print(f"report: {paths['report']}")
    print(f"alerts: {paths['alerts']}; wells: {paths['wells']}")
    return 0


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid report`` to the ``pumpid`` command's subparsers."""
    p = subparsers.add_parser(
        "report", help="fleet report of a results table: trends, distributions, alerts",
        description="Write report.html (self-contained), its PNGs, alerts.csv and wells.csv "
                    "for a results table of many wells' cards (pumpid batch's RESULTS).")
    p.add_argument("results", metavar="RESULTS", help="results folder of pumpid batch (or a "
                                                      "Parquet table in its layout)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--quantity", action="append", metavar="NAME",
                   help="a quantity to trend: a derived one by name (natural_frequency), a "
                        "parameter by column (p_k0) or a pump quantity by column "
                        "(pump_fillage); repeat (default: every derived and pump one)")
    p.add_argument("--parameters", action="store_true",
                   help="trend the model parameters too")
    p.add_argument("--false-alarm", type=float, default=0.01,
                   help="probability that a steady well raises any alert (default 0.01)")
    p.add_argument("--min-cards", type=int, default=30,
                   help="cards in each reference window of the change detector (default 30)")
    p.add_argument("--max-wells", type=int, default=24,
                   help="most alerted wells drawn (default 24)")
    p.set_defaults(func=cmd_report)
    return p
