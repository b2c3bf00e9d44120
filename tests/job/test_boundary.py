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


def test_a_value_far_below_its_scale_is_not_said_to_run_to_infinity(shared_raw) -> None:
    # An oilfield card (the first 200 samples of its 250, the rest padding) stopped on its
    # budget at m = 8.4e-7 kN s^2/m, 4e6 below its natural scale; a push of m by 1000 up
    # lowered the unfinished fit's cost, and the answer said "m runs to infinity (fitted
    # value 8.424e-07 ...)".
    from pumpid.cards import Card, read_cards

    path = shared_raw / "shapeformer_oilfield2d" / "OilfieldData2d_TEST_subset360.ts"
    read = read_cards(path, position_unit="m", load_unit="kN", spm=8)[181]
    n, period = 200, 7.5
    card = Card(position=read.position[:n], load=read.load[:n], t=np.arange(n) * period / n,
                position_unit="m", load_unit="kN", time_source="spm", periodic=True,
                period=period, spm=8.0, card_id="oilfield 181")
    res = pumpid.fit(Kelvin, card)
    said = [w for w in res.warnings if "runs to infinity" in w]
    for w in said:
        name = w.split()[0]
        assert res.params[name] >= 1e-3 * res.problem.reference[0][
            list(res.problem.model.param_names()).index(name)], w
    assert not any(w.startswith("m runs to infinity") for w in res.warnings)
