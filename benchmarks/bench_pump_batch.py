"""What a field of pumps costs end to end: ``pumpid batch --well-file``, as users run it.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_pump_batch.py                # 4 wells x 64 cards
    .venv/bin/python benchmarks/bench_pump_batch.py --cards 256    # 1,024 cards

The field is the demo's pump field (:func:`pumpid.fleet.demo.make_pump_field`: four wells
of one three-taper string, 100 samples a card, 1 % load noise, a fluid pound and a leaking
valve starting half way), ``--cards`` cards a well. Each run is the whole ``pumpid batch``
command in a process of its own (reading, the fits, the pump identified, the diagnostic
card, the Parquet partitions), on the 2 cores the command finds:

* ``--well-file``: the lumped model (Kelvin) and the pump, the default (on a worker process
  per core, the command's default engine when it identifies pumps);
* ``--well-file --pump-only``: the pump alone (worker processes);
* ``--well-file --engine local``: the lumped model and the pump on the threads of one
  process (two threads share one interpreter: about a third of a card's work holds it);
* ``--well-file --pump-only --engine local``: the pump alone on threads;
* ``--well-file --pump-only --engine dask --workers 2``: the pump alone on a Dask
  LocalCluster.

For each: the whole command's wall time and cards/s, the fitting part's cards/s as the
command's summary gives it (from the first card read to the last row written), and the
ratio of the rates to the default run's. The baseline beside them, in the same run:
:func:`pumpid.pump.identify_cards` over the same cards in this process, one thread (the
identification alone, no reading or writing). Runs alternate, ``--repeats`` times each; the
best of each is shown.

A benchmark, not a test: it prints figures and checks nothing.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pumpid.cards import read_cards
from pumpid.fleet.demo import make_pump_field
from pumpid.pump import identify_cards
from pumpid.rods import read_well_file

RUNS = {
    "--well-file (lumped fit and pump)": [],
    "--well-file --pump-only": ["--pump-only"],
    "--well-file --engine local": ["--engine", "local"],
    "--well-file --pump-only --engine local": ["--pump-only", "--engine", "local"],
    "--well-file --pump-only, dask 2 processes": ["--pump-only", "--engine", "dask",
                                                  "--workers", "2"],
}
_FITTED = re.compile(r"fitted in this run in ([0-9.]+) s, ([0-9.]+) cards/s")


def batch(field: Path, wells: Path, out: Path, extra: list[str]) -> tuple[float, float]:
    """One ``pumpid batch`` process: (wall time in s, the summary's cards/s)."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "pumpid.cli", "batch", str(field), "--out", str(out),
           "--well-file", str(wells), "--quiet", *extra]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    found = _FITTED.search(proc.stdout)
    if proc.returncode not in (0, 5, 6) or found is None:  # every card fitted
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stdout}\n"
                           f"{proc.stderr}")
    return wall, float(found.group(2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cards", type=int, default=64, help="cards per well (4 wells)")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-pump-batch-"))
    try:
        make_pump_field(root / "field", cards=args.cards, at=args.cards // 2)
        wells = root / "wells.json"
        cards = [c for p in sorted((root / "field").glob("*.json")) for c in read_cards(p)]
        total = len(cards)
        print(f"field: {total} cards of 100 samples, 4 wells; {os.cpu_count()} cores, "
              f"load average {os.getloadavg()[0]:.2f}")
        well_file = read_well_file(wells)
        identify_cards(cards[:2], well_file)  # compiled code loaded, not timed
        # The first command loads the compiled cache too: a warm-up, not timed.
        batch(root / "field" / "P001.json", wells, root / "warm", [])
        best: dict[str, tuple[float, float]] = {}
        alone = float("inf")
        for _ in range(args.repeats):
            for name, extra in RUNS.items():
                wall, rate = batch(root / "field", wells, root / "out", extra)
                old = best.get(name)
                best[name] = (min(wall, old[0]), max(rate, old[1])) if old else (wall, rate)
            start = time.perf_counter()
            identify_cards(cards, well_file)
            alone = min(alone, time.perf_counter() - start)
        base_rate = best[next(iter(RUNS))][1]
        print(f"\n{'pumpid batch FIELD':<46}{'wall s':>8}{'cards/s':>9}{'fitting cards/s':>17}"
              f"{'ratio':>7}")
        for name, (wall, rate) in best.items():
            print(f"{name:<46}{wall:>8.2f}{total / wall:>9.1f}{rate:>17.1f}"
                  f"{rate / base_rate:>7.2f}")
        print(f"{'identify_cards alone, one thread (baseline)':<46}{alone:>8.2f}"
              f"{total / alone:>9.1f}{total / alone:>17.1f}{total / alone / base_rate:>7.2f}")
        print(f"\nratio: the fitting part's cards/s over the default run's (same field, same "
              f"run; best of {args.repeats}); wall includes the command's start (imports, "
              f"compiled cache) and, with dask, its workers' start; load average at the end "
              f"{os.getloadavg()[0]:.2f}")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
