"""Fit time of one long record against its number of samples, stage by stage.

    python benchmarks/bench_long_record.py [--samples 10000,100000,1000000] [--periodic]
                                           [--model-error 0.02]

One record per size through ``pumpid.fit(Kelvin, (t, load, displacement),
options=FitOptions(observe="u"))``: the record of ``bench_memory.py`` (a two-tone load
sampled every 0.01 s, the displacement of a known Kelvin model plus 0.1 % noise), from rest;
with ``--periodic`` one periodic stroke of that many samples instead
(``initial_state="periodic"``, a fitted offset), as a single card of a controller export
would be. ``--model-error`` distorts the displacement a little, as
model error does on a real card, so that the wider search and the boundary refits run.
The job's stages are timed with :mod:`cProfile` (the cumulative time of the automatic
start, the solver runs, the wider search, the boundary checks and the diagnostics), so
the stage that grows faster than the record shows.

Printed per size: the wall time, the time per thousand samples, the ratio of both to the
smallest size's, the stages' times and the fit's status and evaluations. A job that grows
linearly keeps the time per thousand samples flat. The machine may be shared: the load
average is printed beside the figures.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import pumpid

#: The job's stages: (label, module file suffix, function name) for the profiler's table.
STAGES = (
    ("start", "engine/start.py", "find_starts"),
    ("solve", "engine/solvers.py", "solve"),
    ("wider search", "engine/start.py", "search_wider"),
    ("boundaries", "pumpid/job/boundary.py", "check_boundaries"),
    ("diagnostics", "pumpid/job/diagnose.py", "diagnose"),
    ("result", "pumpid/job/assemble.py", "build_result"),
)


def record(n: int, periodic: bool, model_error: float = 0.0
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float | None]:
    """(t, load, displacement, period) of a record of ``n`` samples; ``model_error`` adds a
    smooth cubic distortion of that relative size, which the model cannot explain."""
    if periodic:
        period = 7.5
        t = np.arange(n) * period / n
    else:
        period = None
        t = np.arange(n) * 0.01
    load = 6000 + 2500 * np.sin(2 * np.pi * t / 7.5) + 400 * np.sin(4 * np.pi * t / 7.5 + 1)
    if not periodic:
        load += 400 * np.sin(2 * np.pi * t / 2.3 + 1)
    true = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)
    rng = np.random.default_rng(0)
    disp = pumpid.simulate(true, t, load, observe="u",
                           initial_state="periodic" if periodic else "rest", period=period)
    centred = (disp - disp.mean()) / np.ptp(disp)
    disp = disp + model_error * np.ptp(disp) * 4.0 * centred**3
    disp = disp + 0.001 * np.ptp(disp) * rng.standard_normal(n)
    if periodic:
        disp = disp + 12.0
    return t, load, disp, period


def fit_once(n: int, periodic: bool, model_error: float = 0.0
             ) -> tuple[float, dict[str, float], object]:
    """Wall time, stage times (s) and the result of one fit of ``n`` samples."""
    t, load, disp, period = record(n, periodic, model_error)
    options = pumpid.FitOptions(observe="u")
    if periodic:
        options = options.replace(initial_state="periodic", period=period, offset=True)
    prof = cProfile.Profile()
    start = time.perf_counter()
    prof.enable()
    res = pumpid.fit(pumpid.Kelvin, (t, load, disp), options=options)
    prof.disable()
    wall = time.perf_counter() - start
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    stages = {}
    for label, path, name in STAGES:
        stages[label] = sum(v[3] for (file, _line, fn), v in stats.items()
                            if fn == name and file.replace(os.sep, "/").endswith(path))
    return wall, stages, res


def main() -> None:
    """Fit one record per size and print time against samples."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", default="10000,100000,1000000",
                   help="comma-separated record lengths")
    p.add_argument("--periodic", action="store_true",
                   help="one periodic stroke of that many samples instead of a long record")
    p.add_argument("--model-error", type=float, default=0.0,
                   help="relative size of a cubic distortion the model cannot explain, as on "
                        "a real card (e.g. 0.02): the job's guards then run")
    args = p.parse_args()
    sizes = [int(float(s)) for s in args.samples.split(",")]
    # A short fit first, so that no size pays for loading the compiled code.
    fit_once(1000, args.periodic, args.model_error)
    print(f"# load average at start: {os.getloadavg()[0]:.1f}; "
          f"{'one periodic stroke' if args.periodic else 'one record from rest'}, model error "
          f"{args.model_error:g}")
    labels = [s[0] for s in STAGES]
    print(f"{'samples':>9} {'wall s':>8} {'ms/1e3':>7} {'x wall':>7} {'x per-sample':>12} "
          + " ".join(f"{lab + ' s':>14}" for lab in labels) + "  status, evaluations")
    first: tuple[int, float] | None = None
    for n in sizes:
        wall, stages, res = fit_once(n, args.periodic, args.model_error)
        if first is None:
            first = (n, wall)
        per = wall / n * 1e6
        ratio = wall / first[1]
        per_ratio = (wall / n) / (first[1] / first[0])
        print(f"{n:>9,} {wall:>8.2f} {per:>7.2f} {ratio:>7.1f} {per_ratio:>12.2f} "
              + " ".join(f"{stages[lab]:>14.2f}" for lab in labels)
              + f"  {res.status.key}, {res.nfev}")  # type: ignore[attr-defined]
        sys.stdout.flush()
    print(f"# load average at end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
