"""A field of rod-pumped wells on disk whose pumps are known (not a test module): the
tests' form of :mod:`pumpid.fleet.pumpfield` (fillage per well, little noise)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from pumpid.fleet import pumpfield
from pumpid.fleet.pumpfield import PumpWell, write_well_file

__all__ = ["write_pump_field", "write_well_file"]


def write_pump_field(folder: Path, fillage: Mapping[str, Callable[[int], float]], *,
                     cards: int = 60, n_samples: int = 100, noise: float = 0.002,
                     seed: int = 5) -> pd.DataFrame:
    """Write one JSON file per well (and ``wells.json`` beside the folder); return the
    truth (well_id, card_id, card_index, fillage, fluid_load).

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
    return pumpfield.write_pump_field(
        folder, {w: PumpWell(fillage=f) for w, f in fillage.items()}, cards=cards,
        n_samples=n_samples, noise=noise, level_scatter=noise, seed=seed)
