"""One verb: arrays, a card and a list of cards through ``pumpid.fit``.

``data/pinned/verbs.json`` holds what the old verbs returned on the same data just before
they were replaced by :func:`pumpid.fit` (``pumpid.fit(model, t, load, displacement, ...)``,
``pumpid.fit_many``, ``pumpid.pump.fit_card`` and ``fit_cards``): the one verb must give the
same numbers (the same code runs underneath, so they agree to rounding). The numbers were
taken again when the solver's small SVD (one-sided Jacobi) replaced LAPACK's: on the noisy
arrays a weakly determined damper moved by at most 3e-8 (relative), and on the controller
cards, whose parameters the data do not determine, the walk along their flat valley ended
elsewhere (costs 0.27 % and 0.016 % lower, 0.09 % higher). And again when the equation-error
start's least squares became a Householder QR with the small SVD and its stability test the
Routh array (LAPACK's least squares and eigenvalues, compiled, cost seconds of a fresh
install's first fit): on the noisy arrays, whose stiffness runs to its bound, the damper
moved by 2e-8 and the mass and spring by 4e-9 and 2e-9 (relative), at a cost lower by
3e-14; on a noiseless card of the batch the cost is rounding (2e-28 then 6e-28) and so are
the standard errors that scale with it. And again when a periodic card's closing step
reused the grid's one-step map instead of a second matrix exponential of the same step (a
rounding-level change): the noisy arrays moved by about 1e-11, and the controller cards'
walks along their flat valleys ended elsewhere (costs 0.20 % lower, 0.18 % and 0.02 %
higher; a third card's fit moved from a boundary to undetermined at a cost 1.3e-5 higher).
And again when a periodic card's solve that crawls went on along the harmonic cost: the
controller cards' costs 0.43 %, 0.33 % and 0.09 % lower, the Maxwell card's 0.04 % higher
(undetermined to boundary), the periodic arrays' 4e-9 higher. And again when the harmonic
cost's transfer function became a ratio of polynomials (rounding-level): the controller
cards' walks ended elsewhere along their flat valleys (costs 2.1e-5 and 3.0e-5 lower,
1.0e-6 higher), the Maxwell card's 3.6e-5 lower, the periodic arrays' by 5e-15. And the
errors shown (not the answers) when the serial test learned what a fit leaves of white
noise: two 28-sample controller cards (lag-1 autocorrelation 0.29, 2.3 standard deviations
above a fit's white residuals) now show the robust errors: the offset's 0.00065 where the
independent-noise one is 0.00035, the Maxwell card's c1 12.0 where it is 8.4. And the
offset's error on the controller cards (not the answers) when an offset the card does not
fix (its static stiffness not determined) lost the error it had borrowed from the position
at the card's mean load: 0.00058-0.00065, now infinite. And the errors of the arrays'
boundary fit (not the answers) when a boundary fit's errors came to reach the model's
interior within the noise (k0 back from infinity to 2.54, the truth 4), each its reach
there plus its own error: c1 0.0012 -> 0.081, k1 0.0039 -> 1.59 and m 0.0024 -> 0.0048,
the intervals of c1 and k1 now holding the truth (0.2 and 4). And the Maxwell card's robust
error of c1 (not the answer) when a periodic card's serial statistics came to run around its
stroke (the last sample the first one's neighbour): 11.95 -> 11.91.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import pumpid
from pumpid.cards import read_cards

from .conftest import pinned_periodic_fit

DATA = Path(__file__).parent / "data"
PINNED = json.loads((DATA / "pinned" / "verbs.json").read_text())
TRUTH = pumpid.Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0)


def _row(res: pumpid.FitResult) -> dict[str, Any]:
    unc = res.uncertainty
    return {"status": res.status.key, "cost": float(res.cost), "r2": float(res.r2),
            "params": {k: float(v) for k, v in res.params.items()},
            "scale": float(res.scale), "offset": float(res.offset),
            "stderr": {} if unc is None else {k: float(v) for k, v in unc.stderr.items()}}


def _same(new: dict[str, Any], old: dict[str, Any]) -> None:
    assert new["status"] == old["status"]
    for key in ("cost", "r2", "scale", "offset"):
        assert new[key] == pytest.approx(old[key], rel=1e-9, abs=1e-12), key
    for name, value in old["params"].items():
        assert new["params"][name] == pytest.approx(value, rel=1e-9), name
    assert set(new["stderr"]) == set(old["stderr"])
    for name, value in old["stderr"].items():
        if math.isfinite(value):
            assert new["stderr"][name] == pytest.approx(value, rel=1e-6), name
        else:
            assert not math.isfinite(new["stderr"][name])


def _arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.linspace(0, 20, 400)
    f = np.sin(0.9 * t) + 0.5 * np.sin(2.3 * t)
    d = pumpid.simulate(TRUTH, t, f, observe="u")
    d = d + 0.01 * np.ptp(d) * np.random.default_rng(3).standard_normal(t.size)
    return t, f, d


def test_arrays_give_the_old_answers() -> None:
    t, f, d = _arrays()
    u = pumpid.FitOptions(observe="u")
    _same(_row(pumpid.fit(pumpid.Kelvin(k0=3, m=1.2, c1=0.3, k1=5), (t, f, d), options=u)),
          PINNED["arrays_guess"])
    _same(_row(pumpid.fit(pumpid.Kelvin, (t, f, d), options=u)), PINNED["arrays_auto"])


def test_periodic_arrays_give_the_old_answers() -> None:
    _same(_row(pinned_periodic_fit()), PINNED["arrays_periodic"])


def test_many_arrays_give_the_old_batch() -> None:
    t, f, d = _arrays()
    loads = np.array([f, 1.1 * f, 0.9 * f])
    disps = np.array([d, pumpid.simulate(TRUTH, t, 1.1 * f, observe="u"),
                      pumpid.simulate(TRUTH, t, 0.9 * f, observe="u")])
    batch = pumpid.fit(pumpid.Kelvin, (t, loads, disps),
                       options=pumpid.FitOptions(observe="u"), workers=1)
    assert isinstance(batch, pumpid.FitBatch)
    for res, old in zip(batch.results, PINNED["many"], strict=True):
        _same(_row(res), old)


def test_a_card_a_list_of_cards_and_its_arrays_agree() -> None:
    cards = read_cards(DATA / "cards" / "controller_export.txt")
    for card, old in zip(cards[:3], PINNED["card_kelvin"], strict=True):
        _same(_row(pumpid.fit(pumpid.Kelvin, card)), old)
    batch = pumpid.fit(pumpid.Kelvin, cards[:3], workers=1)
    for res, old in zip(batch.results, PINNED["cards_batch"], strict=True):
        _same(_row(res), old)
        assert res.card is not None
    _same(_row(pumpid.fit("maxwell", cards[0], options=pumpid.FitOptions.for_cards(observe="u"))),
          PINNED["card_maxwell_u"])
    # The same card as arrays with the card preset gives the card's answer ...
    card = cards[0]
    as_arrays = pumpid.fit(pumpid.Kelvin, (card.t, card.load, card.position),
                           options=pumpid.FitOptions.for_cards(initial_state="periodic",
                                                               period=card.period))
    _same(_row(as_arrays), PINNED["card_kelvin"][0])
    # ... and as plain arrays the plain defaults (from rest, no offset), as before.
    _same(_row(pumpid.fit(pumpid.Kelvin, (card.t, card.load, card.position))),
          PINNED["card_arrays_default"])


def test_options_are_validated_and_serialisable() -> None:
    opts = pumpid.FitOptions.for_cards(observe="u", fixed={"m": 2}, initial_state=[0.0, 0.0])
    assert opts.fixed == {"m": 2.0} and opts.initial_state == (0.0, 0.0)
    again = pumpid.FitOptions.from_dict(json.loads(json.dumps(opts.to_dict())))
    assert again == opts
    for bad in ({"integrator": "rk4"}, {"scale": -1.0}, {"min_r2": 2.0},
                {"initial_state": "steady"}, {"period": 0.0}, {"multistart": "yes"},
                {"offset": "yes"}, {"fixed": {"m": "heavy"}}):
        with pytest.raises(ValueError, match="FitOptions"):
            pumpid.FitOptions(**bad)
    with pytest.raises(ValueError, match="unknown option"):
        pumpid.FitOptions.from_dict({"tol": 1e-8})
    with pytest.raises(TypeError, match="solver"):
        pumpid.fit("kelvin", _arrays(), solver="lm")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="data"):
        pumpid.fit("kelvin", {"t": [1, 2, 3]})  # type: ignore[arg-type]
