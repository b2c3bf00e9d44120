"""Automatic starting points: no guess needed.

A lumped model's cost has local minima and its parameters span decades, so a fit never
starts from one fixed point: the start proposes many points per card, ranks them cheaply
and polishes the best few, for every card of a problem at once. One module per strategy:

* :mod:`.equation_error` -- coefficients from one linear least-squares solve (filtered in
  time, or over a periodic stroke's harmonics), refined by Steiglitz-McBride (compiled);
* :mod:`.pool` -- the candidates: those estimates mapped to parameters, the limiting
  models' estimates next to their limit, the model's shape grid and a heuristic;
* :mod:`.coordinates` -- parameter rows to solver points at their best linear scale and
  offset, with their cost (the ranking);
* :mod:`.multistart` -- rank all candidates, polish the best distinct ones in two rounds,
  keep the best (:func:`find_starts`);
* :mod:`.valley` -- long strides along a flat, curved valley where the solver only crawls
  (:func:`walk_valley`);
* :mod:`.harmonics` -- a fast ranking of many shapes on a periodic card (compiled);
* :mod:`.wider` -- a larger multistart, in rounds until two starts agree, for cards whose
  answer does not explain their data (:func:`search_wider`);
* :mod:`.resonance` -- a scan along the model's inertia for the others, whose answer can sit
  in a ripple of the cost at the noise level (:func:`scan_inertia`).

The compiled code is kept to its own modules (listed in :mod:`pumpid.engine.compiled`), so
that editing the Python strategies does not invalidate the compiled cache.
"""

from __future__ import annotations

from .coordinates import complete, to_z
from .equation_error import equation_error_items
from .harmonics import harmonic_scan
from .multistart import StartPlan, Starts, find_starts
from .pool import candidates
from .resonance import InertiaLine, flat_spans, inertia_index, scan_inertia
from .valley import walk_valley
from .wider import WidePlan, compile_ranking, search_wider

__all__ = [
    "InertiaLine",
    "StartPlan",
    "Starts",
    "WidePlan",
    "candidates",
    "compile_ranking",
    "complete",
    "equation_error_items",
    "find_starts",
    "flat_spans",
    "harmonic_scan",
    "inertia_index",
    "scan_inertia",
    "search_wider",
    "to_z",
    "walk_valley",
]
