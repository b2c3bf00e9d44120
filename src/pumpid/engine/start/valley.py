"""The valley walk: long strides along a flat, curved valley where the solver crawls.

When the data hardly constrain one combination of parameters, the cost has a long, curved
valley and a trust-region step along it is cut short by its curvature, so the solver
stops on the valley's floor far from its lowest point. Jumping along the weakest
direction of the scaled Jacobian and letting a short polish drop back to the floor moves
along it in a few long strides; the job walks from a start whose polish ran out of
evaluations.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .. import drive, lm
from ..problem import WINDOW, Problem
from ..solvers import LevenbergMarquardt

__all__ = ["walk_valley"]

Array = NDArray[np.float64]


def walk_valley(problem: Problem, k: int, z: Array, cost: float,
                rounds: int = 8) -> tuple[Array, float]:
    """Follow a long, flat, curved valley where Levenberg-Marquardt only crawls.

    When the data hardly constrain one combination (relative singular value of the scaled
    Jacobian below 1e-4), a trust-region step along the valley is cut short by its
    curvature. Jumping along the weakest direction and letting a short polish drop back to
    the floor moves along it in a few long strides; the floor's cost tells which way is
    down. On noisy data the floor is flat at the noise level and the walk stops at once.

    Parameters
    ----------
    problem : Problem
    k : int
        The card.
    z, cost : ndarray, float
        A point on the valley's floor (solver coordinates) and its cost.
    rounds : int
        Longest walk (rounds of probe-and-grow).

    Returns
    -------
    z, cost
        The walked point and its cost (the given ones when nothing was gained).
    """
    data, model, settings = problem.arrays
    span = float(np.ptp(problem.card(k)[2])) or 1.0
    p = problem.n_free
    ref = np.log(problem.reference[k][problem.free_idx])
    polish = LevenbergMarquardt(tol=1e-10)

    def jump(base: Array, step: Array) -> tuple[Array, float] | None:
        znew = base.copy()
        znew[:p] = np.clip(base[:p] + step[:p], ref - WINDOW, ref + WINDOW)
        j = p
        if problem.scale_fixed is None:
            znew[j] = base[j] + step[j]
            j += 1
        if problem.offset_fixed is None:
            znew[j] = base[j] + step[j] * span
        out = polish.solve(problem, np.array([k]), znew[None], budget=40)
        c = float(out.cost[0])
        return (out.z[0], c) if math.isfinite(c) else None

    for _ in range(rounds):
        q = problem.q
        rows = np.empty((q + 1, problem.n_samples(k)))
        if not drive.rows_at(z, k, data, model, settings, rows):
            break
        if problem.offset_fixed is None:
            rows[q - 1] *= span
        r_fac = np.zeros((q, q))
        lm.householder(rows, q, r_fac, np.zeros(q))
        _u, s, vt = np.linalg.svd(r_fac)
        if not (s[0] > 0) or s[-1] / s[0] > 1e-4:
            break
        direction = vt[-1]
        step = 0.25 * 2.5
        probes: list[tuple[float, Array, float]] = []
        for _shrink in range(3):
            step /= 2.5
            probes = []
            for sign in (1.0, -1.0):
                got = jump(z, sign * step * direction)
                if got is not None and got[1] < 0.95 * cost:
                    probes.append((sign, got[0], got[1]))
            if probes:
                break
        if not probes:
            break
        sign, best_z, best_cost = min(probes, key=lambda item: item[2])
        for _grow in range(4):
            step *= 2.5
            got = jump(z, sign * step * direction)
            if got is None or got[1] >= best_cost:
                break
            best_z, best_cost = got
        z, cost = best_z, best_cost
    return z, cost
