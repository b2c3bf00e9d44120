"""The pump-card application: model choice, predictions, synthetic cards.

A card gives the polished-rod load (the model's input) and position (the measured
displacement); :func:`pumpid.fit` fits one (or many) with the card's own defaults
(:meth:`pumpid.FitOptions.for_cards`: a fitted position offset; a single stroke is one
period of a periodic motion); several strokes of a well share one parameter set with
``FitOptions.for_cards(joint=True)``.
"""

from .choose import CANDIDATES, Candidate, ModelChoice, NestedTest, choose_model
from .fit import evaluate_prediction, predict, predict_card

__all__ = [
           "CANDIDATES",
           "Candidate",
           "ModelChoice",
           "NestedTest",
           "choose_model",
           "evaluate_prediction",
           "predict",
           "predict_card",
]
