"""Mass on a spring k0 in parallel with a Maxwell arm (k1 in series with c1), eqs. (11)-(12)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import EquationError, Limit, Model, Term, param, term
from .kelvin import viscoelastic_shapes

__all__ = ["Maxwell"]


def _from_u(c: np.ndarray) -> np.ndarray:
    # F = e3 y''' + e2 y'' + e1 y' + e0 y - tau F' with tau = c1/k1, e2 = m,
    # e1 = (k0 + k1) tau, e0 = k0.
    e2, e1, e0, tau = c[:, 1], c[:, 2], c[:, 3], -c[:, 4]
    m, k0 = e2, e0
    with np.errstate(all="ignore"):
        k1 = e1 / tau - k0
        c1 = tau * k1
    out = np.stack([k0, m, c1, k1], axis=1)
    ok = np.ones(out.shape[0], dtype=bool)
    for col in (tau, m, k0, k1, c1):
        ok &= np.isfinite(col) & (col > 0)
    out[~ok] = np.nan
    return out


@dataclass(frozen=True)
class Maxwell(Model):
    """Mass on a spring k0 in parallel with a Maxwell arm (k1 in series with c1), eqs. (11)-(12).

    States: mass displacement ``u``, velocity ``v`` and the Maxwell arm's force ``F0``::

        m v' = F - k0 u - F0
        F0'  = k1 (v - F0 / c1)

    Only the load itself drives the system: the paper's form (eq. 13) needs dF/dt, this one
    does not.
    """

    k0: float = param("{load}/{position}", "parallel spring stiffness")
    m: float = param("{load}*s^2/{position}", "lumped mass")
    c1: float = param("{load}*s/{position}", "Maxwell dashpot")
    k1: float = param("{load}/{position}", "Maxwell spring stiffness")

    states: ClassVar[tuple[str, ...]] = ("u", "v", "F0")
    outputs: ClassVar[Mapping[str, str]] = {"u": "displacement of the mass"}
    default_output: ClassVar[str] = "u"
    scale_symmetric: ClassVar[bool] = True
    key: ClassVar[str] = "maxwell"
    resonance: ClassVar[str | None] = "m"
    title: ClassVar[str] = "mass + spring k0 in parallel with Maxwell arm k1 -- c1 (eqs. 11-12)"
    a_terms: ClassVar[Mapping[tuple[int, int], tuple[Term, ...]]] = {
        (0, 1): (term(1),),
        (1, 0): (term(-1, k0=1, m=-1),),
        (1, 2): (term(-1, m=-1),),
        (2, 1): (term(1, k1=1),),
        (2, 2): (term(-1, k1=1, c1=-1),),
    }
    b_terms: ClassVar[Mapping[int, tuple[Term, ...]]] = {1: (term(1, m=-1),)}
    equation_error: ClassVar[Mapping[str, EquationError]] = {
        "u": EquationError(("f", 0), (3, 2, 1, 0), (1,), _from_u),
    }
    limits: ClassVar[tuple[Limit, ...]] = (
        Limit("k1", "infinity",
              "k1 -> inf: the Maxwell arm is a bare dashpot, the mass-spring-dashpot "
              "m u'' + c1 u' + k0 u = F",
              reduced="msd", observe="u",
              to_reduced={"m": (term(1, m=1),), "c": (term(1, c1=1),), "k": (term(1, k0=1),)},
              from_reduced={"k0": (term(1, k=1),), "m": (term(1, m=1),),
                            "c1": (term(1, c=1),),
                            "k1": (term(1e3, k=1), term(1e3, c=1))}),
        Limit("c1", "infinity", "c1 -> inf: the Maxwell arm is a spring, an undamped mass on "
              "k0 + k1"),
        Limit("c1", "zero", "c1 -> 0: the Maxwell arm carries no force, an undamped mass on k0"),
        Limit("k1", "zero", "k1 -> 0: the Maxwell arm carries no force, an undamped mass on k0"),
        Limit("m", "zero", "m -> 0: no inertia (a standard linear solid)"),
        Limit("k0", "zero", "k0 -> 0: no static stiffness, the mass drifts under a mean load"),
    )

    @classmethod
    def shape_grid(cls, w0: float, dense: bool = False) -> np.ndarray:
        """See :func:`pumpid.models.kelvin.viscoelastic_shapes` (parallel springs)."""
        return viscoelastic_shapes(w0, series=False, dense=dense)
