"""pumpid: identify small physical models from measured input/output data.

One way through: data -> problem (with a card axis) -> engine (compiled kernel, one solver
loop) -> immutable result -> report::

    import pumpid
    result = pumpid.fit(pumpid.Kelvin(k0=4, m=1, c1=0.2, k1=4), (t, load, displacement))
    print(result.report())
    batch = pumpid.fit("kelvin", pumpid.cards.read_cards("cards.csv", spm=8.5))
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from .engine.problem import CardData
from .engine.simulate import simulate, simulate_sensitivities
from .engine.solvers import LevenbergMarquardt, PaperNewton, Stop
from .job import FitOptions, fit
from .models import (
    MODELS,
    FirstOrder,
    Kelvin,
    MassSpringDamper,
    Maxwell,
    Model,
    OwnModel,
    Parameter,
    model_class,
)
from .profile import profile as profile_of
from .result import FitBatch, FitResult, Prediction, Status, Units
from .version import __version__ as __version__

if TYPE_CHECKING:
    import pandas

__all__ = [
    "MODELS",
    "CardData",
    "FirstOrder",
    "FitBatch",
    "FitOptions",
    "FitResult",
    "Kelvin",
    "LevenbergMarquardt",
    "MassSpringDamper",
    "Maxwell",
    "Model",
    "OwnModel",
    "PaperNewton",
    "Parameter",
    "Prediction",
    "Status",
    "Stop",
    "Units",
    "fit",
    "model_class",
    "profile_of",
    "read_results",
    "simulate",
    "simulate_sensitivities",
]


def read_results(path: str | os.PathLike[str]) -> pandas.DataFrame:
    """Read the results folder of ``pumpid batch`` as one table, in input order.

    See :func:`pumpid.fleet.read_results` (pandas is imported only when this is called).
    """
    from .fleet.store import read_results as _read_results

    return _read_results(path)
