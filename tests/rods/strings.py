"""Wells and cards the rod tests share (not a test module)."""

from __future__ import annotations

from typing import Any

import numpy as np

from pumpid.cards import Card
from pumpid.rods import MATERIALS, Fluid, Pump, PumpModel, Taper, Well, predict_surface

FT, INCH, LBF = 0.3048, 0.0254, 4.4482216152605
STEEL = MATERIALS["steel"]


def three_tapers(fluid: float | None = 1000.0) -> Well:
    """A 4,900 ft string of 1, 7/8 and 3/4 in steel rods over a 1.75 in pump."""
    e, rho = STEEL
    return Well("three", (Taper(1500 * FT, 1.0 * INCH, e, rho),
                          Taper(1600 * FT, 0.875 * INCH, e, rho),
                          Taper(1800 * FT, 0.75 * INCH, e, rho)),
                Pump(4900 * FT, 1.75 * INCH), fluid=None if fluid is None else Fluid(fluid),
                system="us")


def uniform(length: float = 1500.0, diameter: float = 0.0222) -> Well:
    e, rho = STEEL
    return Well("uniform", (Taper(length, diameter, e, rho),), Pump(length, 0.044),
                fluid=Fluid(1000.0), system="metric")


def surface_motion(n: int = 200, period: float = 7.5, stroke: float = 100 * INCH) -> np.ndarray:
    """A polished-rod position over one stroke (m): a crank-like motion."""
    w = 2 * np.pi * np.arange(n) / n
    return stroke / 2 * (1 - np.cos(w)) + 0.05 * stroke * np.sin(2 * w)


def card(position_m: np.ndarray, load_n: np.ndarray, spm: float, card_id: str = "c",
         metric: bool = False) -> Card:
    """A surface card in in/lbf (or m/kN) with time from the pumping speed."""
    if metric:
        return Card(position=position_m, load=load_n / 1000.0, position_unit="m",
                    load_unit="kN", card_id=card_id).with_spm(spm)
    return Card(position=position_m / INCH, load=load_n / LBF, position_unit="in",
                load_unit="lbf", card_id=card_id).with_spm(spm)


def cmcm_well_document(entry: dict[str, Any], common: dict[str, Any],
                       well_id: str) -> dict[str, Any]:
    """A well of the public CMCM 2012 set (its own ``wells.json`` entry and common values)
    as a well file in pumpid's schema: metric units, anchored tubing, and a fluid of crude
    and water mixed by the water cut (the set gives no mixture density; its notes say its
    teams mixed them so)."""
    water = entry["water_cut"]
    density = (common["crude_oil_density_kg_m3"] * (1 - water)
               + common["water_density_kg_m3"] * water)
    return {"units": {"length": "m", "diameter": "mm", "modulus": "Pa", "density": "kg/m3"},
            "wells": {well_id: {
                "rods": [{"length": t["length_m"], "diameter": t["diameter_mm"],
                          "modulus": t["E_Pa"], "density": t["density_kg_m3"]}
                         for t in entry["rod_tapers"]],
                "pump": {"depth": entry["pump_depth_m"],
                         "plunger_diameter": entry["plunger_diameter_mm"]},
                "tubing": {"anchored": True},
                "fluid": {"density": density}}}}


def pound_70(n: int = 200, spm: float = 8.0) -> tuple[Well, np.ndarray, Any, float]:
    """The three-taper string's 70 % fluid pound at ``spm`` (nu 0.1, 60 elements): the
    well, the surface position (m), the prediction and the fluid load (N)."""
    well = three_tapers()
    s = surface_motion(n=n, period=60 / spm)
    fluid = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=fluid, fillage=0.7, intake_ratio=0.01, transfer=0.05)
    pred = predict_surface(well, s, 60 / spm, pump, nu=0.1, tol=1e-9, elements=60)
    return well, s, pred, fluid
