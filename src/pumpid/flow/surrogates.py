"""First-order surrogates of a fluid delivery system: pressure drop in, flow rate out.

The paper's second application replaces a CFD model of a very viscous polymer delivery system
by a first-order ODE with a time constant and a gain. Three surrogates of increasing physics
are provided here; all share the parameters ``tau`` (s) and ``gain`` (output per input) so
that their numbers can be compared directly.

:class:`FirstOrderLag`
    ``tau q' = gain dp - q``: linear, the paper's model. Used in either direction (pressure
    drop in and flow rate out, or the reverse with the record's columns swapped).
:class:`PowerLawLag`
    A Hammerstein model: ``tau q' = G(dp) - q`` with the steady power-law map
    ``G(dp) = gain dp_ref sign(dp) |dp / dp_ref|^(1/n)``. It gets the steady flow of a
    power-law fluid right at every pressure drop but keeps one time constant for all of them.
:class:`ShearThinningLag`
    ``q' = (G(dp) - q) / tau_eff`` with a time constant that follows the flow level,
    ``tau_eff = tau ((G^2 + q^2) / (2 q_ref^2))^((1 - n)/2)``, ``q_ref = gain dp_ref``.

Why the third model
-------------------
For a power-law fluid started from rest by a pressure-drop step ``a`` the reference
simulator (and the momentum equation) is self-similar: ``Q_a(t) = a^(1/n) Q_1(t / a^m)`` with
``m = (1 - n)/n``. A first-order law ``q' = F(dp, q)`` reproduces that family only when
``F(l dp, l^(1/n) q) = l F(dp, q)`` for every ``l > 0`` (insert the scaled solution into the
ODE: the left side gains ``a^(1/n - m) = a``). Writing ``F = (G(dp) - q) / tau_eff`` with the
power-law ``G`` (degree ``1/n`` in ``dp``), ``tau_eff`` must be homogeneous of degree ``m`` in
``dp``, i.e. of degree ``1 - n`` in the flow-rate scale. A constant ``tau`` (PowerLawLag)
violates this: its step response has the right amplitude but a step-independent time
constant. Among the admissible choices the one used here is the physical one -- the time scale
``rho R^2 / (eta_w j01^2)`` of the pipe with the viscosity at the current wall shear rate,
``eta_w ~ gamma_w^(n - 1)`` and ``gamma_w ~ |q|`` -- but measured on the root mean square of
the target flow ``G(dp)`` and the actual flow ``q``. That keeps ``tau_eff`` finite at the start
from rest (where it is set by the target flow, so the initial acceleration is proportional to
``dp``, as the inviscid start of a pipe flow is) and after a shut-off (set by the flow still
present, which then stops in finite time for ``n < 1``, as a power-law fluid does). For
``n = 1`` all three models coincide.

The pressure reference ``dp_ref``
---------------------------------
``|dp / dp_ref|^(1/n)`` needs a reference pressure. With ``dp_ref = 1 Pa`` the gain would be
the conductance extrapolated to 1 Pa -- for ``n = 0.4`` and ``dp ~ 1e5 Pa`` a number 1e12
times smaller than any flow actually seen, changing by orders of magnitude whenever ``n``
moves, so ``gain`` and ``n`` would be almost perfectly correlated and depend on the pressure
unit. Instead ``dp_ref`` is fixed from the data before the fit (by default the largest
``|dp|`` of the record, rounded to three significant digits): ``gain`` is then the secant
conductance ``q / dp`` of steady flow at that operating point and ``tau`` the time constant
there, both readable in the data and weakly correlated with ``n``. The reference is not a
fitted parameter; it is a class attribute of a reference-bound subclass made by
:meth:`PowerLawLag.at_reference` (the model interface evaluates its matrices and input map from
the parameter vector alone, so the reference has to live on the class). The base classes use
``dp_ref = 1`` in the input unit.

:class:`ShearThinningLag` is not linear in its state, so it cannot use the linear simulator
of :mod:`pumpid.engine.simulate`: :func:`simulate_shear_thinning` integrates it (with its exact
forward sensitivities) by :func:`scipy.integrate.solve_ivp`, and :mod:`pumpid.flow.fit` fits it
with :func:`scipy.optimize.least_squares`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from ..models.base import Model, Term, param, term

__all__ = [
    "SURROGATES",
    "FirstOrderLag",
    "PowerLawLag",
    "ShearThinningLag",
    "power_law_map",
    "reference_pressure",
    "simulate_shear_thinning",
    "surrogate_class",
]

FloatArray = NDArray[np.float64]

#: Unit template of the gain: output unit per input unit (``{position}`` is the output's).
_GAIN_UNIT = "({position})/({load})"
#: Floor of the squared flow level (relative to q_ref^2) in tau_eff: keeps the ODE regular
#: at q = G = 0 (rest with no pressure drop) and changes nothing measurable elsewhere.
_EPS_LEVEL = 1e-12


def reference_pressure(dp: ArrayLike, digits: int = 3) -> float:
    """The data-derived pressure reference: max ``|dp|`` rounded to ``digits`` significant digits.

    Parameters
    ----------
    dp : array_like
        Pressure drops of the record(s) to be fitted.
    digits : int
        Significant digits kept (a readable reference; the exact value does not matter).

    Returns
    -------
    float
        A positive reference; ``1.0`` when every ``dp`` is zero.
    """
    top = float(np.max(np.abs(np.asarray(dp, dtype=float)))) if np.size(dp) else 0.0
    if not (math.isfinite(top) and top > 0):
        return 1.0
    return float(f"{top:.{digits - 1}e}")


def power_law_map(
    dp: ArrayLike, dp_ref: float, n: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """``g = dp_ref sign(dp) |dp/dp_ref|^(1/n)`` and its exact derivative ``dg/dn``.

    ``g`` has the unit of ``dp`` and equals ``dp`` for ``n = 1`` or ``|dp| = dp_ref``, so the
    gain of the linear part keeps the meaning it has in :class:`FirstOrderLag`.

    Parameters
    ----------
    dp : array_like, shape (..., N)
    dp_ref : float
    n : array_like, shape (...,) broadcasting against ``dp[..., 0]``

    Returns
    -------
    g, dg_dn : ndarray, shape (..., N)
    """
    d = np.asarray(dp, dtype=float)
    nn = np.asarray(n, dtype=float)[..., None]
    x = np.abs(d) / dp_ref
    pos = x > 0
    # ln|x| is -inf at dp = 0, where g and its derivative are exactly 0: mask it out.
    logx = np.log(np.where(pos, x, 1.0))
    mag = np.where(pos, np.exp(logx / nn), 0.0)
    g = dp_ref * np.sign(d) * mag
    dg_dn = np.where(pos, -g * logx / nn**2, 0.0)
    return g, dg_dn


@dataclass(frozen=True)
class FirstOrderLag(Model):
    """The paper's first-order surrogate: ``tau q' = gain dp - q``.

    Input ``dp`` (the model's "load"), output ``q`` (its "position"); a constant pressure drop
    settles at ``q = gain dp``. Use it the other way round (flow rate in, pressure drop out)
    by swapping the record's columns: the gain is then in pressure per flow rate.
    """

    tau: float = param("s", "time constant")
    gain: float = param(_GAIN_UNIT, "steady gain: output per unit input")

    states: ClassVar[tuple[str, ...]] = ("q",)
    outputs: ClassVar[Mapping[str, str]] = {"q": "the lagged output (flow rate for dp -> q)"}
    default_output: ClassVar[str] = "q"
    key: ClassVar[str] = "first-order-lag"
    title: ClassVar[str] = "first-order lag tau q' = gain dp - q"
    a_terms: ClassVar[Mapping[tuple[int, int], tuple[Term, ...]]] = {
        (0, 0): (term(-1, tau=-1),),
    }
    b_terms: ClassVar[Mapping[int, tuple[Term, ...]]] = {0: (term(1, gain=1, tau=-1),)}


class _Referenced:
    """Mixin: a pressure reference held on the class (see the module notes)."""

    #: Pressure reference in the input's unit; bound per fit by :meth:`at_reference`.
    dp_ref: ClassVar[float] = 1.0
    input_reference: ClassVar[float] = 1.0

    @classmethod
    def at_reference(cls, dp_ref: float) -> type:
        """This model with the pressure reference ``dp_ref`` (a cached subclass).

        The subclass keeps the class name, parameters and behaviour; only ``dp_ref``
        differs. The same ``dp_ref`` always returns the same class.
        """
        value = float(dp_ref)
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"dp_ref must be positive and finite, got {dp_ref!r}")
        base = cls.__dict__.get("_unbound", cls)
        return _bind(base, value)


@lru_cache(maxsize=64)
def _bind(base: type, dp_ref: float) -> type:
    return type(base.__name__, (base,), {
        "dp_ref": dp_ref, "input_reference": dp_ref, "_unbound": base,
        "__module__": base.__module__, "__qualname__": base.__qualname__,
        "__doc__": base.__doc__,
    })


@dataclass(frozen=True)
class PowerLawLag(_Referenced, FirstOrderLag):
    """Power-law static map before first-order dynamics (a Hammerstein model).

    ``tau q' = gain g(dp) - q``, ``g = dp_ref sign(dp) |dp / dp_ref|^(1/n)``: steady flow
    ``q = gain dp_ref |dp/dp_ref|^(1/n)`` is the power law of a fluid with flow index ``n``
    (Q ~ dp^(1/n)); ``gain`` is the steady q/dp at ``dp_ref``, ``tau`` the time constant at any
    level -- which is why it cannot follow the step-size dependence of a shear-thinning start
    up (see the module notes and :class:`ShearThinningLag`).
    """

    n: float = param("-", "flow-behaviour index of the static map (q ~ dp^(1/n))")

    key: ClassVar[str] = "power-law-lag"
    title: ClassVar[str] = "power-law map + first-order lag tau q' = gain g(dp) - q"
    # The linear part is FirstOrderLag's; n only enters through the input map.
    input_map: ClassVar[tuple[str, str] | None] = ("power-law", "n")

    def steady_flow(self, dp: ArrayLike) -> FloatArray:
        """Steady output for constant inputs ``dp``."""
        g, _ = power_law_map(dp, self.dp_ref, self.n)
        return self.gain * g


@dataclass(frozen=True)
class ShearThinningLag(_Referenced, Model):
    """First-order relaxation to the power-law flow with a flow-dependent time constant.

    ``q' = (G(dp) - q) / tau_eff``, ``G = gain g(dp)`` as in :class:`PowerLawLag` and
    ``tau_eff = tau ((G^2 + q^2) / (2 q_ref^2))^((1 - n)/2)``, ``q_ref = gain dp_ref``.

    ``tau`` is the time constant in steady flow at ``dp_ref``; at a steady pressure drop
    ``dp`` it is ``tau |dp/dp_ref|^((1-n)/n)``, the scaling of the power-law pipe flow. Not
    linear in ``q``: simulate it with :func:`simulate_shear_thinning`, fit it with
    :func:`pumpid.flow.fit_flow` (``model="shear-thinning"``).
    """

    tau: float = param("s", "time constant in steady flow at dp_ref")
    gain: float = param(_GAIN_UNIT, "steady q/dp at dp_ref")
    n: float = param("-", "flow-behaviour index (q ~ dp^(1/n), tau ~ dp^((1-n)/n))")

    states: ClassVar[tuple[str, ...]] = ("q",)
    outputs: ClassVar[Mapping[str, str]] = {"q": "flow rate"}
    default_output: ClassVar[str] = "q"
    key: ClassVar[str] = "shear-thinning-lag"
    title: ClassVar[str] = ("flow-dependent first-order lag q' = (G(dp) - q) / tau_eff(G, q), "
                            "self-similar like a power-law pipe flow")
    #: Not a linear state-space model: pumpid.simulate and pumpid.fit do not apply.
    nonlinear: ClassVar[bool] = True

    def steady_flow(self, dp: ArrayLike) -> FloatArray:
        """Steady flow rate for constant pressure drops ``dp``."""
        g, _ = power_law_map(dp, self.dp_ref, self.n)
        return self.gain * g

    def steady_time_constant(self, dp: ArrayLike) -> FloatArray:
        """Small-signal time constant about steady flow at ``dp``: ``tau |dp/dp_ref|^((1-n)/n)``.

        At steady flow ``q = G``, so ``tau_eff = tau (G/q_ref)^(1-n)``; the linearization of
        ``(G - q)/tau_eff`` about it has this time constant because the numerator vanishes.
        """
        x = np.abs(np.asarray(dp, dtype=float)) / self.dp_ref
        return self.tau * x ** ((1.0 - self.n) / self.n)


def _rhs_factory(
    theta: FloatArray, dp_ref: float, t: FloatArray, dp: FloatArray, with_sens: bool
):
    tau, gain, n = (float(v) for v in theta)
    k = gain * dp_ref  # q_ref
    m = 0.5 * (1.0 - n)
    inv_k2 = 1.0 / (k * k)
    slopes = np.diff(dp) / np.diff(t)

    def dp_at(time: float) -> float:
        # Piecewise linear between samples (the first-order hold of pumpid.simulate), held
        # constant outside.
        i = int(np.clip(np.searchsorted(t, time, side="right") - 1, 0, t.size - 2))
        return float(dp[i] + slopes[i] * (min(max(time, t[0]), t[-1]) - t[i]))

    def terms(time: float, q: float):
        d = dp_at(time)
        x = abs(d) / dp_ref
        if x > 0:
            lx = math.log(x)
            big_g = k * math.copysign(math.exp(lx / n), d)
            dgn = -big_g * lx / n**2
        else:
            big_g, dgn = 0.0, 0.0
        u = 0.5 * (big_g * big_g + q * q) * inv_k2 + _EPS_LEVEL
        um = u ** (-m)
        diff = big_g - q
        f = diff * um / tau
        return big_g, dgn, u, um, diff, f

    def rhs(time: float, y: FloatArray) -> FloatArray:
        q = y[0]
        big_g, dgn, u, um, diff, f = terms(time, q)
        if not with_sens:
            return np.array([f])
        du_dq = q * inv_k2
        f_q = -um / tau - m * diff * um / tau * du_dq / u
        f_tau = -f / tau
        du_dgain = -q * q * inv_k2 / gain
        f_gain = (big_g / gain) * um / tau - m * diff * um / tau * du_dgain / u
        du_dn = big_g * dgn * inv_k2
        f_n = dgn * um / tau + diff * um / tau * (0.5 * math.log(u) - m * du_dn / u)
        s = y[1:]
        return np.array([f, f_q * s[0] + f_tau, f_q * s[1] + f_gain, f_q * s[2] + f_n])

    def jac(time: float, y: FloatArray) -> FloatArray:
        # d rhs / d y for the state block; the sensitivity rows reuse f_q on the diagonal
        # (their coupling to q is left out: the implicit solver only needs an approximation).
        q = y[0]
        _, _, u, um, diff, _ = terms(time, q)
        f_q = -um / tau - m * diff * um / tau * (q * inv_k2) / u
        size = 4 if with_sens else 1
        return np.eye(size) * f_q

    return rhs, jac, dp_at


def simulate_shear_thinning(
    model: ShearThinningLag | ArrayLike,
    t: ArrayLike,
    dp: ArrayLike,
    *,
    dp_ref: float | None = None,
    initial_state: str | float = "rest",
    sensitivities: bool = False,
    rtol: float = 1e-9,
) -> FloatArray | tuple[FloatArray, FloatArray]:
    """Integrate :class:`ShearThinningLag` for a sampled pressure drop.

    Parameters
    ----------
    model : ShearThinningLag or array_like (tau, gain, n)
        The model (its class carries ``dp_ref``) or a parameter vector with ``dp_ref=``.
    t, dp : array_like, shape (N,)
        Times (s, strictly increasing) and pressure drops; ``dp`` is taken piecewise linear
        between samples, as in :func:`pumpid.simulate`.
    dp_ref : float, optional
        Pressure reference for a parameter vector (default: the model class's).
    initial_state : {"rest", "equilibrium"} or float
        ``rest`` (q = 0), ``equilibrium`` (steady flow under ``dp[0]``) or the flow itself.
    sensitivities : bool
        Also return ``dq/d(tau, gain, n)`` from the forward sensitivity equations.
    rtol : float
        Relative tolerance of the implicit integrator (LSODA switches to BDF when stiff: the
        time constant shrinks toward zero flow for n < 1).

    Returns
    -------
    q : ndarray, shape (N,)
    dq : ndarray, shape (N, 3), only with ``sensitivities``
    """
    if isinstance(model, ShearThinningLag):
        theta = model.values
        ref = type(model).dp_ref if dp_ref is None else float(dp_ref)
    else:
        theta = np.asarray(model, dtype=float).ravel()
        if theta.size != 3:
            raise ValueError("parameter vector must be (tau, gain, n)")
        ref = ShearThinningLag.dp_ref if dp_ref is None else float(dp_ref)
    tt = np.asarray(t, dtype=float)
    dd = np.asarray(dp, dtype=float)
    if tt.ndim != 1 or tt.shape != dd.shape or tt.size < 2:
        raise ValueError("t and dp must be 1-D arrays of equal length >= 2")
    if np.any(np.diff(tt) <= 0):
        raise ValueError("t must be strictly increasing")
    if not (np.all(np.isfinite(tt)) and np.all(np.isfinite(dd)) and np.all(theta > 0)):
        raise ValueError("t, dp must be finite and tau, gain, n positive")
    tau, gain, n = theta
    k = gain * ref
    g0, dgn0 = power_law_map(dd[:1], ref, n)
    s0 = np.zeros(3)
    if isinstance(initial_state, str):
        if initial_state == "rest":
            q0 = 0.0
        elif initial_state == "equilibrium":
            q0 = float(gain * g0[0])
            s0 = np.array([0.0, float(g0[0]), float(gain * dgn0[0])])
        else:
            raise ValueError(f"initial_state must be 'rest', 'equilibrium' or a number, "
                             f"got {initial_state!r}")
    else:
        q0 = float(initial_state)
    rhs, jac, _ = _rhs_factory(theta, ref, tt, dd, sensitivities)
    y0 = np.concatenate([[q0], s0]) if sensitivities else np.array([q0])
    # Absolute tolerances on each component's natural scale (flow q_ref, and q_ref per unit
    # of each parameter), so results do not depend on the units of the data.
    scales = np.array([k, k / tau, k / gain, k / n])[: y0.size]
    sol = solve_ivp(rhs, (tt[0], tt[-1]), y0, method="LSODA", t_eval=tt, rtol=rtol,
                    atol=1e-3 * rtol * scales, jac=jac)
    if sol.status != 0 or sol.y.shape[1] != tt.size:
        raise RuntimeError(f"ShearThinningLag integration failed: {sol.message}")
    q = sol.y[0]
    if sensitivities:
        return q, sol.y[1:].T.copy()
    return q


SURROGATES: dict[str, type[Model]] = {
    "first-order": FirstOrderLag,
    "power-law": PowerLawLag,
    "shear-thinning": ShearThinningLag,
}


def surrogate_class(name: str | type[Model]) -> type[Model]:
    """Resolve a surrogate name: ``first-order``, ``power-law`` or ``shear-thinning``."""
    if isinstance(name, type) and issubclass(name, Model):
        return name
    key = str(name).strip().lower().replace("_", "-")
    aliases = {"linear": "first-order", "first-order-lag": "first-order",
               "power-law-lag": "power-law", "hammerstein": "power-law",
               "shear-thinning-lag": "shear-thinning", "self-similar": "shear-thinning"}
    key = aliases.get(key, key)
    if key not in SURROGATES:
        raise ValueError(f"unknown flow model {name!r}; choose one of {sorted(SURROGATES)}")
    return SURROGATES[key]
