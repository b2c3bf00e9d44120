"""Boundary solutions through ``pumpid.fit``: which answers may be called a limit."""

from __future__ import annotations

import numpy as np

import pumpid
from pumpid import FitOptions, Kelvin, LevenbergMarquardt, simulate

T = np.linspace(0.0, 20.0, 401)
LOAD = 10.0 + 3.0 * np.sin(0.9 * T)


def _record(truth: Kelvin) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u = simulate(truth, T, LOAD, observe="u")
    return T, LOAD, u + 0.01 * np.random.default_rng(0).standard_normal(T.size)


def test_a_fit_stopped_on_its_budget_is_not_called_a_limit() -> None:
    # k0 = 4 is interior and well determined (the full fit: 3.995 +- 0.009). Stopped after
    # five evaluations, the unfinished fit and its unfinished reduced fits used to make it a
    # "boundary" (k0 -> infinity, exit 0) with the likelihood-ratio test's words.
    data = _record(Kelvin(k0=4.0, m=1.0, c1=2.0, k1=4.0))
    res = pumpid.fit(Kelvin(k0=6.0, m=1.3, c1=1.5, k1=5.0), data,
                     options=FitOptions(observe="u", multistart=False),
                     solver=LevenbergMarquardt(max_evaluations=5))
    assert res.status is pumpid.Status.FAILED
    assert res.boundary is None or not res.boundary.limits
    # From further away, stopped after 20-40: the solve at the limit beat the unfinished
    # point (and the reduced model converged), and it was a boundary at k0 = 6.1e5. It
    # stays failed, at its own point, the limit said as a suspicion.
    for budget in (20, 40):
        res = pumpid.fit(Kelvin(k0=400.0, m=1.3, c1=1.5, k1=5.0), data,
                         options=FitOptions(observe="u", multistart=False),
                         solver=LevenbergMarquardt(max_evaluations=budget))
        assert res.status is pumpid.Status.FAILED, budget
        assert res.params["k0"] < 1e5
    full = pumpid.fit(Kelvin, data, options=FitOptions(observe="u"))
    assert full.status is pumpid.Status.CONVERGED
    assert abs(full.params["k0"] - 4.0) < 5 * full.stderr["k0"]


def test_a_fixed_value_leaves_the_push_test_on() -> None:
    # With m fixed, k0 = 1e7 (a rigid series spring) ran to 4.5e6 and was "converged": every
    # boundary test was skipped. Pushing k0 a factor 1000 up leaves the cost unchanged.
    data = _record(Kelvin(k0=1e7, m=1.0, c1=2.0, k1=4.0))
    res = pumpid.fit(Kelvin, data, options=FitOptions(observe="u", fixed={"m": 1.0}))
    assert res.status is pumpid.Status.BOUNDARY
    assert [(b.name, b.direction) for b in res.boundary.limits] == [("k0", "infinity")]
    assert res.params["m"] == 1.0
