"""Can the numbers be trended? Spread of parameters and derived quantities on steady wells.

A quantity worth trending is stable while the well is steady. This script fits consecutive
cards of steady wells with the default main job (``fit_card``: Kelvin observing u) and
prints, for every raw parameter and every derived quantity, the card-to-card spread
(coefficient of variation, or the relative difference for a pair) beside the median
relative standard error the fits report, and how often the quantity was called determined.

* **Sandia pairs**: the two consecutive strokes of each of the two public Sandia wells
  (``../shared/data/raw/sandia_dds``, 75 ms sampling; skipped when absent).
* **Synthetic steady wells**: 40 cards of one well each (``synthetic_card``: crank-rocker
  motion, 130 samples, 0.3 % noise, the pumping speed jittered by 0.5 %), for a well whose
  fits are interior and for one stiff enough in k0 that the fits sit at the k0 -> infinity
  limit, as real cards do.

Run from the repository root: ``python benchmarks/bench_trend.py [--cards 40]``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import pumpid
from pumpid.cards import read_cards
from pumpid.pump import fit_card
from pumpid.pump.synthetic import synthetic_card

RAW = Path(__file__).resolve().parents[2] / "shared" / "data" / "raw"


def quantities(res: pumpid.FitResult) -> dict[str, tuple[float, float, bool, str]]:
    """name -> (value, standard error, determined, unit) for parameters and derived ones."""
    out = {}
    det = set(res.determined.get("parameters", ()))
    units = res.param_units()
    unc = res.uncertainty
    for name, value in res.params.items():
        se = unc.stderr.get(name, math.nan) if unc is not None else math.nan
        out[name] = (value, se, name in det, units.get(name, ""))
    for name, d in res.derived.items():
        out[f"{name} (derived)"] = (d.value, d.stderr, d.determined, d.unit)
    return out


def spread_table(title: str, fits: list[pumpid.FitResult]) -> None:
    rows = [quantities(r) for r in fits]
    statuses = ", ".join(sorted({r.status.key for r in fits}))
    print(f"\n{title} ({len(fits)} cards; statuses: {statuses})")
    print(f"  {'quantity':<30}{'unit':<12}{'median':>12}{'spread':>10}{'median rel se':>15}"
          f"{'determined':>12}")
    for name in rows[0]:
        vals = np.array([r[name][0] for r in rows])
        ses = np.array([r[name][1] for r in rows])
        dets = sum(r[name][2] for r in rows)
        med = float(np.median(vals))
        if len(vals) == 2:
            spread = abs(vals[1] - vals[0]) / abs(med) if med else math.nan
        else:
            spread = float(np.std(vals, ddof=1) / abs(np.mean(vals))) if med else math.nan
        rel_se = float(np.nanmedian(ses / np.abs(vals))) if np.any(np.isfinite(ses)) \
            else math.nan
        print(f"  {name:<30}{rows[0][name][3]:<12}{med:>12.4g}{spread:>10.2%}"
              f"{rel_se:>15.2%}{dets:>8}/{len(rows)}")


def sandia() -> None:
    path = RAW / "sandia_dds" / "surface_cards.csv"
    if not path.is_file():
        print("Sandia cards absent (../shared/data/raw): skipped")
        return
    cards = {c.card_id: c.with_dt(0.075) for c in read_cards(path)}
    for a, b in (("SX6E03A", "SX6E03B"), ("SX6I03A", "SX6I03B")):
        spread_table(f"Sandia well, strokes {a} and {b} (spread: relative difference)",
                     [fit_card(cards[a]), fit_card(cards[b])])


def steady_well(model: pumpid.Kelvin, n: int, seed: int) -> list[pumpid.FitResult]:
    rng = np.random.default_rng(seed)
    fits = []
    for i in range(n):
        card = synthetic_card(model, spm=8.0 * (1 + 0.005 * rng.standard_normal()),
                              n_samples=130, observe="u", noise=0.003, seed=rng,
                              card_id=f"w{seed}-{i}")
        fits.append(fit_card(card))
    return fits


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cards", type=int, default=40, help="cards per synthetic well")
    args = parser.parse_args()
    sandia()
    interior = pumpid.Kelvin(k0=5200.0, m=20.0, c1=900.0, k1=5200.0)
    stiff = pumpid.Kelvin(k0=5.0e5, m=20.0, c1=900.0, k1=5200.0)
    spread_table(f"Synthetic steady well, interior {interior.as_dict()}",
                 steady_well(interior, args.cards, 1))
    spread_table(f"Synthetic steady well, stiff k0 {stiff.as_dict()}",
                 steady_well(stiff, args.cards, 2))


if __name__ == "__main__":
    main()
