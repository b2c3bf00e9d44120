"""Generate the bundled example cards (``src/pumpid/data/example_cards.csv``).

The example is a synthetic but realistic rod-pumped well, made entirely by pumpid's own
generator, :func:`pumpid.pump.synthetic.synthetic_card`:

* the polished rod moves as a conventional crank-rocker pumping unit moves it (the exact
  four-bar linkage of :class:`pumpid.pump.synthetic.CrankRocker`): a single smooth rise from
  bottom to top dead centre and back, stroke 100 in, 200 samples per stroke, no time column
  (only the SPM, as most controller exports), so pumpid rebuilds time from the SPM;
* the polished-rod load is the periodic load a known Kelvin model needs to follow that
  motion, with the polished-rod load acting on the mass (observed output ``u``, the mass
  displacement), plus a 6,000 lbf buoyant rod weight; load against position is a closed
  loop, as on a real card;
* two consecutive strokes: "EX-1A" at 8.0 strokes per minute and "EX-1B" at 8.2 (the unit
  runs slightly faster as the motor's slip changes), each with its own independent
  Gaussian noise of 0.1 % of the range on position and on load, rounded as a controller
  writes them (0.0001 in, 0.01 lbf).

The truth is ``TRUE`` below (lbf/in, lbf*s^2/in, lbf*s/in, lbf/in). A pumping unit's
motion is nearly sinusoidal, so one card determines one combination of the four parameters
(k0 against c1 and k1) only weakly: fitted to EX-1A, k0 and c1 come out about 16 % off, the
truth inside their 95 % intervals, while the natural frequency and the static stiffness are
within 0.5 % (and EX-1B's fit is within 2 % everywhere). With 0.2 % noise instead of 0.1 %
about one noise draw in six makes k0 run to its bound (a limiting model).

Run ``python scripts/make_example_cards.py`` to regenerate; the seed is fixed, so the output
is identical from run to run on the same numpy version.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

import pumpid
from pumpid.pump.synthetic import CardLabel, synthetic_card

TRUE = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)
OBSERVE = "u"
STROKES = (("EX-1A", 8.0), ("EX-1B", 8.2))
N_SAMPLES = 200
STROKE_IN = 100.0
ROD_WEIGHT_LBF = 6000.0
NOISE = 0.001
SEED = 20261122
OUT = Path(__file__).resolve().parents[1] / "src" / "pumpid" / "data" / "example_cards.csv"


def make_cards() -> list[pumpid.cards.Card]:
    """The example's cards, exactly as written to the file (before rounding)."""
    rng = np.random.default_rng(SEED)
    return [synthetic_card(TRUE, spm=spm, n_samples=N_SAMPLES, stroke=STROKE_IN,
                           observe=OBSERVE, rod_weight=ROD_WEIGHT_LBF, noise=NOISE, seed=rng,
                           label=CardLabel(well_id="EX-1", card_id=card_id))
            for card_id, spm in STROKES]


def main() -> None:
    """Write the example file."""
    rows = []
    for card in make_cards():
        for pos, load in zip(card.position, card.load, strict=True):
            rows.append([card.card_id, f"{card.spm:.2f}", f"{pos:.4f}", f"{load:.2f}"])
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with OUT.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["card_id", "spm", "position_in", "load_lbf"])
        writer.writerows(rows)
    print(f"wrote {OUT.name}: {len(STROKES)} cards x {N_SAMPLES} samples, true model {TRUE} "
          f"(observed output {OBSERVE})")


if __name__ == "__main__":
    main()
