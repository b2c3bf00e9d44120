"""How much does a fit cost? Single Kelvin fits, scipy baselines, batches, scaling.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_fit.py            # full run (a few minutes)
    .venv/bin/python benchmarks/bench_fit.py --quick    # smaller sizes, fewer repeats

BLAS/OpenMP threads are pinned to one per process *before numpy is imported* (the single-fit
targets are per core). The batch section also reports ``fit_many(..., workers=2)``: two
Python threads on different chunks of cards, which is how one process uses both cores.
Timings are wall-clock medians; other processes on the machine inflate them (the load
average is printed).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _baselines import lm_fd_fit, newton_fd_fit  # noqa: E402

import pumpid  # noqa: E402
from pumpid import Kelvin  # noqa: E402
from pumpid.batch import fit_many  # noqa: E402
from pumpid.simulate import make_grid, propagate  # noqa: E402

Array = np.ndarray
PERIOD = 7.5  # s, one stroke at 8 strokes per minute
TRUE = Kelvin(k0=9000.0, m=45.0, c1=900.0, k1=5200.0)
GUESS_FACTORS = np.array([1.3, 1 / 1.3, 1.3, 1 / 1.3])  # ~30 % off, alternating


# --------------------------------------------------------------------------- data
def stroke_load(t: Array, seed: int = 0) -> Array:
    """A dynamometer-card-like polished-rod load over repeated strokes (N).

    Rod weight, the fluid load taken up when the travelling valve closes and dropped when it
    opens (smooth steps at random phases), a rod-stretch oscillation and a stroke harmonic.
    """
    rng = np.random.default_rng(seed)
    phase = (t / PERIOD) % 1.0
    up_at, down_at = 0.06 + 0.06 * rng.random(), 0.5 + 0.1 * rng.random()
    taken = 0.5 * (1.0 + np.tanh((phase - up_at) / 0.025))
    dropped = 0.5 * (1.0 + np.tanh((phase - down_at) / 0.035))
    fluid = (3500.0 + 1000.0 * rng.random()) * taken * (1.0 - dropped)
    wobble = (250.0 + 100.0 * rng.random()) * np.sin(2 * np.pi * (3 * phase + rng.random()))
    return 5500.0 + fluid + wobble + 400.0 * np.sin(2 * np.pi * phase)


def noisy(clean: Array, level: float, seed: int) -> Array:
    """Add white noise of ``level`` times the record's range."""
    if level == 0:
        return clean
    rng = np.random.default_rng(seed)
    return clean + level * np.ptp(clean, axis=-1, keepdims=True) * rng.standard_normal(
        clean.shape)


def single_record(n_samples: int, level: float) -> tuple[Array, Array, Array]:
    t = np.linspace(0.0, PERIOD, n_samples)
    load = stroke_load(t)
    data = noisy(pumpid.simulate(TRUE, t, load), level, seed=n_samples)
    return t, load, data


# --------------------------------------------------------------------------- helpers
def timed(fn: Callable[[], object], repeats: int) -> tuple[Array, object]:
    out = fn()  # warm-up (imports, caches)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return np.array(times), out


def rel_err(theta: Array, ref: Array) -> float:
    return float(np.max(np.abs(np.asarray(theta) / ref - 1.0)))


def table(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print(f"\n{title}")
    print("  " + "  ".join(h.rjust(w) for h, w in zip(header, widths, strict=True)))
    print("  " + "  ".join("-" * w for w in widths))
    for r in rows:
        print("  " + "  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)))


def machine_reference() -> float:
    """ms for a fixed small-matrix workload (2,000 x a 17 x 17 product and solve), the kind of
    work a fit is made of: printed beside the single-fit timings so that a slow phase of a
    shared machine shows up as a slow reference too (about 13 ms on a quiet run here)."""
    a = np.random.default_rng(0).standard_normal((17, 17))
    t0 = time.perf_counter()
    for _ in range(2000):
        a @ a
        np.linalg.solve(a, a[0])
    return (time.perf_counter() - t0) * 1e3


def pumpid_fit(t: Array, load: Array, data: Array) -> pumpid.FitResult:
    return pumpid.fit(Kelvin.from_values(TRUE.values * GUESS_FACTORS), t, load, data)


# --------------------------------------------------------------------------- sections
def section_single(quick: bool) -> dict[float, float]:
    repeats = 10 if quick else 30
    base_runs = 1 if quick else 2
    rows, medians = [], {}
    base_rows = []
    for level in (0.0, 0.01):
        t, load, data = single_record(2001, level)
        ref_before = machine_reference()
        times, res = timed(lambda t=t, load=load, data=data: pumpid_fit(t, load, data),
                           repeats)
        ref_after = machine_reference()
        assert isinstance(res, pumpid.FitResult)
        med = float(np.median(times))
        medians[level] = med
        rows.append([f"{level:.0%}", f"{med * 1e3:.2f}", f"{np.percentile(times, 90) * 1e3:.2f}",
                     res.status, str(res.nfev), f"{rel_err(res.model.values, TRUE.values):.1e}",
                     f"{ref_before:.0f} / {ref_after:.0f}"])
        guess = TRUE.values * GUESS_FACTORS
        close = TRUE.values * np.array([1.05, 1 / 1.05, 1.05, 1 / 1.05])
        plan = [("least_squares lm + FD over solve_ivp", lm_fd_fit, guess, "30 %"),
                ("paper newton-fd over solve_ivp", newton_fd_fit, guess, "30 %")]
        while plan:
            name, method, start, label = plan.pop(0)
            secs, run = [], None
            for _ in range(base_runs):
                t0 = time.perf_counter()
                run = method(Kelvin, t, load, data, start, k_obs=2)
                secs.append(time.perf_counter() - t0)
                if not run.ok:
                    break
            assert run is not None
            sec = float(np.median(secs))
            base_rows.append([
                f"{level:.0%}", name, label, f"{sec:.2f}", str(run.simulations),
                "yes" if run.ok else "NO", f"{rel_err(run.theta, TRUE.values):.1e}",
                f"{rel_err(res.model.values, TRUE.values):.1e}", f"{sec / med:,.0f}x",
            ])
            if not run.ok and label == "30 %":
                # The paper's method has no step control: from far away it diverges. Time it
                # from a close start too, so the ratio compares converged fits.
                plan.append((name, method, close, "5 %"))
    table("(a) Single Kelvin fit, 2001 stations, pumpid.fit defaults (lm, exact Jacobian), "
          f"start ~30 % off, {repeats} runs",
          ["noise", "median ms", "p90 ms", "status", "sims", "max rel err vs truth",
           "reference ms before / after"], rows)
    table(f"(b) Baselines on the same data (median of {base_runs} run(s)); ratio = baseline "
          "time / pumpid median",
          ["noise", "method", "start", "time s", "sims", "conv", "its err", "pumpid err",
           "ratio"],
          base_rows)
    return medians


def batch_data(n_cards: int, n_samples: int, level: float, seed: int = 7
               ) -> tuple[Array, Array, Array, Array]:
    """Cards on one stroke (periodic steady state) with an unknown position offset."""
    t = np.linspace(0.0, PERIOD, n_samples, endpoint=False)
    grid = make_grid(t)
    rng = np.random.default_rng(seed)
    theta = TRUE.values * np.exp(0.3 * rng.standard_normal((n_cards, 4)))
    loads = np.empty((n_cards, n_samples))
    disp = np.empty((n_cards, n_samples))
    for start in range(0, n_cards, 500):
        sl = slice(start, min(start + 500, n_cards))
        loads[sl] = [stroke_load(t, seed=seed * 100_000 + i) for i in range(sl.start, sl.stop)]
        y = propagate(Kelvin, theta[sl], grid, loads[sl], initial_state="periodic",
                      sensitivities=False)[..., 2]
        offsets = rng.uniform(-0.5, 0.5, size=(sl.stop - sl.start, 1))
        disp[sl] = noisy(y, level, seed=start) + offsets
    return t, loads, disp, theta


def section_batch(quick: bool) -> None:
    sizes = (200, 1000) if quick else (1000, 3000, 10000)
    n_samples = 400
    t, loads_all, disp_all, theta_all = batch_data(max(sizes), n_samples, 0.01)
    rows = []
    for workers in (1, 2):
        for n_cards in sizes:
            loads, disp = loads_all[:n_cards], disp_all[:n_cards]
            inputs_mb = (loads.nbytes + disp.nbytes) / 2**20
            t0 = time.perf_counter()
            res = fit_many(Kelvin, t, loads, disp, initial_state="periodic", offset=True,
                           workers=workers)
            sec = time.perf_counter() - t0
            # Memory in a second, traced call: tracemalloc slows every allocation, so it
            # must not run during the timed one.
            tracemalloc.start()
            base = tracemalloc.get_traced_memory()[0]
            fit_many(Kelvin, t, loads, disp, initial_state="periodic", offset=True,
                     workers=workers)
            peak = (tracemalloc.get_traced_memory()[1] - base) / 2**20
            tracemalloc.stop()
            good = res.status == "converged"
            err = np.abs(res.theta[good] / theta_all[:n_cards][good] - 1.0)
            rows.append([
                str(workers), f"{n_cards:,}", f"{sec:.2f}", f"{n_cards / sec:,.0f}",
                f"{inputs_mb:.1f}", f"{peak:.1f}", f"{good.mean():.1%}",
                f"{np.median(res.iterations):.0f}", f"{np.median(res.r2):.5f}",
                f"{np.median(err):.1e}",
            ])
    table(f"(c) Batch: fit_many(Kelvin, ...) on cards x {n_samples} samples, one stroke each "
          "(periodic, fitted offset), 1 % noise, parameters +-30 % (log-normal) per card, "
          "automatic start per card; peak = tracemalloc peak during the call beyond the inputs",
          ["workers", "cards", "time s", "cards/s", "inputs MB", "peak MB", "converged",
           "median its", "median R^2", "median |err|"], rows)


def section_scaling(quick: bool, single_ms: float) -> None:
    sizes = (250, 1000, 4000) if quick else (250, 500, 1000, 2001, 5000, 10000, 20000)
    repeats = 3 if quick else 7
    rows = []
    for n in sizes:
        t, load, data = single_record(n, 0.01)
        times, res = timed(lambda t=t, load=load, data=data: pumpid_fit(t, load, data),
                           repeats)
        assert isinstance(res, pumpid.FitResult)
        med = float(np.median(times))
        rows.append([f"{n:,}", f"{med * 1e3:.1f}", f"{med * 1e6 / n:.2f}", str(res.nfev),
                     res.status])
    table("(d) Scaling with the number of samples: single Kelvin fit, 1 % noise",
          ["samples", "median ms", "us/sample", "sims", "status"], rows)
    del single_ms
    card_sizes = (10, 100, 1000) if quick else (10, 100, 1000, 3000)
    t, loads_all, disp_all, _ = batch_data(max(card_sizes), 400, 0.01, seed=11)
    rows = []
    for n_cards in card_sizes:
        t0 = time.perf_counter()
        fit_many(Kelvin, t, loads_all[:n_cards], disp_all[:n_cards],
                 initial_state="periodic", offset=True)
        sec = time.perf_counter() - t0
        rows.append([f"{n_cards:,}", f"{sec:.3f}", f"{sec / n_cards * 1e3:.2f}"])
    table("    Scaling with the number of cards (fit_many, 400 samples, workers=1)",
          ["cards", "time s", "ms/card"], rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, few repeats")
    parser.add_argument("--only", choices=("single", "batch", "scaling"), default=None)
    args = parser.parse_args()
    sys.stdout.reconfigure(line_buffering=True)  # type: ignore[union-attr]
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print("pumpid fit benchmark")
    print(f"  machine: {platform.machine()} {platform.processor() or ''} "
          f"os.cpu_count() = {os.cpu_count()}, load average {load[0]:.2f}")
    print(f"  python {platform.python_version()}, numpy {np.__version__}, scipy "
          f"{scipy.__version__}, pumpid {pumpid.__version__}")
    print("  BLAS/OpenMP threads pinned to 1 (OMP/OPENBLAS/MKL_NUM_THREADS=1)")
    medians = {0.0: float("nan")}
    if args.only in (None, "single"):
        medians = section_single(args.quick)
    if args.only in (None, "batch"):
        section_batch(args.quick)
    if args.only in (None, "scaling"):
        section_scaling(args.quick, medians[0.0])


if __name__ == "__main__":
    main()
