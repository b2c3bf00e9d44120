"""How fast are downhole cards? Cards per second of the diagnostic, batched and alone.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_downhole.py               # 2,000 cards
    .venv/bin/python benchmarks/bench_downhole.py --cards 500   # quicker

The cards: surface cards of 200 samples over a three-taper steel string (1, 7/8, 3/4 in;
4,900 ft), made by the exact frequency-domain predictive solution from pump loads that pick
up and release the fluid load at varied points of the stroke, with 0.3 % load noise; 20
wells, each at its own pumping speed (so 20 distinct sets of transfer matrices per batch).
Rows:

* ``solver``: :func:`pumpid.rods.fourier_diagnostic` on the arrays alone;
* ``diagnose_cards``: the API end to end (card checks, loop sense, solve, static loads,
  pump quantities), one call for the whole batch, one thread;
* ``diagnose_cards, 2 threads``: the batch cut in two halves run on two threads (numpy's
  FFT and array arithmetic release the interpreter lock);
* ``diagnose_card, one by one`` (the baseline): the same API called card by card;
* ``finite differences``: the same batch by ``method="fd"`` (the cross-check, not the
  production path), on a tenth of the cards;
* ``predictive (valves)``: :func:`pumpid.rods.predict_surface`, time stepping to the
  periodic state, on 5 cards at once.

Every ratio is against the baseline measured in the same run. This is a benchmark, not a
test: it prints figures and checks nothing.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import time

import numpy as np

from pumpid.cards import Card
from pumpid.rods import (
    MATERIALS,
    Fluid,
    Pump,
    PumpModel,
    StringArrays,
    Taper,
    Well,
    diagnose_card,
    diagnose_cards,
    fourier_diagnostic,
    fourier_predict,
    predict_surface,
)

FT, INCH, LBF = 0.3048, 0.0254, 4.4482216152605
SAMPLES = 200
WELLS = 20


def make_well(k: int) -> Well:
    e, rho = MATERIALS["steel"]
    return Well(f"W-{k:02d}", (Taper(1500 * FT, 1.0 * INCH, e, rho),
                               Taper(1600 * FT, 0.875 * INCH, e, rho),
                               Taper(1800 * FT, 0.75 * INCH, e, rho)),
                Pump(4900 * FT, 1.75 * INCH), fluid=Fluid(1000.0), system="us")


def make_cards(count: int, seed: int = 0) -> tuple[list[Card], list[Well]]:
    rng = np.random.default_rng(seed)
    wells = [make_well(k) for k in range(WELLS)]
    phase = np.arange(SAMPLES) / SAMPLES
    stroke = 100 * INCH
    s = stroke / 2 * (1 - np.cos(2 * np.pi * phase)) + 0.05 * stroke * np.sin(
        4 * np.pi * phase)
    cards: list[Card] = []
    owners: list[Well] = []
    for k in range(count):
        well = wells[k % WELLS]
        spm = 5.0 + 0.25 * (k % WELLS)
        release = rng.uniform(0.55, 0.95)
        fluid = rng.uniform(15000, 22000)
        pump = fluid * 0.25 * (1 + np.tanh((phase - 0.04) / 0.02)) * (
            1 - np.tanh((phase - release) / 0.02))
        surface, _plunger = fourier_predict(s, pump, 60 / spm, StringArrays.of([well]), 0.05)
        load = surface[0] + well.buoyant_weight()
        load = load + 0.003 * np.ptp(load) * rng.standard_normal(SAMPLES)
        cards.append(Card(position=s / INCH, load=load / LBF, position_unit="in",
                          load_unit="lbf", card_id=f"C{k:05d}", well_id=well.well_id)
                     .with_spm(spm))
        owners.append(well)
    return cards, owners


def rate(fn, count: int, repeat: int) -> float:
    """Cards per second, best of ``repeat`` runs."""
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return count / best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cards", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    cards, wells = make_cards(args.cards)
    n = len(cards)
    strings = StringArrays.of(wells)
    y = np.stack([c.position * INCH for c in cards])
    f = np.stack([c.load * LBF for c in cards]) - np.array(
        [w.buoyant_weight() for w in wells])[:, None]
    period = np.array([c.period for c in cards])

    def two_threads() -> None:
        half = n // 2
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            list(pool.map(lambda part: diagnose_cards(cards[part], wells[part]),
                          [slice(0, half), slice(half, n)]))

    one_by_one = max(50, n // 10)
    rows = [
        ("solver (fourier_diagnostic, arrays)",
         rate(lambda: fourier_diagnostic(y, f, period, strings, 0.05), n, args.repeat)),
        ("diagnose_cards, one call", rate(lambda: diagnose_cards(cards, wells), n,
                                          args.repeat)),
        ("diagnose_cards, 2 threads", rate(two_threads, n, args.repeat)),
        ("diagnose_card, one by one (baseline)",
         rate(lambda: [diagnose_card(c, w) for c, w in zip(cards[:one_by_one],
                                                            wells[:one_by_one], strict=True)],
              one_by_one, 1)),
        ("finite differences (method='fd')",
         rate(lambda: diagnose_cards(cards[: n // 10], wells[: n // 10], method="fd"),
              n // 10, 1)),
    ]
    pump = PumpModel(fluid_load=18000.0, fillage=np.array([1.0, 0.9, 0.7, 0.5, 0.7]),
                     intake_ratio=np.array([0.01, 0.01, 0.01, 0.01, 0.3]), transfer=0.05)
    # Once first: the compiled march is loaded from its cache (or compiled) on first use.
    predict_surface(wells[0], y[:1], float(period[0]), PumpModel(fluid_load=18000.0), nu=0.1,
                    tol=1e-6)
    start = time.perf_counter()
    pred = predict_surface(wells[0], np.repeat(y[:1], 5, 0), float(period[0]), pump,
                           nu=0.1, tol=1e-6)
    rows.append((f"predictive with valves ({pred.cycles} strokes to periodic)",
                 5 / (time.perf_counter() - start)))
    base = rows[3][1]
    print(f"downhole cards: {n} cards of {SAMPLES} samples, three tapers, {WELLS} wells at "
          "their own speeds, Fourier method unless said")
    print(f"{'path':<52} {'cards/s':>10} {'vs baseline':>12}")
    for name, value in rows:
        shown = f"{value:.0f}" if value >= 10 else f"{value:.2f}"
        print(f"{name:<52} {shown:>10} {value / base:>11.2g}x")


if __name__ == "__main__":
    main()
