"""A result's small parts: its status, the data's units, where the card came from, how the
start was found, a prediction of another record, and the JSON conversion they share."""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["CardInfo", "Prediction", "StartInfo", "Status", "Units", "jsonable"]

Array = NDArray[np.float64]


class Status(enum.StrEnum):
    """What a fit's answer is, with its meaning in words.

    A member is its name as a string (``Status.CONVERGED == "converged"``), the name JSON,
    tables and exit codes use.
    """

    CONVERGED = ("converged", "the solver met a convergence test at an interior optimum")
    BOUNDARY = ("boundary", "a parameter ran to 0 or infinity: the data want a limiting "
                "model, whose parameters are reported beside the full model's")
    UNDETERMINED = ("undetermined", "the solver found its optimum, but the data determine "
                    "none of the model's parameters (each ran to a limit, is structurally free "
                    "or has an error over 100 % of its value): the numbers are one point of a "
                    "wide set of models that fit as well; only derived quantities marked "
                    "determined, if any, say something")
    POOR_FIT = ("poor-fit", "the solver found its optimum, but the model explains less of "
                "the data than the quality threshold asks (R^2 below min_r2): the numbers "
                "describe a model that does not reproduce this record")
    FAILED = ("failed", "no converged solution: the solver stopped without meeting a "
              "convergence test, or the model could not be simulated")
    INVALID_INPUT = ("invalid-input", "the card could not be read or validated")

    def __new__(cls, key: str, meaning: str) -> Status:
        obj = str.__new__(cls, key)
        obj._value_ = key
        obj.meaning = meaning  # type: ignore[attr-defined]
        return obj

    @property
    def key(self) -> str:
        """The status' name."""
        return str(self.value)

    def __str__(self) -> str:
        return str(self.value)

    @classmethod
    def parse(cls, text: str) -> Status:
        """The member named ``text``."""
        try:
            return cls(text)
        except ValueError:
            raise ValueError(f"unknown status {text!r}; one of {[m.value for m in cls]}") \
                from None


@dataclass(frozen=True)
class Units:
    """Units of the data a fit was made on (time is always seconds)."""

    load: str = "N"
    position: str = "m"
    time: str = "s"

    def to_dict(self) -> dict[str, str]:
        """As a plain dictionary."""
        return {"load": self.load, "position": self.position, "time": self.time}


@dataclass(frozen=True)
class CardInfo:
    """Where a fit's data came from and everything done to them."""

    id: str | None = None
    well: str | None = None
    source: str | None = None
    time_source: str | None = None
    spm: float | None = None
    period: float | None = None
    notes: tuple[str, ...] = ()
    #: When the card was recorded (ISO 8601), where the file says.
    time: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {"id": self.id, "well": self.well, "time": self.time, "source": self.source,
                "time_source": self.time_source, "spm": self.spm, "period": self.period,
                "notes": list(self.notes)}


@dataclass(frozen=True)
class StartInfo:
    """How the starting point was found."""

    note: str
    candidates: int = 0
    polished: int = 0


def jsonable(value: Any) -> Any:
    """Turn numpy values, mappings, tuples and non-finite floats into JSON-safe values."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, enum.Enum):
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@dataclass(frozen=True)
class Prediction:
    """A fitted model's prediction of another record (the paper's Fig. 9).

    ``r2_fundamental`` is the R^2 of the predicted card's stroke fundamental alone (NaN off
    a periodic card): any linear model reproduces that much from any load, so the
    prediction's R^2 means something only beside it.
    """

    card: str | None
    t: Array
    load: Array
    measured: Array
    predicted: Array
    rmse: float
    r2: float
    r2_fundamental: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """The scores (no arrays)."""
        return {"card": self.card, "rmse": self.rmse, "r2": self.r2,
                "r2_fundamental": self.r2_fundamental}

    def __getitem__(self, key: str) -> Any:
        # Dictionary-style access to the fields (``pred["r2"]``).
        return getattr(self, key)
