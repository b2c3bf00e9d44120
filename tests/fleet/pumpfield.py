"""A field of rod-pumped wells on disk whose pumps are known (not a test module).

Each well is the same three-taper string over a 1.75 in pump; each card is the surface card
the rods' predictive solver gives for a prescribed valve pump (its liquid fillage per card),
with a little measurement noise and a slowly varying fluid level, written in the synthetic
field's JSON layout (one file per well, in/lbf, time stamps, SPM).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from pumpid.rods import PumpModel, predict_surface
from tests.rods.strings import INCH, LBF, surface_motion, three_tapers

SPM = 8.0
NU = 0.1

#: The well file of :func:`write_pump_field` (US units), one entry per well id.
WELL_SPEC = {"rods": [{"length": 1500, "diameter": 1.0, "material": "steel"},
                      {"length": 1600, "diameter": 0.875, "material": "steel"},
                      {"length": 1800, "diameter": 0.75, "material": "steel"}],
             "pump": {"depth": 4900, "plunger_diameter": 1.75},
             "tubing": {"anchored": True}, "fluid": {"density": 1000.0 / 16.01846337396014}}


def write_well_file(path: Path, wells: list[str]) -> Path:
    """Write the well file of the given well ids."""
    doc = {"units": {"length": "ft", "diameter": "in"}, "wells": dict.fromkeys(wells,
                                                                                WELL_SPEC)}
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return path


def write_pump_field(folder: Path, fillage: Mapping[str, Callable[[int], float]], *,
                     cards: int = 60, n_samples: int = 100, noise: float = 0.002,
                     seed: int = 5) -> pd.DataFrame:
    """Write one JSON file per well; return the truth (well_id, card_id, fillage).

    Parameters
    ----------
    fillage : mapping of well id to a function of the card's index
        The liquid fraction the pump admits on that card.
    cards : int
        Cards per well, one every six hours.
    noise : float
        Load noise, relative to the card's load range (and the fluid level's card-to-card
        scatter, relative).
    """
    rng = np.random.default_rng(seed)
    well = three_tapers()
    s = surface_motion(n=n_samples, period=60 / SPM)
    base_load = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    truth = []
    folder.mkdir(parents=True, exist_ok=True)
    start = pd.Timestamp("2026-01-01T00:00:00Z")
    # Every card of the field in one call of the predictive solver (one string).
    fill = np.array([fill_of(k) for fill_of in fillage.values() for k in range(cards)])
    total = fill.size
    level = base_load * (1 + noise * rng.standard_normal(total))
    pump = PumpModel(fluid_load=level, fillage=fill, intake_ratio=np.full(total, 0.01),
                     transfer=np.full(total, 0.05))
    pred = predict_surface(well, np.repeat(s[None], total, 0), 60 / SPM, pump, nu=NU,
                           tol=1e-5)
    loads = pred.surface_load + well.buoyant_weight()
    loads = loads + noise * np.ptp(loads, axis=1, keepdims=True) * rng.standard_normal(
        loads.shape)
    for w, wid in enumerate(fillage):
        load = loads[w * cards:(w + 1) * cards]
        entries = []
        for k in range(cards):
            stamp = start + pd.Timedelta(hours=6 * k)
            cid = f"{wid}_{stamp.strftime('%Y%m%dT%H%M')}Z"
            entries.append({"card_id": cid, "timestamp": stamp.strftime("%Y-%m-%dT%H:%M:%SZ"),
                            "spm": SPM, "position": [round(v, 5) for v in s / INCH],
                            "load": [round(v, 3) for v in load[k] / LBF]})
            truth.append({"well_id": wid, "card_id": cid, "fillage": fill[w * cards + k]})
        doc = {"well": wid, "units": {"position": "in", "load": "lbf"}, "cards": entries}
        (folder / f"{wid}.json").write_text(json.dumps(doc), encoding="utf-8")
    return pd.DataFrame(truth)
