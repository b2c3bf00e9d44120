"""The pump-card application: fit dynamometer cards, predict strokes, synthetic cards.

A card gives the polished-rod load (the model's input) and position (the measured
displacement); :func:`fit_card` fits one with the main job of :func:`pumpid.fit` and the
card's own defaults (a fitted position offset; a single stroke is one period of a periodic
motion).
"""

from .choose import CANDIDATES, Candidate, ModelChoice, NestedTest, choose_model
from .fit import evaluate_prediction, fit_card, fit_cards, predict, predict_card
from .joint import JointFit, fit_joint

__all__ = [
           "CANDIDATES",
           "Candidate",
           "JointFit",
           "ModelChoice",
           "NestedTest",
           "choose_model",
           "evaluate_prediction",
           "fit_card",
           "fit_cards",
           "fit_joint",
           "predict",
           "predict_card",
]
