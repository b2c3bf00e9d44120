"""Boundary solutions: a parameter the data drive to 0 or to infinity.

A least-squares fit on log-parameters has no hard bounds, so when the data prefer a limiting
model (for example k0 -> infinity: the Kelvin model's series spring becomes rigid and the
model reduces to a mass-spring-dashpot) the parameter keeps growing while the fitted curve no
longer changes. Such a solution is not an ordinary converged answer. Two tests recognise it:

* the push test: moving one parameter a factor 1000 further in one direction leaves the cost
  unchanged (in both directions: not determined at all, which the identifiability analysis
  reports instead, unless the value already lies beyond a factor 1000 from its natural
  scale toward a limit the model declares: it is in that limit);
* the nested test, for limits where pumpid has the reduced model: the reduced model fits as
  well as the full one by a likelihood-ratio test at the 95 % level. It catches a curved
  valley toward the limit, where the other parameters compensate a single push.

Each model names its limits (:attr:`pumpid.models.base.Model.limits`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..engine import drive
from ..engine.problem import Problem
from ..models import Limit
from ..result import BoundaryInfo, Limiting, ReducedFit

__all__ = [
    "PUSH",
    "SUSPICION",
    "BoundaryInfo",
    "Limiting",
    "ReducedFit",
    "nested_candidates",
    "push_test",
]

Array = NDArray[np.float64]
#: The factor of the push test.
PUSH = 1e3
#: Relative log-sensitivity below which a parameter is suspected to be heading to a limit.
SUSPICION = 1e-2


def spread(problem: Problem, k: int) -> float:
    """The data's spread |d - mean d| on the residual's scale."""
    d = problem.card(k)[2]
    if problem.residual == "log":
        d = np.log(d)
    return float(np.linalg.norm(d - d.mean())) or 1.0


def push_test(problem: Problem, cards: NDArray[np.int64], z: Array, cost: Array,
              edges: list[dict[int, str]]) -> list[list[Limiting]]:
    """Parameters at 0 or infinity by the push test, per item.

    A parameter is at a boundary when the solver stopped on the edge of its search window
    (``edges``: free index -> direction) and pushing it further leaves the cost unchanged,
    when a push by a factor 1000 leaves the cost unchanged (or lowers it) in exactly one
    direction, or in both where it lies beyond a factor 1000 from its natural scale already
    (on that side). Beyond that factor, only the side it lies on can be its limit.
    """
    m = cards.size
    p = problem.n_free
    names = [problem.model.param_names()[i] for i in problem.free_idx]
    trials = np.repeat(z, 2 * p, axis=0)
    for i in range(p):
        trials[2 * i::2 * p, i] += math.log(PUSH)
        trials[2 * i + 1::2 * p, i] -= math.log(PUSH)
    data, model, settings = problem.arrays
    item_cards = np.repeat(np.asarray(cards, dtype=np.int64), 2 * p)
    costs = drive.cost_items(item_cards, np.ascontiguousarray(trials), data, model,
                             settings).reshape(m, p, 2)
    # How far each value lies from its natural scale (log).
    far = z[:, :p] - np.log(problem.reference[np.asarray(cards, dtype=np.int64)][
        :, problem.free_idx])
    out: list[list[Limiting]] = []
    for j in range(m):
        k = int(cards[j])
        d = problem.card(k)[2]
        sst = float(np.sum((d - d.mean()) ** 2))
        tol = max(1e-3 * 2.0 * cost[j], 1e-10 * sst)
        found: list[Limiting] = []
        for i, name in enumerate(names):
            hits = [direction for c, direction in zip(costs[j, i], ("infinity", "zero"),
                                                       strict=True)
                    if 2.0 * c - 2.0 * cost[j] <= tol]
            if i in edges[j] and edges[j][i] in hits:
                hits = [edges[j][i]]
            elif abs(far[j, i]) > math.log(PUSH):
                side = "infinity" if far[j, i] > 0 else "zero"
                if len(hits) == 2:
                    # Flat both ways and already beyond a factor 1000 from its natural
                    # scale: a push cannot leave the limit it is in (k1 = 1.4e-5 kN/m, 1e-6
                    # of its scale, stayed "converged" with an offset of -5e6 m and a time
                    # constant of 5e9 s). Only toward a limit the model declares: elsewhere
                    # flat both ways is a value the data do not fix, wherever it started.
                    if any(lim.param == name and lim.direction == side
                           for lim in problem.model.limits):
                        hits = [side]
                else:
                    # A push back toward its natural scale moves it inward, not to a
                    # limit: an unfinished fit's m = 8.4e-7 kN s^2/m, 4e6 below its scale,
                    # whose push up lowered the cost, was said to "run to infinity".
                    hits = [h for h in hits if h == side]
            if len(hits) == 1:
                lim = problem.model.limit(name, hits[0])
                found.append(Limiting(name, hits[0], _exp(float(z[j, i])),
                                      lim.description, "push"))
        out.append(found)
    return out


def nested_candidates(problem: Problem, k: int, z: Array, log_sens: Array,
                      edges: dict[int, str], stopped_early: bool) -> list[Limit]:
    """Known limits with a reduced model that card k's fitted point may be heading to.

    A parameter is a candidate when the fit hardly depends on it any more (relative
    log-sensitivity below 1 % toward the limit's side of its natural scale), when the solver
    stopped on the edge of its window, or when it ran out of evaluations.
    """
    names = problem.model.param_names()
    ref = problem.reference[k]
    out = []
    for lim in problem.model.limits:
        if lim.reduced is None:
            continue
        i = names.index(lim.param)
        free = list(problem.free_idx)
        if i not in free:
            continue
        f = free.index(i)
        # In logs: a parameter far out (a scale of 1e300 on the data) overflows exp.
        heading = "infinity" if z[f] > math.log(ref[i]) else "zero"
        weak = log_sens[f] < SUSPICION and heading == lim.direction
        if weak or edges.get(f) == lim.direction or stopped_early:
            out.append(lim)
    return out


def _exp(x: float) -> float:
    """exp that saturates to infinity instead of raising for a parameter far out."""
    return math.exp(x) if x < 709.0 else math.inf
