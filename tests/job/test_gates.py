"""The gates: a fit that reproduces only the stroke's fundamental is no answer about the well."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import pumpid
from pumpid.cards import read_cards

from ..conftest import spread_card

PERIOD = 7.5


def _crank_card(load: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One period of a crank-like motion (in): its second harmonic is a tenth of its first,
    so the fundamental alone leaves 1 % of the variance."""
    t = np.arange(load.size) * PERIOD / load.size
    w = 2 * np.pi / PERIOD
    position = 60.0 * (1.0 - np.cos(w * t) + 0.1 * np.sin(2 * w * t))
    return t, load, position


def _periodic() -> pumpid.FitOptions:
    return pumpid.FitOptions(initial_state="periodic", period=PERIOD, offset=True)


def test_a_fit_of_the_fundamental_alone_is_undetermined_whatever_its_local_errors() -> None:
    # A load of pure noise: a mass-spring-dashpot reproduces the position's fundamental by a
    # resonance on the stroke frequency (m and k running to 1e8 together), R^2 = 100/101,
    # and its c, the ratio of the two fundamentals, had a finite error: "converged".
    load = 10_000.0 + 3_000.0 * np.random.default_rng(2).standard_normal(200)
    fit = pumpid.fit(pumpid.MassSpringDamper, _crank_card(load), options=_periodic())
    assert math.isclose(fit.r2_fundamental, 100 / 101, rel_tol=1e-9)
    assert fit.r2 < fit.r2_fundamental + 1e-6
    assert fit.r2_beyond < 1e-3
    assert fit.status is pumpid.Status.UNDETERMINED
    assert "reproduces only the stroke's fundamental" in fit.reason
    assert fit.determined["parameters"] == []
    assert set(fit.determined["not_determined"]) >= {"m", "c", "k"}
    # nor any derived quantity: the natural frequency is the stroke frequency it echoes
    assert fit.derived and not any(d.determined for d in fit.derived.values())
    out = json.loads(fit.to_json())
    assert math.isclose(out["r2_fundamental"], 100 / 101, rel_tol=1e-9)
    assert out["r2_beyond_fundamental"] < 1e-3
    row = fit.to_row()
    assert math.isclose(row["r2_beyond"], fit.r2_beyond) and "r2_fundamental" in row
    assert "the stroke's fundamental alone: 0.990099" in fit.report()


def test_a_model_that_explains_the_rest_keeps_its_status_and_says_how_much() -> None:
    card, _truth = spread_card(6)
    fit = pumpid.fit(pumpid.Kelvin, card)
    assert fit.status is pumpid.Status.CONVERGED
    assert fit.r2_fundamental < fit.r2
    assert fit.r2_beyond > 0.9
    assert "% of what it leaves" in fit.report()


def test_a_sinusoidal_position_leaves_nothing_beyond_its_fundamental_to_judge_by() -> None:
    # The controller export's positions are one sinusoid to its noise: no model can explain
    # more than the fundamental there, so the comparison says nothing of the fit.
    cards = read_cards(Path(__file__).parents[1] / "data" / "cards" / "controller_export.txt")
    fit = pumpid.fit(pumpid.Kelvin, cards[2])
    assert fit.r2_fundamental > 1 - 1e-6
    assert fit.determined["signal_beyond_fundamental"] is False
    assert "reproduces only the stroke's fundamental" not in fit.reason


def test_a_sinusoidal_position_says_what_its_two_numbers_determine() -> None:
    # A mass-spring-dashpot on a position that is one sinusoid within the noise: c (the
    # ratio of the fundamentals' quadrature) is determined and m, k are not, converged; it
    # read "explains 0.0 % of the rest" beside m in the millions, without a word.
    t = np.arange(200) * PERIOD / 200
    w = 2 * np.pi / PERIOD
    load = 50.0 + 10.0 * np.sin(w * t) + 2.0 * np.sin(2 * w * t)
    position = 1.5 * np.sin(w * t - 1.2) + 0.01 * np.random.default_rng(0).standard_normal(200)
    fit = pumpid.fit(pumpid.MassSpringDamper, (t, load, position), options=_periodic())
    assert fit.determined["signal_beyond_fundamental"] is False
    assert fit.status is pumpid.Status.CONVERGED and fit.determined["parameters"] == ["c"]
    assert any(w.startswith("the position is the stroke's fundamental within the noise")
               for w in fit.warnings)
    assert "what it leaves is at the noise level" in fit.report()
    assert "% of what it leaves" not in fit.report()


def test_records_that_are_not_one_period_have_no_fundamental_share() -> None:
    t = np.linspace(0.0, 20.0, 401)
    truth = pumpid.Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)
    load = 1000.0 + 300.0 * np.sin(2 * np.pi * t / 7.5)
    d = pumpid.simulate(truth, t, load)
    fit = pumpid.fit(pumpid.Kelvin, (t, load, d))
    assert math.isnan(fit.r2_fundamental) and math.isnan(fit.r2_beyond)
    assert "fundamental" not in fit.report()


def test_a_fit_worse_than_the_fundamental_is_not_said_to_reproduce_it() -> None:
    # The crank card read backwards in time: the fit is far worse than the fundamental
    # alone (R^2 0.18 against 0.99 on a real card) and the quality gate speaks for it; the
    # sentence "R^2 is about the share of the fundamental" would be false there.
    rng = np.random.default_rng(5)
    t, _, position = _crank_card(np.zeros(200))
    w = 2 * np.pi / PERIOD
    load = 9_000.0 + 2_000.0 * np.tanh(4 * np.sin(w * t)) + 20.0 * rng.standard_normal(200)
    fit = pumpid.fit(pumpid.Kelvin, (t, load[::-1], position), options=_periodic())
    assert fit.r2_beyond < -1e-3
    assert "reproduces only the stroke's fundamental" not in fit.reason
    assert "better than this fit" in fit.report()


def test_an_undetermined_fits_echo_is_named_in_its_reason() -> None:
    # No parameter determined, the fit explaining more than the fundamental, and the
    # natural frequency determined but an echo of the stroke: the reason listed it among
    # the "determined derived quantities" as if it were the well's.
    import dataclasses

    from pumpid.job.assemble import determination_gate

    card, _truth = spread_card(6)
    fit = pumpid.fit(pumpid.Kelvin, card)
    assert fit.status is pumpid.Status.CONVERGED and fit.r2_beyond > 0.9
    derived = dict(fit.derived)
    derived["natural_frequency"] = dataclasses.replace(
        derived["natural_frequency"], determined=True, well_property=False)
    gated = determination_gate(fit.with_parts(
        determined={**fit.determined, "parameters": []}, derived=derived))
    assert gated.status is pumpid.Status.UNDETERMINED
    assert ("determined derived quantities: natural_frequency (an echo of the stroke, not "
            "the well's)") in gated.reason
