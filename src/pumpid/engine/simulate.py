"""Simulation of a model driven by a sampled load (the compiled kernel behind a plain API).

Two integrators share one recursion ``x[k+1] = Phi_k x[k] + G0_k g[k] + G1_k g[k+1]``:
``exact`` (first-order hold: the load linear between samples, Phi, G0, G1 from one matrix
exponential; exact for any steps, so non-uniform time stamps are handled exactly) and
``euler`` (the paper's explicit scheme ``x[k+1] = x[k] + dt (A x[k] + B g[k])``, kept to
reproduce its tables). Parameter sensitivities are exact for either: they are the
derivatives of the discrete recursion itself (:mod:`pumpid.engine.kernel`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..models import Model
from . import kernel
from .problem import INITIAL_MODES, check_signal, initial_state_vector, make_time

__all__ = ["simulate", "simulate_sensitivities"]

Array = NDArray[np.float64]
InitialState = str | Sequence[float] | Mapping[str, float] | NDArray[np.float64]


def _prepare(model: Model, t: ArrayLike, load: ArrayLike, initial_state: InitialState,
             integrator: str, period: float | None) -> tuple[Array, Array, bool, int, Array,
                                                             float, int]:
    if not isinstance(model, Model):
        raise TypeError(
            f"model must be a model instance such as Kelvin(k0=4, m=1, c1=0.2, k1=4), "
            f"got {model!r}")
    if model.nonlinear:
        raise TypeError(f"{type(model).__name__} is not a linear state-space model; use its "
                        "own simulator")
    if integrator not in ("exact", "euler"):
        raise ValueError(f"integrator must be 'exact' or 'euler', got {integrator!r}")
    tt, uniform = make_time(t)
    f = check_signal("load", load, tt.size)
    x0 = initial_state_vector(type(model), initial_state)
    mode = kernel.GIVEN if x0 is not None else INITIAL_MODES[str(initial_state)]
    per = math.nan
    if mode == kernel.PERIODIC:
        span = float(tt[-1] - tt[0])
        if period is None:
            if not uniform:
                raise ValueError(
                    "initial_state='periodic' on a non-uniform grid needs period= (the stroke "
                    "period in s): the closing step cannot be inferred")
            per = span + span / (tt.size - 1)
        else:
            per = float(period)
            if not (math.isfinite(per) and per > span):
                raise ValueError(
                    f"period = {per:g} s must exceed the record's span {span:g} s (the samples "
                    "cover one period, without a repeated closing point)")
    integ = kernel.EULER if integrator == "euler" else kernel.EXACT
    return tt, f, uniform, mode, (np.zeros(model.n_states()) if x0 is None else x0), per, integ


def _run(model: Model, t: ArrayLike, load: ArrayLike, observe: str | None,
         initial_state: InitialState, integrator: str, period: float | None,
         sensitivities: bool, all_states: bool) -> tuple[Array, Array, Array]:
    tt, f, uniform, mode, x0, per, integ = _prepare(model, t, load, initial_state, integrator,
                                                    period)
    cls = type(model)
    k = cls.output_index(observe)
    n = cls.n_states()
    values = model.values
    lz = np.log(values)
    p = values.size
    y = np.full(tt.size, np.nan)
    dy = np.full((p if sensitivities else 0, tt.size), np.nan)
    states = np.full((tt.size if all_states else 0, n), np.nan)
    ok = kernel.simulate_card(lz, np.arange(p, dtype=np.int64), cls.code(), n, cls.input_code(),
                              tt, f, mode, x0, 0.0 if not math.isfinite(per) else per,
                              uniform, integ, k, y, dy, states)
    if not ok:
        # Report what the recursion gives (non-finite values) rather than raising: a model
        # whose response blows up is an answer, not an input error -- unless the initial
        # state itself cannot be formed.
        if mode in (kernel.EQUILIBRIUM, kernel.PERIODIC) and np.all(np.isfinite(lz)):
            what = "static equilibrium" if mode == kernel.EQUILIBRIUM else "periodic steady state"
            raise ValueError(
                f"initial_state={initial_state!r}: the {what} of {cls.__name__} with these "
                "parameters does not exist (a singular system)")
    # Sensitivities come out along ln theta; the API gives them per unit of theta.
    if sensitivities:
        dy = dy / values[:, None]
    return y, dy, states


def simulate(
    model: Model,
    t: ArrayLike,
    load: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    integrator: Literal["exact", "euler"] = "exact",
    scale: float = 1.0,
    period: float | None = None,
    all_states: bool = False,
) -> Array:
    """Simulate the model's response to a sampled load.

    Parameters
    ----------
    model : Model
        A model instance, e.g. ``Kelvin(k0=4, m=1, c1=0.2, k1=4)``.
    t : array_like, shape (N,)
        Sample times in seconds, strictly increasing (non-uniform steps are handled exactly by
        the ``exact`` integrator).
    load : array_like, shape (N,)
        The input at those times (load for the mechanical models; a rate for
        :class:`~pumpid.models.FirstOrder`), taken piecewise linear between samples.
    observe : str, optional
        The observed state (default: the model's ``default_output``).
    initial_state : {"rest", "equilibrium", "periodic"} or sequence or mapping
        ``rest`` (zero state), ``equilibrium`` (static equilibrium under the first load
        sample), ``periodic`` (periodic steady state: the samples cover one period), or the
        state itself as numbers in the order of ``model.states`` or as ``{state: value}``.
    integrator : {"exact", "euler"}
        ``exact`` first-order-hold discretization, or the paper's explicit Euler scheme.
    scale : float
        The paper's output scale factor C (the output is multiplied by it).
    period : float, optional
        Period in s for ``initial_state="periodic"``; default: span + one step.
    all_states : bool
        Return every state (N, n) instead of the observed one.

    Returns
    -------
    ndarray
        The observed displacement ``scale * y(t)`` of shape (N,), or all states (N, n).
    """
    y, _dy, states = _run(model, t, load, observe, initial_state, integrator, period, False,
                          all_states)
    return scale * (states if all_states else y)


def simulate_sensitivities(
    model: Model,
    t: ArrayLike,
    load: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    integrator: Literal["exact", "euler"] = "exact",
    period: float | None = None,
) -> tuple[Array, Array]:
    """Observed output and its exact parameter sensitivities.

    Returns
    -------
    y : ndarray, shape (N,)
    dy : ndarray, shape (N, p)
        ``dy[:, i] = dy/dtheta_i`` in the model's canonical parameter order.
    """
    y, dy, _states = _run(model, t, load, observe, initial_state, integrator, period, True,
                          False)
    return y, dy.T.copy()
