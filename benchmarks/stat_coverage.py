"""Coverage of the 95 % intervals: white noise, and autocorrelated (AR(1)) noise.

For Kelvin and Maxwell (exact simulator, noise of 1 % of the displacement range, 801 samples
from rest; and a periodic card with an offset), fits ``--n`` noisy replicates from the
truth and counts how often each parameter's 95 % interval contains the true value. The
intervals (``ci95``) assume white, homoscedastic Gaussian noise and linearise the model at
the optimum (Student t quantile, N - p degrees of freedom); see :mod:`pumpid.diagnostics`.
Each count is followed by the exact binomial test of "the true coverage is 95 %" (two-sided
p-value) and the Clopper-Pearson 95 % interval of the coverage: with 200 replicates a
calibrated interval's observed coverage scatters by +-1.5 % (one binomial standard error).

The second part repeats the two fits from rest with AR(1) noise of the same size
(``x_t = rho x_{t-1} + e_t``, as from a low-pass filtered load cell; ``--rho``) and counts
both the independent-noise intervals (``ci95_white``) and the default ones (``ci95``: the
autocorrelation-robust ones, a prewhitened Bartlett-kernel sandwich widened for its own
spread, where the residuals fail the whiteness check). The white-noise part prints the
robust intervals' coverage too. The third part samples the card coarsely (``--short``
samples per stroke, white and every ``--rho`` noise), where the robust estimate has little
to go on. Each setting also prints the default interval's coverage over the replicates
whose fit calls the parameter determined (the target: 90-97 % for every one). The fourth
part fits one card each of the best-optimum benchmark's family (``--spread`` cards, Kelvin
parameters spread log-uniformly over x100, periodic, 1 % white noise and an offset) and
counts, over the converged fits calling a value determined, how often its default interval
holds the truth (a boundary fit's values are its limiting model's, not comparable).

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
import scipy.signal  # noqa: E402
import scipy.stats  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.conftest import spread_card, well_load  # noqa: E402

from pumpid import FitOptions, Kelvin, Maxwell, fit, simulate  # noqa: E402


def ar1_noise(rng: np.random.Generator, rho: float, n: int) -> np.ndarray:
    """A stationary AR(1) series with unit marginal variance (white noise for rho = 0)."""
    shocks = rng.standard_normal(n)
    shocks[0] /= np.sqrt(1.0 - rho**2)  # start in the stationary distribution
    return scipy.signal.lfilter([1.0], [1.0, -rho], shocks) * np.sqrt(1.0 - rho**2)


def count_coverage(truth, t, load, opts, n, seed, rho=0.0, level=0.01):
    """Replicates inside the white and the robust intervals, by parameter."""
    clean = simulate(truth, t, load, initial_state=opts.initial_state or "rest",
                     period=opts.period)
    rng = np.random.default_rng(seed)
    names = truth.param_names()
    inside = {kind: dict.fromkeys(names, 0) for kind in ("ci95", "ci95_white", "ci95_hac")}
    # The shown interval counted only where the fit calls the parameter determined.
    determined = dict.fromkeys(names, 0)
    inside["determined"] = dict.fromkeys(names, 0)
    rel_se = dict.fromkeys(names, 0.0)
    for _ in range(n):
        data = clean + level * np.ptp(clean) * ar1_noise(rng, rho, t.size)
        res = fit(truth, (t, load, data), options=opts)
        known = set(res.determined.get("parameters", ()))
        for kind in ("ci95", "ci95_white", "ci95_hac"):
            intervals = res.extra.get(kind, {})
            for name, value in truth.as_dict().items():
                ci = intervals.get(name)
                hit = ci is not None and ci[0] <= value <= ci[1]
                inside[kind][name] += hit
                if kind == "ci95" and name in known:
                    inside["determined"][name] += hit
                    determined[name] += 1
        for name in rel_se:
            rel_se[name] += res.stderr_white[name] / res.params[name] / n
    inside["n_determined"] = determined
    return inside, rel_se


def shown_line(inside: dict, n: int) -> str:
    """Coverage of the default interval where the fit calls the parameter determined."""
    parts = []
    for k, hits in inside["determined"].items():
        m = inside["n_determined"][k]
        parts.append(f"{k} {100 * hits / m:.1f} % of {m}" if m else f"{k} never determined")
    return "shown (ci95), over the fits calling it determined: " + ", ".join(parts)


def binomial_line(hits: dict[str, int], n: int) -> str:
    # The count is binomial: with n replicates a calibrated interval's observed coverage
    # scatters around 95 % by sqrt(0.95 * 0.05 / n) (1.5 % for n = 200).
    checks = []
    for k, v in hits.items():
        test = scipy.stats.binomtest(int(v), n, 0.95)
        low, high = test.proportion_ci(0.95)
        checks.append(f"{k} [{100 * low:.1f}, {100 * high:.1f}] % p = {test.pvalue:.2f}")
    return "exact binomial test of 95 %: " + "; ".join(checks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="noisy replicates per setting")
    parser.add_argument("--seed", type=int, default=31)
    parser.add_argument("--rho", type=float, nargs="*", default=[0.5, 0.8, 0.9, 0.95],
                        help="AR(1) coefficients of the autocorrelated-noise part")
    parser.add_argument("--short", type=int, nargs="*", default=[30, 60],
                        help="samples per stroke of the short-card part")
    parser.add_argument("--spread", type=int, default=60,
                        help="cards of the spread family (0: skip that part)")
    args = parser.parse_args()
    print(f"coverage of 95 % intervals: {args.n} replicates, 1 % white Gaussian noise")
    t = np.linspace(0.0, 20.0, 801)
    load = well_load(t)
    rest = [(f"{type(truth).__name__} from rest", truth, t, load, FitOptions())
            for truth in (Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0),
                          Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0))]
    period = 7.5
    tc = np.arange(500) * period / 500
    loadc = well_load(tc, period=period, seed=3)
    card = ("Kelvin periodic card + offset", Kelvin(k0=400.0, m=5.0, c1=40.0, k1=80.0),
            tc, loadc, FitOptions(initial_state="periodic", period=period, offset=True))
    for label, truth, tt, ff, opts in [*rest, card]:
        inside, rel_se = count_coverage(truth, tt, ff, opts, args.n, args.seed)
        cover = ", ".join(f"{k} {100 * v / args.n:.1f} % (se {100 * rel_se[k]:.2g} %)"
                          for k, v in inside["ci95"].items())
        print(f"  {label:30s} {cover}", flush=True)
        print(f"  {'':30s} {binomial_line(inside['ci95'], args.n)}", flush=True)
        robust = ", ".join(f"{k} {100 * v / args.n:.1f} %" for k, v in inside["ci95_hac"].items())
        print(f"  {'':30s} robust (ci95_hac): {robust}", flush=True)
        print(f"  {'':30s} {shown_line(inside, args.n)}", flush=True)

    if args.rho:
        coloured(args, rest)
    if args.short:
        short_cards(args, card)
    if args.spread:
        spread(args.spread)


def spread(n: int) -> None:
    """One card each of a family spread over x100: the truth differs from card to card."""
    names = Kelvin.param_names()
    status: dict[str, int] = {}
    hits = dict.fromkeys(names, 0)
    called = dict.fromkeys(names, 0)
    for i in range(n):
        card, truth = spread_card(i)
        res = fit(Kelvin, card)
        status[res.status.key] = status.get(res.status.key, 0) + 1
        if res.status.key != "converged":
            continue
        for j, name in enumerate(names):
            if name in res.determined.get("parameters", []):
                called[name] += 1
                low, high = res.ci95[name]
                hits[name] += bool(low <= truth[j] <= high)
    print(f"\nspread family: {n} cards, Kelvin over x100, periodic, 1 % white noise; statuses "
          + ", ".join(f"{k} {v}" for k, v in sorted(status.items())))
    print("  shown (ci95), over the converged fits calling it determined: " + ", ".join(
        f"{k} {hits[k]} of {called[k]} ({100 * hits[k] / called[k]:.0f} %)" if called[k]
        else f"{k} never determined" for k in names), flush=True)


def short_cards(args: argparse.Namespace, card: tuple) -> None:
    """The periodic card sampled coarsely: few samples against five fitted values."""
    print(f"\nshort cards ({card[0]}, 1 % noise, a stroke of --short samples): "
          f"{args.n} replicates; ci95 against ci95_hac")
    _label, truth, _tt, _ff, opts = card
    period = opts.period
    for n_samples in args.short:
        tt = np.arange(n_samples) * period / n_samples
        ff = well_load(tt, period=period, seed=3)
        for rho in (0.0, *args.rho):
            inside, _ = count_coverage(truth, tt, ff, opts, args.n, args.seed, rho=rho)
            parts = [f"{kind}: " + ", ".join(f"{k} {100 * v / args.n:.1f} %"
                                             for k, v in inside[kind].items())
                     for kind in ("ci95_white", "ci95")]
            print(f"  {n_samples:4d} samples, rho = {rho:.2f}: " + " | ".join(parts),
                  flush=True)
            print(f"  {'':26s}{shown_line(inside, args.n)}", flush=True)


def coloured(args: argparse.Namespace, rest: list) -> None:
    """The fits from rest under AR(1) noise: white-noise against robust intervals."""
    print(f"\ncoverage under AR(1) noise of the same size: {args.n} replicates; white-noise "
          "intervals (ci95) against the autocorrelation-robust ones (ci95_hac)")
    for rho in args.rho:
        factor = np.sqrt((1 + rho) / (1 - rho))
        for label, truth, tt, ff, opts in rest:
            inside, _ = count_coverage(truth, tt, ff, opts, args.n, args.seed, rho=rho)
            parts = []
            for kind in ("ci95_white", "ci95"):
                cover = ", ".join(f"{k} {100 * v / args.n:.1f} %"
                                  for k, v in inside[kind].items())
                parts.append(f"{kind}: {cover}")
            print(f"  rho = {rho:.2f} (AR(1) widening {factor:.1f}x) {label:18s} "
                  + " | ".join(parts), flush=True)
            print(f"  {'':50s} {shown_line(inside, args.n)}", flush=True)
            print(f"  {'':50s} shown: {binomial_line(inside['ci95'], args.n)}", flush=True)


if __name__ == "__main__":
    main()
