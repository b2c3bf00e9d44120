"""Basin of attraction: starts log-uniform within x10 of the truth (Kelvin and Maxwell).

Prints, on the same seeded starts and noiseless data, how often each method reaches the
global minimum (every parameter within 1e-6 of the truth):

* default: ``fit(guess, data)``: lm from the guess, retried with the automatic start's
  multistart (the guess joins it) when the first result failed, stopped on a boundary or
  has R^2 < 0.99 (``multistart="auto"``);
* always guarded (``FitOptions(multistart=True)``) and lm from the guess alone
  (``FitOptions(multistart=False)``);
* the paper's Newton-Raphson with finite differences (``solver=PaperNewton()``).

Run from the repository root: ``python benchmarks/stat_basin.py [--n 200]``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

# Small matrices: a multi-threaded BLAS only oversubscribes the cores (100x slower under load).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.conftest import well_load  # noqa: E402
from tests.test_statistics import guarded_fit, max_rel_error  # noqa: E402

from pumpid import FitOptions, Kelvin, Maxwell, PaperNewton, fit, simulate  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="starts per model")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--max-iter", type=int, default=100,
                        help="iteration cap of the paper's method")
    args = parser.parse_args()
    t = np.linspace(0.0, 20.0, 1001)
    load = well_load(t)
    print(f"basin: {args.n} starts log-uniform within x10 of the truth, noiseless, "
          f"{t.size} samples from rest; success = all parameters within 1e-6")
    for truth in (Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0),
                  Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0)):
        data = simulate(truth, t, load)
        rng = np.random.default_rng(args.seed)
        starts = truth.values * np.exp(rng.uniform(-math.log(10), math.log(10),
                                                   (args.n, truth.values.size)))
        runs = {
            "default fit(guess) (multistart='auto')":
                lambda g, d=data: guarded_fit(g, t, load, d),
            "always guarded (multistart=True)":
                lambda g, d=data: fit(g, (t, load, d), options=FitOptions(multistart=True)),
            "lm from the guess alone (multistart=False)":
                lambda g, d=data: fit(g, (t, load, d), options=FitOptions(multistart=False)),
            "paper newton-fd": lambda g, d=data: fit(g, (t, load, d),
                                                     solver=PaperNewton(max_iter=args.max_iter)),
        }
        for label, run in runs.items():
            hits = 0
            t0 = time.perf_counter()
            for s in starts:
                res = run(type(truth).from_values(s))
                hits += res.model is not None and max_rel_error(res.params, truth) < 1e-6
            dt = (time.perf_counter() - t0) / args.n
            print(f"  {type(truth).__name__:8s} {label:36s} {hits:4d}/{args.n} "
                  f"= {100 * hits / args.n:5.1f} %   ({dt:.2f} s per fit)", flush=True)


if __name__ == "__main__":
    main()
