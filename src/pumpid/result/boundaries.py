"""Parameters a fit drove to 0 or to infinity, and the reduced model fitted there.

The plain parts of a result; :mod:`pumpid.inference.boundaries` finds them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["BoundaryInfo", "Limiting", "ReducedFit"]


@dataclass(frozen=True)
class Limiting:
    """A parameter at a boundary: where it runs and the limit it means."""

    name: str
    direction: str  # "infinity" or "zero"; "lower" or "upper" for a declared bound
    value: float
    limit: str
    #: "push": moving it a further factor 1000 leaves the cost unchanged; "push10": a further
    #: factor 10 leaves it within the noise or lowers it; "nested": the limiting model fits
    #: as well (likelihood-ratio test); "bound": the fit ended on a bound a model declares.
    evidence: str = "push"

    @property
    def where(self) -> str:
        """Where it runs, in words ("to infinity", "to its lower bound", ...)."""
        return {"infinity": "to infinity", "zero": "to zero", "lower": "to its lower bound",
                "upper": "to its upper bound"}[self.direction]

    def describe(self) -> str:
        """Plain-language statement."""
        where = self.where
        why = {"push": "pushing it a further factor 1000 leaves the fit unchanged",
               "push10": "pushing it a further factor 10 leaves the fit as good or better",
               "nested": "the limiting model fits the data as well (likelihood-ratio test, "
                         "95 %)",
               "bound": "the fit stopped on the bound the model declares"}[self.evidence]
        said = "is the bound itself" if self.evidence == "bound" else "is arbitrary"
        return (f"{self.name} runs {where} (fitted value {self.value:.4g} {said}: {why}); "
                f"the data want the limit {self.limit}")


@dataclass(frozen=True)
class ReducedFit:
    """The limiting (reduced) model fitted where the full model ran to a boundary; ``limit``
    names the limits it stands for (``m -> 0 with k0 -> inf``: a Kelvin model's first-order
    lag observing u, which may lie beyond the limits the fit reached)."""

    model: str
    params: Mapping[str, float]
    units: Mapping[str, str]
    scale: float
    offset: float
    rmse: float
    r2: float
    status: str
    reason: str
    limit: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {"model": self.model, "limit": self.limit, "params": dict(self.params),
                "scale": self.scale, "offset": self.offset, "units": dict(self.units),
                "rmse": self.rmse, "r2": self.r2, "converged": self.status == "converged",
                "status": self.status, "reason": self.reason}


@dataclass(frozen=True)
class BoundaryInfo:
    """Parameters that ran to a bound, and the reduced model the data want."""

    limits: tuple[Limiting, ...]
    reduced: ReducedFit | None = None
