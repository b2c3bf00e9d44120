"""The three families of cards the main job is measured and checked on.

(a) ``periodic``: one stroke each, periodic steady state, a position offset to fit,
    Kelvin parameters log-uniform over a factor 10 around a field-like centre, 200 samples,
    1 % noise; (b) ``rest``: three strokes from rest whose slow (creep) mode has not decayed
    within the record, parameters log-uniform over a factor 10, 600 samples, 1 % noise;
    (c) ``controller``: controller-export-like cards of 130 samples, position from a
    crank-rocker unit's kinematics, load from the model, 0.3 % noise.

Used by the equivalence tests and by the benchmarks (the same cards in both).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

import pumpid
from pumpid.cards import Card
from pumpid.pump.synthetic import CardLabel, synthetic_card

from .conftest import well_load

#: Centre of the parameter cloud (inch, lbf, s): k0, m, c1, k1.
CENTRE = np.array([5200.0, 20.0, 900.0, 5200.0])
#: Creep families: c1 times this makes the slow mode's time constant (about
#: c1 (k0 + k1) / (k0 k1), some 35 s at the centre) longer than the record (18-36 s).
SLOW = 100.0


def _theta(rng: np.random.Generator) -> np.ndarray:
    half = math.log(10.0) / 2
    return CENTRE * np.exp(rng.uniform(-half, half, CENTRE.size))


def periodic_card(i: int, rng: np.random.Generator, n: int = 200) -> Card:
    """Family (a): one periodic stroke with an offset."""
    model = pumpid.Kelvin.from_values(_theta(rng))
    period = 60.0 / rng.uniform(5.0, 10.0)
    t = np.arange(n) * period / n
    load = well_load(t, period, seed=i)
    pos = pumpid.simulate(model, t, load, observe="u", initial_state="periodic",
                          period=period)
    pos = pos + 0.01 * np.ptp(pos) * rng.standard_normal(n) + rng.uniform(-50.0, 50.0)
    return Card(position=pos, load=load, t=t, card_id=f"a{i}", source="family a",
                position_unit="in", load_unit="lbf", time_source="file", periodic=True,
                period=period)


def rest_card(i: int, rng: np.random.Generator, n: int = 600) -> Card:
    """Family (b): three strokes from rest, the creep mode still running at the end."""
    theta = _theta(rng)
    theta[2] *= SLOW
    model = pumpid.Kelvin.from_values(theta)
    period = 60.0 / rng.uniform(5.0, 10.0)
    t = np.linspace(0.0, 3.0 * period, n)
    load = well_load(t, period, seed=i)
    pos = pumpid.simulate(model, t, load, observe="u")
    pos = pos + 0.01 * np.ptp(pos) * rng.standard_normal(n)
    return Card(position=pos, load=load, t=t, card_id=f"b{i}", source="family b",
                position_unit="in", load_unit="lbf", time_source="file", periodic=False)


def controller_card(i: int, rng: np.random.Generator) -> Card:
    """Family (c): a controller-export-like card of 130 samples."""
    model = pumpid.Kelvin.from_values(_theta(rng))
    return synthetic_card(model, spm=rng.uniform(5.0, 10.0), n_samples=130, stroke=100.0,
                          observe="u", noise=0.003, seed=i,
                          label=CardLabel(card_id=f"c{i}"))


FAMILIES: dict[str, Callable[[int, np.random.Generator], Card]] = {
    "periodic": periodic_card,
    "rest": rest_card,
    "controller": controller_card,
}


def family(name: str, n: int, seed: int = 0) -> list[Card]:
    """``n`` cards of a family, the same for the same seed."""
    rng = np.random.default_rng(seed)
    make = FAMILIES[name]
    return [make(i, rng) for i in range(n)]
