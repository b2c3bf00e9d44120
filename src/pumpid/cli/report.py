"""``pumpid report``: the fleet report of a results table (which wells changed, when, how).

    pumpid report RESULTS --out DIR [--quantity NAME ...] [--parameters]
                  [--false-alarm 0.01] [--min-cards 30]

A thin shell over :func:`pumpid.fleet.report.write_fleet_report` on the table
:func:`pumpid.fleet.read_results` reads (a ``pumpid batch`` results folder, or any Parquet
file or folder in the same layout).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..cards import printable
from .common import CliError, plural

__all__ = ["cmd_report", "register"]

#: What to give instead, said by every refusal of RESULTS.
_GIVE = "give the results folder that pumpid batch --out wrote (or a Parquet file of it)"
#: The columns every results table has; the report groups and counts by them.
_NEEDED = ("well_id", "card_id", "status")
#: The first bytes of every Parquet file (its format's magic number).
_PARQUET_MAGIC = b"PAR1"


def _check_results(path: str) -> None:
    """Refuse, in words, a RESULTS that is not a results table (CliError, exit 2)."""
    where = printable(path)
    p = Path(path)
    if not p.exists():
        raise CliError(f"{where}: no such file or folder; {_GIVE}")
    files = [p] if p.is_file() else sorted(p.rglob("*.parquet"))
    if not files:
        raise CliError(f"{where}: the folder holds no Parquet results (no *.parquet file); "
                       f"{_GIVE}")
    for f in files:
        try:
            with f.open("rb") as fh:
                head = fh.read(len(_PARQUET_MAGIC))
        except OSError as exc:
            raise CliError(f"{printable(str(f))}: cannot read ({exc.strerror or exc})") \
                from None
        if head != _PARQUET_MAGIC:
            kind = ("a CSV file (pumpid batch --csv writes one beside the results; the "
                    "report reads the Parquet folder)" if f.suffix.lower() == ".csv"
                    else "not a Parquet file")
            raise CliError(f"{printable(str(f))}: {kind}; {_GIVE}")


def _check_columns(path: str, columns: list[str], rows: int) -> None:
    """Refuse a Parquet table that lacks the columns of a results table."""
    missing = [c for c in _NEEDED if c not in columns]
    if not missing:
        return
    has = (f"its columns are {', '.join(printable(str(c)) for c in columns[:20])}"
           + (f" and {len(columns) - 20} more" if len(columns) > 20 else "")
           if columns else "it has no columns")
    raise CliError(f"{printable(path)}: not a results table of pumpid batch ({rows} "
                   f"row{'' if rows == 1 else 's'}; {has}; a results table has "
                   f"{', '.join(_NEEDED)}); {_GIVE}")


def cmd_report(args: argparse.Namespace) -> int:
    """Write the fleet report; print where, and the alerts in one line each."""

    from ..fleet.changes import card_counts, detect_changes
    from ..fleet.events import count_events, ordered_by_event
    from ..fleet.quantities import available_quantities, echo_count
    from ..fleet.report import write_fleet_report
    from ..fleet.store import read_results

    _check_results(args.results)
    try:
        table = read_results(args.results)
    except (OSError, ValueError) as exc:
        # pyarrow's own words (ArrowInvalid is a ValueError) after the file's name.
        raise CliError(f"{printable(args.results)}: cannot be read as a results table "
                       f"({exc}); {_GIVE}") from None
    _check_columns(args.results, [str(c) for c in table.columns], len(table))
    quantities = args.quantity
    if quantities is None and args.parameters:
        quantities = available_quantities(table, parameters=True)
    # The alerts are found here and handed to the report, so that they are printed with the
    # ids as the files have them (alerts.csv neutralises text a spreadsheet would evaluate).
    # --parameters names no quantity: an echo of the stroke stays out, as in the views.
    options = {"false_alarm": args.false_alarm, "min_cards": args.min_cards}
    alerts = detect_changes(table, args.quantity, parameters=args.parameters, **options)
    paths = write_fleet_report(table, args.out, alerts=alerts, quantities=quantities,
                               asked=args.quantity or (), max_wells_plotted=args.max_wells,
                               **options)
    n = card_counts(table)
    alerted = alerts["well_id"].nunique() if len(alerts) else 0
    aside = [*([f"{plural(n['repeats'], 'repeat')} set aside"] if n["repeats"] else []),
             *([f"{n['unnamed']} without a well id, not trended"] if n["unnamed"] else []),
             *([f"{n['undated']} without a time in wells with dated cards, not trended"]
               if n["undated"] else [])]
    changes = count_events(alerts)
    print(f"pumpid report: {plural(n['cards'], 'card')} of {plural(n['wells'], 'well')}"
          f"{' (' + '; '.join(aside) + ')' if aside else ''}, "
          f"{plural(len(alerts), 'alert')} in {plural(alerted, 'well')}"
          + (f", {plural(changes, 'change')} (a change seen in several quantities counts "
             "once)" if changes < len(alerts) else ""))
    for _, a in ordered_by_event(alerts).iterrows():
        drift = (" (a steady drift over the history: its fitted line, first card to last)"
                 if a["method"] == "drift" else "")
        print(f"  change {int(a['event'])}, well {printable(str(a['well_id']))}: "
              f"{a['quantity']} {a['before']:.4g} -> "
              f"{a['after']:.4g} {a['unit']} ({a['change_rel']:+.1%}, {a['change_se']:.3g} "
              f"standard errors) from card {printable(str(a['first_card_id']))}{drift}")
    for q in args.quantity or ():
        echoes = echo_count(table, q)
        if echoes:
            # Named, the stroke's echoes are trended: a change in pumping speed moves them.
            print(f"  {q}: named, so its {plural(echoes, 'value')} that echo the stroke "
                  "are trended too; a change in them may follow the pumping speed, not the "
                  "well")
    print(f"report: {printable(str(paths['report']))}")
    print(f"alerts: {printable(str(paths['alerts']))}; wells: {printable(str(paths['wells']))}")
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
                   help="most alerted wells drawn (default 24); 6 wells without an alert "
                        "are drawn beside them for comparison, those the detector tested "
                        "first, picked at random")
    p.set_defaults(func=cmd_report)
    return p
