"""Boundaries: answers at a limit of the model, decided by tests, not by the solver's patience.

A parameter that runs toward zero or infinity leaves a limiting model (a spring that
becomes rigid, a mass that vanishes). Two tests find it (:mod:`pumpid.inference.boundaries`):
the push test (the cost does not rise when the parameter is pushed further) and the nested
test (the reduced model, fitted on its own, is not worse by more than the likelihood ratio's
95 % point). The reduced models are fitted by a ``refit`` function the job hands in (the job
itself on the reduced problem), so this module decides and never runs the job.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..engine.problem import CardData, Problem, build_problem
from ..inference import boundaries as bnd
from ..models import model_class
from ..result import FitBatch, FitResult, Limiting, ReducedFit, Status
from .options import JobOptions
from .state import CardState, scale_offset, theta_of

__all__ = ["LR_95", "Refit", "check_boundaries"]

Array = NDArray[np.float64]
#: The likelihood-ratio test's 95 % point of chi^2 with one degree of freedom.
LR_95 = 3.84
#: Fits a reduced model's problem from per-card starting parameters (and, when its scale is
#: free, starting scales): the job on that problem, summarised (no diagnostics).
Refit = Callable[[Problem, Array, "Array | None"], FitBatch]


def _reduced_problem(problem: Problem, cards: NDArray[np.int64], lim: Any,
                     gains: Array) -> tuple[Problem, str | float]:
    """The reduced model's problem over the given cards (same data and options)."""
    reduced = model_class(lim.reduced)
    scale: float | str = "free" if problem.scale_fixed is None else float(problem.scale_fixed)
    if (not np.allclose(gains, 1.0) and not reduced.scale_symmetric):
        scale = "free"
    cards_data = [CardData(*problem.card(int(k)), initial_state=problem.initial_states[int(k)],
                           period=None if not math.isfinite(problem.period[int(k)])
                           else float(problem.period[int(k)])) for k in cards]
    sub = build_problem(
        reduced, cards_data, observe=lim.observe, integrator=problem.integrator,
        residual=problem.residual, scale=scale,
        offset=True if problem.offset_fixed is None else problem.offset_fixed, strict=False)
    return sub, scale


def _fit_reduced(problem: Problem, items: list[tuple[int, Any]], fits: list[CardState],
                 position: Mapping[int, int], refit: Refit
                 ) -> dict[tuple[int, str, str], tuple[FitBatch, int]]:
    """Fit the limiting models of (card, limit) items; results keyed by (card, param, dir)."""
    out: dict[tuple[int, str, str], tuple[FitBatch, int]] = {}
    groups: dict[tuple[str, str], list[tuple[int, Any]]] = {}
    for k, lim in items:
        groups.setdefault((lim.param, lim.direction), []).append((k, lim))
    for members in groups.values():
        lim = members[0][1]
        cards = np.array([k for k, _ in members], dtype=np.int64)
        starts = []
        gains = []
        scales = []
        for k, _ in members:
            card = fits[position[k]]
            params = dict(zip(problem.model.param_names(), theta_of(problem, card.z), strict=True))
            start, gain = lim.reduced_start(params)
            starts.append(start)
            gains.append(gain)
            scales.append(scale_offset(problem, card.z)[0])
        sub, scale = _reduced_problem(problem, cards, lim, np.array(gains))
        names = sub.model.param_names()
        guess = np.array([[s[n] for n in names] for s in starts])
        bad = ~np.all(np.isfinite(guess) & (guess > 0), axis=1)
        guess[bad] = 1.0
        c_start = None
        if scale == "free" and sub.scale_fixed is None:
            c_start = np.array(gains) * np.array(scales)
        batch = refit(sub, guess, c_start)
        for j, (k, lim_k) in enumerate(members):
            if not bad[j]:
                out[(k, lim_k.param, lim_k.direction)] = (batch, j)
    return out


def _summary_of(res: FitResult) -> ReducedFit:
    return ReducedFit(model=res.model_name, params=dict(res.params), units=res.param_units(),
                      scale=res.scale, offset=res.offset, rmse=res.rmse, r2=res.r2,
                      status=res.status.key, reason=res.reason)


def check_boundaries(problem: Problem, cards: NDArray[np.int64], fits: list[CardState],
                     options: JobOptions, refit: Refit) -> dict[int, Array]:
    """Mark boundary solutions; return restart points for cards a reduced model beats.

    Parameters
    ----------
    problem : Problem
    cards : array of int
        The problem's cards that ``fits`` hold, in order.
    fits : list of CardState
        Each card's answer; cards found at a limit are moved to it and marked (status,
        reason, warnings, limits and the reduced model's summary).
    options : JobOptions
        The solver used to move a card to its limit.
    refit : Refit
        Fits the reduced models.

    Returns
    -------
    dict
        Card -> starting parameters of a restart next to a reduced model that fitted
        clearly better than the card's answer.
    """
    idx = [i for i, k in enumerate(cards)
           if np.all(np.isfinite(fits[i].z)) and math.isfinite(fits[i].cost)]
    if not idx:
        return {}
    # A reduced model cannot hold the full model's fixed values: with any value fixed only
    # the push test (which needs none) runs.
    nested = not problem.fixed
    sub_cards = cards[idx]
    z = np.array([fits[i].z for i in idx])
    norms = np.array([fits[i].norms if fits[i].norms is not None
                      else np.full(problem.q, math.nan) for i in idx])
    spreads = np.array([bnd.spread(problem, int(k)) for k in sub_cards])
    log_sens = norms[:, : problem.n_free] / spreads[:, None]
    interior = np.array([not fits[i].edges and not fits[i].stopped_early
                         and bool(np.all(log_sens[j] >= bnd.SUSPICION))
                         for j, i in enumerate(idx)])
    found: list[list[Limiting]] = [[] for _ in idx]
    push = [j for j in range(len(idx)) if not interior[j]]
    if push:
        res = bnd.push_test(problem, sub_cards[push], z[push],
                            np.array([fits[idx[j]].cost for j in push]),
                            [fits[idx[j]].edges for j in push])
        for j, lims in zip(push, res, strict=True):
            found[j] = lims
    # Nested candidates: the reduced model's fit decides.
    position = {int(k): i for i, k in enumerate(cards)}
    items: list[tuple[int, Any]] = []
    cand: list[list[Any]] = []
    for j, i in enumerate(idx):
        k = int(cards[i])
        lims = []
        if nested and isinstance(problem.initial_states[k], str):
            lims = bnd.nested_candidates(problem, k, fits[i].z, log_sens[j], fits[i].edges,
                                         fits[i].stopped_early)
        cand.append(lims)
        items.extend((k, lim) for lim in lims)
    reduced = _fit_reduced(problem, items, fits, position, refit) if items else {}
    restarts: dict[int, Array] = {}
    for j, i in enumerate(idx):
        k = int(cards[i])
        card = fits[i]
        # Where the fit stopped, before any move to a limit: a fit that ran out of
        # evaluations is taken on from here, and kept here when no limit holds.
        z_before, cost_before = card.z.copy(), card.cost
        d = problem.card(k)[2]
        n_free = problem.q
        sigma2 = 2.0 * card.cost / max(d.size - n_free, 1)
        sst = float(np.sum((d - d.mean()) ** 2))
        known = {b.name for b in found[j]}
        best_red: tuple[float, FitResult, Any] | None = None
        restart_cost = math.inf
        for lim in cand[j]:
            got = reduced.get((k, lim.param, lim.direction))
            if got is None:
                continue
            red = got[0].results[got[1]]
            # A reduced fit that stopped unfinished is no optimum to compare with.
            if red is None or not math.isfinite(red.cost) or red.status is Status.FAILED:
                continue
            excess = 2.0 * (red.cost - card.cost)
            if excess < -LR_95 * sigma2 - 1e-12 * sst and lim.from_reduced:
                # The reduced model fits clearly better: the full fit has not reached the
                # limit it crawls toward, or it is stuck elsewhere. The limit itself first
                # (the parameter at the window's edge, the others refitted) ...
                if lim.param in known or _limit_reaches(problem, k, card, lim, red.cost,
                                                        options):
                    if lim.param not in known:
                        f = list(problem.free_idx).index(problem.model.param_names().index(
                            lim.param))
                        found[j].append(Limiting(lim.param, lim.direction,
                                                 float(np.exp(min(card.z[f], 709.0))),
                                                 lim.description, "nested"))
                        known.add(lim.param)
                    if best_red is None or red.cost < best_red[0]:
                        best_red = (red.cost, red, lim)
                    continue
                # ... else a restart of the full model next to the reduced solution.
                point = lim.full_point(dict(red.params))
                if point is not None and red.cost < restart_cost:
                    restart_cost = red.cost
                    restarts[k] = np.array([point[n] for n in problem.model.param_names()])
                continue
            if excess <= LR_95 * sigma2 + 1e-12 * sst:
                if lim.param not in known:
                    f = list(problem.free_idx).index(problem.model.param_names().index(
                        lim.param))
                    found[j].append(Limiting(lim.param, lim.direction,
                                             float(np.exp(min(card.z[f], 709.0))), lim.description,
                                             "nested"))
                    known.add(lim.param)
                if best_red is None or red.cost < best_red[0]:
                    best_red = (red.cost, red, lim)
        if not found[j] or k in restarts:
            continue
        at_limit = _to_the_limit(problem, k, card, found[j], options)
        if not card.stop.converged and not _crawled_to(problem, k, card, z_before, at_limit,
                                                       best_red is not None,
                                                       d.size - n_free, sst, options):
            # No solve finished, at the limit or before it: the limit is a suspicion the
            # answer's words carry, not a status (a budget-stopped fit stays failed), and
            # the card keeps its own point (the window's edge is no answer of it).
            card.z, card.cost = z_before, cost_before
            card.warnings.extend(f"{b.describe()} (suspected only: no solve converged, at "
                                 "the limit or before it)" for b in found[j])
            continue
        found[j] = _at_final_values(problem, card, found[j])
        card.status = Status.BOUNDARY
        names = ", ".join(b.name for b in found[j])
        # The solver's stop after the status's own words: "converged: ..." first read as
        # if the answer were an ordinary converged one (the JSON's converged: false beside it).
        card.reason = (f"{names} ran to a bound: the solution is a limiting model, not an "
                       f"interior optimum (the solver's stop: {card.reason})")
        card.warnings.extend(b.describe() for b in found[j])
        card.limits = tuple(found[j])
        if best_red is None and nested and isinstance(problem.initial_states[k], str):
            target = next((problem.model.limit(b.name, b.direction) for b in found[j]
                           if problem.model.limit(b.name, b.direction).reduced), None)
            if target is not None:
                got = _fit_reduced(problem, [(k, target)], fits, position,
                                   refit).get((k, target.param, target.direction))
                red = got[0].results[got[1]] if got else None
                if red is not None:
                    best_red = (red.cost, red, target)
        if best_red is not None:
            red, lim = best_red[1], best_red[2]
            card.reduced = dataclasses.replace(_summary_of(red),
                                               limit=lim.named(problem.observe))
            card.warnings.append(
                f"reduced model {red.model_name} ({lim.named(problem.observe)}) fitted: "
                f"R^2 = {red.r2:.6g}, RMSE = {red.rmse:.4g} {{position}}")
    return restarts


#: Evaluations of the solve that checks a budget-stopped fit's limit: enough to move on to
#: an interior optimum far below the limit's cost (200 reach k0 = 4 from a fit stopped at
#: 8e4), without a default budget (2,000 evaluations) spent again on a crawl that was one.
CHECK_EVALUATIONS = 200


def _crawled_to(problem: Problem, k: int, card: CardState, z_before: Array,
                at_limit: float, reduced: bool, dof: int, sst: float,
                options: JobOptions) -> bool:
    """Whether a fit that ran out of evaluations at ``z_before`` was crawling to the limit
    the card is now at.

    Some solve at the limit must have converged (the reduced model's, which fits as well,
    or the full model's at the window's edge, within the likelihood-ratio test), and the
    fit, taken on from where it stopped for :data:`CHECK_EVALUATIONS` more, must not fall
    below the limit's cost by more than the test allows: with a budget of 20-40
    evaluations a fit of an interior k0 = 4 stopped on its way there, the solve at the
    limit beat that unfinished point, and the fit was called a boundary. (Taken on from the
    limit instead, it stays: the cost is flat along the limit's direction there.) A budget
    below that check's is the user's word that a fit stops there: it stays failed.
    """
    if options.solver.budget(problem.q) < CHECK_EVALUATIONS:
        return False
    free = options.solver.solve(problem, np.array([k], dtype=np.int64), z_before[None],
                                budget=CHECK_EVALUATIONS)
    card.evaluations += int(free.evaluations[0])
    best = min(card.cost, float(free.cost[0])) if math.isfinite(free.cost[0]) else card.cost
    # The test's noise from the best cost seen: the unfinished fit's may be far above it.
    tol = LR_95 * 2.0 * best / max(dof, 1) + 1e-12 * sst
    if not (reduced or 2.0 * (at_limit - card.cost) <= tol):
        return False
    return not 2.0 * (card.cost - best) > tol


def _limit_reaches(problem: Problem, k: int, card: CardState, lim: Any, target: float,
                   options: JobOptions) -> bool:
    """Move card k to the limit ``lim`` (parameter at the window's edge, the others refitted);
    True, with the card moved there, when that reaches the reduced model's cost ``target``."""
    trial = CardState(z=card.z.copy(), cost=card.cost)
    _to_the_limit(problem, k, trial, [Limiting(lim.param, lim.direction, math.nan,
                                               lim.description, "nested")], options)
    if not trial.cost <= target * (1 + 1e-6) + 1e-300:
        return False
    card.evaluations += trial.evaluations
    card.accepted += trial.accepted
    card.z, card.cost = trial.z, trial.cost
    return True


def _to_the_limit(problem: Problem, k: int, card: CardState, limits: Sequence[Limiting],
                  options: JobOptions) -> float:
    """Move parameters found at a boundary to the edge of the search window (the limit as
    far as the window reaches) and refit the others there; kept when it fits better.
    Returns that refit's cost where it met a convergence test (infinity elsewhere).

    Along a limit the cost keeps creeping down while the solver's steps shrink, so where a
    boundary parameter stops is a matter of the solver's patience: at the window's edge the
    answer is the limit itself, the same for every run.
    """
    names = [problem.model.param_names()[i] for i in problem.free_idx]
    z0 = card.z.copy()
    lo, hi = problem.window(np.array([k], dtype=np.int64), z0[None])
    lo, hi = lo.copy(), hi.copy()
    for b in limits:
        if b.name not in names:
            continue
        f = names.index(b.name)
        edge = hi[0, f] if b.direction == "infinity" else lo[0, f]
        z0[f] = lo[0, f] = hi[0, f] = edge
    out = options.solver.solve(problem, np.array([k], dtype=np.int64), z0[None],
                               bounds=(lo, hi))
    card.evaluations += int(out.evaluations[0])
    if math.isfinite(out.cost[0]) and out.cost[0] < card.cost:
        card.z = out.z[0].copy()
        card.cost = float(out.cost[0])
        card.accepted += int(out.accepted[0])
    return float(out.cost[0]) if out.stops[0].converged else math.inf


def _at_final_values(problem: Problem, card: CardState, limits: list[Limiting]) -> list[Limiting]:
    """The limits with the values the card ends at, not those where they were found: the
    move to the window's edge changes them (6.4e8 said, 1.7e9 reported), and the words must
    quote the reported value."""
    free = [problem.model.param_names()[i] for i in problem.free_idx]
    return [dataclasses.replace(b, value=float(np.exp(min(card.z[free.index(b.name)], 709.0))))
            if b.name in free else b for b in limits]
