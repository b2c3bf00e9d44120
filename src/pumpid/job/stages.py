"""The main job as stages: start -> solve -> guard -> widen -> boundaries -> diagnose.

Each stage is a compiled pass over all the cards that need it (spread over threads), with
Python deciding between the stages on arrays:

1. start: the automatic multistart (:mod:`pumpid.engine.start`), a user's guess, or a guess
   guarded by the multistart;
2. solve: Levenberg-Marquardt (or the paper's Newton);
3. guard: a fit from a user's guess that failed, explains less than 99 % of the data's
   variance or stays above the data's noise floor is redone with the multistart, and the
   better of the two is kept;
4. widen: a wider search where the answer does not explain the data, a scan along the
   model's inertia where it does;
5. boundaries (:mod:`pumpid.job.boundary`), whose reduced-model fits are this same job on the
   reduced problem, handed in as a function; a reduced model that fits clearly better sends
   the full fit back to a start next to it;
6. diagnose (:mod:`pumpid.job.diagnose`), then each card's result and its two gates.

A card's answer does not depend on which other cards share its problem: every stage treats
each card on its own numbers, so a batch and card-by-card fits agree exactly.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..engine import aside, drive
from ..engine.problem import Problem
from ..engine.solvers import Stop
from ..engine.spectrum import SEARCH_HARMONICS
from ..engine.start import (
    InertiaLine,
    compile_ranking,
    complete,
    find_starts,
    inertia_index,
    scan_inertia,
    search_wider,
    to_z,
    walk_valley,
)
from ..inference.uncertainty import analyse_rows
from ..result import FitBatch, FitResult, StartInfo, Status, Units
from .assemble import build_result, determination_gate, quality_gate
from .boundary import check_boundaries
from .diagnose import diagnose
from .options import NO_START, JobOptions
from .state import (
    CardState,
    apply_outcome,
    doubt,
    doubtful,
    mark_edges,
    scale_offset,
    start_problem,
    summarize,
    theta_of,
)

__all__ = ["BETTER_OPTIMUM", "cost_change", "run", "run_batch"]

Array = NDArray[np.float64]

#: A search's answer is said to be a better optimum only when it is lower than the first
#: by at least this (relative cost), the best-optimum benchmark's own tolerance. Two
#: converged runs into one basin end within about the solver's tolerance (1e-12) of each
#: other, and other points of a flat valley lower by 1e-9 to 1e-6 (2.4e-8 on the demo pump
#: field, 5.3e-9 on a public field card): neither is a better optimum to claim. The answer
#: is still taken from there: its solve walks further along a flat valley, where the
#: boundary tests can then see a limit (kept from the first answer instead, 12 of 130
#: public field cards changed status at the same cost).
BETTER_OPTIMUM = 1e-6


def _automatic_start(problem: Problem, cards: NDArray[np.int64], fits: list[CardState],
                     guess: Array | None, options: JobOptions) -> Array:
    """Stage 1, automatic: the multistart's points (a given guess competes when guarded)."""
    m = cards.size
    guarded = guess is not None
    # Long cards start from a shorter copy of themselves (same coordinates).
    at = start_problem(problem, cards)
    on, on_cards = (problem, cards) if at is None else (at, np.arange(m, dtype=np.int64))
    starts = find_starts(on, on_cards, guess=guess, plan=options.plan,
                         workers=options.workers)
    z0 = starts.z.copy()
    for i in range(m):
        kind = "automatic start"
        if guarded:
            kind = ("start: the given guess, checked against the automatic start"
                    if starts.from_guess[i] else
                    "start: automatic (it reached a lower cost than the given guess)")
        walked = ""
        if starts.stopped_early[i] and np.all(np.isfinite(z0[i])):
            zw, cw = walk_valley(on, int(on_cards[i]), z0[i], float(starts.cost[i]))
            if cw < starts.cost[i]:
                z0[i] = zw
                walked = ", then walked along a flat valley"
        part = ""
        used = on.n_samples(int(on_cards[i]))
        if used < problem.n_samples(int(cards[i])):
            part = f" on {used} of the card's {problem.n_samples(int(cards[i]))} samples"
        fits[i].start = StartInfo(
            f"{kind}: equation-error and grid estimates ({int(starts.n_candidates[i])} "
            f"candidates){part}, best {int(starts.n_polished[i])} polished{walked}",
            int(starts.n_candidates[i]), int(starts.n_polished[i]))
    return z0


def _given_start(problem: Problem, cards: NDArray[np.int64], guess: Array,
                 c_start: Array | None, offset_start: Array | None,
                 options: JobOptions) -> Array:
    """Stage 1, from a guess: the solver point of each card's given parameters (the scale
    and offset completed by least squares unless given)."""
    z0, _c = complete(problem, cards, np.asarray(guess, dtype=float), rescale=False,
                      workers=options.workers)
    j = problem.n_free
    if problem.scale_fixed is None:
        if c_start is not None:
            given = np.isfinite(c_start)
            z0[given, j] = np.log(c_start[given])
        j += 1
    if problem.offset_fixed is None and offset_start is not None:
        # The user's offset is the reported one; the solver's exceeds it by the gap.
        for i in np.flatnonzero(np.isfinite(offset_start)):
            k = int(cards[i])
            gap = problem.offset_gap(k, theta_of(problem, z0[i]),
                                     scale_offset(problem, z0[i])[0])
            z0[i, j] = offset_start[i] + float(gap)
    lost = ~np.all(np.isfinite(z0), axis=1)
    z0[lost] = to_z(problem, np.asarray(guess, dtype=float))[lost]
    return np.where(np.isfinite(z0), z0, 0.0)


#: Exact evaluations a periodic card's solve gets before it counts as crawling (see
#: :func:`_lm_solve`).
QUICK_EVALUATIONS = 40


def _harmonic_stage(problem: Problem, cards: NDArray[np.int64], z0: Array,
                    fits: list[CardState], options: JobOptions,
                    history: bool) -> tuple[Array, Array]:
    """The starts of the exact solve: for cards the harmonic cost applies to
    (:meth:`Problem.harmonic`), its optimum from z0 (its evaluations counted on the cards),
    or z0 where that is not finite. With ``history`` (one card), also the stage's accepted
    points with their exact costs (rows ``z, cost``).

    A real card's residual is model error and its parameters often lie along a long flat
    valley: from the automatic start the exact solver crawled it for a median of 289
    evaluations a card (mean 764) on 130 public field cards. On the cards' first harmonics
    the same crawl took a median of 222 steps (mean 719) at a fraction of the price each,
    and the exact solve from its end a median of 54 (mean 259); the answers were as low or
    lower (47 of the 130 lower by more than 1e-6 of the cost, 2 higher, by at most 1e-3).
    """
    z_run = z0.copy()
    path = np.zeros((0, problem.q + 1))
    solver = dataclasses.replace(options.solver, harmonics=SEARCH_HARMONICS)
    first = solver.solve(problem, cards, z0, history=history, workers=options.workers)
    for i in range(cards.size):
        fits[i].evaluations += int(first.evaluations[i])
        if np.all(np.isfinite(first.z[i])) and math.isfinite(first.cost[i]):
            z_run[i] = first.z[i]
    if first.history.size:
        points = first.history[:, :-1]
        exact = drive.cost_items(np.full(points.shape[0], cards[0], dtype=np.int64),
                                 points, *problem.arrays)
        path = np.column_stack([points, exact])
    return z_run, path


def _lm_solve(problem: Problem, cards: NDArray[np.int64], z0: Array, fits: list[CardState],
              options: JobOptions, *, history: bool) -> Array:
    """The exact solve of each card from z0, through the harmonic cost where the card's
    solve crawls; returns the points the last solve of each card started from.

    A card the harmonic cost applies to first gets ``QUICK_EVALUATIONS`` exact evaluations:
    a card whose start is already in its optimum's basin (most synthetic cards, whose
    residual is white noise) converges within them, with the answer of one exact solve.
    One that does not is crawling along a flat valley, as real cards do: it goes on along
    the harmonic cost (:func:`_harmonic_stage`), then the exact solver runs from there.
    With ``history`` (one card), the card's path is the three stages' in a row.

    Counted over the job's solves (refits included): on 130 public field cards 97 of 239
    crawled, and 4 of those ended above the quick solve's point and went on from it; on
    100 synthetic periodic cards, 15 of 130 and 2; on 100 controller-like cards, 48 of 223
    and 12. Where the harmonic cost ran from the start itself instead, 14 of 100 synthetic
    periodic answers moved by more than 1e-6 (7 higher, by up to 0.7 %); now 2 move, both
    higher (by 0.2 and 0.6 %), and of the 100 controller-like cards 10 move, 8 lower and 2
    higher (by up to 0.75 %), against the exact solve alone.
    """
    solver = options.solver
    z_from = z0.copy()
    full = solver.budget(problem.q)
    # A budget the user set at or below the quick one is the whole solve, as it says.
    periodic = np.array([problem.harmonic(int(k)) and QUICK_EVALUATIONS < full
                         for k in cards], dtype=bool)
    budget = np.where(periodic, QUICK_EVALUATIONS, full)
    first = solver.solve(problem, cards, z0, budget=budget, history=history,
                         workers=options.workers)
    for j in range(cards.size):
        apply_outcome(fits[j], first, j, problem)
    crawl = np.flatnonzero(periodic & np.array([s is Stop.BUDGET for s in first.stops]))
    if not crawl.size:
        return z_from
    z_run, path = _harmonic_stage(problem, cards[crawl], first.z[crawl],
                                  [fits[j] for j in crawl], options, history)
    out = solver.solve(problem, cards[crawl], z_run, history=history, workers=options.workers)
    # Along a flat valley the harmonic cost can lead into a basin whose exact floor lies
    # above the point the quick solve had reached: such a card goes on exactly from there.
    astray = [jj for jj, j in enumerate(crawl) if not out.cost[jj] <= first.cost[j]]
    before = fits[crawl[0]].history
    for jj, j in enumerate(crawl):
        apply_outcome(fits[j], out, jj, problem)
        z_from[j] = z_run[jj]
    after = fits[crawl[0]].history
    if astray:
        back = crawl[astray]
        again = solver.solve(problem, cards[back], first.z[back], history=history,
                             workers=options.workers)
        for jj, j in enumerate(back):
            apply_outcome(fits[j], again, jj, problem)
            z_from[j] = first.z[j]
        if history and before is not None and fits[back[0]].history is not None:
            fits[back[0]].history = np.vstack([before, fits[back[0]].history[1:]])
    elif (history and before is not None and after is not None and path.shape[0] >= 2
            and np.array_equal(path[-1, :-1], z_run[0])):
        # The harmonic path's ends are the quick solve's last point and the exact solve's
        # first: each kept once.
        fits[crawl[0]].history = np.vstack([before, path[1:-1], after])
    return z_from


def _solve(problem: Problem, cards: NDArray[np.int64], fits: list[CardState], z0: Array,
           options: JobOptions) -> None:
    """Stage 2: the solver from each card's start."""
    m = cards.size
    if options.method == "newton-fd":
        for i in range(m):
            k = int(cards[i])
            theta0 = theta_of(problem, z0[i])
            scale0, offset0 = scale_offset(problem, z0[i])
            out, hist = options.newton.solve(problem, k, theta0, scale0, offset0)
            apply_outcome(fits[i], out, 0, problem)
            fits[i].newton_history = hist
    else:
        ok = np.all(np.isfinite(z0), axis=1)
        run_idx = np.flatnonzero(ok)
        if run_idx.size:
            z_from = _lm_solve(problem, cards[run_idx], z0[run_idx],
                               [fits[i] for i in run_idx], options,
                               history=options.history and m == 1)
            mark_edges(problem, cards[run_idx], z_from, fits, list(run_idx))
        for i in np.flatnonzero(~ok):
            # Not run: without this the row would say failed and nothing else.
            fits[i].message = NO_START
    for card in fits:
        card.status = Status.CONVERGED if card.stop.converged else Status.FAILED
        card.reason = card.message
    summarize(problem, cards, fits)


def _guard(problem: Problem, cards: NDArray[np.int64], fits: list[CardState], guess: Array,
           options: JobOptions, depth: int) -> None:
    """Stage 3: a doubtful fit from a user's guess is redone with the multistart."""
    bad = [i for i in range(cards.size) if doubtful(problem, int(cards[i]), fits[i])]
    if not bad:
        return
    guarded = run(problem, cards[bad], guess=np.asarray(guess, dtype=float)[bad],
                  options=dataclasses.replace(options, multistart=True), depth=depth)
    for j, i in enumerate(bad):
        g = guarded[j]
        first = fits[i]
        if math.isfinite(g.cost) and not (g.cost >= first.cost):
            # Said only where it is better by more than rounding: "a better solution (cost
            # 1.98183e-09 -> 1.98183e-09)" contradicted itself.
            if g.cost < first.cost * (1 - BETTER_OPTIMUM):
                g.warnings.append(
                    "the fit from the starting guess looked wrong (status "
                    f"{first.status.key}, R^2 = {first.r2:.4g}); the automatic multistart "
                    f"found a better solution ({cost_change(first.cost, g.cost)})")
            g.evaluations += first.evaluations
            g.done = True
            fits[i] = g


def _searched(problem: Problem, cards: NDArray[np.int64], z_now: Array, c_now: Array,
              search: Callable[[Problem, NDArray[np.int64], Array, Array],
                               tuple[Array, Array, NDArray[np.int64]]]
              ) -> tuple[Array, Array, NDArray[np.int64]]:
    """A search beyond the answer's basin, on the cards or (long cards) on their shorter
    copy, like the start; the whole record's cost then judges the point found. Returns the
    points, their costs on the problem and the search's counts."""
    at = start_problem(problem, cards)
    if at is None:
        return search(problem, cards, z_now, c_now)
    local = np.arange(cards.size, dtype=np.int64)
    z_new, _c, counts = search(at, local, z_now, drive.cost_items(local, z_now, *at.arrays))
    return z_new, drive.cost_items(cards, z_new, *problem.arrays), counts


def _widen(problem: Problem, cards: NDArray[np.int64], fits: list[CardState],
           options: JobOptions) -> None:
    """Stage 4: a wider search where the answer does not explain the data (a wrong basin,
    or a model that misses part of the response: then other basins compete); where it does,
    a scan along the model's inertia (:mod:`pumpid.engine.start.resonance`), whose ripples
    hold answers at the noise level."""
    plan = options.wide
    if plan is None:
        return
    solver = options.solver
    ready = [i for i in range(cards.size)
             if not fits[i].done and np.all(np.isfinite(fits[i].z))]
    why = {i: doubt(problem, int(cards[i]), fits[i]) for i in ready}
    hard = [i for i in ready if why[i]]
    calm = sorted(set(ready) - set(hard))
    found: dict[int, tuple[Array, str]] = {}

    def search_wide(on: Problem, on_cards: NDArray[np.int64], z: Array,
                    c: Array) -> tuple[Array, Array, NDArray[np.int64]]:
        return search_wider(on, on_cards, z, c, plan=plan, solver=solver,
                            workers=options.workers)

    # The local minima the scan converged to, with the first answer's (on the card itself,
    # not a long card's shorter copy, whose costs are another sum): the diagnostics widen
    # the inertia's error to those within the noise of the best.
    minima: list[list[tuple[float, float]]] = [[] for _ in calm]
    lines: list[InertiaLine | None] = [None] * len(calm)

    inertia = inertia_index(problem)

    def scan(on: Problem, on_cards: NDArray[np.int64], z: Array,
             c: Array) -> tuple[Array, Array, NDArray[np.int64]]:
        seen = None
        if on is problem and inertia is not None:
            seen = minima
            for i in range(len(calm)):
                seen[i].append((float(z[i, inertia]), float(c[i])))
        return scan_inertia(on, on_cards, z, c, plan=plan, solver=solver,
                            workers=options.workers, minima=seen,
                            lines=lines if seen is not None else None)

    name = problem.model.resonance
    for group, search, words in (
            (hard, search_wide, "{why}; a wider search ({n} more starts)"),
            (calm, scan, f"the first answer sat in a ripple of the cost along {name} (a "
                         "resonance the card sees only through its weak harmonics); a scan "
                         f"along {name} ({{n}} more starts)")):
        if not group or (search is scan and (not plan.scan_points or inertia is None)):
            continue
        z_now = np.array([fits[i].z for i in group])
        c_now = np.array([fits[i].cost for i in group])
        z_new, c_new, counts = _searched(problem, cards[group], z_now, c_now, search)
        for j, i in enumerate(group):
            if c_new[j] < fits[i].cost * (1 - 1e-12):
                found[i] = (z_new[j], words.format(why=why.get(i, ""), n=int(counts[j])))
    for j, i in enumerate(calm):
        fits[i].inertia_minima = tuple(minima[j])
        fits[i].inertia_line = lines[j]
    if not found:
        return
    # The improved points are converged already: one more solver run from each gives them
    # their stop test and history.
    idx = sorted(found)
    z_found = np.array([found[i][0] for i in idx])
    again = solver.solve(problem, cards[idx], z_found,
                         history=options.history and cards.size == 1,
                         workers=options.workers)
    for j, i in enumerate(idx):
        before = fits[i].cost
        evals = fits[i].evaluations
        fits[i].evaluations = 0
        fits[i].accepted = 0
        apply_outcome(fits[i], again, j, problem)
        fits[i].evaluations += evals
        fits[i].status = Status.CONVERGED if fits[i].stop.converged else Status.FAILED
        fits[i].reason = fits[i].message
        if fits[i].cost < before * (1 - BETTER_OPTIMUM):
            fits[i].warnings.append(
                f"{found[i][1]} found a better optimum ({cost_change(before, fits[i].cost)})")
    mark_edges(problem, cards[idx], z_found, fits, idx)
    summarize(problem, cards, fits)


def _boundaries(problem: Problem, cards: NDArray[np.int64], fits: list[CardState],
                options: JobOptions, depth: int, allow_restart: bool) -> None:
    """Stage 5: answers at a limit of the model; restarts next to a better reduced model."""
    todo = [i for i in range(cards.size) if not fits[i].done]
    if not todo:
        return
    reduced_options = JobOptions(method=options.method, solver=options.solver,
                                 newton=options.newton, plan=options.plan, multistart="auto",
                                 workers=options.workers, boundaries=True)

    def refit(sub: Problem, guess: Array, c_start: Array | None) -> FitBatch:
        return run_batch(sub, guess=guess, c_start=c_start, options=reduced_options,
                         depth=depth + 1)

    restarts = check_boundaries(problem, cards[todo], [fits[i] for i in todo], options, refit)
    # Cards moved to a limit have a new point: their quality figures follow it.
    moved = [i for i in todo if fits[i].limits]
    if moved:
        summarize(problem, cards[moved], [fits[i] for i in moved])
    if not (restarts and allow_restart):
        return
    again_cards = np.array(sorted(restarts), dtype=np.int64)
    again = run(problem, again_cards, guess=np.array([restarts[int(k)] for k in again_cards]),
                options=dataclasses.replace(options, multistart=False), depth=depth,
                allow_restart=False)
    position = {int(k): i for i, k in enumerate(cards)}
    for j, k in enumerate(again_cards):
        i = position[int(k)]
        a = again[j]
        if math.isfinite(a.cost) and a.cost < fits[i].cost:
            a.warnings.append(
                "restarted next to a limiting model that fitted better than the first "
                f"solution (cost {fits[i].cost:.6g} -> {a.cost:.6g})")
            a.start = fits[i].start
            a.done = True
            fits[i] = a


def run(problem: Problem, cards: NDArray[np.int64], *, guess: Array | None,
        c_start: Array | None = None, offset_start: Array | None = None,
        options: JobOptions, depth: int = 0, allow_restart: bool = True) -> list[CardState]:
    """The main job's stages 1-5 for the given cards of a problem.

    Parameters
    ----------
    problem : Problem
    cards : array of int
        The cards to fit.
    guess : array, shape (cards, p), optional
        Starting parameters per card (None: the automatic start).
    c_start, offset_start : array, optional
        Starting scale and (reported) offset per card (NaN: completed by least squares).
    options : JobOptions
    depth : int
        0 for the user's fit, 1 and more for reduced models fitted by the boundary tests.
    allow_restart : bool
        False inside a restart (no second guard, wider search or restart).

    Returns
    -------
    list of CardState
        One per card, in order.
    """
    cards = np.asarray(cards, dtype=np.int64)
    m = cards.size
    fits = [CardState(z=np.full(problem.q, math.nan)) for _ in range(m)]
    if m == 0:
        return fits
    auto = guess is None
    lm = options.method == "lm"
    if auto or (options.multistart is True and lm):
        z0 = _automatic_start(problem, cards, fits, guess, options)
    else:
        z0 = _given_start(problem, cards, guess, c_start, offset_start, options)
    _solve(problem, cards, fits, z0, options)
    # A reduced model's refit (depth > 0) starts from the user's fit's answer taken to the
    # limit, which the wider search has already placed: the guard's multistart and a wider
    # search of its own found nothing more on 130 public field cards and 200 synthetic ones
    # (the same answers and statuses) and took a tenth of a field card's time.
    top = depth == 0
    if not auto and options.multistart == "auto" and lm and allow_restart and top:
        _guard(problem, cards, fits, guess, options, depth)
    if options.multistart is not False and lm and allow_restart and top:
        _widen(problem, cards, fits, options)
    if options.boundaries:
        _boundaries(problem, cards, fits, options, depth, allow_restart)
    return fits


def cost_change(before: float, after: float) -> str:
    """``cost A -> B`` with enough digits that A and B differ in print, and the relative
    change (a claim of a better optimum must show one)."""
    digits = 6
    while digits < 17 and f"{before:.{digits}g}" == f"{after:.{digits}g}":
        digits += 1
    rel = (before - after) / before if before > 0 else math.nan
    said = f"cost {before:.{digits}g} -> {after:.{digits}g}"
    if not math.isfinite(rel):
        return said
    # In per cent from 1e-3 on: "lower by 1 of it" was 0.9988 rounded.
    share = f"{100 * rel:.3g} %" if rel >= 1e-3 else f"{rel:.2g}"
    return f"{said}, lower by {share} of it"


def compile_first(problem: Problem, k: int) -> bool:
    """On a fresh install (an empty compiled cache), the first fit's compiles on two cores.

    The simulating entry point is compiled in a second process (:mod:`pumpid.engine.aside`);
    meanwhile this one compiles the parts that need no simulation and that the job reaches
    only after it (the summary, the uncertainty's analysis, the wider search's harmonic
    ranking for card k's kind of arrays), then the start as the job goes on. True if the
    second process was started.
    """
    if not aside.start(problem.arrays):
        return False
    data, _model, settings = problem.arrays
    q = problem.q
    rows = np.random.default_rng(0).standard_normal((q + 1, 4 * q + 8))
    warm_ups = (
        lambda: drive.summary_rows(np.zeros(0, np.int64), q, np.empty(0),
                                   np.zeros(1, np.int64), np.zeros(0, np.bool_), data,
                                   settings),
        lambda: analyse_rows(rows, np.ones(q, np.bool_), -1, 1.0, True),
        lambda: compile_ranking(problem, k),
    )
    for warm_up in warm_ups:
        # Warm-ups only, on stand-in numbers: whatever goes wrong in one, the job compiles
        # what it needs as it goes and reports on the real numbers.
        with contextlib.suppress(Exception):
            warm_up()
    return True


def run_batch(problem: Problem, *, guess: Array | None, c_start: Array | None = None,
              offset_start: Array | None = None, options: JobOptions, depth: int = 0,
              units: Units | Sequence[Units] | None = None,
              warnings: Sequence[str] = ()) -> FitBatch:
    """The whole job over every valid card of a problem, as a :class:`FitBatch`.

    Stages 1-5 (:func:`run`), then (for the user's fit, ``depth`` 0) the diagnostics and
    each card's result through the determination and quality gates. ``units`` is shared or
    one per card; ``warnings`` are the option-level warnings every result carries.
    """
    valid = np.flatnonzero(problem.valid)
    if depth == 0 and valid.size:
        compile_first(problem, int(valid[0]))
    fits = run(problem, valid, guess=None if guess is None else np.asarray(guess)[valid],
               c_start=None if c_start is None else np.asarray(c_start)[valid],
               offset_start=None if offset_start is None else np.asarray(offset_start)[valid],
               options=options, depth=depth)
    per_card = (list(units) if units is not None and not isinstance(units, Units)
                else [units or Units()] * problem.n_cards)
    if depth == 0:
        # A reduced model's fit is summarised (parameters, quality, status): no diagnostics.
        diagnose(problem, valid, fits, per_card, workers=options.workers)
    results: list[FitResult | None] = [None] * problem.n_cards
    for j, k in enumerate(valid):
        res = build_result(problem, int(k), fits[j], options, per_card[int(k)], warnings)
        results[int(k)] = (quality_gate(determination_gate(res), options.min_r2)
                           if depth == 0 else res)
    return FitBatch(model_name=problem.model.__name__,
                    param_names=problem.model.param_names(), results=tuple(results),
                    invalid=problem.invalid)
