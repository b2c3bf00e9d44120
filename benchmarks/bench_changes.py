"""Change detection over many synthetic wells: false alarms and detection delay (figures).

Usage::

    .venv/bin/python benchmarks/bench_changes.py            # about a minute or two
    .venv/bin/python benchmarks/bench_changes.py --quick    # fewer wells
    .venv/bin/python benchmarks/bench_changes.py --wells 6000   # a tighter false-alarm figure

Part 1, false alarms: steady wells (300 cards, three derived quantities each, card-to-card
scatter of 4 %) under three noise models (Gaussian; Student t with 5 degrees of freedom;
t5 with 1 % outlier cards of 6-12 noise scales), each card's reported standard error 30 %
of the scatter. The figure is the fraction of wells with any alert, with its exact
(Clopper-Pearson) 95 % interval; the method's target is ``false_alarm = 0.01``.

Part 2, detection: one quantity of each well steps by -40 % ... +40 % (10 % steps are
below what the defaults target at 5 % noise) at card 150 of 300
under t5 noise with a coefficient of variation of 2 %, 3.5 % and 5 %. Figures: the fraction
of wells whose change was found (an alert whose first card is within 10 cards of the true
one), the alarm delay (alarm card minus true first card: median, 90th percentile, largest)
and the error of the estimated first card (fraction within 0 and +-3 cards, largest).

Part 3, short histories (the two-segment and drift tests, 6 to 30 cards): false alarms of
steady wells of 6, 8, 10, 15, 20 and 30 cards under the three noise models of part 1 (CV
4 %); the fraction of wells whose step (after half the cards, -20 % ... +20 %) is found (an
alert whose first card is within 1 card of the true one) at CV 1 %, 2 % and 4 %; and the
fraction of wells whose steady drift (-40 % ... +25 % over the history) is alerted in its
direction, and how many of those alerts the drift test made.

Figures from one run (``--wells 6000``; 2 cores, Python 3.11, numpy 2.4, pandas 3.1; the
run is seeded, so the same versions give the same counts):

* false alarms (wells with any alert): Gaussian 60 of 6000 (1.00 %, 95 % interval
  0.76-1.29 %), t5 59 (0.98 %, 0.75-1.27 %), t5 with outliers 47 (0.78 %, 0.58-1.04 %);
* steps of 20-40 % at 2-5 % noise: all found; alarm 3 cards after the first changed card
  (median), 90th percentile 3-5, largest 7 (+20 % at 5 %); first card exact for 88.5-100 %
  of wells and within +-3 cards for all;
* steps of 10 %: at 2 % noise like the larger ones (largest delay 5); at 5 % noise a median
  delay of 8-10 cards, largest 26-40, first card within +-3 for 93-96.5 %.

Part 3 with the two-segment test alone, from one run (``--short-only``, 2000 wells per
cell; 1428 s on 2 shared cores):

* false alarms (wells with any alert, target 1 %): 6 cards 0.35-0.50 %; 8 cards 0.35-1.10 %;
  10 cards 0.65-1.20 %; 15 cards 0.65-0.85 %; 20 cards 0.55-1.00 %; 30 cards 0.70-1.10 %;
  every 95 % interval contains or lies below 1 % (largest: Gaussian at 10 cards, 24 of 2000,
  0.77-1.78 %). Calibrated on t5 noise alone, Gaussian wells of 10 cards alerted at 1.65 %
  (1.14-2.31 %): hence the threshold is the larger of the t5+outlier and Gaussian ones;
* steps found with their first card within 1 card (after half the cards): at 1 % noise
  +-10 % in 97-100 % of wells from 6 cards on, +-5 % in 57-64 % at 6 cards, 88-94 % at 10,
  99 % at 20; at 2 % noise +-20 % in 96-100 % from 6 cards, +-10 % in 65-72 % at 6 cards,
  83-96 % at 10, 100 % at 20; at 4 % noise +-20 % in 59-75 % at 6 cards, 81-95 % at 10,
  100 % at 20 (a +20 % step is 0.18 on the log scale, -20 % is 0.22: found more often).

Part 3 with both tests, each at half the probability, against the two-segment test alone
(``--short-only --quick``: 500 steady wells, 50 changing ones a cell; both in one hour; the
figures "alone" are this script's run on the version before the drift test, 677e5c8):

* false alarms: 0.0-1.2 % (alone 0.0-1.2 %), every 95 % interval reaching 1 % or below;
* steps: +-10 % at 1 % noise 90-100 % from 6 cards (alone 94-100 %); +-20 % at 4 % noise
  46-74 % at 6 cards, 72-86 % at 10, 98-100 % at 20 (alone 56-78 %, 74-94 %, 98-100 %);
* drifts: -20 % at 2 % noise 86 % at 6 cards, 100 % from 10 (alone 12 %, 30 %, 90 % at 14);
  -40 % at 1 % noise 100 % from 6 cards (alone 0 % at 6, 10 % at 10); nearly every drift
  alert is the drift test's.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time

import numpy as np
import pandas as pd
import scipy.stats

from pumpid.fleet.changes import detect_changes

QUANTITIES = {"stiffness": (80.0, "lbf/in"), "natural_frequency": (0.55, "Hz"),
              "damping_ratio": (0.18, "-")}  # fmt: skip
ROBUST_T5 = float(scipy.stats.t.ppf(0.75, 5) / scipy.stats.norm.ppf(0.75))


def table(n_wells: int, n_cards: int, *, cv: float, noise: str, seed: int,
          step: tuple[str, float, int] | None = None,
          drift: tuple[str, float] | None = None) -> pd.DataFrame:
    """A results table of steady wells; ``step`` = (quantity, factor, first card) for all;
    ``drift`` = (quantity, factor): the level moves geometrically from 1 to ``factor``
    times its first card's over the history."""
    rng = np.random.default_rng(seed)
    well = np.repeat(np.arange(n_wells), n_cards)
    card = np.tile(np.arange(n_cards), n_wells)
    ids = np.char.add(np.char.add("W", np.char.zfill(well.astype(str), 5)), "-")
    frame = pd.DataFrame({
        "well_id": np.char.add("W", np.char.zfill(well.astype(str), 5)),
        "card_id": np.char.add(ids, np.char.zfill(card.astype(str), 4)),
        "time": pd.Timestamp("2024-01-01", tz="UTC") + pd.to_timedelta(card * 6, unit="h"),
        "status": "converged",
    })
    for q, (centre, unit) in QUANTITIES.items():
        level = centre * np.exp(rng.uniform(-0.4, 0.4, n_wells))[well]
        if noise == "gaussian":
            e = rng.standard_normal(well.size)
        else:
            e = rng.standard_t(5, well.size) / ROBUST_T5  # robust scale 1: CV as the MAD says
            if noise == "t5+outliers":
                hit = rng.random(well.size) < 0.01
                e = np.where(hit, rng.choice([-1.0, 1.0], well.size) * rng.uniform(6, 12,
                                                                                   well.size), e)
        value = level * np.exp(cv * e)
        if step is not None and step[0] == q:
            value = np.where(card >= step[2], value * step[1], value)
        if drift is not None and drift[0] == q:
            value = value * drift[1] ** (card / (n_cards - 1))
        frame[f"d_{q}"] = value
        frame[f"d_{q}_se"] = 0.3 * cv * value
        frame[f"d_{q}_determined"] = True
        frame[f"d_{q}_unit"] = unit
    return frame


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    lo = scipy.stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = scipy.stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def false_alarms(n_wells: int, n_cards: int) -> None:
    print(f"\n1. False alarms: {n_wells} steady wells x {n_cards} cards x "
          f"{len(QUANTITIES)} quantities, CV 4 %, false_alarm = 0.01")
    print(f"{'noise':<14}{'wells alerting':>16}{'rate':>9}{'95 % interval':>20}{'time':>9}")
    for seed, noise in enumerate(("gaussian", "t5", "t5+outliers")):
        tab = table(n_wells, n_cards, cv=0.04, noise=noise, seed=100 + seed)
        t0 = time.perf_counter()
        alerts = detect_changes(tab)
        dt = time.perf_counter() - t0
        k = alerts["well_id"].nunique()
        lo, hi = clopper_pearson(k, n_wells)
        print(f"{noise:<14}{k:>16d}{k / n_wells:>9.2%}   [{lo:.2%}, {hi:.2%}]{dt:>8.1f}s")


def detection(n_wells: int, n_cards: int) -> None:
    at = n_cards // 2
    print(f"\n2. Detection: one quantity steps at card {at} of {n_cards}; t5 noise; "
          f"{n_wells} wells per cell")
    print(f"{'CV':>5}{'step':>7}{'found':>8}{'delay med':>11}{'p90':>5}{'max':>5}"
          f"{'first exact':>13}{'+-3 cards':>11}{'max err':>9}")
    for cv in (0.02, 0.035, 0.05):
        for factor in (0.6, 0.7, 0.8, 0.9, 1.1, 1.2, 1.3, 1.4):
            tab = table(n_wells, n_cards, cv=cv, noise="t5", seed=int(1000 * cv + 10 * factor),
                        step=("stiffness", factor, at))
            alerts = detect_changes(tab, ["stiffness"], false_alarm=0.01)
            hits = alerts[(alerts["first_index"] - at).abs() <= 10]
            hits = hits.sort_values("alarm_index").groupby("well_id").head(1)
            delay = hits["alarm_index"].to_numpy() - at
            err = hits["first_index"].to_numpy() - at
            found = len(hits) / n_wells
            if len(hits):
                print(f"{cv:>5.1%}{factor - 1:>+7.0%}{found:>8.1%}{np.median(delay):>11.0f}"
                      f"{np.quantile(delay, 0.9):>5.0f}{delay.max():>5d}"
                      f"{np.mean(err == 0):>13.1%}{np.mean(np.abs(err) <= 3):>11.1%}"
                      f"{np.abs(err).max():>9d}")
            else:
                print(f"{cv:>5.1%}{factor - 1:>+7.0%}{found:>8.1%}")


def short_false_alarms(n_wells: int) -> None:
    print(f"\n3a. Short histories, false alarms: {n_wells} steady wells per cell x "
          f"{len(QUANTITIES)} quantities, CV 4 %, false_alarm = 0.01 (two-segment and drift tests)")
    print(f"{'cards':>6}{'noise':>14}{'wells alerting':>16}{'rate':>9}{'95 % interval':>20}"
          f"{'time':>9}")
    for n in (6, 8, 10, 15, 20, 30):
        for seed, noise in enumerate(("gaussian", "t5", "t5+outliers")):
            tab = table(n_wells, n, cv=0.04, noise=noise, seed=300 + 10 * n + seed)
            t0 = time.perf_counter()
            alerts = detect_changes(tab)
            dt = time.perf_counter() - t0
            k = alerts["well_id"].nunique()
            lo, hi = clopper_pearson(k, n_wells)
            print(f"{n:>6d}{noise:>14}{k:>16d}{k / n_wells:>9.2%}   [{lo:.2%}, {hi:.2%}]"
                  f"{dt:>8.1f}s")


def short_detection(n_wells: int) -> None:
    print(f"\n3b. Short histories, detection: stiffness steps after half the cards; t5 noise; "
          f"{n_wells} wells per cell; found = an alert whose first card is within 1 card")
    print(f"{'cards':>6}{'CV':>6}" + "".join(f"{f - 1:>+8.0%}" for f in STEPS_SHORT))
    for n in (6, 10, 20):
        for cv in (0.01, 0.02, 0.04):
            cells = []
            for factor in STEPS_SHORT:
                tab = table(n_wells, n, cv=cv, noise="t5", seed=int(7000 * cv + 100 * factor + n),
                            step=("stiffness", factor, n // 2))
                alerts = detect_changes(tab, ["stiffness"])
                hits = alerts[(alerts["first_index"] - n // 2).abs() <= 1]
                cells.append(hits["well_id"].nunique() / n_wells)
            print(f"{n:>6d}{cv:>6.0%}" + "".join(f"{c:>8.1%}" for c in cells))


STEPS_SHORT = (0.8, 0.9, 0.95, 1.05, 1.1, 1.2)
DRIFTS_SHORT = (0.6, 0.8, 0.9, 1.1, 1.25)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer wells")
    parser.add_argument("--wells", type=int, default=2000,
                        help="steady wells per noise model in part 1 (default 2000)")
    parser.add_argument("--short-only", action="store_true",
                        help="only part 3 (short histories)")
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, pandas {pd.__version__}, "
          f"{platform.machine()}")
    t0 = time.perf_counter()
    if not args.short_only:
        false_alarms(500 if args.quick else args.wells, 300)
        detection(50 if args.quick else 200, 300)
    short_false_alarms(500 if args.quick else args.wells)
    short_detection(50 if args.quick else 200)
    short_drift(50 if args.quick else 200)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s (thresholds are simulated once per "
          "history length and cached)")


def short_drift(n_wells: int) -> None:
    print(f"\n3c. Short histories, drift: stiffness moves steadily by the factor over the "
          f"history; t5 noise; {n_wells} wells per cell; found = an alert in the drift's "
          "direction (either test)")
    print(f"{'cards':>6}{'CV':>6}" + "".join(f"{f - 1:>+8.0%}" for f in DRIFTS_SHORT)
          + "  by the drift test")
    for n in (6, 10, 14, 20):
        for cv in (0.01, 0.02, 0.04):
            cells, by_drift, found = [], [], []
            for factor in DRIFTS_SHORT:
                tab = table(n_wells, n, cv=cv, noise="t5", seed=int(9000 * cv + 100 * factor + n),
                            drift=("stiffness", factor))
                alerts = detect_changes(tab, ["stiffness"])
                hits = alerts[alerts["direction"] == ("up" if factor > 1 else "down")]
                cells.append(hits["well_id"].nunique() / n_wells)
                by_drift.append(int((hits["method"] == "drift").sum()))
                found.append(int(hits["well_id"].nunique()))
            print(f"{n:>6d}{cv:>6.0%}" + "".join(f"{c:>8.1%}" for c in cells)
                  + f"  {sum(by_drift)} of {sum(found)}")


if __name__ == "__main__":
    main()
