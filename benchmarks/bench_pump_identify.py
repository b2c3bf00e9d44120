"""The pump identified from the surface card: recovery, coverage, real cards and speed.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_pump_identify.py            # 200 cards per case
    .venv/bin/python benchmarks/bench_pump_identify.py --quick    # 20 cards per case
    .venv/bin/python benchmarks/bench_pump_identify.py --cards 50 --processes 2

Sections:

1. **Recovery and coverage.** Five cases (a full pump; fluid pound at 50, 70 and 90 %
   liquid fraction with intake ratio 0.01; gas interference at liquid fraction 0.7 and
   intake ratio 0.3), N cards each. Every card has its own three-taper steel string drawn
   around ``tests/rods/strings.three_tapers`` (taper lengths x0.9-1.1, diameters x0.95-1.05,
   the pump at the string's foot), its own fluid load (0.75-1.0 of the water column on the
   plunger), damping (Gibbs' nu 0.05-0.3), transfer (0.02-0.08 m), pumping speed (6-10 SPM),
   stroke (85-115 in) and samples (144-240). The surface card is made by
   :func:`pumpid.rods.predict_surface` with 120 elements, standing for the continuous
   string (the fit's model marches 30, so it is never fitted to its own output, and its
   own discretization error is part of what the intervals must cover); each clean card
   gets 1 % load noise (of its load range), once white and once AR(1) with rho 0.8 (the
   same clean card under both). A row
   per case and noise: the fits' statuses, the median absolute error of the fillage (points;
   the truth is :func:`pumpid.rods.measure_pump_card` on the true pump card the predictive
   solver returns) and of the fluid load (%, against the pump model's fluid load), and how
   often the 95 % interval shown (value +- t x the standard error that
   :meth:`PumpFit.quantities` and :meth:`PumpFit.damping` give: the robust one when the
   residuals are serially correlated) holds the truth, for the fluid load, the damping and
   the fillage. A card the fit could not give an error for counts as not covered. The last
   column counts the cards whose fitted model does not reach a periodic stroke at the
   optimum (the march's last stroke still changing by over 1e-6 of the load range), and the
   one after it checks the predictive solver against the diagnostic one on each card: the
   fitted pump card against the diagnostic pump card of the fitted surface load
   (``PumpFit.consistency``), RMS after a constant: median, largest, and how many cards
   are over 1 % of the load range.
   Cards run on ``--processes`` worker processes (2 by default); the elapsed time is printed.
2. **Real cards.** The two public CMCM 2012 cards (``../shared/data/raw/cmcm2012_rod_pump``
   beside the repository; skipped when absent), each with its well built from the data
   set's ``wells.json``: status, R^2, the residuals' lag-1 autocorrelation, each pump
   quantity with its error and unit, the damping with its error and rule, the energy balance
   and the agreement of the fitted pump card with the diagnostic one (of the measured
   surface load, and of the fitted one).
3. **Speed.** On the first 20 white-noise cards of each case (the quick run's cards): the
   median time of :func:`pumpid.pump.identify_card` per card, and cards/s of
   :func:`pumpid.pump.identify_cards` over the list in one call, against the diagnostic
   alone (:func:`pumpid.rods.diagnose_cards` on the same cards) measured in the same run.

``--save FILE.csv`` writes one row per fitted card (truths, values, errors white and robust,
residual autocorrelation) for a closer look. A benchmark, not a test: it prints figures and
checks nothing.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import multiprocessing
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench_main_job import table  # noqa: E402
from tests.rods.strings import (  # noqa: E402
    FT,
    INCH,
    LBF,
    STEEL,
    card,
    cmcm_well_document,
    surface_motion,
    three_tapers,
)

from pumpid.cards import Card, read_card  # noqa: E402
from pumpid.pump import PumpFit, PumpSystem, identify_card, identify_cards  # noqa: E402
from pumpid.pump.system import TOL  # noqa: E402
from pumpid.rods import (  # noqa: E402
    Fluid,
    Pump,
    PumpModel,
    Taper,
    Tubing,
    Well,
    diagnose_cards,
    measure_pump_card,
    predict_surface,
    wells_from_dict,
)

#: Case name: (liquid fraction admitted, intake ratio).
CASES = {"full pump": (1.0, 0.01), "pound 90 %": (0.9, 0.01), "pound 70 %": (0.7, 0.01),
         "pound 50 %": (0.5, 0.01), "gas 70 %": (0.7, 0.3)}
NOISES = ("white", "AR(1) 0.8")
NOISE = 0.01
RHO = 0.8
#: Elements of the predictive solver that makes the cards (the fit's model uses 30).
TRUTH_ELEMENTS = 120
REAL = ROOT.parent / "shared" / "data" / "raw" / "cmcm2012_rod_pump"


# --------------------------------------------------------------------------- the cards
def draw_well(rng: np.random.Generator, k: int) -> Well:
    """A three-taper string drawn around the tests' one; the pump at its foot."""
    base = three_tapers()
    tapers = tuple(Taper(t.length * rng.uniform(0.9, 1.1), t.diameter * rng.uniform(0.95, 1.05),
                         t.modulus, t.density) for t in base.tapers)
    depth = sum(t.length for t in tapers)
    pump = Pump(depth, base.pump.plunger_diameter)
    return Well(f"W{k:04d}", tapers, pump, fluid=base.fluid, system="us")


def make_case(case: str, index: int, seed: int) -> dict[str, Any]:
    """One clean surface card of ``case`` with its truths (and the two noisy cards)."""
    rng = np.random.default_rng([seed, list(CASES).index(case), index])
    fill, ratio = CASES[case]
    well = draw_well(rng, index)
    spm = rng.uniform(6.0, 10.0)
    n = int(rng.integers(144, 241))
    s = surface_motion(n, 60 / spm, stroke=100 * INCH * rng.uniform(0.85, 1.15))
    column = 1000.0 * 9.80665 * well.pump.depth * well.pump.area
    fluid = column * rng.uniform(0.75, 1.0)
    nu = rng.uniform(0.05, 0.3)
    transfer = rng.uniform(0.02, 0.08)
    pred = predict_surface(well, s, 60 / spm, PumpModel(fluid_load=fluid, fillage=fill,
                                                         intake_ratio=ratio, transfer=transfer),
                           nu=nu, elements=TRUTH_ELEMENTS, max_cycles=300, tol=1e-9)
    clean = pred.surface_load[0] + well.buoyant_weight()
    truth = measure_pump_card(pred.pump_position[0], pred.pump_load[0], well, spm)
    sigma = NOISE * float(np.ptp(clean))
    white = rng.standard_normal(n)
    ar = np.empty(n)
    ar[0] = rng.standard_normal()
    step = rng.standard_normal(n)
    for i in range(1, n):
        ar[i] = RHO * ar[i - 1] + math.sqrt(1 - RHO ** 2) * step[i]
    cards = {name: card(s, clean + sigma * e, spm, f"{case}/{index}/{name}")
             for name, e in zip(NOISES, (white, ar), strict=True)}
    return {"well": well, "cards": cards, "spm": spm, "n": n, "nu": nu,
            "fluid_lbf": fluid / LBF, "fill": float(truth.fillage), "transfer": transfer}


def inside(value: float | None, se: float | None, t: float, truth: float) -> bool:
    """The interval value +- t se holds the truth (no error: not covered)."""
    if value is None or se is None or not math.isfinite(se):
        return False
    return abs(value - truth) <= t * se


def record(case: str, index: int, noise: str, made: dict[str, Any], got: PumpFit,
           ms: float) -> dict[str, Any]:
    """One card's figures: truths, values, errors shown, white and robust."""
    row: dict[str, Any] = {"case": case, "index": index, "noise": noise, "status": got.status,
                           "ms": ms, "spm": made["spm"], "samples": made["n"],
                           "true_nu": made["nu"], "true_fluid": made["fluid_lbf"],
                           "true_fillage": made["fill"], "true_transfer": made["transfer"],
                           "full_pump": got.full_pump}
    if not got.ok:
        return row
    f = got.fit
    u = f.uncertainty
    q = got.quantities()
    d = got.damping()
    t = u.t_quantile if u is not None else math.nan
    white = u.whiteness if u is not None and u.whiteness is not None else {}
    row.update({
        "r2": f.r2, "rho": white.get("lag1_autocorrelation", math.nan),
        "serial": not white.get("white", True), "t": t,
        "liquid_fraction": f.params["liquid_fraction"],
        "intake_ratio": f.params["intake_ratio"], "transfer": f.params["transfer"],
        "fluid": _real(q["fluid_load"]["value"]), "fluid_se": _real(q["fluid_load"]["stderr"]),
        "fillage": _real(q["fillage"]["value"]), "fillage_se": _real(q["fillage"]["stderr"]),
        "nu": _real(d["value"]), "nu_se": _real(d["stderr"]),
        "nu_fitted": f.params["damping"],
        "agreement": got.agreement, "consistency": got.consistency,
        # Does the fit's model reach a periodic stroke at the optimum? (When it does not, its
        # output and its forward-difference sensitivities depend on where the march started.)
        "periodic": _periodic(got.model, np.array(list(f.params.values()))),
    })
    for name, key in (("fluid_load", "fluid"), ("damping", "nu")):
        # (u.stderr is the error shown: the robust one when the residuals are serial.)
        row[f"{key}_se_white"] = u.stderr_white.get(name, math.nan) if u else math.nan
        row[f"{key}_se_hac"] = u.stderr_hac.get(name, math.nan) if u else math.nan
    fd = f.derived.get("fillage")
    row["fillage_se_white"] = fd.stderr_white if fd is not None else math.nan
    row["fillage_se_hac"] = fd.stderr_hac if fd is not None else math.nan
    row["cover_fluid"] = inside(row["fluid"], row["fluid_se"], t, made["fluid_lbf"])
    row["cover_nu"] = inside(row["nu"], row["nu_se"], t, made["nu"])
    row["cover_fillage"] = inside(row["fillage"], row["fillage_se"], t, made["fill"])
    return row


def run_one(task: tuple[str, int, int]) -> list[dict[str, Any]]:
    """Make one clean card of a case and identify it under each noise."""
    case, index, seed = task
    made = make_case(case, index, seed)
    out = []
    for noise in NOISES:
        start = time.perf_counter()
        got = identify_card(made["cards"][noise], made["well"])
        out.append(record(case, index, noise, made, got,
                          1e3 * (time.perf_counter() - start)))
    return out


# --------------------------------------------------------------------------- printing
def pct(flags: list[bool]) -> str:
    return f"{100 * np.mean(flags):.1f} %" if flags else "-"


def section_recovery(count: int, processes: int, seed: int, save: str | None) -> None:
    tasks = [(case, i, seed) for case in CASES for i in range(count)]
    start = time.perf_counter()
    parts = []
    with multiprocessing.get_context("fork").Pool(processes) as pool:
        # Cards as they finish, with progress on stderr: a run stopped early still shows
        # how far it got.
        for k, part in enumerate(pool.imap_unordered(run_one, tasks), 1):
            parts.append(part)
            if k % max(1, len(tasks) // 20) == 0:
                print(f"  {k}/{len(tasks)} cards made and fitted, "
                      f"{time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - start
    rows = [r for part in parts for r in part]
    out = []
    for case in CASES:
        for noise in NOISES:
            got = [r for r in rows if r["case"] == case and r["noise"] == noise]
            fitted = [r for r in got if "fluid" in r]
            counts = collections.Counter(r["status"] for r in got)
            fill_err = [100 * abs(r["fillage"] - r["true_fillage"]) for r in fitted
                        if math.isfinite(r["fillage"])]
            fluid_err = [100 * abs(r["fluid"] - r["true_fluid"]) / r["true_fluid"]
                         for r in fitted]
            rhos = np.array([r["rho"] for r in fitted], dtype=float)
            solvers = np.array([r["consistency"] for r in fitted], dtype=float)
            solvers = 100 * solvers[np.isfinite(solvers)]
            out.append([case, noise, ", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
                        f"{np.median(fill_err):.2f}" if fill_err else "-",
                        f"{np.median(fluid_err):.2f}" if fluid_err else "-",
                        pct([r["cover_fluid"] for r in fitted]),
                        pct([r["cover_nu"] for r in fitted]),
                        pct([r["cover_fillage"] for r in fitted]),
                        # over the fits that have residuals (a failed fit has none)
                        f"{np.nanmedian(rhos):.2f}" if np.any(np.isfinite(rhos)) else "-",
                        str(sum(not r["periodic"] for r in fitted)),
                        f"{np.median(solvers):.2f} / {solvers.max():.2f} / "
                        f"{np.sum(solvers > 1)}" if solvers.size else "-"])
    table(f"(1) recovery and coverage: {count} cards per case and noise, three-taper strings "
          f"drawn card by card, cards by the predictive solver at {TRUTH_ELEMENTS} elements, "
          f"{100 * NOISE:g} % load noise; 95 % intervals value +- t x stderr as shown "
          "(robust where the residuals are serially correlated)",
          ["case", "noise", "statuses", "fillage |err| median, points",
           "fluid load |err| median, %", "cover fluid load", "cover damping",
           "cover fillage", "residual lag-1 rho median", "optimum not periodic",
           "two solvers on the fitted card, % of the load range: median / max / cards "
           "over 1 %"], out)
    ms = [r["ms"] for r in rows]
    print(f"  elapsed: {elapsed:.0f} s for {len(rows)} fits on {processes} process(es) "
          f"({len(rows) / elapsed:.2f} cards/s; identify_card inside the workers, card making "
          f"not included: median {np.median(ms):.0f} ms, mean {np.mean(ms):.0f} ms, "
          f"{sum(m > 5000 for m in ms)} cards over 5 s)")
    if save:
        import pandas as pd

        pd.DataFrame(rows).to_csv(save, index=False)
        print(f"  per-card rows written to {save}")


# --------------------------------------------------------------------------- real cards
def real_well(entry: dict[str, Any], common: dict[str, Any], well_id: str) -> Well:
    """The data set's well in pumpid's well-file schema."""
    doc = cmcm_well_document(entry, common, well_id)
    return wells_from_dict(doc, source=f"{well_id} (from wells.json)")[well_id]


def fmt(entry: dict[str, Any]) -> str:
    v, se = entry["value"], entry["stderr"]
    if v is None:
        return f"- {entry['unit']}"
    err = "-" if se is None else f"{se:.3g}"
    return f"{v:.4g} +- {err} {entry['unit']}"


def section_real() -> None:
    if not (REAL / "wells.json").is_file():
        print("\n(2) real cards: skipped (no ../shared/data/raw/cmcm2012_rod_pump beside the "
              "repository)")
        return
    source = json.loads((REAL / "wells.json").read_text(encoding="utf-8"))
    print("\n(2) real cards: the public CMCM 2012 cards, wells from the data set's wells.json "
          "(anchored tubing, mixture density by the water cut)")
    for well_id, entry in source["wells"].items():
        well = real_well(entry, source["common"], well_id)
        c = read_card(REAL / entry["card_csv"], spm=float(entry["spm"]))
        start = time.perf_counter()
        got = identify_card(c, well)
        ms = 1e3 * (time.perf_counter() - start)
        print(f"\n  {well_id} ({entry['card_csv']}, {c.position.size} samples, "
              f"{entry['spm']} SPM): status {got.status}, {ms:.0f} ms")
        if not got.ok:
            print(f"    reason: {got.reason}")
            continue
        doc = got.to_dict()
        print(f"    surface-load fit: R^2 {doc['r2']:.5f}, RMSE {doc['rmse']['value']:.3g} "
              f"{doc['rmse']['unit']}, residual lag-1 autocorrelation "
              f"{doc['residual_autocorrelation']:.3f}")
        for name, q in got.quantities().items():
            print(f"    {name:<16} {fmt(q)}")
        d = got.damping()
        print(f"    {'damping':<16} {fmt(d)}")
        print(f"    damping rule:    {d['rule']}")
        e = got.energy()
        print(f"    energy per stroke ({e['unit']}): measured surface card "
              f"{e['surface_work']:.4g}, fitted surface card {e['fitted_surface_work']:.4g}, "
              f"fitted pump card {e['pump_work']:.4g}; string loss "
              f"{100 * e['string_loss']:.1f} % of the fitted surface work; the measured card "
              f"against the diagnostic pump card ({e['diagnostic_pump_work']:.4g}) at the "
              f"damping used: {100 * e['measured_loss']:.1f} %")
        print(f"    agreement with the diagnostic pump card (RMS after a constant, of its load "
              f"range): {100 * got.agreement:.2f} %; with the diagnostic of the fitted "
              f"surface load (the two solvers on one card): {100 * got.consistency:.2f} %")
        print(f"    full pump: {got.full_pump}; parameters: "
              + ", ".join(f"{k} {v['value']:.4g} {v['unit']}"
                          for k, v in doc["parameters"].items()))
        for line in (*doc["identifiability"], *doc["warnings"], *doc["notes"]):
            print(f"    - {line}")


# --------------------------------------------------------------------------- families
def family_well(name: str, tapers: list[tuple[float, float]], plunger_in: float,
                tubing: Tubing | None = None) -> Well:
    """Steel tapers (length ft, diameter in) over a pump at their foot, water; anchored
    tubing unless given."""
    e, rho = STEEL
    rods = tuple(Taper(length * FT, diameter * INCH, e, rho) for length, diameter in tapers)
    depth = sum(t.length for t in rods)
    return Well(name, rods, Pump(depth, plunger_in * INCH), tubing=tubing or Tubing(),
                fluid=Fluid(1000.0), system="us")


#: Wells unlike the recovery's: name -> (well, SPM range, polished-rod stroke in inches).
FAMILIES = {
    "shallow, 2 tapers, 10-14 SPM": (
        family_well("shallow", [(1200, 0.875), (1300, 0.75)], 2.25), (10.0, 14.0), 64.0),
    "deep, 4 tapers, 4-6 SPM": (
        family_well("deep", [(2000, 1.125), (2200, 1.0), (2400, 0.875), (2400, 0.75)], 1.5),
        (4.0, 6.0), 144.0),
    "one taper, 7-9 SPM": (family_well("one", [(4000, 0.875)], 1.75), (7.0, 9.0), 100.0),
    "3 tapers, free tubing": (
        family_well("free", [(1500, 1.0), (1600, 0.875), (1800, 0.75)], 1.75,
                    Tubing(False, 2.875 * INCH, 2.441 * INCH)), (6.0, 10.0), 100.0),
}
#: Field-like damage to a card: as made; started mid-stroke with a load-cell offset and the
#: positions rounded to a transducer's 1 cm.
DAMAGES = ("as made", "rolled, +2000 lbf, 1 cm positions")


def section_families(seed: int, per_case: int) -> None:
    rng = np.random.default_rng([seed, 7])
    rows = []
    for family, (well, spm_range, stroke) in FAMILIES.items():
        for case in ("full pump", "pound 70 %", "gas 70 %"):
            fill, ratio = CASES[case]
            for damage in DAMAGES:
                got = []
                for _ in range(per_case):
                    spm = rng.uniform(*spm_range)
                    n = int(rng.integers(144, 241))
                    s = surface_motion(n, 60 / spm, stroke=stroke * INCH * rng.uniform(0.9, 1.1))
                    fluid = (1000.0 * 9.80665 * well.pump.depth * well.pump.area
                             * rng.uniform(0.75, 1.0))
                    pump = PumpModel(fluid_load=fluid, fillage=fill, intake_ratio=ratio,
                                     transfer=rng.uniform(0.02, 0.08))
                    pred = predict_surface(well, s, 60 / spm, pump, nu=rng.uniform(0.05, 0.3),
                                           elements=90, max_cycles=400, tol=1e-9)
                    clean = pred.surface_load[0] + well.buoyant_weight()
                    truth = measure_pump_card(pred.pump_position[0], pred.pump_load[0], well,
                                              spm)
                    load = clean + NOISE * float(np.ptp(clean)) * rng.standard_normal(n)
                    pos = s
                    if damage != "as made":
                        shift = int(rng.integers(1, n))
                        pos = np.round(np.roll(s, shift) / 0.01) * 0.01
                        load = np.roll(load, shift) + 2000.0 * LBF
                    start = time.perf_counter()
                    fit = identify_card(card(pos, load, spm, family), well)
                    ms = 1e3 * (time.perf_counter() - start)
                    if not fit.ok:
                        got.append((fit.status, math.nan, math.nan, False, False, ms))
                        continue
                    q = fit.quantities()
                    fl, fi = q["fluid_load"], q["fillage"]
                    fl_err = fl["value"] * LBF - fluid
                    fi_err = fi["value"] - truth.fillage
                    got.append((fit.status, 100 * abs(fi_err), 100 * abs(fl_err) / fluid,
                                inside(fl["value"], fl["stderr"], 2.0, fluid / LBF),
                                inside(fi["value"], fi["stderr"], 2.0, truth.fillage), ms))
                counts = collections.Counter(g[0] for g in got)
                rows.append([family, case, damage,
                             ", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
                             f"{np.nanmedian([g[1] for g in got]):.2f} / "
                             f"{np.nanmax([g[1] for g in got]):.2f}",
                             f"{np.nanmedian([g[2] for g in got]):.2f} / "
                             f"{np.nanmax([g[2] for g in got]):.2f}",
                             f"{sum(g[3] for g in got)} / {sum(g[4] for g in got)} of {len(got)}",
                             f"{np.median([g[5] for g in got]):.0f}"])
    table(f"(4) families not in the recovery: {per_case} cards per family, case and damage "
          "(made at 90 elements, 1 % white load noise); errors: median / largest",
          ["family", "case", "card", "statuses", "fillage |err|, points",
           "fluid load |err|, %", "within 2 SE: fluid / fillage", "ms per card"], rows)


# --------------------------------------------------------------------------- speed
def section_speed(seed: int, per_case: int) -> None:
    made = [make_case(case, i, seed) for case in CASES for i in range(per_case)]
    cards: list[Card] = [m["cards"]["white"] for m in made]
    wells = [m["well"] for m in made]
    alone = []
    for c, w in zip(cards, wells, strict=True):
        start = time.perf_counter()
        identify_card(c, w)
        alone.append(time.perf_counter() - start)
    start = time.perf_counter()
    identify_cards(cards, wells)
    listed = len(cards) / (time.perf_counter() - start)
    base = math.inf
    for _ in range(3):
        start = time.perf_counter()
        diagnose_cards(cards, wells)
        base = min(base, time.perf_counter() - start)
    base_rate = len(cards) / base
    alone_rate = 1.0 / float(np.median(alone))
    ms = 1e3 * np.array(alone)
    table(f"(3) speed: {len(cards)} white-noise cards (the quick run's: {per_case} per case, "
          "144-240 samples), one process",
          ["path", "ms per card", "cards/s", "vs diagnose_cards"],
          [["identify_card, one at a time (median)", f"{np.median(ms):.0f}",
            f"{alone_rate:.2f}", f"{alone_rate / base_rate:.2g}x"],
           [f"identify_card, one at a time (mean; p90 {np.percentile(ms, 90):.0f} ms, "
            f"max {ms.max():.0f} ms)", f"{ms.mean():.0f}", f"{1e3 / ms.mean():.2f}",
            f"{1e3 / ms.mean() / base_rate:.2g}x"],
           ["identify_cards, one call over the list", f"{1e3 / listed:.0f}",
            f"{listed:.2f}", f"{listed / base_rate:.2g}x"],
           ["diagnose_cards, one call (baseline, best of 3)", f"{1e3 / base_rate:.2f}",
            f"{base_rate:.0f}", "1x"]])


def _real(value: float | None) -> float:
    """A JSON-style value (None where not measurable) as a float (NaN)."""
    return math.nan if value is None else float(value)


def _periodic(model: PumpSystem, values: np.ndarray) -> bool:
    """Does the model reach a periodic stroke at these values (the march raises if not)?"""
    try:
        return bool(model.run(values).change < 1e3 * TOL)
    except ArithmeticError:
        return False


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cards", type=int, default=200, help="cards per case and noise")
    parser.add_argument("--quick", action="store_true", help="20 cards per case")
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--seed", type=int, default=25)
    parser.add_argument("--save", help="write one row per fitted card to this CSV file")
    parser.add_argument("--only", nargs="+", choices=("recovery", "real", "speed", "families"),
                        default=("recovery", "real", "speed", "families"),
                        help="sections to run")
    args = parser.parse_args()
    count = 20 if args.quick else args.cards
    # Compiled code loaded (and the cache filled) once, before the workers fork.
    start = time.perf_counter()
    run_one(("pound 70 %", 0, args.seed + 1))
    print(f"warm-up (compiled code loaded, one card made and fitted twice): "
          f"{time.perf_counter() - start:.1f} s")
    total = time.perf_counter()
    if "recovery" in args.only:
        section_recovery(count, args.processes, args.seed, args.save)
    if "real" in args.only:
        section_real()
    if "speed" in args.only:
        section_speed(args.seed, 20)
    if "families" in args.only:
        section_families(args.seed, 2 if args.quick else 4)
    print(f"\ntotal: {time.perf_counter() - total:.0f} s")


if __name__ == "__main__":
    main()
