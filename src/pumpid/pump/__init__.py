"""The pump-card application: model choice, predictions, synthetic cards.

A card gives the polished-rod load (the model's input) and position (the measured
displacement); :func:`pumpid.fit` fits one (or many) with the card's own defaults
(:meth:`pumpid.FitOptions.for_cards`: a fitted position offset; a single stroke is one
period of a periodic motion); several strokes of a well share one parameter set with
``FitOptions.for_cards(joint=True)``.

The pump itself is identified from a surface card and its well by fitting the whole system
(rod string driven by the measured position, valve pump at its bottom) to the measured load:
:func:`identify_cards` (:mod:`pumpid.pump.identify`, :mod:`pumpid.pump.system`).
"""

from .choose import CANDIDATES, Candidate, ModelChoice, NestedTest, choose_model
from .fit import evaluate_prediction, predict, predict_card
from .identify import PumpFit, identify_card, identify_cards, solver_difference
from .system import PumpSystem, SurfaceCard

__all__ = [
           "CANDIDATES",
           "Candidate",
           "ModelChoice",
           "NestedTest",
           "PumpFit",
           "PumpSystem",
           "SurfaceCard",
           "choose_model",
           "evaluate_prediction",
           "identify_card",
           "identify_cards",
           "predict",
           "predict_card",
           "solver_difference",
]
