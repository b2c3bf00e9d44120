"""Peak memory (resident set size) of a long fit and of ``pumpid fit`` over many cards.

    python benchmarks/bench_memory.py [--samples 1000000] [--cards 100,2000] [--out]

Each measurement runs in a fresh process and reads that process's peak resident set size
(``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` in a wrapper process that runs nothing
else), so the figures include the interpreter, numpy, numba and the compiled kernels.

1. **One long record through the API**: ``pumpid.fit(Kelvin, (t, load, displacement))`` on
   one card of ``--samples`` samples (a multi-sine load, the displacement of a known Kelvin
   model plus noise). Printed: the peak of a process that only builds the arrays (the
   baseline), the peak with the fit, and the difference per sample.
2. **Many cards through the command line**: ``pumpid fit FILES --brief`` over synthetic
   fields (:func:`pumpid.pump.synthetic.synthetic_field`, CSV layout, 100 samples a card)
   of each size in ``--cards``; with ``--out`` also writing every card's figures and report.
   A streaming command's peak should not grow with the number of cards.
3. **Reading**: the peak of ``read_cards`` on the largest field's cards in one CSV file,
   against the file's size.

Timings are printed too, for orientation only (the machine is shared).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

_WRAPPER = textwrap.dedent("""
    import resource, subprocess, sys
    done = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True)
    peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    print(done.returncode, peak_kib)
    sys.stderr.write(done.stderr[-2000:])
""")

_LONG_FIT = textwrap.dedent("""
    import sys
    import numpy as np
    import pumpid
    n, fit = int(sys.argv[1]), sys.argv[2] == "fit"
    t = np.arange(n) * 0.01
    load = 6000 + 2500 * np.sin(2 * np.pi * t / 7.5) + 400 * np.sin(2 * np.pi * t / 2.3 + 1)
    true = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)
    rng = np.random.default_rng(0)
    disp = pumpid.simulate(true, t, load, observe="u")
    disp += 0.001 * np.ptp(disp) * rng.standard_normal(n)
    if fit:
        res = pumpid.fit(pumpid.Kelvin, (t, load, disp),
                         options=pumpid.FitOptions(observe="u"))
        print(res.status, file=sys.stderr)
""")

_READ = textwrap.dedent("""
    import sys
    from pumpid.cards import read_cards
    cards = read_cards(sys.argv[1]) if sys.argv[2] == "read" else None
""")


def _peak(cmd: list[str]) -> tuple[int, float, float, str]:
    """Exit code, peak RSS (MiB) and wall time (s) of one command in a fresh process."""
    env_cmd = [sys.executable, "-c", _WRAPPER, *cmd]
    start = time.perf_counter()
    done = subprocess.run(env_cmd, capture_output=True, text=True, check=False,
                          env={"PYTHONPATH": str(SRC), "MPLBACKEND": "Agg",
                               "PATH": "/usr/bin:/bin"})
    wall = time.perf_counter() - start
    code, kib = done.stdout.split()
    return int(code), int(kib) / 1024.0, wall, done.stderr.strip()


def bench_long(samples: int) -> None:
    """One record of ``samples`` samples through ``pumpid.fit``."""
    py = [sys.executable, "-c", _LONG_FIT, str(samples)]
    _code0, base, _, _ = _peak([*py, "data"])
    code, peak, wall, err = _peak([*py, "fit"])
    status = err.splitlines()[-1] if err else "?"
    print(f"one record of {samples:,} samples through pumpid.fit (exit {code}, status "
          f"{status}): peak RSS {peak:,.0f} MiB; arrays alone {base:,.0f} MiB; the fit adds "
          f"{peak - base:,.0f} MiB = {(peak - base) * 2**20 / samples:,.0f} bytes per sample; "
          f"wall time {wall:,.0f} s")


def bench_cli(counts: list[int], with_out: bool) -> None:
    """``pumpid fit`` over synthetic fields of the given numbers of cards."""
    sys.path.insert(0, str(SRC))
    from pumpid.pump.synthetic import FieldCards, synthetic_field

    root = Path(tempfile.mkdtemp(prefix="pumpid-bench-memory-"))
    try:
        for n_cards in counts:
            wells = max(1, n_cards // 20)
            field_dir = root / f"field{n_cards}"
            synthetic_field(field_dir, n_wells=wells, days=n_cards // wells, formats=["csv"],
                            model="kelvin", cards=FieldCards(observe="u", n_samples=100),
                            seed=1)
            files = sorted(str(p) for p in (field_dir / "csv").glob("*.csv"))
            cmd = [sys.executable, "-m", "pumpid.cli", "fit", *files, "--observe", "u",
                   "--brief"]
            if with_out:
                cmd += ["--out", str(root / f"out{n_cards}")]
            code, peak, wall, _err = _peak(cmd)
            print(f"pumpid fit over {n_cards:,} cards in {len(files)} files"
                  f"{' with --out (figures and reports)' if with_out else ''} (exit {code}): "
                  f"peak RSS {peak:,.0f} MiB; wall time {wall:,.0f} s "
                  f"({1000 * wall / n_cards:,.0f} ms per card)")
        biggest = max(counts)
        one = root / "one_file.csv"
        with one.open("w", encoding="utf-8") as out:
            for i, path in enumerate(sorted((root / f"field{biggest}" / "csv").glob("*.csv"))):
                lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
                out.writelines(lines if i == 0 else lines[1:])
        size = one.stat().st_size / 2**20
        py = [sys.executable, "-c", _READ, str(one)]
        _, base, _, _ = _peak([*py, "none"])
        code, peak, wall, _ = _peak([*py, "read"])
        print(f"read_cards on one CSV of {biggest:,} cards ({size:,.1f} MiB, exit {code}): peak "
              f"RSS {peak:,.0f} MiB, {peak - base:,.0f} MiB above the import alone = "
              f"{(peak - base) / size:,.1f} x the file's size; wall time {wall:,.1f} s")
    finally:
        shutil.rmtree(root, ignore_errors=True)


def main() -> None:
    """Run the measurements asked for."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=1_000_000, help="length of the long record")
    p.add_argument("--cards", default="100,2000", help="field sizes for the CLI runs")
    p.add_argument("--out", action="store_true", help="also write figures and reports")
    p.add_argument("--skip-long", action="store_true", help="leave out the long record")
    args = p.parse_args()
    if not args.skip_long:
        bench_long(args.samples)
    counts = [int(c) for c in args.cards.split(",") if c.strip()]
    bench_cli(counts, with_out=False)
    if args.out:
        bench_cli(counts, with_out=True)


if __name__ == "__main__":
    main()
