"""Parameter rows to solver points, with the best linear scale and offset, and their cost.

The solver works on log-parameters plus a scale and an offset (the solver coordinates);
a candidate only names the physical parameters. Given those, the best scale and offset
are a linear least-squares problem, so every candidate is ranked at its own best linear
fit rather than at an arbitrary scale. Used by the multistart, the wider search and the
job (a user's guess goes the same way).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .. import drive, kernel
from ..problem import Problem
from ..threads import run_chunks

__all__ = ["complete", "to_z"]

Array = NDArray[np.float64]


def to_z(problem: Problem, theta: Array) -> Array:
    """Solver coordinates (m, q) for parameter rows (m, p); scale and offset left at 0/1."""
    m = theta.shape[0]
    z = np.zeros((m, problem.q))
    with np.errstate(divide="ignore", invalid="ignore"):
        z[:, : problem.n_free] = np.log(theta[:, problem.free_idx])
    return z


def complete(problem: Problem, cards: NDArray[np.int64], theta: Array,
             rescale: bool = True, workers: int | None = 1) -> tuple[Array, Array]:
    """Points with their best linear scale and offset, and their costs."""
    z = to_z(problem, theta)
    data, model, settings = problem.arrays
    do_rescale = bool((rescale and problem.gauge_fixed) or (
        rescale and problem.model.scale_symmetric and problem.scale_fixed is not None
        and not problem.fixed and bool(np.all(problem.mode != kernel.GIVEN))))
    mode = drive.RESCALE if do_rescale else drive.BEST_LINEAR
    out = np.empty_like(z)
    cost = np.empty(z.shape[0])
    cards = np.ascontiguousarray(cards, dtype=np.int64)

    def work(a: int, b: int) -> None:
        out[a:b], cost[a:b] = drive.linear_items(cards[a:b], np.ascontiguousarray(z[a:b]),
                                                 mode, data, model, settings)

    run_chunks(work, z.shape[0], workers=workers, chunk=256)
    return out, cost
