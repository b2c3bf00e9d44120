"""Fitting dynamometer cards: the main job, on top of :func:`pumpid.fit`.

A card gives the polished-rod load (the model's input) and position (the measured
displacement). Its position zero and the static part of its load are arbitrary for the
model, so a position offset is fitted by default; a single stroke is one period of a
periodic motion, so the periodic steady state is the default initial state for such cards.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cards import Card
from ..engine.problem import CardData
from ..engine.simulate import InitialState, simulate
from ..job import fit, fit_records
from ..models import Kelvin, Model, model_class
from ..result import CardInfo, FitBatch, FitResult, Prediction, Units

__all__ = ["evaluate_prediction", "fit_card", "fit_cards", "predict", "predict_card"]


def _units(card: Card) -> Units:
    return Units(load=card.load_unit or "load-unit", position=card.position_unit or "position-unit")


def _require_card(card: Any, name: str = "card") -> Card:
    """``card`` itself, or a TypeError naming the argument (not an AttributeError later)."""
    if not isinstance(card, Card):
        raise TypeError(f"{name} must be a pumpid.cards.Card, got {type(card).__name__}")
    return card


def _require_time(card: Card) -> tuple[NDArray[np.float64], float | None]:
    if card.t is None:
        raise ValueError(
            f"card {card.card_id or card.source!r} has no time: give the pumping speed "
            "(spm=..., e.g. --spm 8.5) or the stroke period (period=... s)"
        )
    t = np.asarray(card.t, dtype=float)
    period = card.period if card.periodic else None
    if card.periodic and period is None and card.dt is not None:
        period = card.n * card.dt
    return t, period


def fit_card(
    card: Card,
    model: str | Model | type[Model] = Kelvin,
    *,
    initial_state: InitialState | None = None,
    offset: bool | float = True,
    **fit_options: Any,
) -> FitResult:
    """Fit a model to one card (load in, position out).

    Parameters
    ----------
    card : Card
        A card with time (rebuilt from SPM or period when the file has none).
    model : str, Model class or Model instance
        ``"kelvin"`` (default), ``"maxwell"``, ``"msd"``; a class means an automatic start,
        an instance is the starting guess.
    initial_state : str or numbers, optional
        Default: ``"periodic"`` for a single stroke (``card.periodic``), else ``"rest"``.
    offset : bool or float
        Fit a position offset (default True): a card's position zero is arbitrary.
    **fit_options
        Passed to :func:`pumpid.fit` (method, observe, scale, ...).

    Returns
    -------
    FitResult
        With ``extra["card"]`` holding the card's id, source and the notes of everything done
        to its data.
    """
    _require_card(card)
    record = _record(card, initial_state)
    if isinstance(model, str):
        model = model_class(model)
    result = fit(
        model, record.t, record.load, record.data, initial_state=record.initial_state,
        offset=offset, period=record.period, units=_units(card), **fit_options,
    )
    return result.with_parts(card=_card_info(card))


def _record(card: Card, initial_state: InitialState | None) -> CardData:
    """The card as the engine's record; ValueError when it cannot be fitted as asked."""
    t, period = _require_time(card)
    if initial_state is None:
        initial_state = "periodic" if card.periodic else "rest"
    if initial_state == "periodic" and period is None:
        raise ValueError(
            f"card {card.card_id!r}: initial_state='periodic' needs the stroke period"
        )
    return CardData(t, card.load, card.position, initial_state,
                    period if initial_state == "periodic" else None)


def _card_info(card: Card) -> CardInfo:
    stamp = card.metadata.get("time", card.metadata.get("timestamp"))
    return CardInfo(id=card.card_id, well=card.well_id, source=card.source,
                    time_source=card.time_source, spm=card.spm, period=card.period,
                    notes=tuple(card.notes), time=None if stamp is None else str(stamp))


def fit_cards(
    cards: Sequence[Card],
    model: str | Model | type[Model] = Kelvin,
    *,
    initial_state: InitialState | None = None,
    offset: bool | float = True,
    workers: int | None = None,
    **fit_options: Any,
) -> FitBatch:
    """Fit one model structure to many cards in one batch: :func:`fit_card` for each.

    Every card keeps its own time, stroke period, initial state and units; the answers are
    those :func:`fit_card` gives for each card alone (the batch only shares the work).

    Parameters
    ----------
    cards : sequence of Card
    model, initial_state, offset
        As for :func:`fit_card`.
    workers : int, optional
        Threads (default: every core this process may use). Results do not depend on it.
    **fit_options
        Passed to :func:`pumpid.fit_records` (observe, scale, fixed, x0, solver, ...).

    Returns
    -------
    FitBatch
        One result per card, in order. A card that cannot be fitted (no time, no period for
        a periodic start, invalid samples) is an ``invalid-input`` row with the reason; it
        does not stop the others.

    Raises
    ------
    TypeError
        If ``cards`` is not a sequence of :class:`~pumpid.cards.Card` (the message names
        the first item that is not, as ``cards[k]``).
    """
    if isinstance(cards, Card) or not isinstance(cards, Sequence):
        raise TypeError(f"cards must be a sequence of pumpid.cards.Card, got "
                        f"{type(cards).__name__}")
    for k, card in enumerate(cards):
        _require_card(card, f"cards[{k}]")
    if isinstance(model, str):
        model = model_class(model)
    records: list[CardData] = []
    reasons: list[str] = []
    for card in cards:
        try:
            records.append(_record(card, initial_state))
            reasons.append("")
        except ValueError as exc:
            # A placeholder the engine will not fit: the row keeps the reason.
            records.append(CardData(np.arange(10.0), np.ones(10), np.ones(10)))
            reasons.append(str(exc))
    batch = fit_records(model, records, offset=offset, units=[_units(c) for c in cards],
                        workers=workers, invalid=reasons, **fit_options)
    results = tuple(None if r is None else r.with_parts(card=_card_info(c))
                    for r, c in zip(batch.results, cards, strict=True))
    return FitBatch(model_name=batch.model_name, param_names=batch.param_names,
                    results=results, invalid=batch.invalid)


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
    t, period = _require_time(card)
    state = "periodic" if card.periodic else "rest"
    predicted = predict(result, t, card.load, initial_state=state,
                        period=period if state == "periodic" else None)
    scores = evaluate_prediction(card.position, predicted)
    return Prediction(card=card.card_id, t=t, load=np.asarray(card.load),
                      measured=np.asarray(card.position), predicted=predicted, **scores)
