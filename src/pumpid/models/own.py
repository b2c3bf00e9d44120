"""The model protocol: what the engine needs from a model that brings its own simulator.

The lumped models (:mod:`pumpid.models.base`) describe themselves as monomials in positive
parameters, which the compiled kernel simulates with exact sensitivities. Any other model --
a partial differential equation, a state-space model with signed entries, a black-box
simulator -- implements :class:`OwnModel` instead and gets the same solver, statuses,
boundary marks, diagnostics (errors that hold under correlated residuals, identifiability in
words), result, reports and table columns through :func:`pumpid.fit`.

What the engine needs, and nothing more:

* ``parameters``: each parameter's name, unit and bounds (a parameter whose lower bound is
  0 or more is searched on the log scale, like the lumped models'; any other on its own
  scale);
* :meth:`OwnModel.simulate`: the predicted observation for one data item at given parameter
  values and, when asked, its sensitivities (the derivatives with respect to each
  parameter, exact or supplied by the model: finite differences are the model's choice);
* :meth:`OwnModel.observed`: the measured observation the prediction is compared with;
* :meth:`OwnModel.start`: one or more starting points for an item (default: each
  parameter's ``start``).

Optional: :attr:`OwnModel.analyse` (False: the answer alone, for a search) and
:meth:`OwnModel.hold` (the parameters a fit holds, whose sensitivities it never uses).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["OwnModel", "Parameter"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Parameter:
    """One parameter of an :class:`OwnModel`.

    Parameters
    ----------
    name : str
        The name results and tables use (an identifier; not ``C``, ``D`` or ``offset``,
        which name the lumped models' scale and offset).
    unit : str
        Its unit, as printed.
    lower, upper : float
        Bounds. ``lower >= 0`` makes the parameter positive, searched on the log scale
        (``lower = 0`` means "positive, no other bound"); otherwise it is searched on its own
        scale within the bounds (infinite bounds allowed).
    start : float, optional
        The default starting value (required unless the model's :meth:`OwnModel.start` gives
        one).
    doc : str
        What it means, in words.
    closed : bool
        Its bounds are states the modelled system can be in (a pump's fillage of 1: a full
        pump), not the edge of a search: a fit that sits on one is a fit of that state
        (status ``converged``, the parameter held there and said so), not a limiting model.
    """

    name: str
    unit: str = "1"
    lower: float = 0.0
    upper: float = math.inf
    start: float | None = None
    doc: str = ""
    closed: bool = False

    def __post_init__(self) -> None:
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            raise ValueError(f"Parameter name must be an identifier, got {self.name!r}")
        if self.name in ("C", "D", "offset"):
            raise ValueError(f"Parameter name {self.name!r} is reserved (the lumped models' "
                             "scale and offset)")
        if not self.lower < self.upper:
            raise ValueError(f"parameter {self.name}: lower bound {self.lower!r} is not below "
                             f"upper bound {self.upper!r}")
        if self.start is not None and not self.lower <= self.start <= self.upper:
            raise ValueError(f"parameter {self.name}: start {self.start!r} is outside "
                             f"[{self.lower!r}, {self.upper!r}]")

    @property
    def positive(self) -> bool:
        """Searched on the log scale (a lower bound of 0 or more)."""
        return self.lower >= 0.0

    def unit_for(self, load: str, position: str) -> str:
        """The unit as printed (an own model states its units itself)."""
        return self.unit


class OwnModel(abc.ABC):
    """A model that brings its own simulator and sensitivities (see the module's text).

    Subclass it, set :attr:`name` and :attr:`parameters`, and implement :meth:`simulate`
    (and :meth:`observed` unless the data are :class:`~pumpid.engine.problem.CardData`
    records or cards whose measured output is the displacement / position). Then
    ``pumpid.fit(MyModel(), data)`` fits it.
    """

    #: The model's name in results and tables.
    name: str = "own model"
    #: The parameters, in the order :meth:`simulate` takes their values.
    parameters: tuple[Parameter, ...] = ()
    #: What the observation is and its unit (for reports).
    output: str = "output"
    output_unit: str = "1"
    #: The unit of the input that drives it (for reports).
    input_unit: str = "1"
    #: How it simulates and from what state, in words (for reports).
    integrator: str = "the model's own simulator"
    initial_state: str = "defined by the model"
    #: The data item is one period of a steady state (a stroke that repeats): its last
    #: sample is the first one's neighbour, and the errors' serial statistics run around
    #: the period, so they do not depend on which sample the record starts at.
    periodic: bool = False
    #: Analyse the answer: its errors, identifiability and derived quantities. A model that
    #: only searches for a start of another fit may say False: its result then has the
    #: values, cost, fit statistics and the solver's status alone (no ``uncertainty``), and
    #: the sensitivities at the answer are not asked for.
    analyse: bool = True

    @abc.abstractmethod
    def simulate(self, values: Array, data: Any, sensitivities: bool
                 ) -> tuple[Array, Array | None]:
        """The predicted observation for ``data`` at parameter ``values``.

        Parameters
        ----------
        values : ndarray, shape (p,)
            The parameters' values, in the order of :attr:`parameters`.
        data : any
            One data item as given to :func:`pumpid.fit`.
        sensitivities : bool
            Also return the derivatives.

        Returns
        -------
        prediction : ndarray, shape (N,)
            Comparable sample by sample with :meth:`observed`.
        derivatives : ndarray, shape (N, p), or None
            d prediction / d values (None when ``sensitivities`` is False).

        Raises
        ------
        ValueError, ArithmeticError
            Where the model cannot be simulated at these values (the solver then steps
            back), or the data item does not suit the model.
        """

    def observed(self, data: Any) -> Array:
        """The measured observation of ``data`` (default: a record's ``data`` field, a
        card's position)."""
        for attr in ("data", "position"):
            value = getattr(data, attr, None)
            if value is not None:
                return np.asarray(value, dtype=float)
        raise TypeError(f"{type(self).__name__}.observed: cannot find the measured output "
                        f"of a {type(data).__name__}; override observed()")

    def time(self, data: Any) -> Array | None:
        """The sample times of ``data`` (s), for the residuals' order and plots."""
        t = getattr(data, "t", None)
        return None if t is None else np.asarray(t, dtype=float)

    def driving(self, data: Any) -> Array | None:
        """The input that drives the model, for plots (default: a record's ``load``)."""
        value = getattr(data, "load", None)
        return None if value is None else np.asarray(value, dtype=float)

    def hold(self, names: frozenset[str]) -> None:
        """Told by the engine before each fit: the parameters it holds (``fixed``). Their
        sensitivities are never used, so a model that pays a simulation for each (finite
        differences) may leave their columns at any finite value. Default: nothing."""
        return None

    def start(self, data: Any) -> Array | Sequence[Array]:
        """One starting point (p,) or several (k, p) for ``data`` (default: each parameter's
        ``start``); with several, the fit starts from the one with the lowest cost."""
        missing = [p.name for p in self.parameters if p.start is None]
        if missing:
            raise ValueError(f"{self.name}: no start for {missing}; give Parameter(start=...) "
                             "or override start()")
        return np.array([float(p.start) for p in self.parameters])  # type: ignore[arg-type]

    def derived(self, values: Array, numbers: Any, serial: bool,
                limits: Sequence[tuple[str, str]]) -> Mapping[str, Any]:
        """Quantities derived from the parameters, with their errors (default: none).

        Parameters
        ----------
        values : ndarray, shape (p,)
            The fitted values.
        numbers : pumpid.inference.uncertainty.Numbers
            The analysis at the optimum (covariances over the solver's coordinates: the
            logarithm of each positive parameter, a signed one divided by the data's range;
            ``numbers.scales`` holds each coordinate's unit step in the value's units).
        serial : bool
            The residuals are serially correlated (the robust errors are shown).
        limits : sequence of (name, direction)
            Parameters at a boundary.

        Returns
        -------
        mapping of str to pumpid.inference.derived.Derived
        """
        return {}

    # What the result needs to describe the fitted values like a lumped model's.
    def param_names(self) -> tuple[str, ...]:
        """The parameters' names, in order."""
        return tuple(p.name for p in self.parameters)

    def param_info(self) -> tuple[Parameter, ...]:
        """The parameters (name, unit, bounds)."""
        return self.parameters
