"""What a cold first run compiles: every compiled function, its signatures and their time.

    python benchmarks/bench_compile.py [FILE] [--keep-cache]

Runs ``pumpid fit FILE`` (default: the bundled example card) in this process with an empty
compiled cache (a fresh temporary ``NUMBA_CACHE_DIR``, as a new install has) and records
numba's compile events. Printed: the whole run's wall time; the entry points compiled from
Python (each with its signature and the time of its compile, callees included); and per
compiled function the time spent in its own compiles (callees excluded) and the number of
signatures it was compiled for. Run it on a quiet machine: the figures are wall times.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "src" / "pumpid" / "data" / "example_cards.csv"


def main() -> None:
    """Fit one file on an empty cache and print what was compiled."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("file", nargs="?", default=str(EXAMPLE), help="card file to fit")
    p.add_argument("--keep-cache", action="store_true",
                   help="use the current cache instead of an empty one (a warm run)")
    args = p.parse_args()
    if not args.keep_cache:
        os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="pumpid-cold-")
    sys.path.insert(0, str(ROOT / "src"))
    import numba.core.event as ev

    stack: list[list[float]] = []
    records: list[tuple[str, str, float, float, int]] = []

    class Listener(ev.Listener):
        def on_start(self, event: ev.Event) -> None:
            stack.append([time.perf_counter(), 0.0])

        def on_end(self, event: ev.Event) -> None:
            start, children = stack.pop()
            took = time.perf_counter() - start
            if stack:
                stack[-1][1] += took
            fn = event.data["dispatcher"].py_func
            name = f"{fn.__module__.rsplit('.', 1)[-1]}.{fn.__name__}"
            records.append((name, str(event.data["args"]), took, took - children, len(stack)))

    ev.register("numba:compile", Listener())
    from pumpid.cli import main as cli_main

    start = time.perf_counter()
    code = cli_main(["fit", args.file, "--brief"])
    wall = time.perf_counter() - start
    top = [r for r in records if r[4] == 0]
    print(f"pumpid fit {Path(args.file).name}: exit {code}, wall {wall:.1f} s, load average "
          f"{os.getloadavg()[0]:.1f}; {len(records)} compiles, {len(top)} from Python, "
          f"{sum(r[2] for r in top):.1f} s compiling")
    print("\nentry points compiled from Python (s, callees included)")
    for name, sig, took, _own, _depth in sorted(top, key=lambda r: -r[2]):
        print(f"  {took:8.2f}  {name}  {sig[:150]}")
    own: dict[str, list[float]] = {}
    for name, _sig, _took, self_time, _depth in records:
        entry = own.setdefault(name, [0.0, 0])
        entry[0] += self_time
        entry[1] += 1
    print("\nper compiled function (s of its own compiles, callees excluded; signatures)")
    for name, (secs, count) in sorted(own.items(), key=lambda kv: -kv[1][0]):
        print(f"  {secs:8.2f}  {count:3d}  {name}")


if __name__ == "__main__":
    main()
