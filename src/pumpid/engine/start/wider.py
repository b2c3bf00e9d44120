"""The wider search: a larger multistart for cards whose answer does not explain the data.

The first multistart (:mod:`.multistart`) is cheap and usually enough; when a card's answer
does not explain its data (the job's test: R^2 below 0.99, or an error above twice the
data's noise), a wrong local minimum is the first suspect. This search polishes, in rounds,
the best-ranked shapes of the model's dense grid (ranked by the card's harmonics,
:mod:`.harmonics`, for a periodic stroke; by its samples otherwise) and random log-uniform
points around the natural scales, and runs the solver to convergence from the best distinct
ones. It stops for a card when two independent starts agree on the best cost -- the best
basin found twice -- so it spends its budget only where the answer is still in doubt. Random
points are seeded by the card's own samples: a card's search is the same in any batch.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import kernel
from ..problem import Problem
from ..solvers import LevenbergMarquardt
from ..spectrum import SEARCH_HARMONICS
from .coordinates import complete
from .harmonics import harmonic_scan
from .pool import fundamental

__all__ = ["WidePlan", "compile_ranking", "search_wider"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class WidePlan:
    """How far the wide search goes when the first answer does not explain the data.

    Each round polishes ``per_round`` new points -- the best-ranked shapes of the model's
    dense grid (ranked by the card's harmonics for a periodic stroke, by its samples
    otherwise) and ``random`` log-uniform points within ``spread`` of the natural scales --
    then runs the solver from the best distinct ones (``finals`` a card, each for at most
    ``final_evaluations``). The search stops when two independent starts agree on the best
    cost (``agree``, relative), or after ``rounds`` rounds.

    The finals only have to tell the basins apart: the job runs the solver to convergence
    again from the best point found. On real cards, whose parameters are often
    undetermined along a long flat valley, a final given the solver's whole budget (400
    per coordinate) crawled along the valley: on 41 public field cards, 36 of 169 finals
    spent all 2,000 evaluations, half of the search's evaluations, and ended within 1e-7
    to 2e-3 (relative cost) of the card's best. At 200 evaluations a final, 389 public
    field cards took 22 % less time in all; 48 answers lost more than 1e-6 of the cost, at
    most 2.1e-4, 47 of them on fits reported as undetermined and one on a poor fit; 7
    gained.

    A card whose answer explains its data gets instead the scan along the model's inertia
    (``scan_points`` values from the answer's divided by ``scan_spread`` to multiplied by
    it; the solver runs from the ``scan_dips`` lowest dips within ``scan_within`` of the
    answer's cost, for at most ``scan_evaluations`` each; again from a point that moved,
    ``scan_passes`` times at most).

    The ranking looks at the card's first ``harmonics`` harmonics: those carry a card (its
    shapes' responses beyond them are small, and the continuous transfer function the scan
    uses drifts from the exact discrete one there). On 389 public field cards 24 harmonics
    instead of 64 took 4 % less time in all (median 86 against 95 ms a card); 357 answers
    were identical, 17 lower and 15 higher in cost by at most 6.2e-5, all on fits reported as
    undetermined, and 4 fits moved between undetermined and a boundary at the same cost; 60
    synthetic periodic cards unchanged.

    On a card the harmonic cost applies to (:meth:`Problem.harmonic`), the polish minimises
    the cost of those same first harmonics (:mod:`pumpid.engine.spectrum`), and each final
    follows its basin on it (up to ``final_evaluations``) before its exact run. On 130
    public field cards (every third) the polish took 1,100-1,350 evaluations a card either
    way, at about 7 us each on the harmonics (the solver's step included; 5-6 us since the
    transfer function became a ratio of polynomials) against 23 us exact. With the polish
    alone on the harmonics the job's answers came within 1e-6 of a brute force's best on 90
    of those cards (91 on the exact polish); with the finals and the job's solve on them
    too, 125.
    """

    rounds: int = 3
    per_round: int = 8
    random: int = 4
    spread: float = 1e3
    polish_evaluations: int = 80
    finals: int = 2
    final_evaluations: int = 200
    agree: float = 1e-6
    harmonics: int = SEARCH_HARMONICS
    #: The scan along the inertia for the cards whose answer explains the data
    #: (:func:`~pumpid.engine.start.resonance.scan_inertia`; 0 points: off).
    scan_points: int = 40
    scan_spread: float = 30.0
    scan_within: float = 0.05
    scan_dips: int = 3
    scan_evaluations: int = 200
    scan_passes: int = 3


def _card_rng(problem: Problem, k: int) -> np.random.Generator:
    """A generator seeded by the card's own samples: its search is the same in any batch."""
    _t, f, d = problem.card(k)
    seed = zlib.crc32(np.ascontiguousarray(f).tobytes() + np.ascontiguousarray(d).tobytes())
    return np.random.default_rng(seed)


def _harmonic_costs(problem: Problem, k: int, shapes: Array,
                    harmonics: int) -> tuple[Array, Array] | None:
    """Shapes ranked on card k's harmonics (costs, amplitude factors); None when the card
    is not one uniformly sampled period of a model without an input map."""
    t, f, d = problem.card(k)
    periodic = (problem.mode[k] == kernel.PERIODIC and problem.uniform[k]
                and problem.model.input_map is None
                and abs(problem.period[k] - t.size * (t[1] - t[0])) <= 1e-6 * problem.period[k])
    if not periodic:
        return None
    symmetric = bool(problem.model.scale_symmetric and problem.scale_fixed is not None
                     and not problem.fixed)
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    return harmonic_scan(t, f, d, np.ascontiguousarray(shapes), problem.model.code(),
                         problem.model.n_states(), problem.out_index,
                         problem.offset_fixed is None, symmetric, float(scale), harmonics)


def compile_ranking(problem: Problem, k: int) -> None:
    """Compile (or load) the harmonic ranking for card k's kind of arrays, if it uses it.

    A warm-up: a fresh install's first fit compiles this while another process compiles
    the simulation, instead of after it when the first card reaches the wider search.
    """
    shapes = problem.model.shape_grid(fundamental(problem, k))[:1]
    _harmonic_costs(problem, k, shapes, 2)


def _ranked_shapes(problem: Problem, k: int, plan: WidePlan) -> Array:
    """The model's dense shapes on card k, best first, as rescaled parameter rows."""
    w0 = fundamental(problem, k)
    shapes = problem.model.shape_grid(w0, dense=True)
    if problem.fixed:
        for i, value in problem.fixed:
            shapes[:, i] = value
    ranked = _harmonic_costs(problem, k, shapes, plan.harmonics)
    if ranked is not None:
        costs, factors = ranked
        # The factors are exactly 1 unless the scan solved for the amplitude.
        shapes = shapes * factors[:, None]
    else:
        z, costs = complete(problem, np.full(shapes.shape[0], k, dtype=np.int64), shapes)
        shapes = problem.full_theta(np.exp(z[:, : problem.n_free]))
    order = np.argsort(costs)
    return shapes[order[np.isfinite(costs[order])]]


def _distinct(points: list[Array], z: Array, p: int, tol: float = 0.05) -> bool:
    return all(np.max(np.abs(z[:p] - q[:p])) > tol for q in points)


def search_wider(
    problem: Problem,
    cards: NDArray[np.int64],
    z_now: Array,
    cost_now: Array,
    *,
    plan: WidePlan = WidePlan(),
    solver: LevenbergMarquardt | None = None,
    workers: int | None = 1,
) -> tuple[Array, Array, NDArray[np.int64]]:
    """A wider multistart for cards whose answer does not explain their data.

    The model's dense shape grid (ranked cheaply) and random points within ``plan.spread``
    of the natural scales are polished in rounds; the solver runs from the best distinct
    polished points (for at most ``plan.final_evaluations`` each). Stops for a
    card when two independent starts agree on its best cost, which then is the global
    optimum with good confidence.

    Returns the best points (m, q), their costs (m,) and the number of points polished.
    """
    solver = solver or LevenbergMarquardt()
    cards = np.asarray(cards, dtype=np.int64)
    m = cards.size
    p = problem.n_free
    best_z = np.array(z_now, dtype=float).copy()
    best_cost = np.array(cost_now, dtype=float).copy()
    polished_count = np.zeros(m, dtype=np.int64)
    pools = [_ranked_shapes(problem, int(k), plan) for k in cards]
    rngs = [_card_rng(problem, int(k)) for k in cards]
    finals: list[list[tuple[float, Array]]] = [[] for _ in range(m)]
    for i in range(m):
        if math.isfinite(best_cost[i]):
            finals[i].append((float(best_cost[i]), best_z[i].copy()))
    active = list(range(m))
    # The polish only tells basins apart: on a periodic card it minimises the cost of the
    # card's first harmonics (pumpid.engine.spectrum), a fraction of an exact evaluation;
    # the finals below then run on the exact cost.
    polish = LevenbergMarquardt(tol=1e-10, harmonics=plan.harmonics)
    for round_ in range(plan.rounds):
        if not active:
            break
        items_card: list[int] = []
        items_theta: list[Array] = []
        owner: list[int] = []
        for i in active:
            k = int(cards[i])
            pool = pools[i][round_ * plan.per_round:(round_ + 1) * plan.per_round]
            ref = problem.reference[k]
            rand = ref * np.exp(rngs[i].uniform(-math.log(plan.spread), math.log(plan.spread),
                                                (plan.random, problem.n_params)))
            for i_fix, value in problem.fixed:
                rand[:, i_fix] = value
            for theta in (*pool, *rand):
                items_card.append(k)
                items_theta.append(theta)
                owner.append(i)
        if not items_card:
            break
        item_cards = np.array(items_card, dtype=np.int64)
        z0, c0 = complete(problem, item_cards, np.array(items_theta), workers=workers)
        keep = np.isfinite(c0)
        owner_arr = np.array(owner)[keep]
        out = polish.solve(problem, item_cards[keep], z0[keep],
                           budget=plan.polish_evaluations, workers=workers)
        # The best distinct polished points of each card go on to convergence.
        chosen_card: list[int] = []
        chosen_z: list[Array] = []
        chosen_owner: list[int] = []
        for i in active:
            mine = np.flatnonzero(owner_arr == i)
            polished_count[i] += mine.size
            mine = mine[np.isfinite(out.cost[mine])]
            picked: list[Array] = []
            for j in mine[np.argsort(out.cost[mine])]:
                if len(picked) >= plan.finals:
                    break
                if _distinct(picked, out.z[j], p):
                    picked.append(out.z[j])
            for z in picked:
                chosen_card.append(int(cards[i]))
                chosen_z.append(z)
                chosen_owner.append(i)
        if chosen_card:
            chosen = np.array(chosen_card, dtype=np.int64)
            z_final = np.array(chosen_z)
            # A final first follows its basin on the harmonic cost, then on the exact one.
            cheap = dataclasses.replace(solver, harmonics=plan.harmonics).solve(
                problem, chosen, z_final, budget=plan.final_evaluations, workers=workers)
            moved = np.all(np.isfinite(cheap.z), axis=1) & np.isfinite(cheap.cost)
            z_final[moved] = cheap.z[moved]
            full = solver.solve(problem, chosen, z_final, budget=plan.final_evaluations,
                                workers=workers)
            for j, i in enumerate(chosen_owner):
                if math.isfinite(full.cost[j]):
                    finals[i].append((float(full.cost[j]), full.z[j].copy()))
        still = []
        for i in active:
            results = sorted(finals[i], key=lambda item: item[0])
            if not results:
                continue
            top = results[0][0]
            best_cost[i], best_z[i] = results[0]
            agreeing = [z for c, z in results if c <= top * (1 + plan.agree) + 1e-300]
            # Two starts that end on the same best cost from different places: the best
            # basin has been found twice.
            if len(agreeing) < 2:
                still.append(i)
        active = still
    return best_z, best_cost, polished_count
