"""The compiled driver: every task that simulates runs through one compiled signature."""

from __future__ import annotations

import numpy as np

from pumpid import Kelvin, fit, simulate
from pumpid.engine import drive
from pumpid.engine.problem import CardData, build_problem

from ..conftest import well_load

TRUTH = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)


def _problem():
    period, n = 8.0, 200
    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=3)
    data = simulate(TRUTH, t, load, initial_state="periodic", period=period) + 5.0
    return build_problem(Kelvin, [CardData(t, load, data, "periodic", period)], offset=True)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a.flags.writeable = False
    return a


def test_every_task_shares_one_compiled_signature() -> None:
    # A second signature of drive.items compiles the whole simulation again on a fresh
    # install (about 14 s on one core): every task, whatever arrays its caller hands over
    # (read-only, another integer type, a list), must reach it with the same types.
    problem = _problem()
    data, model, settings = problem.arrays
    z = np.r_[np.log(TRUTH.values), 5.0 + float(problem.offset_gap(0, TRUTH.values, 1.0))]
    q = z.size
    cards = np.zeros(2, dtype=np.int64)
    points = np.vstack([z, z + 0.01])
    before = set(drive.items.signatures)

    lo, hi = points - 3.0, points + 3.0
    out = drive.solve_items(_frozen(cards.astype(np.int32)), _frozen(points), lo, hi, 1e-10,
                            [30, 30], 4, 0.0, data, model, settings)
    assert np.all(np.isfinite(out[1])) and np.all(out[2] >= 1)
    history = np.zeros((31, q + 1))
    one = drive.solve_one(points[1], lo[1], hi[1], 1e-10, 30, 0.0, 0, data, model,
                          settings, history)
    assert one[6] >= 1 and history[0, q] > 0.0
    np.testing.assert_allclose(one[0], out[0][1], rtol=1e-12)
    completed, cost = drive.linear_items([0], points[:1, :].tolist(), drive.BEST_LINEAR,
                                         data, model, settings)
    assert np.isfinite(cost[0])
    # Costing the completed point as given gives the cost its completion reported.
    np.testing.assert_allclose(drive.cost_items([0], _frozen(completed), data, model,
                                                settings), cost, rtol=1e-12)
    buffer, starts, ok = drive.rows_items(cards, points, data, model, settings)
    assert ok.all() and starts[-1] == buffer.size == 2 * (q + 1) * problem.n_samples(0)
    y, good = drive.outputs(cards, points, data, model, settings, 2 * problem.n_samples(0))
    assert good.all() and np.isfinite(y).all()

    # The main job on the same card: the same signature again.
    t, load, d = problem.card(0)
    res = fit(Kelvin, CardData(t, load, d, "periodic", 8.0))
    assert res.converged, res.reason
    assert len(set(drive.items.signatures) - before) <= 1
    assert len(drive.items.signatures) <= len(before) + 1


def test_a_card_timed_far_from_zero_is_still_uniformly_sampled() -> None:
    # 0.02 s steps written after 777600 s (the ninth day of a record) differ by 3e-9 of a
    # step in floating point: judged against 1e-9 alone, the card was simulated step by
    # step as non-uniform, 37 s a fit instead of 64 ms. Its answer is the card's at zero.
    period, n = 8.0, 200
    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=3)
    data = simulate(TRUTH, t, load, initial_state="periodic", period=period) + 5.0
    for start in (777600.0, 1.7e9):
        late = start + t
        assert np.ptp(np.diff(late)) > 1e-9 * period / n
        problem = build_problem(Kelvin, [CardData(late, load, data, "periodic", period)],
                                offset=True)
        assert problem.uniform[0]
    # Sampling that is not uniform stays so, near zero and far from it.
    for start in (0.0, 777600.0):
        jitter = start + t + np.r_[0.0, 1e-6 * np.sin(np.arange(1, n))]
        problem = build_problem(Kelvin, [CardData(jitter, load, data, "periodic", period)],
                                offset=True)
        assert not problem.uniform[0]
