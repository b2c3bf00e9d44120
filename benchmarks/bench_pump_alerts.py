"""The demo's pump alerts: how soon the two changes are found, how often steady wells alert.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_pump_alerts.py                 # the demo's field
    .venv/bin/python benchmarks/bench_pump_alerts.py --cards 24 --seed 3

The field is the demo's pump field (:func:`pumpid.fleet.demo.make_pump_field`: wells P001
and P004 steady, P002's fillage 1 -> 0.75 and P003's fluid load -18 % from card ``--at``),
batched once with each card's pump identified (``pumpid batch --well-file``). The report is
then run as it would be after every new card: the change detector (default options) on each
well's history up to that card. For each changing well: the first card at which its change
is alerted, the delay in cards after the change, and the change's first card found. For the
steady wells: how many of those report runs raised any pump alert on them.

``--drift``: a second field of the same string and noise, well P005's fillage falling
steadily from 1 to ``--to`` (default 0.6) over its ``--cards`` cards beside the steady P001
and P004; the report run after every card as above: the first card at which the fillage
is alerted, and by which test. One run (seed 11): to 0.6 and to 0.8 alike, alerted on
card_index 5 (the first history tested, 6 cards) by the drift test; the steady wells: 0 of 22
runs alerted. With the two-segment test alone, the same field: not alerted within 16 cards.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import pandas as pd

from pumpid.fleet import FitSpec, detect_changes, read_results, run_batch
from pumpid.fleet.demo import DEMO_PUMP_FIELD, PUMP_CHANGE_AT, make_pump_field
from pumpid.fleet.downhole import DownholeSpec
from pumpid.fleet.pumpfield import PumpWell, write_pump_field

#: The changing wells and the quantity each change is about.
CHANGES = {"P002": "pump_fillage", "P003": "pump_fluid_load"}
STEADY = ("P001", "P004")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cards", type=int, default=DEMO_PUMP_FIELD["cards"])
    ap.add_argument("--at", type=int, default=PUMP_CHANGE_AT)
    ap.add_argument("--seed", type=int, default=DEMO_PUMP_FIELD["seed"])
    ap.add_argument("--drift", action="store_true", help="the drifting well's field instead")
    ap.add_argument("--to", type=float, default=0.6, help="the drifting fillage's last value")
    args = ap.parse_args()
    if args.drift:
        drift(args)
        return
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        truth = pd.read_csv(make_pump_field(root / "field", cards=args.cards, at=args.at,
                                            seed=args.seed))
        t0 = time.perf_counter()
        run_batch([root / "field"], root / "results",
                  fit=FitSpec("msd", options={"max_nfev": 20}),
                  downhole=DownholeSpec.load(root / "wells.json"))
        took = time.perf_counter() - t0
        table = read_results(root / "results").merge(
            truth[["card_id", "card_index"]], on="card_id")
    n_cards = len(table)
    print(f"field: {n_cards} cards of {table['well_id'].nunique()} wells, changes from "
          f"card_index {args.at}, seed {args.seed}; batch with identification "
          f"{took:.1f} s ({took / n_cards:.2f} s per card)")
    found: dict[str, tuple[int, int] | None] = dict.fromkeys(CHANGES)
    steady_runs = steady_alerts = 0
    first_len = 6  # the shortest history the detector tests
    for n in range(first_len, args.cards + 1):
        alerts = detect_changes(table[table["card_index"] < n])
        pump = alerts[alerts["kind"] == "pump"]
        for well, quantity in CHANGES.items():
            hit = pump[(pump["well_id"] == well) & (pump["quantity"] == quantity)]
            if found[well] is None and len(hit):
                found[well] = (n - 1, int(hit.iloc[0]["first_index"]))
        for well in STEADY:
            steady_runs += 1
            steady_alerts += int((pump["well_id"] == well).any())
    print("changing wells (the report run after every card):")
    for well, quantity in CHANGES.items():
        if found[well] is None:
            print(f"  {well} {quantity}: not alerted within {args.cards} cards")
            continue
        alarm, first = found[well]
        print(f"  {well} {quantity}: first alerted on card_index {alarm}: delay "
              f"{alarm - args.at} cards after the change; change's first card found at "
              f"card_index {first} (true {args.at})")
    print(f"steady wells {', '.join(STEADY)}: {steady_alerts} of {steady_runs} report runs "
          f"raised a pump alert (false-alarm rate {steady_alerts / steady_runs:.1%} of "
          f"runs; histories of {first_len} to {args.cards} cards)")


def drift(args: argparse.Namespace) -> None:
    n_cards = args.cards
    wells = {"P001": PumpWell(),
             "P004": PumpWell(fillage=0.85),
             "P005": PumpWell(fillage=lambda k: 1.0 - (1.0 - args.to) * k / (n_cards - 1))}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        options = {k: v for k, v in DEMO_PUMP_FIELD.items() if k != "cards"}
        truth = write_pump_field(root / "field", wells, cards=n_cards,
                                 **{**options, "seed": args.seed})
        run_batch([root / "field"], root / "results",
                  fit=FitSpec("msd", options={"max_nfev": 20}),
                  downhole=DownholeSpec.load(root / "wells.json"))
        table = read_results(root / "results").merge(
            truth[["card_id", "card_index"]], on="card_id")
    print(f"field: {len(table)} cards; P005's fillage 1 -> {args.to} over {n_cards} cards, "
          f"seed {args.seed}")
    first_len, found, steady_runs, steady_alerts = 6, None, 0, 0
    for n in range(first_len, n_cards + 1):
        pump = detect_changes(table[table["card_index"] < n])
        pump = pump[pump["kind"] == "pump"]
        hit = pump[(pump["well_id"] == "P005") & (pump["quantity"] == "pump_fillage")]
        if found is None and len(hit):
            row = hit.iloc[0]
            found = (n - 1, str(row["method"]), float(row["before"]), float(row["after"]))
        for well in STEADY:
            steady_runs += 1
            steady_alerts += int((pump["well_id"] == well).any())
    if found is None:
        print(f"  P005 pump_fillage: not alerted within {n_cards} cards")
    else:
        print(f"  P005 pump_fillage: first alerted on card_index {found[0]} by the "
              f"{found[1]} test ({found[2]:.3f} -> {found[3]:.3f})")
    print(f"steady wells: {steady_alerts} of {steady_runs} report runs raised a pump alert")


if __name__ == "__main__":
    main()
