"""pumpid batch end to end: cards/s (read, fit, write) and peak memory, local and Dask.

Usage::

    .venv/bin/python benchmarks/bench_batch.py                 # 2,000 and 10,000 cards
    .venv/bin/python benchmarks/bench_batch.py --sizes 2000    # a quicker look
    .venv/bin/python benchmarks/bench_batch.py --model msd     # the cheaper model

A synthetic field (:func:`pumpid.pump.synthetic.synthetic_field`: wells of 100 cards of 100
samples in CSV, SCADA, JSON and Parquet files, 1 % broken; Kelvin wells whose ``u`` follows
the polished rod) is written once per size, untimed. Each run is then a fresh process
running :func:`pumpid.fleet.run_batch` on it, the same work as ``pumpid batch FIELD --out
RESULTS --observe u``: listing, reading, fitting, writing the Parquet parts and the
manifest, so cards/s are end to end. The engines:

* ``local``: this process, partitions one after another on every core;
* ``dask``: a LocalCluster of 2 single-threaded worker processes (started inside the timed
  run, as ``--engine dask`` does).

Peak memory is each process's largest resident set (``ru_maxrss``): the driver's, and for
Dask the largest worker process's. Flat in the number of cards means the 10,000-card run
peaks where the 2,000-card run does; a fresh process per run keeps one run's peak out of
the next one's figure. Timings are wall clock on a shared machine: the load average is
printed beside them.

Figures from one run are in the README (section "A field, not a file").
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

CARDS_PER_WELL = 100


def make_field(folder: Path, cards: int, model: str) -> None:
    """A field of ``cards`` cards (wells of 100 cards, four cards a day)."""
    from pumpid.pump.synthetic import FieldCards, synthetic_field

    synthetic_field(folder, n_wells=cards // CARDS_PER_WELL, days=CARDS_PER_WELL // 4,
                    cards_per_day=4, formats=("csv", "scada", "json", "parquet"), seed=1,
                    model=model, broken_fraction=0.01,
                    cards=FieldCards(observe="u" if model == "kelvin" else None, n_samples=100,
                                     hold="none"))


def child(args: argparse.Namespace) -> None:
    """One timed run in this (fresh) process; prints its figures as JSON."""
    from pumpid.fleet import FitSpec, run_batch

    options = {"observe": "u"} if args.model == "kelvin" else {}
    t0 = time.perf_counter()
    summary = run_batch([args.field], args.out, fit=FitSpec(args.model, options=options),
                        engine=args.engine, workers=2 if args.engine == "dask" else None)
    elapsed = time.perf_counter() - t0
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(json.dumps({"cards": summary.cards, "elapsed": elapsed,
                      "statuses": dict(summary.statuses), "driver_mib": own,
                      "worker_mib": kids if args.engine == "dask" else None,
                      "engine": summary.engine}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default="2000,10000", help="card counts (default 2000,10000)")
    parser.add_argument("--engines", default="local,dask", help="local, dask or both")
    parser.add_argument("--model", default="kelvin", choices=["kelvin", "msd"])
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--field", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--engine", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args)
        return
    import dask
    import numpy
    import pandas
    import pyarrow

    import pumpid

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}, Python "
          f"{platform.python_version()}, numpy {numpy.__version__}, pandas "
          f"{pandas.__version__}, pyarrow {pyarrow.__version__}, dask {dask.__version__}, "
          f"pumpid {pumpid.__version__}")
    print(f"model {args.model} (observe u for Kelvin), wells of {CARDS_PER_WELL} cards x 100 "
          "samples, CSV/SCADA/JSON/Parquet, 1 % broken; end to end = list, read, fit, write")
    print(f"{'cards':>7} {'engine':<7} {'time':>9} {'cards/s':>9} {'driver peak':>12} "
          f"{'worker peak':>12}  statuses")
    with tempfile.TemporaryDirectory(prefix="pumpid-bench-batch-") as tmp:
        for size in (int(s) for s in args.sizes.split(",")):
            field = Path(tmp) / f"field-{size}"
            make_field(field, size, args.model)
            for engine in args.engines.split(","):
                out = Path(tmp) / f"results-{size}-{engine}"
                load = os.getloadavg()[0]
                run = subprocess.run(
                    [sys.executable, __file__, "--child", "--field", str(field), "--out",
                     str(out), "--engine", engine, "--model", args.model],
                    capture_output=True, text=True, check=True)
                fig = json.loads(run.stdout.strip().splitlines()[-1])
                worker = "" if fig["worker_mib"] is None else f"{fig['worker_mib']:.0f} MiB"
                statuses = ", ".join(f"{k} {v}" for k, v in sorted(fig["statuses"].items()))
                print(f"{fig['cards']:>7} {engine:<7} {fig['elapsed']:>7.1f} s "
                      f"{fig['cards'] / fig['elapsed']:>9.1f} {fig['driver_mib']:>8.0f} MiB "
                      f"{worker:>12}  {statuses} (load before {load:.2f})")


if __name__ == "__main__":
    main()
