"""Which output does a card observe? Kelvin fitted observing u and observing u2, every real card.

The Kelvin model has two displacements: ``u``, the mass's, where the polished-rod load acts,
and ``u2``, the inner node between the spring k0 and the Kelvin element (the output the
paper's tables use). A dynamometer measures the polished rod's position, so the physics
points to ``u``; this script puts both to the data. Each card is fitted twice by the main
job (``pumpid.fit(Kelvin, cards)``, the card preset otherwise) and the two sums of squares compared:
a card favours one output when its cost is lower by more than 1e-6 relative.

Also printed: the spread of R^2 on the real cards under the chosen default, which the
quality gate's default threshold (``pumpid.job.MIN_R2``) is set against.

Run from the repository root: ``python benchmarks/bench_observe.py [--limit N]`` (cards from
``../shared/data/raw``; nothing to do when that folder is absent).
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_optimum import real_cards

import pumpid

REL = 1e-6
#: The quality gate open (the lowest threshold FitOptions takes: finite numbers only), so
#: that every card's R^2 is counted whatever it is.
OPEN_GATE = -np.finfo(float).max


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=None, help="cards per data set")
    args = parser.parse_args()
    sets = real_cards(args.limit)
    if not sets:
        print("no real cards (../shared/data/raw is absent)")
        return
    header = (f"{'data set':<26}{'cards':>6}{'u better':>10}{'u2 better':>10}{'tie':>5}"
              f"{'median R2 u':>13}{'median R2 u2':>14}{'min R2 u':>10}  statuses (u)")
    print(header)
    print("-" * len(header))
    all_r2: list[float] = []
    totals = collections.Counter()
    gaps: dict[str, list[float]] = {"u": [], "u2": []}
    for name, cards in sets.items():
        fits = {obs: pumpid.fit(pumpid.Kelvin, cards,
                                options=pumpid.FitOptions.for_cards(observe=obs,
                                                                    min_r2=OPEN_GATE)).results
                for obs in ("u", "u2")}
        better = collections.Counter()
        r2 = {"u": [], "u2": []}
        statuses = collections.Counter()
        for a, b in zip(fits["u"], fits["u2"], strict=True):
            if a is None or b is None:
                statuses["invalid-input"] += 1
                continue
            statuses[a.status.key] += 1
            r2["u"].append(a.r2)
            r2["u2"].append(b.r2)
            if a.cost < b.cost * (1 - REL):
                better["u"] += 1
                gaps["u"].append(b.cost / a.cost - 1)
            elif b.cost < a.cost * (1 - REL):
                better["u2"] += 1
                gaps["u2"].append(a.cost / b.cost - 1)
            else:
                better["tie"] += 1
        totals.update(better)
        all_r2 += r2["u"]
        print(f"{name:<26}{len(cards):>6}{better['u']:>10}{better['u2']:>10}{better['tie']:>5}"
              f"{np.nanmedian(r2['u']):>13.5f}{np.nanmedian(r2['u2']):>14.5f}"
              f"{np.nanmin(r2['u']):>10.4f}  "
              + ", ".join(f"{k} {v}" for k, v in sorted(statuses.items())))
    print("-" * len(header))
    print(f"all real cards: u better on {totals['u']}, u2 better on {totals['u2']}, "
          f"tied on {totals['tie']}")
    for obs, g in gaps.items():
        if g:
            print(f"where {obs} is better, the other's sum of squares is higher by: median "
                  f"{np.median(g):.2%}, 90th percentile {np.percentile(g, 90):.2%}; by more "
                  f"than 1 % on {sum(x > 0.01 for x in g)} cards, more than 10 % on "
                  f"{sum(x > 0.1 for x in g)}")
    q = np.nanpercentile(all_r2, [0, 1, 5, 50])
    print(f"R^2 observing u over all real cards: min {q[0]:.4f}, 1st percentile {q[1]:.4f}, "
          f"5th {q[2]:.4f}, median {q[3]:.5f}; below 0.95: "
          f"{int(np.sum(np.asarray(all_r2) < 0.95))} of {len(all_r2)}")


if __name__ == "__main__":
    main()
