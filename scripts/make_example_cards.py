"""Generate the bundled example cards (``src/pumpid/data/example_cards.csv``).

The example is a synthetic but realistic rod-pumped well, made entirely by pumpid's own code:

* pumping speed 8.0 strokes per minute, 100 samples per stroke, two consecutive strokes
  ("EX-1A" and "EX-1B") whose loads differ slightly (fluid load and rod ripple vary);
* the polished-rod load has the usual surface-card shape: rod weight plus the fluid load
  picked up early in the upstroke and released early in the downstroke, smoothed transitions,
  and a rod-vibration ripple (lbf);
* the position is the periodic steady-state response of a Kelvin model (mass displacement u)
  to that load, plus an arbitrary position zero and 0.3 % Gaussian noise (inches);
* the file has no time column, only the SPM, as most field exports: pumpid rebuilds time.

Run ``python scripts/make_example_cards.py`` to regenerate; the seed is fixed, so the output
is identical from run to run on the same numpy version.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

import pumpid

SPM = 8.0
N = 100
TRUE = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)  # lbf/in, lbf s^2/in, lbf s/in, lbf/in
OUT = Path(__file__).resolve().parents[1] / "src" / "pumpid" / "data" / "example_cards.csv"


def surface_load(phase: np.ndarray, fluid: float, ripple: float) -> np.ndarray:
    """Polished-rod load (lbf) over one stroke; phase in [0, 1), 0 = bottom dead centre."""
    rods = 6200.0
    pickup = 0.5 * (1 + np.tanh((phase - 0.08) / 0.035))
    release = 0.5 * (1 + np.tanh((phase - 0.55) / 0.04))
    fluid_load = fluid * pickup * (1 - release)
    vibration = ripple * np.sin(2 * np.pi * 3 * phase + 0.6) * np.exp(-2.0 * phase)
    return rods + fluid_load + vibration + 350.0 * np.sin(2 * np.pi * phase)


def main() -> None:
    rng = np.random.default_rng(20261122)
    period = 60.0 / SPM
    t = np.arange(N) * period / N
    rows = []
    for card_id, fluid, ripple in (("EX-1A", 5200.0, 650.0), ("EX-1B", 5050.0, 700.0)):
        load = surface_load(t / period, fluid, ripple)
        u = pumpid.simulate(TRUE, t, load, observe="u", initial_state="periodic",
                            period=period)
        position = u - u.min() + 2.0  # the card's position zero is arbitrary
        noise = 0.003 * np.ptp(position) * rng.standard_normal(N)
        for pos, f in zip(position + noise, load, strict=True):
            rows.append([card_id, f"{SPM:.2f}", f"{pos:.4f}", f"{f:.2f}"])
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with OUT.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["card_id", "spm", "position_in", "load_lbf"])
        writer.writerows(rows)
    print(f"wrote {OUT.name}: 2 cards x {N} samples, true model {TRUE}")


if __name__ == "__main__":
    main()
