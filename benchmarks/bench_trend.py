"""Can the numbers be trended? Spread of parameters and derived quantities on steady wells.

A quantity worth trending is stable while the well is steady. This script fits consecutive
cards of steady wells with the default main job (``pumpid.fit(Kelvin, card)``: observing u)
and prints, for every raw parameter and every derived quantity, the card-to-card spread
(coefficient of variation, or the relative difference for a pair) beside the median
relative standard error the fits report, and how often the quantity was called determined.

* **Sandia pairs**: the two consecutive strokes of each of the two public Sandia wells
  (``../shared/data/raw/sandia_dds``, 75 ms sampling; skipped when absent).
* **Synthetic steady wells**: 40 cards of one well each (``synthetic_card``: crank-rocker
  motion, 130 samples, 0.3 % noise, the pumping speed jittered by 0.5 %), for a well whose
  fits are interior and for one stiff enough in k0 that the fits sit at the k0 -> infinity
  limit, as real cards do.

* **The target on real strokes**: Sandia's two 60 s downhole records split into their
  strokes (``split_strokes``) and the surface pairs: for every quantity reported as
  determined (and a property of the well, not an echo of the stroke), the card-to-card
  spread (CV) beside 2x its median reported relative error, and the count of fits called
  ``converged`` with no parameter determined (the target: none).

Run from the repository root: ``python benchmarks/bench_trend.py [--cards 40] [--real-only]``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import pumpid
from pumpid.cards import read_cards, split_strokes
from pumpid.pump.synthetic import CardLabel, synthetic_card

RAW = Path(__file__).resolve().parents[2] / "shared" / "data" / "raw"


def quantities(res: pumpid.FitResult) -> dict[str, tuple[float, float, bool, str, bool]]:
    """name -> (value, standard error shown, determined, unit, a property of the well) for
    parameters and derived ones."""
    out = {}
    det = set(res.determined.get("parameters", ()))
    units = res.param_units()
    unc = res.uncertainty
    for name, value in res.params.items():
        se = unc.stderr.get(name, math.nan) if unc is not None else math.nan
        out[name] = (value, se, name in det, units.get(name, ""), True)
    if "offset" in res.free:
        se = unc.stderr.get("offset", math.nan) if unc is not None else math.nan
        out["offset"] = (res.offset, se, "offset" in det, res.units.position, True)
    for name, d in res.derived.items():
        out[f"{name} (derived)"] = (d.value, d.stderr, d.determined, d.unit, d.well_property)
    return out


def target_table(title: str, fits: list[pumpid.FitResult]) -> tuple[int, int]:
    """The issue's target on consecutive strokes of one well: for every quantity the fits
    report as determined (a property of the well), the card-to-card spread (CV over the
    cards calling it determined) is at most 2x its median reported relative error; and no
    fit that determines no parameter is ``converged``. Returns (quantities meeting the
    target, quantities reported as determined)."""
    rows = [quantities(r) for r in fits]
    statuses = {s: sum(r.status.key == s for r in fits) for s in
                sorted({r.status.key for r in fits})}
    bad = sum(1 for r in fits if r.status.key == "converged"
              and not r.determined.get("parameters"))
    print(f"\n{title} ({len(fits)} cards; statuses {statuses}; errors shown: "
          f"{sorted({r.errors_shown for r in fits})}; converged with no parameter "
          f"determined: {bad})")
    print(f"  {'quantity':<30}{'unit':<12}{'determined':>11}{'median':>12}{'CV':>9}"
          f"{'med rel se':>12}{'CV/se':>8}  verdict")
    met = total = 0
    for name in rows[0]:
        keep = [r[name] for r in rows if r[name][2] and r[name][4]]
        echo = sum(1 for r in rows if not r[name][4])
        tag = f" ({echo} echo)" if echo else ""
        if len(keep) < 2:
            print(f"  {name:<30}{rows[0][name][3]:<12}{len(keep):>7}/{len(rows):<3}"
                  f"{'':>41}  not reported as determined{tag}")
            continue
        vals = np.array([k[0] for k in keep])
        ses = np.array([k[1] for k in keep])
        cv = float(np.std(vals, ddof=1) / abs(np.mean(vals)))
        rel = float(np.nanmedian(ses / np.abs(vals)))
        ok = cv <= 2 * rel
        met += ok
        total += 1
        print(f"  {name:<30}{rows[0][name][3]:<12}{len(keep):>7}/{len(rows):<3}"
              f"{np.median(vals):>12.4g}{cv:>9.1%}{rel:>12.1%}{cv / rel:>8.2f}  "
              f"{'met' if ok else 'NOT met'}{tag}")
    ratios = [r.derived["natural_frequency"].value * r.card.period for r in fits
              if "natural_frequency" in r.derived and r.card is not None and r.card.period]
    if ratios:
        print(f"  natural frequency / stroke frequency: {min(ratios):.3f}-{max(ratios):.3f} "
              f"(median {float(np.median(ratios)):.3f}); echo of the stroke on "
              f"{sum(not r.derived['natural_frequency'].well_property for r in fits)} of "
              f"{len(fits)} cards")
    return met, total


def sandia_strokes() -> None:
    """The issue's target on Sandia's two 60 s records split into strokes, and its pairs."""
    path = RAW / "sandia_dds" / "downhole_timeseries.csv"
    if not path.is_file():
        print("Sandia records absent (../shared/data/raw): skipped")
        return
    met = total = 0
    for record in read_cards(path):
        strokes = split_strokes(record)
        got = target_table(f"Sandia record {record.card_id}, {len(strokes)} consecutive "
                           "strokes (target: CV <= 2 x median rel. error)",
                           [pumpid.fit(pumpid.Kelvin, s) for s in strokes])
        met, total = met + got[0], total + got[1]
    surface = RAW / "sandia_dds" / "surface_cards.csv"
    cards = {c.card_id: c.with_dt(0.075) for c in read_cards(surface)}
    for a, b in (("SX6E03A", "SX6E03B"), ("SX6I03A", "SX6I03B")):
        got = target_table(f"Sandia surface pair {a}, {b}",
                           [pumpid.fit(pumpid.Kelvin, cards[a]),
                            pumpid.fit(pumpid.Kelvin, cards[b])])
        met, total = met + got[0], total + got[1]
    print(f"\ntarget met by {met} of {total} quantities reported as determined")


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
                     [pumpid.fit(pumpid.Kelvin, cards[a]), pumpid.fit(pumpid.Kelvin, cards[b])])


def steady_well(model: pumpid.Kelvin, n: int, seed: int) -> list[pumpid.FitResult]:
    rng = np.random.default_rng(seed)
    fits = []
    for i in range(n):
        card = synthetic_card(model, spm=8.0 * (1 + 0.005 * rng.standard_normal()),
                              n_samples=130, observe="u", noise=0.003, seed=rng,
                              label=CardLabel(card_id=f"w{seed}-{i}"))
        fits.append(pumpid.fit(pumpid.Kelvin, card))
    return fits


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cards", type=int, default=40, help="cards per synthetic well")
    parser.add_argument("--real-only", action="store_true",
                        help="only the real strokes' target tables")
    args = parser.parse_args()
    sandia_strokes()
    if args.real_only:
        return
    sandia()
    interior = pumpid.Kelvin(k0=5200.0, m=20.0, c1=900.0, k1=5200.0)
    stiff = pumpid.Kelvin(k0=5.0e5, m=20.0, c1=900.0, k1=5200.0)
    spread_table(f"Synthetic steady well, interior {interior.as_dict()}",
                 steady_well(interior, args.cards, 1))
    spread_table(f"Synthetic steady well, stiff k0 {stiff.as_dict()}",
                 steady_well(stiff, args.cards, 2))


if __name__ == "__main__":
    main()
