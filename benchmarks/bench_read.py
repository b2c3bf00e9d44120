"""How much memory does reading cards cost? Peak traced memory per MB of input.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_read.py               # 50 MB per layout
    .venv/bin/python benchmarks/bench_read.py --mb 5        # quicker
    .venv/bin/python benchmarks/bench_read.py --only table  # one layout

For each layout a made-up file of about ``--mb`` megabytes is written to a temporary folder,
then read with :func:`pumpid.cards.read_cards` under :mod:`tracemalloc`. The peak counts
everything the reader allocates, the file's bytes included (about 1 MB per MB), and the
cards it returns (16 bytes per sample for position and load, plus time and extra columns).
Layouts:

* ``table``: a comma-separated table with a header and a card-id column, many cards of 200
  samples (``card_id,spm,position_in,load_lbf``);
* ``headerless``: one long two-column table without header (column roles detected);
* ``scada``: a pipe-delimited controller export, one card of 200 samples per row.

This is a benchmark, not a test: it prints figures and checks nothing.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from pumpid.cards import read_cards

SAMPLES = 200  # per card


def _stroke(rng: np.random.Generator, n: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    th = 2 * np.pi * np.arange(n) / n
    pos = 60.0 * (1 - np.cos(th)) + 0.01 * rng.standard_normal(n)
    load = 8000 + 2000 * np.tanh(4 * np.sin(th)) + 30 * rng.standard_normal(n)
    return pos, load


def write_table(path: Path, mb: float) -> None:
    rng = np.random.default_rng(1)
    target = int(mb * 1e6)
    written = 0
    k = 0
    with path.open("w") as fh:
        fh.write("card_id,spm,position_in,load_lbf\n")
        while written < target:
            pos, load = _stroke(rng)
            block = "".join(
                f"C{k:06d},8.5,{x:.4f},{f:.2f}\n" for x, f in zip(pos, load, strict=True)
            )
            fh.write(block)
            written += len(block)
            k += 1


def write_headerless(path: Path, mb: float) -> None:
    rng = np.random.default_rng(2)
    target = int(mb * 1e6)
    written = 0
    with path.open("w") as fh:
        while written < target:
            pos, load = _stroke(rng)
            block = "".join(f"{x:.4f},{f:.2f}\n" for x, f in zip(pos, load, strict=True))
            fh.write(block)
            written += len(block)


def write_scada(path: Path, mb: float) -> None:
    rng = np.random.default_rng(3)
    target = int(mb * 1e6)
    written = 0
    k = 0
    with path.open("w") as fh:
        fh.write("Well|Timestamp|SPM|Stroke Length (in)|Surface Positions|Surface Loads\n")
        while written < target:
            pos, load = _stroke(rng)
            row = (
                f"W-{k % 97}|2021-06-01 {k // 3600 % 24:02d}:{k // 60 % 60:02d}:{k % 60:02d}.{k}"
                f"|8.5|{pos.max():.2f}|{','.join(f'{x:.2f}' for x in pos)}"
                f"|{','.join(f'{f:.1f}' for f in load)}\n"
            )
            fh.write(row)
            written += len(row)
            k += 1


LAYOUTS = {"table": write_table, "headerless": write_headerless, "scada": write_scada}


def measure(path: Path) -> tuple[float, float, int, int]:
    """Peak traced MB, seconds, cards and samples read."""
    tracemalloc.start()
    t0 = time.perf_counter()
    cards = read_cards(path)
    seconds = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 1e6, seconds, len(cards), sum(c.n for c in cards)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mb", type=float, default=50.0, help="size of each file in MB")
    parser.add_argument("--only", choices=sorted(LAYOUTS), help="one layout")
    args = parser.parse_args()
    layouts = [args.only] if args.only else list(LAYOUTS)
    print(f"{'layout':<11} {'input MB':>9} {'cards':>7} {'samples':>10} {'peak MB':>9} "
          f"{'peak/input':>10} {'s':>7}")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        for name in layouts:
            path = Path(tmp) / f"{name}.txt"
            LAYOUTS[name](path, args.mb)
            size = path.stat().st_size / 1e6
            peak, seconds, n_cards, n_samples = measure(path)
            print(f"{name:<11} {size:9.1f} {n_cards:7d} {n_samples:10d} {peak:9.1f} "
                  f"{peak / size:10.1f} {seconds:7.1f}")  # fmt: skip
            path.unlink()


if __name__ == "__main__":
    main()
