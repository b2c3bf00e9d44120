"""What the user's path costs: the card main job end to end, a single fit, and the CLI.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_main_job.py            # full run (about 15 minutes)
    .venv/bin/python benchmarks/bench_main_job.py --quick    # smaller sizes (about 3 minutes)
    .venv/bin/python benchmarks/bench_main_job.py --only families   # single | families | cli

Sections:

* **families**: the card main job (automatic start, fit, boundary checks with the reduced
  models, standard errors, HAC intervals, identifiability, derived quantities; no plots) on
  the three families of ``tests/families.py``: (a) periodic strokes with a fitted offset,
  (b) three strokes from rest with a slow creep mode still running, (c) controller-like cards
  of 130 samples; Kelvin parameters log-uniform over a factor 10. For each family:
  ``pumpid.fit(Kelvin, card)`` one card at a time (median and p90 ms per card, statuses);
  ``pumpid.fit(Kelvin, cards)`` on the same cards as one list with 2 threads and the
  comparison of its answers with the per-card ones (statuses identical, determined
  parameters to 1e-8); the list of 10,000 cards (cards per second) and the growth of the
  process's peak resident memory from a tenth of that number to all of it.
* **real**: the same per-card measurement on real cards, every public set under
  ``../shared/data/raw`` (beside the repository; skipped when absent) that holds strokes of
  one well: Sandia's surface cards and the strokes of its two downhole records (split with
  ``split_strokes``), the CUPB and dzhang sets, and the oilfield set. A real card's residual
  is model error, not white noise: the table also counts how often the job's guards fire
  (the wider search, the boundary refits, a limit reached), the work the synthetic cards
  rarely need.
* **single**: one Kelvin fit of 2001 samples from a start about 30 % off
  (``pumpid.fit(guess, data, options=FitOptions(multistart=False))``; no automatic
  start), noiseless and with 1 % noise, beside ``least_squares`` with the exact sensitivity
  Jacobian over ``scipy.signal.lsim`` (``_baselines.lsq_lsim_fit``) on the same data:
  times, accuracy, ratio.
* **cli**: wall time of a whole ``pumpid fit CARD`` process (no ``--out``) on the bundled
  example card, with a warm compiled cache (median of 5) and with an empty one (cold).

Every ratio is between figures measured in the same run. BLAS threads are left to pumpid
(it limits them itself at its entry points). The machine's load average is printed: other
processes inflate wall-clock times.
"""

from __future__ import annotations

import argparse
import collections
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT))

from _baselines import lsq_lsim_fit  # noqa: E402
from tests.families import family  # noqa: E402

import pumpid  # noqa: E402
from pumpid import Kelvin  # noqa: E402
from pumpid.cards import read_cards  # noqa: E402

Array = np.ndarray
PERIOD = 7.5  # s, one stroke at 8 strokes per minute
TRUE = Kelvin(k0=9000.0, m=45.0, c1=900.0, k1=5200.0)
GUESS_FACTORS = np.array([1.3, 1 / 1.3, 1.3, 1 / 1.3])  # ~30 % off, alternating


def table(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print(f"\n{title}")
    print("  " + "  ".join(h.rjust(w) for h, w in zip(header, widths, strict=True)))
    print("  " + "  ".join("-" * w for w in widths))
    for r in rows:
        print("  " + "  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)))
    sys.stdout.flush()


def peak_rss_mib() -> float:
    """This process's peak resident set size so far (MiB; Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# --------------------------------------------------------------------------- families
def determined(res: pumpid.FitResult) -> list[str]:
    return [p for p in res.determined.get("parameters", ()) if p in res.params]


def compare(alone: list[pumpid.FitResult], together: list[pumpid.FitResult | None]
            ) -> tuple[int, int, float]:
    """(status mismatches, cards whose determined parameters differ by > 1e-8, worst rel)."""
    status_diff = param_diff = 0
    worst = 0.0
    for a, b in zip(alone, together, strict=True):
        if b is None or a.status != b.status:
            status_diff += 1
            continue
        rel = max((abs(b.params[p] - a.params[p]) / abs(a.params[p]) for p in determined(a)),
                  default=0.0)
        worst = max(worst, rel)
        param_diff += rel > 1e-8
    return status_diff, param_diff, worst


def section_families(quick: bool) -> None:
    n_each = 100 if quick else 1000
    n_big = 1000 if quick else 10_000
    per_card_rows, batch_rows, equal_rows = [], [], []
    for name in ("periodic", "rest", "controller"):
        cards = family(name, n_each, seed=1)
        pumpid.fit(Kelvin, cards[0])  # compiled code loaded, caches warm
        times, alone = [], []
        for card in cards:
            t0 = time.perf_counter()
            alone.append(pumpid.fit(Kelvin, card))
            times.append(time.perf_counter() - t0)
        ms = np.array(times) * 1e3
        counts = collections.Counter(r.status.value for r in alone)
        per_card_rows.append([
            name, str(n_each), f"{np.median(ms):.1f}", f"{np.percentile(ms, 90):.1f}",
            f"{ms.mean():.1f}", f"{np.median([r.nfev for r in alone]):.0f}",
            str(sum(any(words in w for w in r.warnings for _label, words in GUARDS[:2])
                    for r in alone)),
            ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))])
        together = pumpid.fit(Kelvin, cards, workers=2).results
        s_diff, p_diff, worst = compare(alone, list(together))
        equal_rows.append([name, str(n_each), str(s_diff), str(p_diff), f"{worst:.1e}"])

        big = family(name, n_big, seed=2)
        small = big[: n_big // 10]
        pumpid.fit(Kelvin, small, workers=2)
        rss_small = peak_rss_mib()
        t0 = time.perf_counter()
        pumpid.fit(Kelvin, big, workers=2)
        sec = time.perf_counter() - t0
        rss_big = peak_rss_mib()
        batch_rows.append([name, f"{n_big:,}", f"{sec:.1f}", f"{n_big / sec:,.0f}",
                           f"{rss_small:.0f} -> {rss_big:.0f}"])
    table("(1) pumpid.fit(Kelvin, card), one card at a time (the main job end to end, no "
          "plots)",
          ["family", "cards", "median ms", "p90 ms", "mean ms", "median evals",
           "better optimum found by a search", "statuses"],
          per_card_rows)
    table("(2) pumpid.fit(Kelvin, cards) (one list, 2 threads) against one card at a time "
          "on the same cards",
          ["family", "cards", "status differs", "params differ > 1e-8", "worst rel diff"],
          equal_rows)
    table("(3) pumpid.fit(Kelvin, cards), 2 threads, one call",
          ["family", "cards", "seconds", "cards/s",
           "peak RSS MiB (tenth of the cards -> all)"], batch_rows)


# --------------------------------------------------------------------------- real
#: Words of the warnings that say which of the job's guards changed the answer.
GUARDS = (("wider search", "wider search"), ("scan along the mass", "a scan along"),
          ("limit", "ran to a bound"), ("reduced fit", "reduced model"),
          ("restart", "restarted next"))


def real_sets(limit: int | None) -> dict[str, list]:
    """The public real card sets of single wells, by name (empty when the folder is absent)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_optimum import real_cards

    return real_cards(limit)


def section_real(quick: bool) -> None:
    sets = real_sets(10 if quick else None)
    if not sets:
        print("\n(1r) real cards: skipped (no ../shared/data/raw beside the repository)")
        return
    pumpid.fit(Kelvin, next(iter(sets.values()))[0])  # compiled code loaded, caches warm
    rows = []
    for name, cards in sets.items():
        times, nfev, counts, guards = [], [], collections.Counter(), collections.Counter()
        for card in cards:
            t0 = time.perf_counter()
            try:
                res = pumpid.fit(Kelvin, card)
            except ValueError:
                counts["not fitted"] += 1
                continue
            times.append(time.perf_counter() - t0)
            nfev.append(res.nfev)
            counts[res.status.value] += 1
            for label, words in GUARDS:
                guards[label] += any(words in w for w in res.warnings)
        ms = np.array(times) * 1e3
        rows.append([
            name, str(len(times)), f"{np.median(ms):.1f}", f"{np.percentile(ms, 90):.1f}",
            f"{ms.mean():.1f}", f"{np.median(nfev):.0f}",
            ", ".join(f"{k} {v}" for k, v in sorted(guards.items())),
            ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))])
    table("(1r) pumpid.fit(Kelvin, card) on real cards, one at a time (the main job end to "
          "end, no plots)",
          ["set", "cards", "median ms", "p90 ms", "mean ms", "median evals",
           "guards that changed the answer", "statuses"], rows)


# --------------------------------------------------------------------------- single
def stroke_load(t: Array, seed: int = 0) -> Array:
    """A dynamometer-card-like polished-rod load over repeated strokes (N)."""
    rng = np.random.default_rng(seed)
    phase = (t / PERIOD) % 1.0
    up_at, down_at = 0.06 + 0.06 * rng.random(), 0.5 + 0.1 * rng.random()
    taken = 0.5 * (1.0 + np.tanh((phase - up_at) / 0.025))
    dropped = 0.5 * (1.0 + np.tanh((phase - down_at) / 0.035))
    fluid = (3500.0 + 1000.0 * rng.random()) * taken * (1.0 - dropped)
    wobble = (250.0 + 100.0 * rng.random()) * np.sin(2 * np.pi * (3 * phase + rng.random()))
    return 5500.0 + fluid + wobble + 400.0 * np.sin(2 * np.pi * phase)


def timed(fn: Callable[[], object], repeats: int) -> tuple[Array, object]:
    out = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return np.array(times), out


def rel_err(theta: Array, ref: Array) -> float:
    return float(np.max(np.abs(np.asarray(theta) / ref - 1.0)))


def section_single(quick: bool) -> None:
    repeats = 10 if quick else 30
    base_runs = 1 if quick else 3
    observe = "u2"  # the paper's observed output, as in its tables
    k_obs = Kelvin.output_index(observe)
    t = np.linspace(0.0, PERIOD, 2001)
    load = stroke_load(t)
    clean = pumpid.simulate(TRUE, t, load, observe=observe)
    guess = TRUE.values * GUESS_FACTORS
    rows = []
    for level in (0.0, 0.01):
        rng = np.random.default_rng(5)
        data = clean + level * np.ptp(clean) * rng.standard_normal(t.size)

        def ours(data: Array = data) -> pumpid.FitResult:
            return pumpid.fit(Kelvin.from_values(guess), (t, load, data),
                              options=pumpid.FitOptions(observe=observe, multistart=False))

        times, res = timed(ours, repeats)
        assert isinstance(res, pumpid.FitResult)
        secs = []
        for _ in range(base_runs):
            t0 = time.perf_counter()
            base = lsq_lsim_fit(Kelvin, t, load, data, guess, k_obs)
            secs.append(time.perf_counter() - t0)
        med, bmed = float(np.median(times)), float(np.median(secs))
        # Accuracy against the best answer either finds: the truth for noiseless data.
        rows.append([
            f"{level:.0%}", f"{med * 1e3:.2f}", f"{np.percentile(times, 90) * 1e3:.2f}",
            str(res.nfev), f"{rel_err(res.model.values, TRUE.values):.1e}",
            f"{res.cost:.6g}", f"{bmed * 1e3:.0f}", str(base.simulations),
            f"{rel_err(base.theta, TRUE.values):.1e}",
            f"{0.5 * float(np.sum((pumpid.simulate(Kelvin.from_values(base.theta), t, load, observe=observe) - data) ** 2)):.6g}",  # noqa: E501
            f"{bmed / med:,.0f}x"])
    table(f"(4) One Kelvin fit, 2001 samples, start ~30 % off (pumpid: median of {repeats}; "
          f"least_squares + exact Jacobian over lsim: median of {base_runs})",
          ["noise", "pumpid ms", "p90 ms", "evals", "err vs truth", "cost",
           "baseline ms", "sims", "err vs truth", "cost", "ratio"], rows)


# --------------------------------------------------------------------------- cli
def section_cli(quick: bool) -> None:
    card = ROOT / "src" / "pumpid" / "data" / "example_cards.csv"
    first = read_cards(card)[0].card_id
    command = [sys.executable, "-m", "pumpid.cli", "fit", str(card), "--card", first]
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT / "src")

    def wall(env: dict[str, str]) -> float:
        t0 = time.perf_counter()
        done = subprocess.run(command, env=env, capture_output=True, text=True)
        sec = time.perf_counter() - t0
        if done.returncode != 0:
            raise SystemExit(f"pumpid fit failed ({done.returncode}): {done.stderr}")
        return sec

    wall(env)  # the cache is warm from here on
    warm = [wall(env) for _ in range(3 if quick else 5)]
    with tempfile.TemporaryDirectory() as empty:
        cold = wall({**env, "NUMBA_CACHE_DIR": empty})
    table("(5) pumpid fit CARD (one card of the bundled example, no --out): whole process",
          ["cache", "wall s"],
          [["warm (median)", f"{np.median(warm):.2f}"], ["cold (empty cache)", f"{cold:.1f}"]])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes")
    parser.add_argument("--only", choices=("families", "real", "single", "cli"))
    args = parser.parse_args()
    print(f"pumpid {pumpid.__version__}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"python {platform.python_version()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.2f}")
    sections = {"families": section_families, "real": section_real, "single": section_single,
                "cli": section_cli}
    for name, run in sections.items():
        if args.only in (None, name):
            run(args.quick)
    print(f"\nload average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
