"""The scan along the inertia: a resonance the data see only through weak harmonics.

When a model's resonance lies far above the stroke's frequency, the card sees the mass only
through its highest, weakest harmonics. The cost along the mass is then flat to within the
noise over a decade or more, and rippled: each harmonic the resonance crosses, and the
noise near it, leaves a local minimum a few per cent deep. The job's answer can stop in
any of them at the noise level, where nothing looks wrong (the wider search is not asked
for) and the local curvature gives the mass an error of a few per cent. On 60 synthetic
periodic cards spread over x100 (1 % noise; bench_optimum's family), 8 answers lay above a
brute force's best this way, 4 of them by 2.7 to 11 % of the cost, with the mass off by a
factor 2-4 and errors of 5-11 %; with the scan, 1 (6.2 %: its best dip is narrower than
the scan's step).

The scan costs the answer's neighbours along the inertia alone (every other coordinate
held), a row of residuals, and runs the solver only from the dips of that profile that
come within a few per cent of the answer: 9 of those 59 cards had any, 15 of 100 periodic
cards of the benchmark's family and 39 of 88 controller-like ones (whose solves are most
of the scan's price there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import drive
from ..problem import Problem
from ..solvers import LevenbergMarquardt
from ..threads import run_chunks
from .wider import WidePlan

__all__ = ["InertiaLine", "flat_spans", "inertia_index", "scan_inertia"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class InertiaLine:
    """A card's costs along the inertia from one point (every other coordinate held): the
    point ``z``, the inertia's solver coordinate ``values`` along the line and their
    ``costs``. :func:`flat_spans` reuses it for the same point instead of costing the line
    again."""

    z: Array
    values: Array
    costs: Array


def inertia_index(problem: Problem) -> int | None:
    """The solver coordinate of the model's inertia (:attr:`Model.resonance`), or None when
    the model has none or it is held fixed."""
    name = problem.model.resonance
    if name is None:
        return None
    index = problem.model.param_names().index(name)
    free = list(problem.free_idx)
    return free.index(index) if index in free else None


def scan_inertia(
    problem: Problem,
    cards: NDArray[np.int64],
    z_now: Array,
    cost_now: Array,
    *,
    plan: WidePlan | None = None,
    solver: LevenbergMarquardt | None = None,
    workers: int | None = 1,
    minima: list[list[tuple[float, float]]] | None = None,
    lines: list[InertiaLine | None] | None = None,
) -> tuple[Array, Array, NDArray[np.int64]]:
    """The best point of each card after a scan along the model's inertia.

    The plan's ``scan_points`` values of the inertia from the answer's divided by
    ``scan_spread`` to multiplied by it (the other coordinates held) are costed; the solver
    runs from the lowest ``scan_dips`` local minima of that profile whose cost is within
    ``scan_within`` (relative) of the answer's, the answer's own neighbours excepted, for at
    most ``scan_evaluations`` each; a card whose point moved is scanned again from there,
    ``scan_passes`` times at most. ``minima``, one list per card,
    receives the (ln inertia, cost) of every point the solver converged to (local minima
    of the cost, the answers' of other dips: where one lies within the noise of the best,
    the inertia is not determined). ``lines``, one entry per card, receives the first
    scan's line from the given point (for :func:`flat_spans`).

    Returns the best points (m, q), their costs (m,) and the number of points the solver
    ran from per card (the given point and cost where nothing was lower).
    """
    solver = solver or LevenbergMarquardt()
    plan = plan or WidePlan()
    cards = np.asarray(cards, dtype=np.int64)
    best_z = np.array(z_now, dtype=float).copy()
    best_cost = np.array(cost_now, dtype=float).copy()
    runs = np.zeros(cards.size, dtype=np.int64)
    j = inertia_index(problem)
    if j is None or not cards.size:
        return best_z, best_cost, runs
    steps = _steps(plan)
    todo = np.arange(cards.size)
    # A dip the solver left for a lower one is scanned from again: the profile seen from
    # the new point's other coordinates has its own dips (on the card of the module's note
    # whose mass was off by 4, the first scan stopped half way).
    for pass_ in range(plan.scan_passes):
        lower = _scan_once(problem, cards, best_z, best_cost, runs, todo, j, steps, plan,
                           solver, workers, minima, lines if pass_ == 0 else None)
        todo = todo[lower]
        if not todo.size:
            break
    return best_z, best_cost, runs


def _steps(plan: WidePlan) -> Array:
    """The scan's moves of the inertia's log, both ways to the plan's spread."""
    return np.linspace(-math.log(plan.scan_spread), math.log(plan.scan_spread),
                       plan.scan_points)


def _lines(problem: Problem, cards: NDArray[np.int64], z: Array, j: int, steps: Array,
           workers: int | None) -> tuple[Array, Array]:
    """Each card's point moved along coordinate j by ``steps`` (within the search window),
    (m, s, q), and their costs (m, s), spread over ``workers`` threads."""
    m, q = z.shape
    lo, hi = problem.window(cards, z)
    lines = np.repeat(z[:, None, :], steps.size, axis=1)
    lines[:, :, j] = np.clip(z[:, j, None] + steps[None, :], lo[:, j, None], hi[:, j, None])
    items = np.repeat(cards, steps.size)
    points = lines.reshape(-1, q)
    costs = np.empty(items.size)

    def work(a: int, b: int) -> None:
        costs[a:b] = drive.cost_items(items[a:b], points[a:b], *problem.arrays)

    run_chunks(work, items.size, workers=workers, chunk=8 * steps.size)
    return lines, costs.reshape(m, steps.size)


def _scan_once(problem: Problem, cards: NDArray[np.int64], best_z: Array, best_cost: Array,
               runs: NDArray[np.int64], todo: NDArray[np.int64], j: int, steps: Array,
               plan: WidePlan, solver: LevenbergMarquardt, workers: int | None,
               minima: list[list[tuple[float, float]]] | None,
               record: list[InertiaLine | None] | None) -> NDArray[np.bool_]:
    """One scan of the cards ``todo`` (in place); whether each found a lower point. Each
    card's line goes into ``record`` when given."""
    step = float(steps[1] - steps[0])
    go = todo[np.isfinite(best_cost[todo]) & np.all(np.isfinite(best_z[todo]), axis=1)]
    from_cards: list[int] = []
    from_z: list[Array] = []
    owner: list[int] = []
    if go.size:
        lines, all_costs = _lines(problem, cards[go], best_z[go], j, steps, workers)
    for t, i in enumerate(go):
        line, costs = lines[t], all_costs[t]
        if record is not None:
            record[i] = InertiaLine(best_z[i].copy(), line[:, j].copy(), costs.copy())
        lower_left = np.concatenate([[True], costs[1:] <= costs[:-1]])
        lower_right = np.concatenate([costs[:-1] <= costs[1:], [True]])
        # Points clipped to the search window repeat each other: one start is enough.
        first = np.concatenate([[True], line[1:, j] != line[:-1, j]])
        # The answer's own neighbours lie in its basin: the solver would return there.
        away = np.abs(line[:, j] - best_z[i, j]) > 1.01 * step
        near = costs < best_cost[i] * (1.0 + plan.scan_within)
        found = np.flatnonzero(lower_left & lower_right & first & away & near
                               & np.isfinite(costs))
        for d in found[np.argsort(costs[found])][: plan.scan_dips]:
            from_cards.append(int(cards[i]))
            from_z.append(line[d])
            owner.append(int(i))
    lower = np.zeros(todo.size, dtype=bool)
    if not from_cards:
        return lower
    out = solver.solve(problem, np.array(from_cards, dtype=np.int64), np.array(from_z),
                       budget=plan.scan_evaluations, workers=workers)
    where = {int(i): t for t, i in enumerate(todo)}
    for jj, i in enumerate(owner):
        runs[i] += 1
        if minima is not None and out.stops[jj].converged and math.isfinite(out.cost[jj]):
            minima[i].append((float(out.z[jj, j]), float(out.cost[jj])))
        if math.isfinite(out.cost[jj]) and out.cost[jj] < best_cost[i] * (1 - 1e-12):
            best_cost[i] = float(out.cost[jj])
            best_z[i] = out.z[jj]
            lower[where[i]] = True
    return lower


def flat_spans(problem: Problem, cards: NDArray[np.int64], z: Array, limits: Array,
               coordinate: int | None = None, *, plan: WidePlan | None = None,
               workers: int | None = 1,
               known: Sequence[InertiaLine | None] | None = None
               ) -> list[tuple[float, float] | None]:
    """How far one parameter can move on each card, every other coordinate held, with the
    card's cost staying at or below its limit: the lowest and highest such values on the
    scan's line (the plan's ``scan_points`` from the answer's divided by ``scan_spread`` to
    multiplied by it, and the answer's own value). ``coordinate``: a free parameter's
    solver coordinate (default: the model's inertia). None for a card without a finite
    answer or limit, and for every card without that coordinate. ``workers`` threads share
    the costs.

    Every coordinate but one held, the cost is at or above the profile's (the others
    refitted), so a value found here lies within the likelihood-ratio interval whose
    threshold is the limit: the span is a lower bound of that interval's extent.
    """
    cards = np.asarray(cards, dtype=np.int64)
    z = np.asarray(z, dtype=float).reshape(cards.size, -1)
    limits = np.asarray(limits, dtype=float)
    out: list[tuple[float, float] | None] = [None] * cards.size
    j = inertia_index(problem) if coordinate is None else coordinate
    if j is None:
        return out
    go = np.flatnonzero(np.isfinite(limits) & np.all(np.isfinite(z), axis=1))
    if not go.size:
        return out
    steps = np.concatenate([[0.0], _steps(plan or WidePlan())])
    along = j == inertia_index(problem)
    reuse = [i for i in go if known is not None and along and known[i] is not None
             and known[i].values.size == steps.size - 1 and np.array_equal(known[i].z, z[i])]
    values: dict[int, Array] = {}
    costs: dict[int, Array] = {}
    if reuse:
        # The scan's line from this very point: only the point's own cost is new.
        own = drive.cost_items(cards[reuse], z[reuse], *problem.arrays)
        for t, i in enumerate(reuse):
            line = known[i]
            values[i] = np.concatenate([[z[i, j]], line.values])
            costs[i] = np.concatenate([[own[t]], line.costs])
    fresh = [i for i in go if i not in values]
    if fresh:
        lines, new_costs = _lines(problem, cards[fresh], z[fresh], j, steps, workers)
        for t, i in enumerate(fresh):
            values[i], costs[i] = lines[t, :, j], new_costs[t]
    for i in go:
        inside = values[i][costs[i] <= limits[i]]
        if inside.size:
            out[i] = (float(np.exp(inside.min())), float(np.exp(inside.max())))
    return out
