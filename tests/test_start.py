"""Automatic start (pumpid.start): candidates, multistart with a guess, valley walk."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pumpid import FirstOrder, Kelvin, MassSpringDamper, Maxwell, fit, simulate
from pumpid.problem import build_problem
from pumpid.start import (
    _move,
    _Point,
    _polish,
    _valley_walk,
    _weakest_direction,
    candidate_starts,
    initial_estimate,
)

from .conftest import well_load

T = np.linspace(0.0, 20.0, 1001)
LOAD = well_load(T)
KELVIN = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)


def _err(params, truth) -> float:
    return max(abs(params[k] / v - 1) for k, v in truth.as_dict().items())


@pytest.mark.parametrize("truth", [KELVIN, Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0),
                                   MassSpringDamper(m=2.0, c=30.0, k=90.0)],
                         ids=lambda m: type(m).__name__)
def test_model_class_means_automatic_start(truth) -> None:
    data = simulate(truth, T, LOAD)
    res = fit(type(truth), T, LOAD, data)
    assert res.converged, res.reason
    assert _err(res.params, truth) < 1e-7
    assert res.extra["start"].startswith("automatic start")


def test_first_order_automatic_start() -> None:
    t = np.linspace(0, 10, 501)
    f = np.sin(t) + 2
    data = simulate(FirstOrder(tau=0.8), t, f)
    res = fit(FirstOrder, t, f, data)
    assert res.params["tau"] == pytest.approx(0.8, rel=1e-8)


def test_candidates_are_physical() -> None:
    problem = build_problem(Kelvin, T, LOAD, simulate(KELVIN, T, LOAD))
    cands = candidate_starts(problem)
    assert len(cands) >= 3
    assert all(np.all(np.isfinite(c)) and np.all(c > 0) for c in cands)


def test_a_poor_guess_joins_the_multistart_and_loses() -> None:
    data = simulate(KELVIN, T, LOAD)
    problem = build_problem(Kelvin, T, LOAD, data)
    # A guess far away (factors 0.005 to 1.4): plain lm from it ends in another minimum,
    # not at the truth.
    guess = KELVIN.values * np.array([0.0052, 1.3856, 0.6288, 0.0068])
    plain = fit(Kelvin.from_values(guess), T, LOAD, data, multistart=False)
    assert _err(plain.params, KELVIN) > 1e-3
    theta, note = initial_estimate(problem, guess=guess)
    assert "automatic" in note
    res = fit(Kelvin.from_values(theta), T, LOAD, data)
    assert _err(res.params, KELVIN) < 1e-7


def test_a_good_guess_is_kept() -> None:
    data = simulate(KELVIN, T, LOAD)
    problem = build_problem(Kelvin, T, LOAD, data)
    theta, note = initial_estimate(problem, guess=KELVIN.values * 1.01)
    assert "given guess" in note or np.allclose(theta, KELVIN.values, rtol=1e-6)
    assert np.allclose(theta, KELVIN.values, rtol=1e-3)


def _weak_arm_card(noise: float = 0.0):
    # A Maxwell arm much softer than the main spring (k0/k1 ~ 28), on a periodic card with
    # an offset: the data pin the arm only along a long, curved, flat valley.
    truth = Maxwell(k0=118.0, m=18.6, c1=52.0, k1=4.2)
    period, n = 8.0, 401
    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=5)
    data = simulate(truth, t, load, initial_state="periodic", period=period) + 12.0
    data = data + noise * np.ptp(data) * np.random.default_rng(0).standard_normal(n)
    return truth, t, load, data, {"initial_state": "periodic", "period": period,
                                  "offset": True}


@pytest.mark.parametrize("jump", [1.0, 2.0])
def test_valley_walk_reaches_the_truth_on_a_weak_maxwell_arm(jump) -> None:
    truth, t, load, data, opts = _weak_arm_card()
    problem = build_problem(Maxwell, t, load, data, **opts)
    # A point on the valley's floor far from the truth: a jump along the weakest direction
    # from the truth, dropped back to the floor by a short polish that runs out there.
    at_truth = _Point(truth.values, 1.0, 12.0, 0.0, False)
    weak, size = _weakest_direction(problem, at_truth)
    assert size < 1e-4  # a valley the walk is meant for
    theta, scale, offset = _move(problem, at_truth, jump * weak)
    floor = _polish(problem, theta, 10, scale, offset)
    assert floor is not None and floor.stopped_early
    names = truth.param_names()
    assert _err(dict(zip(names, floor.theta, strict=True)), truth) > 1.0
    walked = _valley_walk(problem, floor)
    assert walked.cost < 1e-15 * floor.cost
    assert _err(dict(zip(names, walked.theta, strict=True)), truth) < 1e-9
    res = fit(Maxwell, t, load, data, **opts)
    assert _err(res.params, truth) < 1e-6


def test_valley_walk_stays_put_on_noisy_data() -> None:
    # With noise the valley floor is flat at the noise level: nothing to gain by walking.
    truth, t, load, data, opts = _weak_arm_card(noise=0.01)
    problem = build_problem(Maxwell, t, load, data, **opts)
    res = fit(truth, t, load, data, **opts)
    r = problem.residual_vector(problem.outputs(res.model.values), res.scale, res.offset)
    pt = _Point(res.model.values, res.scale, res.offset, 0.5 * float(r @ r))
    walked = _valley_walk(problem, pt)
    assert walked.cost >= 0.95 * pt.cost * (1 - 1e-9) or math.isclose(walked.cost, pt.cost)
