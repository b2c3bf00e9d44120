"""Joint fits: how the shared parameters' errors shrink with the number of cards.

A steady synthetic well (the bundled example's Kelvin model, 130 samples a card, 0.3 %
noise, the pumping speed jittered by 1 %) is fitted jointly on its first 1, 2, 4, 8, 16
and 32 cards (1: the card alone), and the Sandia public pairs (two
consecutive strokes of each of two wells, ``../shared/data/raw``, skipped when absent)
alone and jointly.

Run from the repository root: ``python benchmarks/bench_joint.py``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import pumpid
from pumpid.cards import read_cards
from pumpid.pump.synthetic import CardLabel, synthetic_card

RAW = Path(__file__).resolve().parents[2] / "shared" / "data" / "raw"
TRUTH = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)
JOINT = pumpid.FitOptions.for_cards(joint=True)


def main() -> None:
    rng = np.random.default_rng(0)
    well = [synthetic_card(TRUTH, spm=8.0 * (1 + 0.01 * rng.standard_normal()),
                           n_samples=130, observe="u", noise=0.003, seed=rng,
                           label=CardLabel(card_id=f"s{i}")) for i in range(32)]
    names = TRUTH.param_names()
    print(f"steady well, truth {TRUTH.as_dict()}: estimate +/- standard error")
    print(f"{'cards':>6}  " + "  ".join(f"{n:>20}" for n in names) + "   se(m) x sqrt(cards)")
    for n in (1, 2, 4, 8, 16, 32):
        res = (pumpid.fit(pumpid.Kelvin, well[0]) if n == 1
               else pumpid.fit(pumpid.Kelvin, well[:n], options=JOINT))
        est = dict(res.params)
        se = {k: res.stderr.get(k, math.nan) for k in names}
        print(f"{n:>6}  " + "  ".join(f"{est[k]:>10.4g} +/- {se[k]:<7.2g}" for k in names)
              + f"   {se['m'] * math.sqrt(n):.3g}")
    path = RAW / "sandia_dds" / "surface_cards.csv"
    if not path.is_file():
        print("Sandia cards absent: skipped")
        return
    cards = {c.card_id: c.with_dt(0.075) for c in read_cards(path)}
    for a, b in (("SX6E03A", "SX6E03B"), ("SX6I03A", "SX6I03B")):
        print()
        joint = pumpid.fit(pumpid.Kelvin, [cards[a], cards[b]], options=JOINT)
        print(joint.report())


if __name__ == "__main__":
    main()
