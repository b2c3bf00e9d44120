"""Predictions with a fitted card model: another card's position from its load.

Cards are fitted by :func:`pumpid.fit` (a card gets :meth:`pumpid.FitOptions.for_cards`: a
fitted position offset, the periodic steady state for one stroke); this module predicts
with the result.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cards import Card
from ..engine.simulate import InitialState, simulate
from ..inference.echo import fundamental_share
from ..inference.uncertainty import closes_period
from ..job import FitOptions, card_record
from ..result import FitResult, Prediction

__all__ = ["evaluate_prediction", "predict", "predict_card"]


def _require_card(card: Any, name: str = "card") -> Card:
    """``card`` itself, or a TypeError naming the argument (not an AttributeError later)."""
    if not isinstance(card, Card):
        raise TypeError(f"{name} must be a pumpid.cards.Card, got {type(card).__name__}")
    return card


def predict(
    result: FitResult,
    t: ArrayLike,
    load: ArrayLike,
    *,
    initial_state: InitialState | None = None,
    period: float | None = None,
) -> NDArray[np.float64]:
    """Displacement the fitted model predicts for another load record (same C and offset)."""
    if result.model is None:
        raise ValueError("the fit produced no model to predict with")
    state = result.initial_state if initial_state is None else initial_state
    if isinstance(state, list):
        state = tuple(state)
    y = simulate(result.model, t, load, observe=result.observe, initial_state=state,
                 integrator=result.integrator, period=period)  # type: ignore[arg-type]
    return result.scale * y + result.offset


def evaluate_prediction(
    measured: ArrayLike, predicted: ArrayLike
) -> dict[str, float]:
    """R^2 and RMSE of a prediction against measured displacement."""
    m = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    res = p - m
    sst = float(np.sum((m - m.mean()) ** 2))
    return {
        "rmse": float(np.sqrt(np.mean(res**2))),
        "r2": 1.0 - float(np.sum(res**2)) / sst if sst > 0 else math.nan,
    }


def predict_card(result: FitResult, card: Card) -> Prediction:
    """Predict another card's position from its load with a fitted model (paper's Fig. 9).

    Returns
    -------
    Prediction
        The card's id, ``t``, ``load``, ``measured``, ``predicted`` arrays and the
        prediction's ``r2`` and ``rmse`` (position units). The fit is not changed.
    """
    _require_card(card)
    record = card_record(card, FitOptions.for_cards())
    t = np.asarray(record.t, dtype=float)
    predicted = predict(result, t, card.load, initial_state=record.initial_state,
                        period=record.period)
    scores = evaluate_prediction(card.position, predicted)
    alone = math.nan
    # The fit's own rule: one whole period, uniformly sampled (a card covering 60 % of its
    # period had been given a "fundamental alone" of 0.77).
    if isinstance(record.initial_state, str) and record.initial_state == "periodic" \
            and t.size >= 2 and np.allclose(np.diff(t), t[1] - t[0], rtol=1e-6) \
            and closes_period(t, record.period):
        alone = fundamental_share(np.asarray(card.position, dtype=float))
    return Prediction(card=card.card_id, t=t, load=np.asarray(card.load),
                      measured=np.asarray(card.position), predicted=predicted,
                      r2_fundamental=alone, **scores)
