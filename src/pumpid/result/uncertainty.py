"""A fit's standard errors, intervals and what they assume.

A plain part of a result; :mod:`pumpid.inference.uncertainty` computes it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Uncertainty"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Uncertainty:
    """Standard errors, intervals and what they assume, for the fitted values (``names``)."""

    names: tuple[str, ...]
    stderr: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float] | None]
    stderr_hac: Mapping[str, float]
    ci95_hac: Mapping[str, tuple[float, float] | None]
    covariance: Array
    correlation: Array
    sigma2: float
    dof: int
    t_quantile: float
    singular_values: tuple[float, ...]
    whiteness: Mapping[str, Any] | None
    hac: Mapping[str, Any] | None
    notes: tuple[str, ...] = ()
    sigma2_unit: str = ""
    assumptions: str = field(default=(
        "linearised (Wald) intervals at the optimum; noise assumed white (independent "
        "samples), homoscedastic and Gaussian; sigma^2 = SSR/(N - q) estimated from the "
        "residuals (q the fitted values: parameters, C when free, the offset), Student t "
        "quantile; positive parameters (and C) on the log scale, "
        "value*exp(+-t se/value). stderr_hac and ci95_hac drop the independence and "
        "equal-variance assumptions (HAC sandwich, see hac)"))

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (the layout of the result's ``uncertainty`` entry)."""
        return {
            "sigma2_unit": self.sigma2_unit, "dof": self.dof, "t_quantile": self.t_quantile,
            "singular_values": list(self.singular_values), "assumptions": self.assumptions,
            "notes": list(self.notes),
            "whiteness": dict(self.whiteness) if self.whiteness is not None else None,
            "hac": dict(self.hac) if self.hac is not None else None,
        }
