"""Mass-spring-dashpot, the paper's eq. (28): ``m u'' + c u' + k u = f``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import EquationError, Limit, Model, Term, param, term

__all__ = ["MassSpringDamper"]


def _from_second_order(c: np.ndarray) -> np.ndarray:
    # F = m y'' + c y' + k y
    out = c[:, :3].copy()
    out[~np.all(out > 0, axis=1)] = np.nan
    return out


@dataclass(frozen=True)
class MassSpringDamper(Model):
    """Mass-spring-dashpot, eq. (28): ``m u'' + c u' + k u = f``.

    States: displacement ``u`` and velocity ``v``.
    """

    m: float = param("{load}*s^2/{position}", "mass")
    c: float = param("{load}*s/{position}", "damping")
    k: float = param("{load}/{position}", "stiffness")

    states: ClassVar[tuple[str, ...]] = ("u", "v")
    outputs: ClassVar[Mapping[str, str]] = {"u": "displacement of the mass"}
    default_output: ClassVar[str] = "u"
    scale_symmetric: ClassVar[bool] = True
    key: ClassVar[str] = "msd"
    resonance: ClassVar[str | None] = "m"
    title: ClassVar[str] = "mass-spring-dashpot m u'' + c u' + k u = f (paper eq. 28)"
    a_terms: ClassVar[Mapping[tuple[int, int], tuple[Term, ...]]] = {
        (0, 1): (term(1),),
        (1, 0): (term(-1, k=1, m=-1),),
        (1, 1): (term(-1, c=1, m=-1),),
    }
    b_terms: ClassVar[Mapping[int, tuple[Term, ...]]] = {1: (term(1, m=-1),)}
    equation_error: ClassVar[Mapping[str, EquationError]] = {
        "u": EquationError(("f", 0), (2, 1, 0), (), _from_second_order),
    }
    limits: ClassVar[tuple[Limit, ...]] = (
        Limit("m", "zero", "m -> 0: no inertia, the first-order lag c u' + k u = f",
              reduced="first-order", observe="u", to_reduced={"tau": (term(1, c=1, k=-1),)},
              gain=(term(1, c=-1),)),
        Limit("c", "zero", "c -> 0: an undamped oscillator"),
        Limit("c", "infinity", "c -> inf: the mass is locked"),
    )

    @classmethod
    def shape_grid(cls, w0: float, dense: bool = False) -> np.ndarray:
        """Natural frequencies of 0.5-16 fundamentals and damping ratios of 0.05-2 (dense:
        0.25-64 fundamentals in steps of 12 %, damping ratios of 0.001-10)."""
        ratios = tuple(np.geomspace(0.25, 64.0, 48)) if dense else (
            0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
        zetas = (0.001, 0.01, 0.05, 0.2, 0.7, 2.0, 10.0) if dense else (0.05, 0.2, 0.7, 2.0)
        rows = []
        for r in ratios:
            for zeta in zetas:
                wn = r * w0
                rows.append([1.0 / wn**2, 2 * zeta / wn, 1.0])
        return np.array(rows)
