"""Mass on a spring k0 in series with a Kelvin element (k1 parallel c1), eqs. (8)-(9)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import EquationError, Limit, Model, Term, param, term

__all__ = ["Kelvin", "viscoelastic_shapes"]


def _positive(*cols: np.ndarray) -> np.ndarray:
    ok = np.ones(cols[0].shape, dtype=bool)
    for c in cols:
        ok &= np.isfinite(c) & (c > 0)
    return ok


def _from_u2(c: np.ndarray) -> np.ndarray:
    # F = a3 y''' + a2 y'' + a1 y' + a0 y with a3 = m c1/k0, a2 = m (k0+k1)/k0, a1 = c1,
    # a0 = k1: the four parameters map one-to-one onto the coefficients.
    a3, a2, a1, a0 = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
    c1, k1 = a1, a0
    with np.errstate(all="ignore"):
        m = a2 - k1 * a3 / c1
        k0 = m * c1 / a3
    out = np.stack([k0, m, c1, k1], axis=1)
    out[~(_positive(a3, c1, k1) & _positive(k0, m))] = np.nan
    return out


def _from_u(c: np.ndarray) -> np.ndarray:
    # F = e3 y''' + e2 y'' + e1 y' + e0 y - g1 F' with e2 = m, g1 = c1/(k0+k1), e1 = g1 k0,
    # e0 = k0 k1/(k0+k1).
    e2, e1, e0, g1 = c[:, 1], c[:, 2], c[:, 3], -c[:, 4]
    m = e2
    with np.errstate(all="ignore"):
        k0 = e1 / g1
        k1 = e0 * k0 / (k0 - e0)
        c1 = g1 * (k0 + k1)
    out = np.stack([k0, m, c1, k1], axis=1)
    ok = _positive(g1, m, e1, e0) & (k0 > e0) & _positive(k0, m, c1, k1)
    out[~ok] = np.nan
    return out


def viscoelastic_shapes(w0: float, series: bool, dense: bool = False) -> np.ndarray:
    """Shapes (k0, m, c1, k1) of the three-parameter viscoelastic models at unit k1.

    Natural frequencies of 0.5-16 fundamentals, k0/k1 from 0.3 to 30 and dashpot time
    constants c1/k1 of 0.1-10 over w0. ``series``: the static stiffness is k0 k1/(k0+k1)
    (Kelvin); otherwise k0 + k1 (Maxwell). ``dense``: the wide search's grid, natural
    frequencies from 0.25 to 64 fundamentals in steps of 12 % and on each of the first 16
    harmonics (a lightly damped resonance has a local optimum near every harmonic of a
    card), k0/k1 from 0.01 to 1e6 and time constants from 1e-5 to 300 over w0.
    """
    if dense:
        # Log-spaced frequencies, and each of the first 16 harmonics itself: a nearly
        # undamped resonance placed on a harmonic is a local optimum of its own.
        ratios = tuple(sorted({*np.geomspace(0.25, 64.0, 48).tolist(),
                               *(float(h) for h in range(1, 17))}))
        stiffness = (0.01, 0.1, 1.0, 10.0, 100.0, 1e4, 1e6)
        taus = (1e-5, 1e-3, 0.03, 0.3, 3.0, 30.0, 300.0)
    else:
        ratios = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
        stiffness = (0.3, 1.0, 3.0, 30.0)
        taus = (0.1, 1.0, 10.0)
    # Every (frequency, stiffness ratio, time constant), the time constant varying fastest;
    # k1 = 1. Broadcast: the dense grid's 3,136 rows cost a millisecond in a Python loop.
    r = np.array(ratios)[:, None, None]
    k0 = np.array(stiffness)[None, :, None]
    tau = np.array(taus)[None, None, :]
    k_static = k0 / (k0 + 1.0) if series else k0 + 1.0
    shape = (r.size, k0.size, tau.size)
    return np.stack([np.broadcast_to(k0, shape), np.broadcast_to(k_static / (r * w0) ** 2, shape),
                     np.broadcast_to(tau / w0, shape), np.ones(shape)], axis=-1).reshape(-1, 4)


@dataclass(frozen=True)
class Kelvin(Model):
    """Mass on a spring k0 in series with a Kelvin element (k1 parallel c1), eqs. (8)-(9).

    States: mass displacement ``u``, its velocity ``v`` and the Kelvin element's
    displacement ``u2``::

        m v'   = F - k0 (u - u2)
        c1 u2' = k0 (u - u2) - k1 u2

    The paper fits ``u2``; the polished rod, where the load is measured, moves with the
    mass: ``u`` is the default (see README, "Which output a card observes").
    """

    k0: float = param("{load}/{position}", "series spring stiffness")
    m: float = param("{load}*s^2/{position}", "lumped mass")
    c1: float = param("{load}*s/{position}", "Kelvin dashpot")
    k1: float = param("{load}/{position}", "Kelvin spring stiffness")

    states: ClassVar[tuple[str, ...]] = ("u", "v", "u2")
    outputs: ClassVar[Mapping[str, str]] = {
        "u": "displacement of the mass, where the load acts (the polished rod; default)",
        "u2": "displacement of the Kelvin element (the paper's fitted output)",
    }
    default_output: ClassVar[str] = "u"
    scale_symmetric: ClassVar[bool] = True
    key: ClassVar[str] = "kelvin"
    resonance: ClassVar[str | None] = "m"
    title: ClassVar[str] = "mass + spring k0 in series with Kelvin element k1 || c1 (eqs. 8-9)"
    a_terms: ClassVar[Mapping[tuple[int, int], tuple[Term, ...]]] = {
        (0, 1): (term(1),),
        (1, 0): (term(-1, k0=1, m=-1),),
        (1, 2): (term(1, k0=1, m=-1),),
        (2, 0): (term(1, k0=1, c1=-1),),
        (2, 2): (term(-1, k0=1, c1=-1), term(-1, k1=1, c1=-1)),
    }
    b_terms: ClassVar[Mapping[int, tuple[Term, ...]]] = {1: (term(1, m=-1),)}
    equation_error: ClassVar[Mapping[str, EquationError]] = {
        "u2": EquationError(("f", 0), (3, 2, 1, 0), (), _from_u2),
        "u": EquationError(("f", 0), (3, 2, 1, 0), (1,), _from_u),
    }
    limits: ClassVar[tuple[Limit, ...]] = (
        Limit("k0", "infinity",
              "k0 -> inf: rigid series spring, the mass-spring-dashpot "
              "m u'' + c1 u' + k1 u = F (u = u2)",
              reduced="msd", observe="u",
              to_reduced={"m": (term(1, m=1),), "c": (term(1, c1=1),), "k": (term(1, k1=1),)},
              from_reduced={"k0": (term(1e3, k=1),), "m": (term(1, m=1),),
                            "c1": (term(1, c=1),), "k1": (term(1, k=1),)}),
        Limit("m", "zero",
              "m -> 0: no inertia, a first-order creep c1 u2' + k1 u2 = F (u = u2 + F/k0)",
              reduced="first-order", observe="u",
              to_reduced={"tau": (term(1, c1=1, k1=-1),)}, gain=(term(1, c1=-1),),
              companions={"u": (("k0", "infinity"),)}),
        Limit("c1", "infinity",
              "c1 -> inf: the Kelvin element is locked, an undamped mass on the spring k0"),
        Limit("c1", "zero", "c1 -> 0: no damping, a mass on the springs k0 and k1 in series"),
        Limit("k1", "zero",
              "k1 -> 0: the Kelvin element is a bare dashpot (a Maxwell fluid in series)"),
        Limit("k1", "infinity",
              "k1 -> inf: the Kelvin element is rigid, an undamped mass on the spring k0"),
        Limit("k0", "zero", "k0 -> 0: the load no longer reaches the Kelvin element"),
    )

    @classmethod
    def shape_grid(cls, w0: float, dense: bool = False) -> np.ndarray:
        """See :func:`viscoelastic_shapes` (series springs)."""
        return viscoelastic_shapes(w0, series=True, dense=dense)

    # A holds (k0 + k1) / c1: where one spring is 1e15 times the other (a fit at its
    # limits) the smaller is lost to rounding, and the static gain and the creep pole taken
    # from A came out 3-6 times off. Both are written from the parameters instead.
    @classmethod
    def characteristic(cls, theta: np.ndarray) -> np.ndarray:
        """det(s I - A) times m c1: m c1 s^3 + m (k0 + k1) s^2 + k0 c1 s + k0 k1."""
        k0, m, c1, k1 = (np.asarray(theta, dtype=float)[..., i] for i in range(4))
        return np.stack([m * c1, m * (k0 + k1), k0 * c1, k0 * k1], axis=-1)

    @classmethod
    def static_gains(cls, theta: np.ndarray, observe: str | None = None) -> np.ndarray:
        """Static displacement per unit load: the springs in series (u), k1 alone (u2)."""
        th = np.asarray(theta, dtype=float)
        k0, k1 = th[..., 0], th[..., 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            if cls.output_index(observe) == cls.states.index("u2"):
                return 1.0 / k1
            return 1.0 / k0 + 1.0 / k1
