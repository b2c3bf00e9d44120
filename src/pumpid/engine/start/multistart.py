"""The multistart: rank the whole candidate pool, polish the best few, keep the best.

Ranking every candidate of :mod:`.pool` costs one simulation each; a Levenberg-Marquardt
polish from all of them would cost hundreds. So the best few distinct candidates of each
card, plus the best of each kind not among them (one kind's estimates often share a bias),
get a short polish, and only the best still-improving points get more evaluations
(successive halving: most show within a few steps whether they lead anywhere). The best
polished point is the card's start; a user's guess joins the polish and wins ties, so a
good guess is kept and a poor one cannot trap the fit. All of it runs for every card of a
problem at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..problem import Problem
from ..solvers import LevenbergMarquardt, SolverOutcome
from .coordinates import complete, to_z
from .pool import candidates

__all__ = ["StartPlan", "Starts", "find_starts"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class StartPlan:
    """How the automatic start searches: candidates polished and their budget.

    The best ``polish`` distinct candidates of each card and the best of each other kind
    get ``first_evaluations``; the best ``keep`` distinct points of a card that are still
    improving then go on to ``polish_evaluations`` in all (successive halving: most
    candidates show within a few steps whether they lead anywhere).
    """

    polish: int = 3
    polish_evaluations: int = 30
    polish_tol: float = 1e-6
    first_evaluations: int = 10
    keep: int = 2


@dataclass(frozen=True)
class Starts:
    """The chosen start of every card and how it was found."""

    z: Array
    cost: Array
    stopped_early: NDArray[np.bool_]
    n_candidates: NDArray[np.int64]
    n_polished: NDArray[np.int64]
    kinds: tuple[str, ...]
    from_guess: NDArray[np.bool_]


def find_starts(
    problem: Problem,
    cards: NDArray[np.int64],
    *,
    guess: Array | None = None,
    plan: StartPlan = StartPlan(),
    workers: int | None = 1,
) -> Starts:
    """The best starting point of every card: rank all candidates, polish the best few.

    ``guess`` (m, p): a user's parameters per card that join the polished points (a good
    guess is kept, a poor one cannot trap the fit).
    """
    cards = np.asarray(cards, dtype=np.int64)
    m = cards.size
    theta, owner, kinds, kind_of = candidates(problem, cards)
    z_all, cost_all = complete(problem, owner, theta, workers=workers)
    position = {int(k): i for i, k in enumerate(cards)}
    picks: list[int] = []
    pick_card: list[int] = []
    n_cand = np.zeros(m, dtype=np.int64)
    p = problem.n_free
    order = np.lexsort((cost_all, owner))
    chosen: dict[int, list[int]] = {}
    for j in order:
        if math.isfinite(cost_all[j]):
            n_cand[position[int(owner[j])]] += 1
    # The best ``polish`` distinct candidates of each card, then the best of each kind not
    # among them: estimates of one kind often share a bias (equation error leans toward a
    # limit), so every kind gets its own chance against local minima.
    for j in order:
        k = int(owner[j])
        mine = chosen.setdefault(k, [])
        if not math.isfinite(cost_all[j]) or len(mine) >= plan.polish:
            continue
        if all(np.max(np.abs(z_all[j, :p] - z_all[i, :p])) > 0.1 for i in mine):
            mine.append(int(j))
    for j in order:
        k = int(owner[j])
        if not math.isfinite(cost_all[j]):
            continue
        mine = chosen[k]
        if all(kind_of[i] != kind_of[j] for i in mine) and all(
                np.max(np.abs(z_all[j, :p] - z_all[i, :p])) > 0.1 for i in mine):
            mine.append(int(j))
    for k, mine in chosen.items():
        picks.extend(mine)
        pick_card.extend([k] * len(mine))
    z_pol = z_all[picks] if picks else np.zeros((0, problem.q))
    item_card = np.array(pick_card, dtype=np.int64)
    is_guess = np.zeros(len(picks), dtype=bool)
    if guess is not None:
        zg, _cg = complete(problem, cards, np.asarray(guess, dtype=float), rescale=False,
                           workers=workers)
        z_pol = np.concatenate([z_pol, zg])
        item_card = np.concatenate([item_card, cards])
        is_guess = np.concatenate([is_guess, np.ones(m, dtype=bool)])
    solver = LevenbergMarquardt(tol=plan.polish_tol)
    polished: SolverOutcome = solver.solve(problem, item_card, z_pol,
                                           budget=plan.first_evaluations, workers=workers)
    polished = _continue_best(problem, item_card, polished, plan, solver, workers)
    best_z = np.full((m, problem.q), math.nan)
    best_cost = np.full(m, math.inf)
    early = np.zeros(m, dtype=bool)
    from_guess = np.zeros(m, dtype=bool)
    n_pol = np.zeros(m, dtype=np.int64)
    for j in range(item_card.size):
        i = position[int(item_card[j])]
        c = polished.cost[j]
        if not math.isfinite(c):
            continue
        n_pol[i] += 1
        # The guess wins ties: a good guess is kept.
        better = c < best_cost[i] or (is_guess[j] and c <= best_cost[i])
        if better:
            best_cost[i] = c
            best_z[i] = polished.z[j]
            early[i] = polished.stops[j].key == "budget"
            from_guess[i] = is_guess[j]
    # Cards with no finite polished point fall back to their best-ranked candidate.
    for i, k in enumerate(cards):
        if math.isfinite(best_cost[i]):
            continue
        mine = np.flatnonzero((owner == k) & np.isfinite(cost_all))
        if mine.size:
            j = mine[np.argmin(cost_all[mine])]
            best_z[i], best_cost[i] = z_all[j], cost_all[j]
        elif guess is not None:
            best_z[i] = to_z(problem, np.asarray(guess, dtype=float)[i:i + 1])[0]
            from_guess[i] = True
    return Starts(z=best_z, cost=best_cost, stopped_early=early, n_candidates=n_cand,
                  n_polished=n_pol, kinds=tuple(kinds), from_guess=from_guess)


def _continue_best(problem: Problem, item_card: NDArray[np.int64], polished: SolverOutcome,
                   plan: StartPlan, solver: LevenbergMarquardt,
                   workers: int | None) -> SolverOutcome:
    """Second round of the polish: the best ``plan.keep`` distinct points of each card that
    ran out of evaluations go on to ``plan.polish_evaluations``; the outcome of both."""
    more = plan.polish_evaluations - plan.first_evaluations
    if more <= 0 or item_card.size == 0:
        return polished
    p = problem.n_free
    chosen: list[int] = []
    for k in np.unique(item_card):
        mine = np.flatnonzero((item_card == k) & np.isfinite(polished.cost))
        picked: list[int] = []
        for j in mine[np.argsort(polished.cost[mine])]:
            if len(picked) >= plan.keep:
                break
            if all(np.max(np.abs(polished.z[j, :p] - polished.z[i, :p])) > 0.05
                   for i in picked):
                picked.append(int(j))
        chosen.extend(j for j in picked if polished.stops[j].key == "budget")
    if not chosen:
        return polished
    idx = np.array(chosen, dtype=np.int64)
    out = solver.solve(problem, item_card[idx], polished.z[idx], budget=more + 1,
                       workers=workers)
    z, cost = polished.z.copy(), polished.cost.copy()
    evaluations = polished.evaluations.copy()
    stops = list(polished.stops)
    for j, i in enumerate(idx):
        z[i], cost[i] = out.z[j], out.cost[j]
        evaluations[i] += out.evaluations[j] - 1
        stops[i] = out.stops[j]
    return replace(polished, z=z, cost=cost, evaluations=evaluations, stops=tuple(stops))
