"""The fits of many cards, :class:`FitBatch`: arrays with one entry per card."""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .fit import FitResult

if TYPE_CHECKING:
    import pandas
from .parts import Status

__all__ = ["FitBatch"]

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class FitBatch:
    """The fits of many cards: arrays with one entry per card, and each card's full result.

    Attributes
    ----------
    model_name : str
        The fitted model class.
    param_names : tuple of str
        Parameter names in canonical order.
    params : mapping of str -> ndarray
        Fitted parameters by name (NaN for failed cards).
    scale, offset, rmse, r2, cost : ndarray
        Per card.
    status : tuple of Status
        Per card (``invalid-input`` for a card that failed validation).
    iterations, nfev : ndarray
        Per card.
    """

    model_name: str
    param_names: tuple[str, ...]
    results: tuple[FitResult | None, ...]
    invalid: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.results)

    def __getitem__(self, i: int) -> FitResult:
        return self.result(i)

    def result(self, i: int) -> FitResult:
        """Card ``i``'s full result; ValueError for a card that failed validation."""
        res = self.results[i]
        if res is None:
            raise ValueError(f"card {i} is not valid: {self.invalid[i]}")
        return res

    def _column(self, get: Any, default: float = math.nan) -> Array:
        return np.array([get(r) if r is not None else default for r in self.results],
                        dtype=float)

    @functools.cached_property
    def params(self) -> Mapping[str, Array]:
        """Fitted parameters by name, one entry per card."""
        return MappingProxyType({n: self._column(lambda r, n=n: r.params.get(n, math.nan))
                                 for n in self.param_names})

    @property
    def theta(self) -> Array:
        """Fitted parameters (cards, p) in canonical order."""
        return np.column_stack([self.params[n] for n in self.param_names])

    @functools.cached_property
    def status(self) -> tuple[Status, ...]:
        """Each card's status."""
        return tuple(r.status if r is not None else Status.INVALID_INPUT
                     for r in self.results)

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Cards with status ``converged``."""
        return np.array([s is Status.CONVERGED for s in self.status])

    @property
    def scale(self) -> Array:
        """Output scale C per card."""
        return self._column(lambda r: r.scale)

    @property
    def offset(self) -> Array:
        """Position offset per card."""
        return self._column(lambda r: r.offset)

    @property
    def rmse(self) -> Array:
        """RMSE per card (position units)."""
        return self._column(lambda r: r.rmse)

    @property
    def r2(self) -> Array:
        """R^2 per card."""
        return self._column(lambda r: r.r2)

    @property
    def cost(self) -> Array:
        """0.5 * sum of squared residuals per card."""
        return self._column(lambda r: r.cost)

    @property
    def iterations(self) -> NDArray[np.int64]:
        """Accepted iterations per card."""
        return self._column(lambda r: r.iterations, 0).astype(np.int64)

    @property
    def nfev(self) -> NDArray[np.int64]:
        """Model evaluations per card."""
        return self._column(lambda r: r.nfev, 0).astype(np.int64)

    def to_frame(self) -> pandas.DataFrame:
        """The batch as the results table (:mod:`pumpid.result.table`): one row per card, in
        order, every column of the table; a card that failed validation is an
        ``invalid-input`` row with its reason."""
        from .table import fit_row, rows_frame, unfitted_row

        rows = [fit_row(r) if r is not None else
                unfitted_row(None, model=self.model_name, observe=None,
                             status="invalid-input", reason=self.invalid[i])
                for i, r in enumerate(self.results)]
        models = [r.model for r in self.results if r is not None and r.model is not None]
        return rows_frame(rows, models or [_Named(self.param_names)])

    def summary(self) -> str:
        """One line: cards per status and the median R^2."""
        counts = ", ".join(f"{s.key} {sum(1 for x in self.status if x is s)}" for s in Status
                           if any(x is s for x in self.status))
        r2 = self.r2
        med = float(np.nanmedian(r2)) if np.any(np.isfinite(r2)) else math.nan
        return f"{self.model_name}: {len(self)} cards ({counts}); median R^2 = {med:.6g}"


class _Named:
    """Parameter names standing in for a model class (a batch none of whose cards fitted)."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.names = tuple(names)

    def param_names(self) -> tuple[str, ...]:
        return self.names
