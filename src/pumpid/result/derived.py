"""One derived quantity of a fit (a physical combination of its parameters) and its errors.

A plain part of a result; :mod:`pumpid.inference.derived` computes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = ["Derived"]


@dataclass(frozen=True)
class Derived:
    """One derived quantity of a fit.

    ``stderr`` is the error shown: the robust one (``stderr_hac``) where the residuals are
    serially correlated, else the independent-noise one (``stderr_white``); ``determined``
    follows it. ``well_property`` is False for a quantity the card's imposed motion sets
    rather than the well (``note`` says why, see :mod:`pumpid.inference.echo`).
    """

    name: str
    value: float
    unit: str
    stderr: float
    stderr_hac: float
    determined: bool
    meaning: str
    stderr_white: float = math.nan
    well_property: bool = True
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {"value": self.value, "unit": self.unit, "stderr": self.stderr,
                "stderr_hac": self.stderr_hac, "stderr_white": self.stderr_white,
                "determined": self.determined, "well_property": self.well_property,
                "note": self.note, "meaning": self.meaning}
