"""Coverage of the 95 % intervals under 1 % white Gaussian noise.

For Kelvin and Maxwell (exact simulator, noise of 1 % of the displacement range, 801 samples
from rest; and a periodic card with an offset), fits ``--n`` noisy replicates from the
truth and counts how often each parameter's 95 % interval contains the true value. The
intervals assume white, homoscedastic Gaussian noise and linearise the model at the optimum
(Student t quantile, N - p degrees of freedom); see :mod:`pumpid.diagnostics`. Each
count is followed by the exact binomial test of "the true coverage is 95 %" (two-sided
p-value) and the Clopper-Pearson 95 % interval of the coverage: with 200 replicates a
calibrated interval's observed coverage scatters by +-1.5 % (one binomial standard error).

Run from the repository root: ``python benchmarks/stat_coverage.py [--n 200]``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

# Small matrices: a multi-threaded BLAS only oversubscribes the cores (100x slower under load).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import scipy.stats  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.conftest import well_load  # noqa: E402

from pumpid import Kelvin, Maxwell, fit, simulate  # noqa: E402
from pumpid.diagnostics import diagnose  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="noisy replicates per setting")
    parser.add_argument("--seed", type=int, default=31)
    args = parser.parse_args()
    print(f"coverage of 95 % intervals: {args.n} replicates, 1 % white Gaussian noise")
    settings = []
    t = np.linspace(0.0, 20.0, 801)
    load = well_load(t)
    for truth in (Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0),
                  Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0)):
        settings.append((f"{type(truth).__name__} from rest", truth, t, load, {}))
    period = 7.5
    tc = np.arange(500) * period / 500
    loadc = well_load(tc, period=period, seed=3)
    settings.append(("Kelvin periodic card + offset", Kelvin(k0=400.0, m=5.0, c1=40.0, k1=80.0),
                     tc, loadc, {"initial_state": "periodic", "period": period,
                                 "offset": True}))
    for label, truth, tt, ff, opts in settings:
        clean = simulate(truth, tt, ff, initial_state=opts.get("initial_state", "rest"),
                         period=opts.get("period"))
        rng = np.random.default_rng(args.seed)
        inside = dict.fromkeys(truth.param_names(), 0)
        rel_se = dict.fromkeys(truth.param_names(), 0.0)
        for _ in range(args.n):
            data = clean + 0.01 * np.ptp(clean) * rng.standard_normal(tt.size)
            res = fit(truth, tt, ff, data, **opts)
            diagnose(res)
            for name, value in truth.as_dict().items():
                ci = res.ci95.get(name)
                inside[name] += ci is not None and ci[0] <= value <= ci[1]
                rel_se[name] += res.stderr[name] / res.params[name] / args.n
        cover = ", ".join(f"{k} {100 * v / args.n:.1f} % (se {100 * rel_se[k]:.2g} %)"
                          for k, v in inside.items())
        print(f"  {label:30s} {cover}", flush=True)
        # The count is binomial: with n replicates a calibrated interval's observed coverage
        # scatters around 95 % by sqrt(0.95 * 0.05 / n) (1.5 % for n = 200).
        checks = []
        for k, v in inside.items():
            test = scipy.stats.binomtest(int(v), args.n, 0.95)
            low, high = test.proportion_ci(0.95)
            checks.append(f"{k} [{100 * low:.1f}, {100 * high:.1f}] % p = {test.pvalue:.2f}")
        print(f"  {'':30s} exact binomial test of 95 %: " + "; ".join(checks), flush=True)


if __name__ == "__main__":
    main()
