"""The one result type, built once: parameters, uncertainty, diagnostics, status, report.

:class:`FitResult` is immutable. Its typed parts are :class:`Uncertainty` (standard errors,
intervals, what they assume), :class:`BoundaryInfo` (parameters that ran to 0 or infinity
and the reduced model fitted there), :class:`Derived` (physical combinations of the
parameters), :class:`StartInfo` (how the start was found) and :class:`CardInfo` (where the
data came from); ``status`` is a :class:`Status` member with its message. A prediction is
its own object (:class:`Prediction`), never written into the fit it was made with.

:class:`FitBatch` holds the fits of many cards as arrays (one entry per card) and builds a
card's :class:`FitResult` on request.

The modules: :mod:`.parts` (status, units, card and start information, predictions, JSON),
:mod:`.uncertainty`, :mod:`.boundaries` and :mod:`.derived` (the typed parts, plain data;
:mod:`pumpid.inference` computes them and imports them from here: the package imports no
inference), :mod:`.fit` (:class:`FitResult` and its text report), :mod:`.batch`
(:class:`FitBatch`) and :mod:`.text` (report pieces that need no result).
"""

from __future__ import annotations

from .batch import FitBatch
from .boundaries import BoundaryInfo, Limiting, ReducedFit
from .derived import Derived
from .fit import FitResult, derived_text, diagnostics_text, format_report
from .parts import CardInfo, Prediction, StartInfo, Status, Units, jsonable
from .text import model_choice_text, n_eff_words, squared
from .uncertainty import Uncertainty

__all__ = [
    "BoundaryInfo",
    "CardInfo",
    "Derived",
    "FitBatch",
    "FitResult",
    "Limiting",
    "Prediction",
    "ReducedFit",
    "StartInfo",
    "Status",
    "Uncertainty",
    "Units",
    "derived_text",
    "diagnostics_text",
    "format_report",
    "jsonable",
    "model_choice_text",
    "n_eff_words",
    "squared",
]
