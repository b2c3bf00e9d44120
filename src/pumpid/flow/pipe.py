"""The pipe, the power-law fluid, and their flows in closed form.

The closed forms are steady fully developed flow of a power-law fluid, Szymanski's series
for Newtonian start-up flow, and the time scales of start-up: the references that the
simulator (:mod:`~pumpid.flow.pipeflow`) is checked against and that choose its output times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import jn_zeros

__all__ = [
    "J01",
    "FloatArray",
    "Pipe",
    "PowerLawFluid",
    "check_positive_finite",
    "newtonian_slowest_time_constant",
    "power_law_time_scale",
    "steady_power_law_flow_rate",
    "steady_power_law_velocity",
    "szymanski_flow_rate",
]

#: First zero of the Bessel function J0.
J01 = float(jn_zeros(0, 1)[0])

FloatArray = NDArray[np.float64]


def check_positive_finite(name: str, value: Any) -> float:
    """Return ``value`` as float, raising a clear ValueError unless it is positive and finite.

    Parameters
    ----------
    name : str
        What the value is, for the message.
    value : Any
        The value given.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If ``value`` is not a real number, or not positive and finite.
    """
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real number, got {value!r}") from exc
    if not math.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return x


@dataclass(frozen=True)
class PowerLawFluid:
    """Generalized-Newtonian power-law fluid, ``eta = K * gamma**(n - 1)`` (SI units).

    Parameters
    ----------
    K : float
        Consistency index in Pa s^n (for ``n = 1`` this is the dynamic viscosity in Pa s).
    n : float
        Flow-behaviour index (``n < 1`` shear-thinning, ``n = 1`` Newtonian).
    rho : float
        Density in kg/m^3.
    """

    K: float
    n: float
    rho: float

    def __post_init__(self) -> None:
        # Normalize to plain floats so that numpy scalars / ints behave identically everywhere.
        object.__setattr__(
            self, "K", check_positive_finite("PowerLawFluid.K (consistency)", self.K)
        )
        object.__setattr__(
            self, "n", check_positive_finite("PowerLawFluid.n (flow index)", self.n)
        )
        object.__setattr__(
            self, "rho", check_positive_finite("PowerLawFluid.rho (density)", self.rho)
        )

    @classmethod
    def newtonian(cls, mu: float, rho: float) -> PowerLawFluid:
        """Newtonian fluid of dynamic viscosity ``mu`` (Pa s) and density ``rho`` (kg/m^3)."""
        return cls(K=mu, n=1.0, rho=rho)


@dataclass(frozen=True)
class Pipe:
    """Straight rigid pipe.

    Parameters
    ----------
    radius : float
        Inner radius ``R`` in m.
    length : float
        Length ``L`` in m over which the pressure drop acts.
    """

    radius: float
    length: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", check_positive_finite("Pipe.radius", self.radius))
        object.__setattr__(self, "length", check_positive_finite("Pipe.length", self.length))


# ----------------------------------------------------------------------------------------------
# Closed-form helpers
# ----------------------------------------------------------------------------------------------


def steady_power_law_flow_rate(dp: ArrayLike, fluid: PowerLawFluid, pipe: Pipe) -> Any:
    """Steady (fully developed) flow rate of an unregularized power-law fluid.

    ``Q = pi n R^3 / (3 n + 1) * (R |dp| / (2 K L))**(1/n)``, with the sign of ``dp``.

    Parameters
    ----------
    dp : float or array_like
        Pressure drop(s) in Pa.
    fluid : PowerLawFluid
    pipe : Pipe

    Returns
    -------
    float or ndarray
        Flow rate in m^3/s (same shape as ``dp``).
    """
    d = np.asarray(dp, dtype=float)
    n, R = fluid.n, pipe.radius
    wall_stress = R * np.abs(d) / (2.0 * pipe.length)  # exact in steady flow, any rheology
    q = np.sign(d) * math.pi * n * R**3 / (3.0 * n + 1.0) * (wall_stress / fluid.K) ** (1.0 / n)
    return float(q) if q.ndim == 0 else q


def steady_power_law_velocity(
    r: ArrayLike, dp: float, fluid: PowerLawFluid, pipe: Pipe
) -> FloatArray:
    """Steady velocity profile of an unregularized power-law fluid.

    ``w(r) = n/(n+1) (|dp|/(2 K L))**(1/n) (R**((n+1)/n) - r**((n+1)/n))`` with the sign of
    ``dp``. Handy as ``initial_velocity`` to start a simulation from steady flow.
    """
    rr = np.abs(np.asarray(r, dtype=float))
    n, R = fluid.n, pipe.radius
    a = (abs(dp) / (2.0 * fluid.K * pipe.length)) ** (1.0 / n)
    e = (n + 1.0) / n
    return np.sign(dp) * n / (n + 1.0) * a * (R**e - np.minimum(rr, R) ** e)


@lru_cache(maxsize=16)
def _bessel_j0_zeros(n_terms: int) -> FloatArray:
    z = jn_zeros(0, n_terms)
    z.setflags(write=False)
    return z


def szymanski_flow_rate(
    t: ArrayLike,
    dp: float,
    mu: float,
    rho: float,
    pipe: Pipe,
    n_terms: int | None = None,
) -> FloatArray:
    """Szymanski's series for Newtonian start-up flow after a pressure-drop step at ``t = 0``.

    ``Q(t) / Q_s = 1 - 32 sum_k exp(-j_k^2 nu t / R^2) / j_k^4`` with ``j_k`` the zeros of
    ``J0``, ``Q_s = pi R^4 dp / (8 mu L)`` and ``nu = mu / rho``; ``Q = 0`` for ``t <= 0``.

    Parameters
    ----------
    t : array_like
        Times in s.
    dp : float
        Pressure drop applied for ``t > 0`` (Pa).
    mu, rho : float
        Dynamic viscosity (Pa s) and density (kg/m^3).
    pipe : Pipe
    n_terms : int, optional
        Number of series terms. By default it is chosen so that the first omitted term,
        ``exp(-j^2 nu t / R^2)``, is below 1e-17 at the smallest positive time (at most 20000
        terms; the truncation error is also bounded by ``32 / (3 pi^4 n_terms^3)`` times
        ``Q_s`` since ``sum_k j_k^-4 = 1/32``).

    Returns
    -------
    ndarray
        Flow rate in m^3/s, same shape as ``t``.
    """
    mu = check_positive_finite("mu", mu)
    rho = check_positive_finite("rho", rho)
    tt = np.asarray(t, dtype=float)
    R = pipe.radius
    q_s = math.pi * R**4 * float(dp) / (8.0 * mu * pipe.length)
    s = mu / rho * tt / R**2  # dimensionless time nu t / R^2
    pos = s > 0.0
    if n_terms is None:
        s_min = float(s[pos].min()) if np.any(pos) else 1.0
        # exp(-j^2 s) < 1e-17 for j > sqrt(39.2 / s); j_k ~ pi (k - 1/4).
        n_terms = int(min(20000, max(50, math.ceil(math.sqrt(39.2 / s_min) / math.pi) + 2)))
    elif int(n_terms) < 1:
        raise ValueError(f"n_terms must be a positive integer, got {n_terms!r}")
    j = _bessel_j0_zeros(int(n_terms))
    sp_ = s[pos].reshape(-1, 1)
    series = np.exp(-(j**2) * sp_) @ (1.0 / j**4)
    out = np.zeros_like(s)
    out[pos] = 1.0 - 32.0 * series
    return q_s * out


def newtonian_slowest_time_constant(mu: float, rho: float, pipe: Pipe) -> float:
    """Slowest time constant of Newtonian start-up flow, ``rho R^2 / (mu j01^2)`` in s."""
    mu = check_positive_finite("mu", mu)
    rho = check_positive_finite("rho", rho)
    return rho * pipe.radius**2 / (mu * J01**2)


def power_law_time_scale(dp: float, fluid: PowerLawFluid, pipe: Pipe) -> float:
    """Apparent slowest time constant ``rho R^2 / (eta_w j01^2)`` of start-up under ``dp``.

    ``eta_w = K gamma_w^(n - 1)`` is the viscosity at the steady wall shear rate
    ``gamma_w = (R |dp| / (2 K L))^(1/n)``; for ``n = 1`` this is
    :func:`newtonian_slowest_time_constant`. For ``n != 1`` it is a scale, not an exact
    eigenvalue (the final approach to steady flow is slower than ``exp(-t / scale)``, by a
    factor of about 1.6 in the exponent for ``n = 0.4``), and it grows like
    ``|dp|^((1 - n)/n)``: the response of a shear-thinning fluid to a larger step is *slower*
    (the model is self-similar, see :func:`simulate_pipe_flow`). Useful to choose output
    times.
    """
    d = check_positive_finite("|dp|", abs(float(dp)))
    gamma_w = (pipe.radius * d / (2.0 * fluid.K * pipe.length)) ** (1.0 / fluid.n)
    eta_w = fluid.K * gamma_w ** (fluid.n - 1.0)
    return fluid.rho * pipe.radius**2 / (eta_w * J01**2)
