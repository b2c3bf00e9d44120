"""The main job: one verb (:func:`fit`), its options (:class:`FitOptions`) and its stages.

:mod:`~pumpid.job.verb` turns the data (arrays, a card, many cards) into a problem;
:mod:`~pumpid.job.stages` runs the stages (start, solve, guard, widen, boundaries, diagnose) on
every card at once; :mod:`~pumpid.job.assemble` makes each card's result;
:mod:`~pumpid.job.own` runs the same solver and diagnostics for a model that brings its own
simulator.
"""

from __future__ import annotations

from ..engine.solvers import LevenbergMarquardt, PaperNewton
from .options import MIN_R2, START_SAMPLES, FitOptions, JobOptions, job_options, solver_for
from .stages import cost_change, run, run_batch
from .state import start_problem
from .verb import card_info, card_record, card_units, fit

__all__ = ["MIN_R2", "START_SAMPLES", "FitOptions", "JobOptions", "LevenbergMarquardt",
           "PaperNewton", "card_info", "card_record",
           "card_units", "cost_change", "fit", "job_options", "run", "run_batch",
           "solver_for", "start_problem"]
