"""Does ``pumpid batch --well-file`` cost anything? The same field with and without it.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_batch_downhole.py               # 4 wells x 40 cards
    .venv/bin/python benchmarks/bench_batch_downhole.py --cards 20    # quicker

The field: wells of one three-taper steel string (1, 7/8, 3/4 in; 4,900 ft) over a 1.75 in
pump, each card the surface card the rods' predictive solver gives for a valve pump of its
own fillage (full to 60 %), 100 samples, 0.2 % load noise, in the JSON layout (in/lbf, SPM,
time stamps). :func:`pumpid.fleet.run_batch` fits it (mass-spring-damper model, local
engine) without and with the pump quantities (``downhole=``, the well file), alternately,
``--repeats`` times each; the best time of each is compared. The downhole part alone
(:func:`pumpid.rods.diagnose_cards` on every card of the field, one call) is timed too.

A benchmark, not a test: it prints figures and checks nothing.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from pumpid.cards import read_cards
from pumpid.fleet import FitSpec, run_batch
from pumpid.fleet.downhole import DownholeSpec
from pumpid.rods import (
    MATERIALS,
    Fluid,
    Pump,
    PumpModel,
    Taper,
    Well,
    diagnose_cards,
    predict_surface,
    read_well_file,
)

FT, INCH, LBF = 0.3048, 0.0254, 4.4482216152605
SPM = 8.0
SPEC = {"rods": [{"length": 1500, "diameter": 1.0, "material": "steel"},
                 {"length": 1600, "diameter": 0.875, "material": "steel"},
                 {"length": 1800, "diameter": 0.75, "material": "steel"}],
        "pump": {"depth": 4900, "plunger_diameter": 1.75}, "tubing": {"anchored": True},
        "fluid": {"specific_gravity": 1.0}}


def write_field(folder: Path, wells: int, cards: int, n: int = 100) -> Path:
    """Write the field's card files and its well file; return the well file."""
    e, rho = MATERIALS["steel"]
    well = Well("w", (Taper(1500 * FT, 1.0 * INCH, e, rho), Taper(1600 * FT, 0.875 * INCH, e, rho),
                      Taper(1800 * FT, 0.75 * INCH, e, rho)),
                Pump(4900 * FT, 1.75 * INCH), fluid=Fluid(1000.0), system="us")
    rng = np.random.default_rng(3)
    w = 2 * np.pi * np.arange(n) / n
    stroke = 100 * INCH
    s = stroke / 2 * (1 - np.cos(w)) + 0.05 * stroke * np.sin(2 * w)
    total = wells * cards
    fill = rng.uniform(0.6, 1.0, total)
    level = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=np.full(total, level), fillage=fill,
                     intake_ratio=np.full(total, 0.01), transfer=np.full(total, 0.05))
    pred = predict_surface(well, np.repeat(s[None], total, 0), 60 / SPM, pump, nu=0.1,
                           tol=1e-5)
    load = pred.surface_load + well.buoyant_weight()
    load += 0.002 * np.ptp(load, axis=1, keepdims=True) * rng.standard_normal(load.shape)
    folder.mkdir(parents=True)
    ids = [f"W{k:02d}" for k in range(wells)]
    for k, wid in enumerate(ids):
        entries = [{"card_id": f"{wid}_{j:04d}", "timestamp": f"2026-01-{1 + j // 4:02d}T"
                    f"{6 * (j % 4):02d}:00:00Z", "spm": SPM,
                    "position": [round(v, 5) for v in s / INCH],
                    "load": [round(v, 3) for v in load[k * cards + j] / LBF]}
                   for j in range(cards)]
        (folder / f"{wid}.json").write_text(json.dumps(
            {"well": wid, "units": {"position": "in", "load": "lbf"}, "cards": entries}),
            encoding="utf-8")
    wf = folder.parent / "wells.json"
    wf.write_text(json.dumps({"units": {"length": "ft", "diameter": "in"},
                              "wells": dict.fromkeys(ids, SPEC)}), encoding="utf-8")
    return wf


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wells", type=int, default=4)
    ap.add_argument("--cards", type=int, default=40, help="cards per well")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-batch-downhole-"))
    try:
        t0 = time.perf_counter()
        wells = write_field(root / "field", args.wells, args.cards)
        total = args.wells * args.cards
        print(f"field: {total} cards of 100 samples, {args.wells} wells "
              f"(made in {time.perf_counter() - t0:.1f} s)")
        fit = FitSpec("msd")
        spec = DownholeSpec.load(wells, identify=False)  # the diagnostic's cost alone
        # warm-up: compiled code and imports, not timed
        run_batch([root / "field" / "W00.json"], root / "warm", fit=fit, downhole=spec)
        times: dict[str, list[float]] = {"without --well-file": [], "with --well-file": []}
        for r in range(args.repeats):
            for name, dh in (("without --well-file", None), ("with --well-file", spec)):
                out = root / f"run-{r}-{dh is not None}"
                t = time.perf_counter()
                run_batch([root / "field"], out, fit=fit, downhole=dh)
                times[name].append(time.perf_counter() - t)
        cards = [c for p in sorted((root / "field").glob("*.json")) for c in read_cards(p)]
        wf = read_well_file(wells)
        t = time.perf_counter()
        res = diagnose_cards(cards, wf)
        alone = time.perf_counter() - t
        assert all(r.ok for r in res)
        base = min(times["without --well-file"])
        print(f"{'run':<34}{'best time (s)':>14}{'cards/s':>10}{'ratio':>8}")
        for name, ts in times.items():
            print(f"{'pumpid batch ' + name:<34}{min(ts):>14.2f}{total / min(ts):>10.1f}"
                  f"{min(ts) / base:>8.3f}")
        print(f"{'diagnose_cards alone (all cards)':<34}{alone:>14.3f}{total / alone:>10.0f}"
              f"{alone / base:>8.3f}")
        every = {k: [round(x, 2) for x in v] for k, v in times.items()}
        print("ratio: time over the run without --well-file (same field, same run); "
              f"all times (s): {json.dumps(every)}")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
