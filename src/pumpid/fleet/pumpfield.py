"""A synthetic field of rod-pumped wells whose pumps are known: cards for the fleet demo.

Every well is the same three-taper steel string over a 1.75 in pump (:data:`WELL_SPEC`,
written as a well file by :func:`write_well_file`). Each card is the surface card the rods'
predictive solver (:func:`pumpid.rods.predict_surface`) gives for a valve pump
(:class:`pumpid.rods.PumpModel`) with the card's liquid fillage and fluid load, plus
measurement noise, in the synthetic field's JSON layout: one file per well, in/lbf, a time
stamp and the pumping speed per card. A well's fillage and fluid load are functions of the
card's index, so a change (fluid pound starting, a leaking valve) is placed exactly.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pumpid.rods import PumpModel, Well, predict_surface, read_well_file

__all__ = ["WELL_SPEC", "PumpWell", "surface_motion", "write_pump_field", "write_well_file"]

_INCH, _LBF, _G = 0.0254, 4.4482216152605, 9.80665

#: A well of the field, as one entry of a well file in US units (ft, in).
WELL_SPEC: dict[str, Any] = {
    "rods": [{"length": 1500, "diameter": 1.0, "material": "steel"},
             {"length": 1600, "diameter": 0.875, "material": "steel"},
             {"length": 1800, "diameter": 0.75, "material": "steel"}],
    "pump": {"depth": 4900, "plunger_diameter": 1.75},
    "tubing": {"anchored": True}, "fluid": {"specific_gravity": 1.0},
}

Schedule = float | Callable[[int], float]


@dataclass(frozen=True)
class PumpWell:
    """The pump of one well over its cards.

    Attributes
    ----------
    fillage : float or callable
        Liquid fraction the pump admits (0-1], or a function of the card's index giving it.
    load_factor : float or callable
        Fluid load as a multiple of the field's (a 90 % fluid column over the pump), or a
        function of the card's index: below 1 a lower fluid load (a leaking valve).
    """

    fillage: Schedule = 1.0
    load_factor: Schedule = 1.0

    def at(self, k: int) -> tuple[float, float]:
        """Fillage and load factor of card ``k``."""
        def value(s: Schedule) -> float:
            return float(s(k) if callable(s) else s)

        return value(self.fillage), value(self.load_factor)


def surface_motion(n: int, stroke: float = 100 * _INCH) -> np.ndarray:
    """A polished-rod position over one stroke (m) at ``n`` instants uniform in time: a
    crank-like motion (a cosine with a little second harmonic)."""
    w = 2 * np.pi * np.arange(n) / n
    return stroke / 2 * (1 - np.cos(w)) + 0.05 * stroke * np.sin(2 * w)


def write_well_file(path: str | Path, wells: list[str]) -> Path:
    """Write a well file (US units) describing each of ``wells`` by :data:`WELL_SPEC`."""
    out = Path(path)
    doc = {"units": {"length": "ft", "diameter": "in"},
           "wells": dict.fromkeys(wells, WELL_SPEC)}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return out


def write_pump_field(folder: str | Path, wells: Mapping[str, PumpWell], *, cards: int = 60,
                     n_samples: int = 100, noise: float = 0.01, level_scatter: float = 0.01,
                     spm: float = 8.0, nu: float = 0.1, hours: float = 6.0,
                     seed: int = 5) -> pd.DataFrame:
    """Write one JSON card file per well and the well file beside them; return the truth.

    Parameters
    ----------
    folder : path
        Where the card files go (``<well>.json``); the well file is ``wells.json`` in
        ``folder``'s parent.
    wells : mapping of well id to PumpWell
        The wells and their pumps.
    cards : int
        Cards per well, one every ``hours`` hours from 2026-01-01 00:00 UTC.
    n_samples : int
        Samples per card.
    noise : float
        Load noise (white, Gaussian), relative to each card's load range.
    level_scatter : float
        Card-to-card scatter of the fluid load (the fluid level), relative.
    spm : float
        Pumping speed, strokes per minute.
    nu : float
        Gibbs' dimensionless damping factor of the strings.
    seed : int
        Seed of the noise.

    Returns
    -------
    pandas.DataFrame
        One row per card: ``well_id``, ``card_id``, ``card_index``, ``fillage`` (liquid
        fraction, 0-1) and ``fluid_load`` (lbf) of the pump that made it.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    ids = list(wells)
    well_file = write_well_file(out.parent / "wells.json", ids)
    well: Well = read_well_file(well_file).wells[ids[0]]  # the same string everywhere
    rng = np.random.default_rng(seed)
    period = 60.0 / spm
    s = surface_motion(n_samples)
    rho = well.fluid.density if well.fluid is not None else 1000.0
    base = 0.9 * rho * _G * well.pump.depth * well.pump.area
    plan = np.array([wells[w].at(k) for w in ids for k in range(cards)])
    total = len(plan)
    fluid_load = base * plan[:, 1] * (1 + level_scatter * rng.standard_normal(total))
    pump = PumpModel(fluid_load=fluid_load, fillage=plan[:, 0],
                     intake_ratio=np.full(total, 0.01), transfer=np.full(total, 0.05))
    # Every card of the field in one call of the predictive solver (one string).
    pred = predict_surface(well, np.repeat(s[None], total, 0), period, pump, nu=nu, tol=1e-5)
    loads = pred.surface_load + well.buoyant_weight()
    loads = loads + noise * np.ptp(loads, axis=1, keepdims=True) * rng.standard_normal(
        loads.shape)
    start = pd.Timestamp("2026-01-01T00:00:00Z")
    truth = []
    for w, wid in enumerate(ids):
        entries = []
        for k in range(cards):
            j = w * cards + k
            stamp = start + pd.Timedelta(hours=hours * k)
            cid = f"{wid}_{stamp.strftime('%Y%m%dT%H%M')}Z"
            entries.append({"card_id": cid, "timestamp": stamp.strftime("%Y-%m-%dT%H:%M:%SZ"),
                            "spm": spm, "position": [round(v, 5) for v in s / _INCH],
                            "load": [round(v, 3) for v in loads[j] / _LBF]})
            truth.append({"well_id": wid, "card_id": cid, "card_index": k,
                          "fillage": plan[j, 0], "fluid_load": fluid_load[j] / _LBF})
        doc = {"well": wid, "units": {"position": "in", "load": "lbf"}, "cards": entries}
        (out / f"{wid}.json").write_text(json.dumps(doc), encoding="utf-8")
    return pd.DataFrame(truth)
