"""First-order relaxation, the paper's eq. (23): ``u' = f - u / tau``."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import EquationError, Limit, Model, Term, param, term

__all__ = ["FirstOrder"]


def _from_rate_form(c: np.ndarray) -> np.ndarray:
    # y' = c_y y + c_f f: c_y = -1/tau (c_f is the gain, fixed to 1 with a fixed scale).
    neg_inv_tau = c[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(neg_inv_tau < 0, -1.0 / neg_inv_tau, math.nan)
    return tau[:, None]


@dataclass(frozen=True)
class FirstOrder(Model):
    """First-order relaxation, eq. (23): ``u' = f - u / tau``.

    The static gain is ``tau``: a constant input ``f`` settles at ``u = tau f``.
    """

    tau: float = param("s", "relaxation time")

    states: ClassVar[tuple[str, ...]] = ("u",)
    outputs: ClassVar[Mapping[str, str]] = {"u": "the relaxing quantity"}
    default_output: ClassVar[str] = "u"
    key: ClassVar[str] = "first-order"
    title: ClassVar[str] = "first-order relaxation u' = f - u/tau (paper eq. 23)"
    input_unit: ClassVar[str] = "{position}/s"
    # The paper's form is driven by a rate; pumpid drives every model with the card's load,
    # so u is in load * s and C turns it into a position (a Kelvin or mass-spring-dashpot
    # model's parameters carry the units and their C is a number).
    scale_unit: ClassVar[str] = "{position}/({load}*s)"
    a_terms: ClassVar[Mapping[tuple[int, int], tuple[Term, ...]]] = {
        (0, 0): (term(-1, tau=-1),),
    }
    b_terms: ClassVar[Mapping[int, tuple[Term, ...]]] = {0: (term(1),)}
    equation_error: ClassVar[Mapping[str, EquationError]] = {
        "u": EquationError(("y", 1), (0,), (0,), _from_rate_form),
    }
    limits: ClassVar[tuple[Limit, ...]] = (
        Limit("tau", "infinity", "tau -> inf: a pure integrator u' = f"),
        Limit("tau", "zero", "tau -> 0: no dynamics, u = tau f"),
    )

    @classmethod
    def shape_grid(cls, w0: float, dense: bool = False) -> np.ndarray:
        """Relaxation times from 0.01 to 3 record fundamentals' periods (dense: 1e-4 to
        100)."""
        span = 2 * math.pi / w0
        factors = np.geomspace(1e-4, 100.0, 31) if dense else (0.01, 0.03, 0.1, 0.3, 1.0, 3.0)
        return np.array([[span * f] for f in factors])
