"""Derived quantities of a fit with their standard errors: what can be trended.

On real cards single parameters are often not determined (the Kelvin model's k0 runs to its
rigid limit and the mass, the Kelvin spring and the offset trade off), while physical
combinations are: the natural frequency and damping ratio of the oscillating pair of poles,
another real pole's time constant, the stiffness seen at the observed output. The model
says what they are (:meth:`pumpid.Model.derived_info`); this module gives each its value,
its standard error by the delta method on the fit's covariance (the white-noise one and the
autocorrelation-robust one; the robust one is shown where the residuals are serially
correlated), and whether the data determine it.

The gradient is taken by central differences in the scaled coordinates the covariance is
expressed in (``ln`` of the positive values), over the coordinates analysed at the optimum (a
parameter at a boundary is held at its limit, as in the covariance). A quantity that moves
along a structurally undetermined direction has an infinite error; it is *determined* when
its relative standard error (the one shown: robust where the residuals are serially
correlated) is below :data:`~pumpid.inference.uncertainty.PRACTICAL_REL_SE`, the rule the
parameters follow.

At a boundary solution a quantity that still moves when the limiting parameter goes further
toward its limit (the Kelvin model's third pole when k0 -> infinity: its time constant
shrinks with 1/k0) only says where the solver stopped on the window's edge: its error is
infinite and it is not determined. Quantities the limit leaves in place (the oscillating
pair's frequency and damping, the static stiffness) keep their errors.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ..models import Model
from ..result import Derived
from .uncertainty import PRACTICAL_REL_SE, STRUCTURAL_TOL, Numbers

__all__ = ["Derived", "delta_errors", "derived_gradient", "derived_of", "moved_by_limits"]

Array = NDArray[np.float64]

#: Central-difference step in the log of a parameter.
_STEP = 1e-6


def derived_gradient(cls: type[Model], theta: Array, observe: str, scale: float,
              coords: Sequence[str]) -> Array:
    """d(derived values)/d(scaled coordinate) for each of ``coords`` (k, len(coords)).

    Coordinates: parameter names (their logarithms), ``C``/``D`` (the log of the scale) and
    ``offset`` (which moves none of them).
    """
    names = cls.param_names()
    k = len(cls.derived_info())
    grad = np.zeros((k, len(coords)))
    thetas: list[Array] = []
    scales: list[float] = []
    moved: list[int] = []
    for a, name in enumerate(coords):
        if name in names:
            i = names.index(name)
            for sign in (1.0, -1.0):
                th = theta.copy()
                th[i] *= math.exp(sign * _STEP)
                thetas.append(th)
                scales.append(scale)
        elif name in ("C", "D"):
            thetas += [theta, theta]
            scales += [scale * math.exp(_STEP), scale * math.exp(-_STEP)]
        else:  # the offset moves no derived quantity
            continue
        moved.append(a)
    if moved:
        vals = cls.derived_values(np.array(thetas), observe, np.array(scales))
        grad[:, moved] = ((vals[0::2] - vals[1::2]) / (2 * _STEP)).T
    return grad


def delta_errors(grad: Array, nums: Numbers) -> tuple[Array, Array]:
    """Standard errors (independent-noise, robust) of quantities by the delta method.

    Parameters
    ----------
    grad : ndarray, shape (k, qi)
        d(quantity)/d(coordinate) over the coordinates analysed at the optimum
        (``nums.inner``, in order), in the analysis' scaled coordinates: the logarithm of a
        positive parameter, an additive one as it is.
    nums : Numbers
        The analysis at the optimum.

    Returns
    -------
    se, se_hac : ndarray, shape (k,)
        Infinite for a quantity that moves along a structurally undetermined direction,
        NaN where its gradient is not finite.
    """
    k = grad.shape[0]
    se = np.full(k, math.nan)
    se_hac = np.full(k, math.nan)
    qi = len(nums.inner)
    cov = nums.cov_scaled[:qi, :qi]
    hac = nums.hac_scaled[:qi, :qi]
    s = nums.singular[:qi]
    vt = nums.vt[:qi, :qi]
    weak = [r for r in range(qi) if not (s[r] > STRUCTURAL_TOL * s[0])]
    for j in range(k):
        g = grad[j]
        if not np.all(np.isfinite(g)):
            continue
        size = float(np.linalg.norm(g))
        if any(abs(float(vt[r] @ g)) > 1e-6 * size for r in weak):
            se[j] = se_hac[j] = math.inf
            continue
        with np.errstate(invalid="ignore", over="ignore"):
            var = float(g @ cov @ g)
            var_hac = float(g @ hac @ g)
        se[j] = math.sqrt(var) if var >= 0 else math.nan
        se_hac[j] = math.sqrt(var_hac) if var_hac >= 0 else math.nan
    return se, se_hac


def moved_by_limits(cls: type[Model], theta: Array, observe: str, scale: float,
                     values: Array, limits: Sequence[tuple[str, str]]) -> NDArray[np.bool_]:
    """The quantities that change when a boundary parameter goes a factor e further."""
    moved = np.zeros(values.size, dtype=bool)
    names = cls.param_names()
    for name, direction in limits:
        if name not in names:
            continue
        further = np.array(theta, dtype=float)
        further[names.index(name)] *= math.e if direction == "infinity" else 1 / math.e
        with np.errstate(all="ignore"):
            changed = np.abs(cls.derived_values(further, observe, scale) - values)
            moved |= ~(changed <= 1e-3 * np.abs(values))
    return moved & np.isfinite(values)


def derived_of(
    cls: type[Model],
    theta: Array,
    *,
    observe: str,
    scale: float,
    nums: Numbers | None,
    units: tuple[str, str],
    serial: bool = False,
    limits: Sequence[tuple[str, str]] = (),
    floor: NDArray[np.float64] | None = None,
    robust_floor: NDArray[np.float64] | None = None,
) -> Mapping[str, Derived]:
    """The derived quantities of one fit.

    Parameters
    ----------
    cls : Model class
    theta : (p,) fitted parameters; observe : the observed output; scale : C.
    nums : the analysis at the optimum (None: values only, errors NaN).
    units : (load unit, position unit) of the data.
    serial : the robust errors are shown (the residuals are serially correlated or too
        few to test; the robust error then counts too).
    limits : (parameter, "zero" or "infinity") of each parameter at a boundary.
    floor : each quantity's smallest error (both kinds), or None: what a point elsewhere
        within the noise implies (its value there).
    robust_floor : the robust error's own, where the noise the robust errors describe
        reaches farther (None: ``floor``).
    """
    infos = cls.derived_info()
    values = cls.derived_values(theta, observe, scale)
    se = np.full(len(infos), math.nan)
    se_hac = np.full(len(infos), math.nan)
    if nums is not None and nums.usable and nums.dof > 0:
        coords = [nums.names[i] for i in nums.inner]
        grad = derived_gradient(cls, theta, observe, scale, coords)
        se, se_hac = delta_errors(grad, nums)
    moved = moved_by_limits(cls, theta, observe, scale, values, limits)
    se[moved] = math.inf
    se_hac[moved] = math.inf
    if floor is not None:
        se = np.fmax(se, floor)
        se_hac = np.fmax(se_hac, floor)
    if robust_floor is not None:
        se_hac = np.fmax(se_hac, robust_floor)
    out: dict[str, Derived] = {}
    load, position = units
    for k, info in enumerate(infos):
        value = float(values[k])
        bound = PRACTICAL_REL_SE * abs(value)
        # The error shown (and the verdict) is the one that holds for these residuals.
        shown = se_hac[k] if serial and not math.isnan(se_hac[k]) else se[k]
        determined = bool(math.isfinite(value) and shown < bound)
        out[info.name] = Derived(info.name, value, info.unit_for(load, position),
                                 float(shown), float(se_hac[k]), determined, info.meaning,
                                 stderr_white=float(se[k]))
    return out
