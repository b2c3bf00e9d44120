"""pumpid: identify small physical models from measured input/output data.

The main path is data -> model -> simulation -> objective -> solver -> result -> report::

    import pumpid
    result = pumpid.fit(pumpid.Kelvin(k0=4, m=1, c1=0.2, k1=4), t, load, displacement)
    print(result.report())
"""

from .batch import BatchResult, fit_many
from .fit import fit
from .models import MODELS, FirstOrder, Kelvin, MassSpringDamper, Maxwell, Model, model_class
from .result import FitResult, Units
from .simulate import simulate, simulate_sensitivities

__all__ = [
    "MODELS",
    "BatchResult",
    "FirstOrder",
    "FitResult",
    "Kelvin",
    "MassSpringDamper",
    "Maxwell",
    "Model",
    "Units",
    "fit",
    "fit_many",
    "model_class",
    "simulate",
    "simulate_sensitivities",
]

__version__ = "0.1.0"
