"""Does the main job find the best optimum? Against a brute-force search, on every card.

For each card the default main job (``pumpid.fit(Kelvin, card)``: automatic start,
boundaries, the default model and options) is compared with a brute-force search on the
same problem: hundreds of starts drawn log-uniformly over each parameter's natural scale
times or divided by 1000 (the whole search window's core), each run by the engine's
Levenberg-Marquardt to convergence with a large budget. The brute force's best sum of
squares is the reference; the job passes a card when its own is within 1e-6 relative of it
(or below it).

Cards: every real card in ``../shared/data/raw`` (the folder beside the repository; skipped
when absent) and synthetic periodic Kelvin cards with each parameter spread log-uniformly
over a factor 100, 1 % noise, a position offset.

Run from the repository root: ``python benchmarks/bench_optimum.py [--starts 300]
[--synthetic 200] [--real-limit N]``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.conftest import well_load

import pumpid
from pumpid.cards import Card, read_cards, split_strokes
from pumpid.engine.problem import WINDOW
from pumpid.engine.solvers import LevenbergMarquardt

RAW = Path(__file__).resolve().parents[2] / "shared" / "data" / "raw"
#: A card within this relative gap of the brute force's best has found the best optimum.
GAP = 1e-6
#: Time for cards without one: a nominal pumping speed (the optimum's structure does not
#: depend on it; only m and c scale with the period).
NOMINAL_SPM = 6.0


def real_cards(limit: int | None) -> dict[str, list[Card]]:
    """Every card of every file in the shared folder, by data set."""
    sets: dict[str, list[Card]] = {}
    if not RAW.is_dir():
        return sets
    sandia = RAW / "sandia_dds"
    sets["sandia surface"] = read_cards(sandia / "surface_cards.csv")
    strokes = []
    for rec in read_cards(sandia / "downhole_timeseries.csv"):
        strokes += split_strokes(rec)
    sets["sandia downhole strokes"] = strokes
    sets["cupb"] = [c for p in sorted((RAW / "cupb_dynamometer_card").glob("*.txt"))
                    for c in read_cards(p, spm=NOMINAL_SPM)]
    sets["dzhang"] = [c for p in sorted((RAW / "dzhang123_dynacard_realdata").glob("*.csv"))
                      for c in read_cards(p, spm=NOMINAL_SPM)]
    ts = RAW / "shapeformer_oilfield2d" / "OilfieldData2d_TEST_subset360.ts"
    sets["oilfield"] = read_cards(ts, position_unit="m", load_unit="kN", spm=NOMINAL_SPM)
    if limit is not None:
        sets = {k: v[:limit] for k, v in sets.items()}
    return sets


def synthetic_cards(n: int, seed: int = 5) -> list[Card]:
    """Periodic Kelvin cards, parameters log-uniform over x100, 1 % noise, an offset."""
    rng = np.random.default_rng(seed)
    base = np.array([5200.0, 20.0, 900.0, 5200.0])
    out = []
    for i in range(n):
        theta = base * np.exp(rng.uniform(-math.log(10), math.log(10), 4))
        period = 60.0 / rng.uniform(5.0, 10.0)
        n_samples = int(rng.integers(100, 400))
        t = np.arange(n_samples) * period / n_samples
        load = well_load(t, period, seed=int(rng.integers(2**31)))
        truth = pumpid.Kelvin.from_values(theta)
        pos = pumpid.simulate(truth, t, load, initial_state="periodic", period=period)
        pos = pos + 0.01 * np.ptp(pos) * rng.standard_normal(n_samples) + rng.uniform(0, 50)
        out.append(Card(position=pos, load=load, t=t, card_id=f"synthetic-{i}",
                        source="synthetic", position_unit="in", load_unit="lbf",
                        time_source="file", periodic=True, period=period))
    return out


def brute_force(card: Card, res: pumpid.FitResult, n_starts: int, rng) -> float:
    """The best cost over many log-uniform starts on the job's own problem."""
    problem = res.problem
    assert problem is not None
    ref = np.log(problem.reference[0][problem.free_idx])
    p = problem.n_free
    z0 = np.zeros((n_starts, problem.q))
    z0[:, :p] = ref + rng.uniform(-math.log(1e3), math.log(1e3), (n_starts, p))
    z0[:, :p] = np.clip(z0[:, :p], ref - WINDOW, ref + WINDOW)
    if problem.offset_fixed is None:
        d = problem.card(0)[2]
        z0[:, -1] = float(np.mean(d))
    out = LevenbergMarquardt(tol=1e-12, max_evaluations=3000).solve(
        problem, np.zeros(n_starts, dtype=np.int64), z0, workers=None)
    finite = out.cost[np.isfinite(out.cost)]
    return float(finite.min()) if finite.size else math.inf


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=300, help="brute-force starts per card")
    parser.add_argument("--synthetic", type=int, default=200, help="synthetic cards")
    parser.add_argument("--real-limit", type=int, default=None,
                        help="at most this many cards per real data set")
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    sets = real_cards(args.real_limit)
    sets["synthetic x100"] = synthetic_cards(args.synthetic)
    print(f"brute force: {args.starts} log-uniform starts per card within x1000 of the "
          f"natural scales, LM to convergence; pass: job's cost <= (1 + {GAP:g}) x best")
    print(f"{'data set':<26}{'cards':>6}{'pass':>6}{'worst gap':>12}"
          f"{'job ms/card':>13}  failing cards")
    total = passed = 0
    for name, cards in sets.items():
        gaps = []
        times = []
        failing = []
        for card in cards:
            t0 = time.perf_counter()
            try:
                res = pumpid.fit(pumpid.Kelvin, card)
            except ValueError as exc:
                print(f"  {card.card_id}: not fitted ({exc})")
                continue
            times.append(time.perf_counter() - t0)
            best = brute_force(card, res, args.starts, rng)
            gap = (res.cost - best) / best if best > 0 else 0.0
            gaps.append(gap)
            if not gap <= GAP:
                failing.append(f"{card.card_id} ({gap:.2g})")
        n_pass = sum(g <= GAP for g in gaps)
        total += len(gaps)
        passed += n_pass
        worst = max(gaps) if gaps else math.nan
        print(f"{name:<26}{len(gaps):>6}{n_pass:>6}{worst:>12.2e}"
              f"{1e3 * float(np.median(times)) if times else math.nan:>13.1f}  "
              f"{', '.join(failing[:6])}{' ...' if len(failing) > 6 else ''}")
    print(f"all: {passed} of {total} cards within {GAP:g} of the brute force's best")


if __name__ == "__main__":
    main()
