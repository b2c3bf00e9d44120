"""No guess: the automatic start alone on random well-like parameter sets (noiseless).

For Kelvin and Maxwell, periodic cards with an offset and records from rest, draws
``--n`` parameter sets (see ``tests.test_statistics.well_like_case``), fits with the model
class (``pumpid.fit(Kelvin, (t, load, displacement), options=...)``) and counts recoveries
to 1e-6.
Sets whose truth is conditioned beyond double precision (relative smallest singular value
of the log-scaled Jacobian below 1e-8) are counted separately, never silently dropped.

Run from the repository root: ``python benchmarks/stat_noguess.py [--n 200]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

# Small matrices: a multi-threaded BLAS only oversubscribes the cores (100x slower under load).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.test_statistics import (  # noqa: E402
    ILL_CONDITIONED,
    conditioning,
    max_rel_error,
    well_like_case,
)

from pumpid import Kelvin, Maxwell, fit  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="sets per model and mode")
    parser.add_argument("--seed", type=int, default=4)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"no guess: {args.n} well-like sets per model and mode, noiseless; success = all "
          "parameters within 1e-6")
    for model_cls in (Kelvin, Maxwell):
        for mode in ("periodic", "rest"):
            hits = ill = ill_hits = 0
            times = []
            failures = []
            for _ in range(args.n):
                case = well_like_case(rng, model_cls, mode)
                cond = conditioning(case)
                t0 = time.perf_counter()
                res = fit(model_cls, (case.t, case.load, case.data), options=case.options)
                times.append(time.perf_counter() - t0)
                ok = max_rel_error(res.params, case.truth) < 1e-6
                if cond < ILL_CONDITIONED:
                    ill += 1
                    ill_hits += ok
                else:
                    hits += ok
                    if not ok:
                        failures.append((case.truth, cond, res.status))
            n_ok = args.n - ill
            print(f"  {model_cls.__name__:8s} {mode:9s} {hits:4d}/{n_ok} = "
                  f"{100 * hits / max(n_ok, 1):5.1f} %  (ill-conditioned beyond double "
                  f"precision: {ill}, of which recovered {ill_hits});  time per fit: median "
                  f"{np.median(times):.3f} s, 95th pct {np.percentile(times, 95):.3f} s, "
                  f"max {max(times):.3f} s", flush=True)
            for truth, cond, status in failures:
                print(f"    failed: {truth} conditioning {cond:.2e} status {status}")


if __name__ == "__main__":
    main()
