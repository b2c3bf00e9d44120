"""The push test of :mod:`pumpid.inference.boundaries` on a solver problem."""

from __future__ import annotations

import math

import numpy as np

import pumpid
from pumpid.engine.problem import CardData, build_problem
from pumpid.inference.boundaries import push_test

from ..conftest import well_load


def _at(k1: float) -> tuple[list[tuple[str, str]], float]:
    """The push test's limits at the truth of a periodic Kelvin card (1 % noise) with this k1
    (the offset refitted, every log-parameter held), and k1 over its natural scale."""
    period, n = 6.0, 120
    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=3)
    truth = pumpid.Kelvin(k0=120.0, m=2.0, c1=60.0, k1=k1)
    clean = pumpid.simulate(truth, t, load, initial_state="periodic", period=period)
    noise = np.random.default_rng(0).standard_normal(n)
    data = clean + 7.0 + 0.01 * np.ptp(clean) * noise
    problem = build_problem(pumpid.Kelvin, [CardData(t, load, data, "periodic", period)],
                            offset=True)
    cards = np.zeros(1, dtype=np.int64)
    z0 = np.append(np.log(truth.values), float(np.mean(data)))[None]
    lo, hi = z0.copy(), z0.copy()
    lo[0, -1], hi[0, -1] = -math.inf, math.inf
    out = pumpid.LevenbergMarquardt().solve(problem, cards, z0, bounds=(lo, hi))
    found = push_test(problem, cards, out.z, out.cost, [{}])[0]
    return [(b.name, b.direction) for b in found], k1 / float(problem.reference[0][3])


def test_a_value_flat_both_ways_far_beyond_its_scale_is_at_that_limit() -> None:
    # k1 a millionth of its natural scale: a push of 1000 either way leaves the cost as it
    # is, and the value already lies in the limit k1 -> 0 (an oilfield card's k1 = 1.4e-5
    # kN/m, offset -5e6 m, stayed "converged": no single direction to call).
    limits, ratio = _at(9e-6)
    assert ratio < 1e-3 and limits == [("k1", "zero")]
    # Near its scale the same value is no limit.
    limits, ratio = _at(90.0)
    assert 1e-3 < ratio < 1e3 and limits == []
