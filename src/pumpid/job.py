"""The main job: start, solve, boundaries and diagnostics for every card of a problem.

:func:`fit` (one card) and :func:`fit_many` (thousands) are the same job: a
:class:`~pumpid.engine.problem.Problem` with a card axis goes through the stages below, each
one a compiled pass over all the cards that need it (spread over threads), with Python
deciding between the stages on arrays:

1. the start: the automatic multistart (:mod:`pumpid.engine.start`), a user's guess, or a
   guess guarded by the multistart;
2. the solver (:class:`~pumpid.engine.solvers.LevenbergMarquardt`, or the paper's Newton);
3. for a user's guess, the guard: a fit that failed, explains less than 99 % of the data's
   variance or stays above the data's noise floor is redone with the multistart, and the
   better of the two is kept;
4. boundaries (:mod:`pumpid.inference.boundaries`): the push test and the nested test, whose
   reduced-model fits are this same job on the reduced model; a reduced model that fits
   clearly better sends the full fit back to a start next to it;
5. diagnostics (:mod:`pumpid.inference`): uncertainty, HAC intervals, whiteness and
   identifiability in words.

A card's answer does not depend on which other cards share its problem: every stage treats
each card on its own numbers, so ``fit_many`` and card-by-card fits agree exactly.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .engine import drive, kernel
from .engine.problem import CardData, Problem, build_problem
from .engine.solvers import LevenbergMarquardt, PaperNewton, SolverOutcome, Stop
from .engine.start import (
    StartPlan,
    WidePlan,
    complete,
    find_starts,
    search_wider,
    to_z,
    walk_valley,
)
from .engine.threads import default_workers
from .inference import boundaries as bnd
from .inference.boundaries import BoundaryInfo, Limiting, ReducedFit
from .inference.derived import derived_of
from .inference.echo import echo_of
from .inference.identifiability import findings_of, whiteness_warning
from .inference.serial import (
    calibrate_robust,
    robust_covariance,
    shown_errors,
    with_ar1_floor,
)
from .inference.uncertainty import Numbers, numbers, uncertainty_of
from .models import Model, model_class
from .result import FitBatch, FitResult, StartInfo, Status, Units

__all__ = ["fit", "fit_many", "run"]

Array = NDArray[np.float64]
Method = Literal["lm", "newton-fd"]
#: The likelihood-ratio test's 95 % point of chi^2 with one degree of freedom.
_LR_95 = 3.84


@dataclass
class _Card:
    """One card's answer while the job works on it (internal, mutable)."""

    z: Array
    cost: float = math.nan
    evaluations: int = 0
    accepted: int = 0
    stop: Stop = Stop.NOT_FINITE
    message: str = ""
    history: Array | None = None
    status: Status = Status.FAILED
    reason: str = ""
    warnings: list[str] = field(default_factory=list)
    start: StartInfo | None = None
    limits: tuple[Limiting, ...] = ()
    reduced: ReducedFit | None = None
    stopped_early: bool = False
    edges: dict[int, str] = field(default_factory=dict)
    findings: tuple[str, ...] = ()
    determined: dict[str, Any] = field(default_factory=dict)
    uncertainty: Any = None
    derived: Mapping[str, Any] = field(default_factory=dict)
    done: bool = False
    newton_history: list[dict[str, float]] | None = None
    rmse: float = math.nan
    r2: float = math.nan
    noise: float = math.nan
    norms: Array | None = None


#: The reason of a card the solver was not run on: no finite point to start from.
_NO_START = ("not fitted: the starting point is not a finite number (the record's values, "
             "the output scale or the initial state are beyond what floating point can "
             "compute from: check the units, the output scale and the initial state)")

#: The automatic start looks at no more than this many samples of a card: the first ones of
#: a longer record, every k-th sample of a longer periodic stroke. The start needs the
#: record's dynamics, which a few strokes carry; ranking a hundred candidates over every
#: sample of a long record made it 97 % of the fit (a million samples: about 4 minutes). The
#: solver then runs on the whole record from the start found.
START_SAMPLES = 20_000


#: The default quality gate: a fit that explains less than 95 % of its record's variance is
#: reported as ``poor-fit``. A card the model describes leaves noise and small model errors
#: (389 public real cards, Kelvin observing u: median R^2 0.99986, 1st percentile 0.960, 4
#: below 0.95); swapped columns, a wrong model or a broken record give far less (0.5-0.72 on
#: two public card sets read with position and load exchanged).
MIN_R2 = 0.95


@dataclass(frozen=True)
class JobOptions:
    """The options of the main job that are not part of the problem."""

    method: Method = "lm"
    solver: LevenbergMarquardt = field(default_factory=LevenbergMarquardt)
    newton: PaperNewton = field(default_factory=PaperNewton)
    plan: StartPlan = field(default_factory=StartPlan)
    #: The wider search for cards whose first answer does not explain the data (None: off).
    wide: WidePlan | None = field(default_factory=WidePlan)
    multistart: bool | Literal["auto"] = "auto"
    workers: int | None = 1
    history: bool = False
    boundaries: bool = True
    #: The quality gate: an answer whose R^2 is below this is ``poor-fit``.
    min_r2: float = MIN_R2


# --------------------------------------------------------------------------- stages
def _theta(problem: Problem, z: Array) -> Array:
    with np.errstate(over="ignore"):
        return problem.full_theta(np.exp(z[..., : problem.n_free]))


def _scale_offset(problem: Problem, z: Array) -> tuple[float, float]:
    p = problem.n_free
    j = p
    if problem.scale_fixed is None:
        scale = math.exp(z[j])
        j += 1
    else:
        scale = float(problem.scale_fixed)
    offset = float(z[j]) if problem.offset_fixed is None else float(problem.offset_fixed)
    return scale, offset


def _true_offset(problem: Problem, k: int, z: Array) -> float:
    """The reported offset of card k at solver point z (the solver's offset less the mean
    level of the load the engine took off, see :func:`pumpid.engine.problem.load_shift`)."""
    scale, offset = _scale_offset(problem, z)
    if problem.offset_fixed is not None or problem.shift_of(k) == 0.0:
        return offset
    return offset - float(problem.offset_gap(k, _theta(problem, z), scale))


def _gap_gradient(problem: Problem, k: int, z: Array) -> tuple[float, Array]:
    """The gap between the solver's and the reported offset at z, and its derivatives
    with respect to the free log-parameters (forward differences)."""
    p = problem.n_free
    scale = _scale_offset(problem, z)[0]
    step = 1e-6
    rows = np.repeat(z[None], p, axis=0)
    rows[np.arange(p), np.arange(p)] += step
    gap0 = float(problem.offset_gap(k, _theta(problem, z), scale))
    grads = (problem.offset_gap(k, _theta(problem, rows), scale) - gap0) / step
    return gap0, grads


def _numbers_for_true_offset(problem: Problem, k: int, z: Array, num: Numbers) -> Numbers:
    """The analysis with the offset coordinate turned into the reported offset.

    The reported offset is o' - g(theta, C) with g = C x static gain x load shift; in the
    analysis' scaled coordinates (log parameters, log C, offset / data range) that is a
    linear map that leaves every other coordinate alone, so only the offset's row and
    column of the covariances change (parameter errors and derived quantities do not).
    """
    if problem.offset_fixed is not None or problem.shift_of(k) == 0.0:
        return num
    names = problem.free_names
    off = len(names) - 1
    inner = list(num.inner)
    if off not in inner:
        return num
    p = problem.n_free
    gap0, grads = _gap_gradient(problem, k, z)
    span = float(num.scales[off])
    t_map = np.eye(len(inner))
    for a, coord in enumerate(inner):
        if coord < p:
            t_map[inner.index(off), a] = -grads[coord] / span
        elif coord != off:  # log C: the gap is proportional to C
            t_map[inner.index(off), a] = -gap0 / span
    qi = len(inner)
    cov = num.cov_scaled.copy()
    hac = num.hac_scaled.copy()
    cov[:qi, :qi] = t_map @ num.cov_scaled[:qi, :qi] @ t_map.T
    hac[:qi, :qi] = t_map @ num.hac_scaled[:qi, :qi] @ t_map.T
    values = num.values.copy()
    values[off] = values[off] - gap0
    return dataclasses.replace(num, values=values, cov_scaled=cov, hac_scaled=hac)


def _apply(card: _Card, out: SolverOutcome, j: int, problem: Problem) -> None:
    card.z = out.z[j].copy()
    card.cost = float(out.cost[j])
    card.evaluations += int(out.evaluations[j])
    card.accepted += int(out.accepted[j])
    card.stop = out.stops[j]
    card.message = out.messages[j]
    card.stopped_early = out.stops[j] is Stop.BUDGET
    card.edges = {}
    if out.history.size:
        card.history = out.history


def _mark_edges(problem: Problem, cards: NDArray[np.int64], z0: Array, fits: list[_Card],
                idx: Sequence[int]) -> None:
    """Record which log-parameters stopped on the edge of the search window."""
    lo, hi = problem.window(cards, z0)
    for j, i in enumerate(idx):
        z = fits[i].z
        if not np.all(np.isfinite(z)):
            continue
        fits[i].edges = {f: ("infinity" if z[f] >= hi[j, f] else "zero")
                         for f in range(problem.n_free)
                         if not lo[j, f] < z[f] < hi[j, f]}


def _summarize(problem: Problem, cards: NDArray[np.int64], fits: list[_Card]) -> None:
    """Quality, noise level and Jacobian column norms at each card's point (one pass)."""
    idx = [i for i in range(len(fits)) if np.all(np.isfinite(fits[i].z))]
    if not idx:
        return
    data, model, settings = problem.arrays
    stats, norms = drive.summary_items(np.ascontiguousarray(cards[idx], dtype=np.int64),
                                       np.ascontiguousarray([fits[i].z for i in idx]),
                                       data, model, settings)
    for j, i in enumerate(idx):
        card = fits[i]
        card.rmse, card.r2, card.noise = (float(v) for v in stats[j, 1:])
        card.norms = norms[j]


def _doubtful(problem: Problem, k: int, card: _Card) -> bool:
    """A fit that deserves a wider search: no finite answer, R^2 < 0.99, or an RMSE above
    twice the data's noise level (a wrong local minimum, or a model that misses part of the
    response, where other minima compete).

    The noise level is a robust estimate from second differences (white noise:
    var(diff2) = 6 sigma^2); smooth signal content only raises it, so a good fit is never
    called doubtful."""
    # A fit that ran out of evaluations in a flat valley may still explain the data: its
    # quality decides, not the stop.
    if not math.isfinite(card.cost) or card.stop is Stop.NOT_FINITE:
        return True
    if not math.isfinite(card.r2) or card.r2 < 0.99:
        return True
    d = problem.card(k)[2]
    return card.rmse > 2.0 * card.noise + 1e-9 * float(np.ptp(d))


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


def _fit_reduced(problem: Problem, items: list[tuple[int, Any]], fits: list[_Card],
                 position: Mapping[int, int], options: JobOptions,
                 depth: int) -> dict[tuple[int, str, str], tuple[FitBatch, int]]:
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
            params = dict(zip(problem.model.param_names(), _theta(problem, card.z), strict=True))
            start, gain = lim.reduced_start(params)
            starts.append(start)
            gains.append(gain)
            scales.append(_scale_offset(problem, card.z)[0])
        sub, scale = _reduced_problem(problem, cards, lim, np.array(gains))
        names = sub.model.param_names()
        guess = np.array([[s[n] for n in names] for s in starts])
        bad = ~np.all(np.isfinite(guess) & (guess > 0), axis=1)
        guess[bad] = 1.0
        c_start = None
        if scale == "free" and sub.scale_fixed is None:
            c_start = np.array(gains) * np.array(scales)
        batch = _run_batch(sub, guess=guess, c_start=c_start,
                           options=JobOptions(method=options.method, solver=options.solver,
                                              newton=options.newton, plan=options.plan,
                                              multistart="auto", workers=options.workers,
                                              boundaries=True),
                           depth=depth + 1)
        for j, (k, lim_k) in enumerate(members):
            if not bad[j]:
                out[(k, lim_k.param, lim_k.direction)] = (batch, j)
    return out


def _summary_of(res: FitResult) -> ReducedFit:
    return ReducedFit(model=res.model_name, params=dict(res.params), units=res.param_units(),
                      scale=res.scale, offset=res.offset, rmse=res.rmse, r2=res.r2,
                      status=res.status.key, reason=res.reason)


def _check_boundaries(problem: Problem, cards: NDArray[np.int64], fits: list[_Card],
                      options: JobOptions, depth: int) -> dict[int, Array]:
    """Mark boundary solutions; return restart points for cards a reduced model beats."""
    idx = [i for i, k in enumerate(cards)
           if np.all(np.isfinite(fits[i].z)) and math.isfinite(fits[i].cost)]
    if not idx or problem.fixed:
        return {}
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
        if isinstance(problem.initial_states[k], str):
            lims = bnd.nested_candidates(problem, k, fits[i].z, log_sens[j], fits[i].edges,
                                         fits[i].stopped_early)
        cand.append(lims)
        items.extend((k, lim) for lim in lims)
    reduced = _fit_reduced(problem, items, fits, position, options, depth) if items else {}
    restarts: dict[int, Array] = {}
    for j, i in enumerate(idx):
        k = int(cards[i])
        card = fits[i]
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
            if red is None or not math.isfinite(red.cost):
                continue
            excess = 2.0 * (red.cost - card.cost)
            if excess < -_LR_95 * sigma2 - 1e-12 * sst and lim.from_reduced:
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
            if excess <= _LR_95 * sigma2 + 1e-12 * sst:
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
        _to_the_limit(problem, k, card, found[j], options)
        found[j] = _at_final_values(problem, card, found[j])
        card.status = Status.BOUNDARY
        names = ", ".join(b.name for b in found[j])
        card.reason = (f"{card.reason}; {names} ran to a bound: the solution is a limiting "
                       "model, not an interior optimum")
        card.warnings.extend(b.describe() for b in found[j])
        card.limits = tuple(found[j])
        if best_red is None and isinstance(problem.initial_states[k], str):
            target = next((problem.model.limit(b.name, b.direction) for b in found[j]
                           if problem.model.limit(b.name, b.direction).reduced), None)
            if target is not None:
                got = _fit_reduced(problem, [(k, target)], fits, position, options,
                                   depth).get((k, target.param, target.direction))
                red = got[0].results[got[1]] if got else None
                if red is not None:
                    best_red = (red.cost, red, target)
        if best_red is not None:
            red, lim = best_red[1], best_red[2]
            card.reduced = _summary_of(red)
            card.warnings.append(
                f"reduced model {red.model_name} ({lim.description.split(':')[0]}) fitted: "
                f"R^2 = {red.r2:.6g}, RMSE = {red.rmse:.4g} {{position}}")
    return restarts


def _limit_reaches(problem: Problem, k: int, card: _Card, lim: Any, target: float,
                   options: JobOptions) -> bool:
    """Move card k to the limit ``lim`` (parameter at the window's edge, the others refitted);
    True, with the card moved there, when that reaches the reduced model's cost ``target``."""
    trial = _Card(z=card.z.copy(), cost=card.cost)
    _to_the_limit(problem, k, trial, [Limiting(lim.param, lim.direction, math.nan,
                                               lim.description, "nested")], options)
    if not trial.cost <= target * (1 + 1e-6) + 1e-300:
        return False
    card.evaluations += trial.evaluations
    card.accepted += trial.accepted
    card.z, card.cost = trial.z, trial.cost
    return True


def _to_the_limit(problem: Problem, k: int, card: _Card, limits: Sequence[Limiting],
                  options: JobOptions) -> None:
    """Move parameters found at a boundary to the edge of the search window (the limit as
    far as the window reaches) and refit the others there; kept when it fits better.

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


def _at_final_values(problem: Problem, card: _Card, limits: list[Limiting]) -> list[Limiting]:
    """The limits with the values the card ends at, not those where they were found: the
    move to the window's edge changes them (6.4e8 said, 1.7e9 reported), and the words must
    quote the reported value."""
    free = [problem.model.param_names()[i] for i in problem.free_idx]
    return [dataclasses.replace(b, value=float(np.exp(min(card.z[free.index(b.name)], 709.0))))
            if b.name in free else b for b in limits]


def _diagnose(problem: Problem, cards: NDArray[np.int64], fits: list[_Card],
              units: Sequence[Units]) -> None:
    """Identifiability, uncertainty and whiteness of every fitted card (``units`` per card
    of the problem)."""
    idx = [i for i in range(len(fits)) if np.all(np.isfinite(fits[i].z))
           and math.isfinite(fits[i].cost)]
    model_names = problem.model.param_names()
    for i in range(len(fits)):
        if i not in idx:
            f = findings_of(None, model_names=model_names, gauge_fixed=problem.gauge_fixed,
                            initial_state=problem.initial_states[int(cards[i])],
                            residual=problem.residual)
            fits[i].findings, fits[i].determined = f.sentences, f.determined
    if not idx:
        return
    names = problem.free_names
    inner = np.ones((len(idx), len(names)), dtype=bool)
    for j, i in enumerate(idx):
        for b in fits[i].limits:
            if b.name in names:
                inner[j, names.index(b.name)] = False
    nums = numbers(problem, cards[idx], np.array([fits[i].z for i in idx]), inner)
    data, model_code, settings = problem.arrays
    for j, i in enumerate(idx):
        card = fits[i]
        k = int(cards[i])
        num, calibration = calibrate_robust(nums[j])
        serial = not num.exact and not (num.rho <= 2.576 / math.sqrt(max(num.n, 1)))
        if serial:
            rows = np.empty((problem.q + 1, problem.n_samples(k)))
            if drive.rows_at(card.z, k, data, model_code, settings, rows):
                num, calibration["ar1"] = with_ar1_floor(
                    num, rows, problem.q - 1 if problem.offset_fixed is None else -1)
        num = _numbers_for_true_offset(problem, k, card.z, num)
        unit = ("(ln of position)^2, dimensionless" if problem.residual == "log"
                else f"{units[k].position}^2")
        f = findings_of(num, model_names=model_names, gauge_fixed=problem.gauge_fixed,
                        initial_state=problem.initial_states[int(cards[i])],
                        residual=problem.residual,
                        boundaries=[(b.name, b.direction, b.limit) for b in card.limits],
                        serial=serial)
        card.findings, card.determined = f.sentences, f.determined
        unc = uncertainty_of(num, f.undetermined, [names.index(b.name) for b in card.limits
                                                   if b.name in names], f.notes, unit)
        unc = shown_errors(unc, serial, robust_covariance(num, f.undetermined), calibration)
        card.uncertainty = unc
        if problem.model.input_map is None:
            z = card.z
            scale = _scale_offset(problem, z)[0]
            card.derived = derived_of(
                problem.model, _theta(problem, z), observe=problem.observe, scale=scale,
                nums=num, units=(units[int(cards[i])].load, units[int(cards[i])].position),
                serial=serial, limits=[(b.name, b.direction) for b in card.limits])
            _offset_gauge(problem, int(cards[i]), card, units[int(cards[i])])
            period = (float(problem.period[int(cards[i])])
                      if problem.initial_states[int(cards[i])] == "periodic" else None)
            card.derived, echo = echo_of(card.derived, period)
            if echo is not None:
                card.warnings.append(echo)
                card.determined["not_well_property"] = [
                    n for n, d in card.derived.items() if not d.well_property]
        if unc is not None and unc.whiteness is not None and not unc.whiteness["white"]:
            card.warnings.append(whiteness_warning(dict(unc.whiteness), num.n, len(names),
                                                   unc.shown == "robust"))


def _offset_gauge(problem: Problem, k: int, card: _Card, units: Units) -> None:
    """The offset a periodic card fixes, and the one it does not.

    A periodic card's mean position is the offset plus the mean load over the static
    stiffness: the data fix that sum (the position at the card's mean load, the solver's
    own offset coordinate), not its parts. Where the static stiffness is not determined,
    the reported offset (the position at zero load) is not either (on real cards k1 and
    the offset correlate 1.000); the combination is reported as determined instead.
    """
    stiff = card.derived.get("static_stiffness")
    if (problem.offset_fixed is not None or problem.shift_of(k) == 0.0 or stiff is None
            or "offset" not in card.determined.get("parameters", [])):
        return
    level = _scale_offset(problem, card.z)[1]
    card.determined.setdefault("combinations", []).append(
        f"the position at the card's mean load, offset + mean load / static stiffness = "
        f"{level:.6g} {units.position}")
    card.determined["offset_at_mean_load"] = level
    if stiff.determined:
        return
    card.determined["parameters"].remove("offset")
    card.determined["not_determined"].append("offset")
    card.findings = (*card.findings,
                     "The offset (the position at zero load) is not determined: the card "
                     "fixes only the position at its mean load, offset + mean load / static "
                     f"stiffness = {level:.6g} {units.position}, and the static stiffness "
                     "is not determined, so the offset trades off with it.")


def _start_problem(problem: Problem, cards: NDArray[np.int64]) -> Problem | None:
    """The problem the automatic start works on: the given cards with every card longer
    than :data:`START_SAMPLES` cut to that many samples (its first ones; every k-th sample of
    a periodic stroke, which must stay one period), in the given order. None when no card
    is that long (the start then works on the problem itself).

    The parameters, scale and offset mean the same in both problems (the cards keep their
    initial state, period and load shift), so a start found here starts the whole record.
    """
    lengths = np.diff(problem.bounds)[cards]
    if not np.any(lengths > START_SAMPLES):
        return None
    ts, fs, ds = [], [], []
    for k in cards:
        t, f, d = problem.card(int(k))
        if t.size > START_SAMPLES:
            if problem.mode[k] == kernel.PERIODIC:
                pick = slice(None, None, -(-t.size // START_SAMPLES))
            else:
                pick = slice(0, START_SAMPLES)
            t, f, d = t[pick], f[pick], d[pick]
        ts.append(t)
        fs.append(f)
        ds.append(d)
    bounds = np.zeros(cards.size + 1, dtype=np.int64)
    bounds[1:] = np.cumsum([t.size for t in ts])

    def frozen(a: np.ndarray) -> np.ndarray:
        a = np.array(a)
        a.flags.writeable = False
        return a

    shift = None if problem.load_shift is None else frozen(problem.load_shift[cards])
    return dataclasses.replace(
        problem, t=frozen(np.concatenate(ts)), load=frozen(np.concatenate(fs)),
        data=frozen(np.concatenate(ds)), bounds=frozen(bounds), mode=frozen(problem.mode[cards]),
        x0=frozen(problem.x0[cards]), period=frozen(problem.period[cards]),
        uniform=frozen(problem.uniform[cards]),
        initial_states=tuple(problem.initial_states[int(k)] for k in cards),
        valid=frozen(problem.valid[cards]),
        invalid=tuple(problem.invalid[int(k)] for k in cards), load_shift=shift)


# --------------------------------------------------------------------------- the job
def run(problem: Problem, cards: NDArray[np.int64], *, guess: Array | None,
        c_start: Array | None = None, offset_start: Array | None = None,
        options: JobOptions, depth: int = 0, allow_restart: bool = True) -> list[_Card]:
    """The main job for the given cards of a problem; one :class:`_Card` per card."""
    cards = np.asarray(cards, dtype=np.int64)
    m = cards.size
    q = problem.q
    fits = [_Card(z=np.full(q, math.nan)) for _ in range(m)]
    if m == 0:
        return fits
    workers = options.workers
    solver = options.solver
    auto = guess is None
    guarded = not auto and options.multistart is True and options.method == "lm"
    if auto or guarded:
        # Long cards start from a shorter copy of themselves (same coordinates).
        at = _start_problem(problem, cards)
        start_problem, start_cards = ((problem, cards) if at is None
                                      else (at, np.arange(m, dtype=np.int64)))
        starts = find_starts(start_problem, start_cards, guess=None if auto else guess,
                             plan=options.plan, workers=workers)
        z0 = starts.z.copy()
        for i in range(m):
            kind = "automatic start"
            if guarded:
                kind = ("start: the given guess, checked against the automatic start"
                        if starts.from_guess[i] else
                        "start: automatic (it reached a lower cost than the given guess)")
            walked = ""
            if starts.stopped_early[i] and np.all(np.isfinite(z0[i])):
                zw, cw = walk_valley(start_problem, int(start_cards[i]), z0[i],
                                     float(starts.cost[i]))
                if cw < starts.cost[i]:
                    z0[i] = zw
                    walked = ", then walked along a flat valley"
            part = ""
            used = start_problem.n_samples(int(start_cards[i]))
            if used < problem.n_samples(int(cards[i])):
                part = (f" on {used} of the card's {problem.n_samples(int(cards[i]))} "
                        "samples")
            fits[i].start = StartInfo(
                f"{kind}: equation-error and grid estimates ({int(starts.n_candidates[i])} "
                f"candidates){part}, best {int(starts.n_polished[i])} polished{walked}",
                int(starts.n_candidates[i]), int(starts.n_polished[i]))
    else:
        z0, _c = complete(problem, cards, np.asarray(guess, dtype=float), rescale=False,
                          workers=workers)
        p = problem.n_free
        j = p
        if problem.scale_fixed is None:
            if c_start is not None:
                given = np.isfinite(c_start)
                z0[given, j] = np.log(c_start[given])
            j += 1
        if problem.offset_fixed is None and offset_start is not None:
            # The user's offset is the reported one; the solver's exceeds it by the gap.
            for i in np.flatnonzero(np.isfinite(offset_start)):
                k = int(cards[i])
                gap = problem.offset_gap(k, _theta(problem, z0[i]),
                                         _scale_offset(problem, z0[i])[0])
                z0[i, j] = offset_start[i] + float(gap)
        z0[~np.all(np.isfinite(z0), axis=1)] = to_z(
            problem, np.asarray(guess, dtype=float))[~np.all(np.isfinite(z0), axis=1)]
        z0 = np.where(np.isfinite(z0), z0, 0.0)

    # 2. The solver.
    if options.method == "newton-fd":
        for i in range(m):
            k = int(cards[i])
            theta0 = _theta(problem, z0[i])
            scale0, offset0 = _scale_offset(problem, z0[i])
            out, hist = options.newton.solve(problem, k, theta0, scale0, offset0)
            _apply(fits[i], out, 0, problem)
            fits[i].newton_history = hist
    else:
        ok = np.all(np.isfinite(z0), axis=1)
        run_idx = np.flatnonzero(ok)
        if run_idx.size:
            out = solver.solve(problem, cards[run_idx], z0[run_idx],
                               history=options.history and m == 1, workers=workers)
            for j, i in enumerate(run_idx):
                _apply(fits[i], out, j, problem)
            _mark_edges(problem, cards[run_idx], z0[run_idx], fits, list(run_idx))
        for i in np.flatnonzero(~ok):
            # Not run: without this the row would say failed and nothing else.
            fits[i].message = _NO_START
    for card in fits:
        card.status = Status.CONVERGED if card.stop.converged else Status.FAILED
        card.reason = card.message
    _summarize(problem, cards, fits)

    # 3. The guard around a user's guess.
    if (not auto and options.multistart == "auto" and options.method == "lm"
            and allow_restart):
        doubtful = [i for i in range(m) if _doubtful(problem, int(cards[i]), fits[i])]
        if doubtful:
            guarded_fits = run(problem, cards[doubtful],
                               guess=np.asarray(guess, dtype=float)[doubtful],
                               options=_with(options, multistart=True), depth=depth)
            for j, i in enumerate(doubtful):
                g = guarded_fits[j]
                first = fits[i]
                if math.isfinite(g.cost) and not (g.cost >= first.cost):
                    g.warnings.append(
                        "the fit from the given guess looked wrong (status "
                        f"{first.status.key}, R^2 = {first.r2:.4g}); the automatic multistart "
                        "found "
                        f"a better solution (cost {first.cost:.6g} -> {g.cost:.6g})")
                    g.evaluations += first.evaluations
                    g.done = True
                    fits[i] = g

    # 4. A wider search where the answer does not explain the data (a wrong basin, or a
    # model that misses part of the response: then other basins compete).
    if (options.wide is not None and options.method == "lm" and options.multistart is not False
            and allow_restart):
        hard = [i for i in range(m) if not fits[i].done
                and np.all(np.isfinite(fits[i].z))
                and _doubtful(problem, int(cards[i]), fits[i])]
        if hard:
            z_now = np.array([fits[i].z for i in hard])
            c_now = np.array([fits[i].cost for i in hard])
            at = _start_problem(problem, cards[hard])
            if at is None:
                z_wide, c_wide, counts = search_wider(
                    problem, cards[hard], z_now, c_now, plan=options.wide, solver=solver,
                    workers=workers)
            else:
                # Long cards search on their shorter copy, like the start; the whole
                # record's cost then judges the point found.
                local = np.arange(len(hard), dtype=np.int64)
                z_wide, _c, counts = search_wider(
                    at, local, z_now, drive.cost_items(local, z_now, *at.arrays),
                    plan=options.wide, solver=solver, workers=workers)
                c_wide = drive.cost_items(cards[hard], z_wide, *problem.arrays)
            better = [j for j, i in enumerate(hard)
                      if c_wide[j] < fits[i].cost * (1 - 1e-12)]
            if better:
                # The improved points are converged already: one more solver run from each
                # gives them their stop test and history.
                idx = [hard[j] for j in better]
                again = solver.solve(problem, cards[idx], z_wide[better],
                                     history=options.history and m == 1, workers=workers)
                for j, i in enumerate(idx):
                    before = fits[i].cost
                    evals = fits[i].evaluations
                    fits[i].evaluations = 0
                    fits[i].accepted = 0
                    _apply(fits[i], again, j, problem)
                    fits[i].evaluations += evals
                    fits[i].status = (Status.CONVERGED if fits[i].stop.converged
                                      else Status.FAILED)
                    fits[i].reason = fits[i].message
                    fits[i].warnings.append(
                        f"the first answer did not explain the data; a wider search "
                        f"({int(counts[better[j]])} more starts) found a better optimum "
                        f"({_cost_change(before, fits[i].cost)})")
                _mark_edges(problem, cards[idx], z_wide[better], fits, idx)
                _summarize(problem, cards, fits)

    # 5. Boundaries.
    todo = [i for i in range(m) if not fits[i].done]
    if options.boundaries and todo:
        restarts = _check_boundaries(problem, cards[todo], [fits[i] for i in todo], options,
                                     depth)
        # Cards moved to a limit have a new point: their quality figures follow it.
        moved = [i for i in todo if fits[i].limits]
        if moved:
            _summarize(problem, cards[moved], [fits[i] for i in moved])
        if restarts and allow_restart:
            again_cards = np.array(sorted(restarts), dtype=np.int64)
            again = run(problem, again_cards,
                        guess=np.array([restarts[int(k)] for k in again_cards]),
                        options=_with(options, multistart=False), depth=depth,
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
    return fits


def _cost_change(before: float, after: float) -> str:
    """``cost A -> B`` with enough digits that A and B differ in print, and the relative
    change (a claim of a better optimum must show one)."""
    digits = 6
    while digits < 17 and f"{before:.{digits}g}" == f"{after:.{digits}g}":
        digits += 1
    rel = (before - after) / before if before > 0 else math.nan
    return (f"cost {before:.{digits}g} -> {after:.{digits}g}, lower by {rel:.2g} of it"
            if math.isfinite(rel) else f"cost {before:.{digits}g} -> {after:.{digits}g}")


def _with(options: JobOptions, **changes: Any) -> JobOptions:
    from dataclasses import replace

    return replace(options, **changes)


def _run_batch(problem: Problem, *, guess: Array | None, c_start: Array | None = None,
               offset_start: Array | None = None, options: JobOptions, depth: int = 0,
               units: Units | Sequence[Units] | None = None,
               warnings: Sequence[str] = ()) -> FitBatch:
    """The job over every valid card of a problem, as a :class:`FitBatch`."""
    valid = np.flatnonzero(problem.valid)
    fits = run(problem, valid, guess=None if guess is None else np.asarray(guess)[valid],
               c_start=None if c_start is None else np.asarray(c_start)[valid],
               offset_start=None if offset_start is None else np.asarray(offset_start)[valid],
               options=options, depth=depth)
    per_card = (list(units) if units is not None and not isinstance(units, Units)
                else [units or Units()] * problem.n_cards)
    if depth == 0:
        # A reduced model's fit is summarised (parameters, quality, status): no diagnostics.
        _diagnose(problem, valid, fits, per_card)
    results: list[FitResult | None] = [None] * problem.n_cards
    for j, k in enumerate(valid):
        res = build_result(problem, int(k), fits[j], options, per_card[int(k)], warnings)
        results[int(k)] = (_quality_gate(_determination_gate(res), options.min_r2)
                           if depth == 0 else res)
    return FitBatch(model_name=problem.model.__name__,
                    param_names=problem.model.param_names(), results=tuple(results),
                    invalid=problem.invalid)


def _determination_gate(res: FitResult) -> FitResult:
    """``undetermined`` for an answer (converged or at a boundary) that determines none of
    the model's parameters: a converged optimum of numbers the data do not fix is not an
    answer (on real cards: m in the millions, damping ratios of 1e-5)."""
    if res.status not in (Status.CONVERGED, Status.BOUNDARY) or res.uncertainty is None:
        return res
    if any(n in res.params for n in res.determined.get("parameters", ())):
        return res
    good = [d.name for d in res.derived.values() if d.determined]
    said = ("no parameter of the model is determined by these data (each ran to a limit, "
            "is structurally free or has an error over 100 % of its value): the fitted "
            "values are one of many that fit as well"
            + (f"; determined derived quantities: {', '.join(good)}" if good else ""))
    return dataclasses.replace(res, status=Status.UNDETERMINED,
                               reason=f"{said} (the solver's own verdict: {res.status.key}: "
                                      f"{res.reason})",
                               warnings=(*res.warnings, said))


def _quality_gate(res: FitResult, min_r2: float) -> FitResult:
    """``poor-fit`` for an answer (converged, at a boundary or undetermined) below the R^2
    threshold."""
    if res.status not in (Status.CONVERGED, Status.BOUNDARY, Status.UNDETERMINED):
        return res
    if math.isfinite(res.r2) and res.r2 >= min_r2:
        return res
    shown = f"{res.r2:.4g}" if math.isfinite(res.r2) else "not defined"
    said = (f"poor fit: R^2 = {shown} is below the quality threshold {min_r2:g} (min_r2); "
            f"the model does not reproduce this record: check the column roles and units, "
            f"the model structure, or the record itself before using these numbers")
    return dataclasses.replace(res, status=Status.POOR_FIT,
                               reason=f"{said} (the solver's own verdict: {res.status.key}: "
                                      f"{res.reason})",
                               warnings=(*res.warnings, said))


def build_result(problem: Problem, k: int, card: _Card, options: JobOptions, units: Units,
                 warnings: Sequence[str] = ()) -> FitResult:
    """One card's :class:`FitResult` from the job's answer."""
    cls = problem.model
    t, f, d = problem.card(k)
    model: Model | None = None
    status, reason = card.status, card.reason
    z = card.z
    if np.all(np.isfinite(z)):
        theta = _theta(problem, z)
        try:
            model = cls.from_values(theta)
        except ValueError as exc:
            status = Status.FAILED
            reason = f"{reason}; final parameters invalid: {exc}"
    rmse, r2 = card.rmse, card.r2
    jac = None
    if model is not None:
        scale = _scale_offset(problem, z)[0]
        offset = _true_offset(problem, k, z)
        fitted, jac = _at_optimum(problem, k, z)
        if jac is not None and problem.offset_fixed is None and problem.shift_of(k) != 0.0:
            # In the reported coordinates each parameter also moves the offset's meaning.
            gap0, grads = _gap_gradient(problem, k, z)
            p = problem.n_free
            jac[:, :p] += grads / np.exp(z[:p])
            if problem.scale_fixed is None:
                jac[:, p] += gap0 / scale
        if not np.all(np.isfinite(fitted)):
            status = Status.FAILED
            reason = f"{reason}; the fitted response is not finite"
    else:
        fitted = np.full_like(d, np.nan)
        scale = offset = math.nan
        if status is not Status.FAILED:
            status = Status.FAILED
        reason = reason or "the fit gave no finite parameters"
    params = model.as_dict() if model is not None else dict.fromkeys(cls.param_names(),
                                                                      math.nan)
    history = _history(problem, card, k)
    text = tuple(w.replace("{position}", units.position) for w in (*warnings, *card.warnings))
    reduced = card.reduced
    if reduced is not None:
        # The reduced model was fitted inside the job, which knows no units: its parameters'
        # units come from this card's, as the full model's do.
        info = model_class(reduced.model).param_info()
        reduced = dataclasses.replace(reduced, units={
            p.name: p.unit_for(units.load, units.position) for p in info})
    boundary = (BoundaryInfo(card.limits, reduced) if card.limits else None)
    state = problem.initial_states[k]
    return FitResult(
        model=model, model_name=cls.__name__, status=status, reason=reason, params=params,
        scale=scale, offset=offset, iterations=card.accepted, nfev=card.evaluations,
        history=history, rmse=rmse, r2=r2, cost=card.cost if model is not None else math.nan,
        warnings=text, method=options.method, integrator=problem.integrator,
        residual=problem.residual, observe=problem.observe, initial_state=state,
        units=units, free=problem.free_names, t=t, load=f, data=d, fitted=fitted,
        jacobian=jac, uncertainty=card.uncertainty, identifiability=card.findings,
        determined=card.determined, derived=card.derived, boundary=boundary,
        start=card.start,
        gauge="C = 1" if problem.gauge_fixed else None, problem=problem,
        options={"method": options.method, "card": k, "solver": options.solver,
                 "newton": options.newton, "units": units},
    )


def _at_optimum(problem: Problem, k: int, z: Array) -> tuple[Array, Array | None]:
    """The fitted displacement and d(residual)/d(free values) in physical coordinates
    (theta, C or D, offset), from one evaluation."""
    data, model, settings = problem.arrays
    q = problem.q
    d = problem.card(k)[2]
    rows = np.empty((q + 1, problem.n_samples(k)))
    if not drive.rows_at(z, k, data, model, settings, rows):
        y, _ok = drive.outputs(np.array([k], dtype=np.int64), np.ascontiguousarray(z[None]),
                              data, model, settings, d.size)
        scale, offset = _scale_offset(problem, z)
        return scale * y + offset, None
    fitted = d * np.exp(rows[q]) if problem.residual == "log" else rows[q] + d
    jac = rows[:q].T.copy()
    p = problem.n_free
    jac[:, :p] /= np.exp(z[:p])
    if problem.scale_fixed is None and problem.residual == "linear":
        jac[:, p] /= math.exp(z[p])
    return fitted, jac


def _history(problem: Problem, card: _Card, k: int) -> tuple[Mapping[str, float], ...]:
    if card.newton_history is not None:
        return tuple(card.newton_history)
    if card.history is None or card.history.size == 0:
        return ()
    # All rows at once: parameters, scale, offset, cost as columns, then one dict per row.
    h = card.history
    p = problem.n_free
    columns: dict[str, Array] = {"iteration": np.arange(h.shape[0], dtype=float)}
    with np.errstate(over="ignore"):
        theta = problem.full_theta(np.exp(h[:, :p]))
    for i, name in enumerate(problem.model.param_names()):
        columns[name] = theta[:, i]
    j = p
    if problem.scale_fixed is None:
        columns["D" if problem.residual == "log" else "C"] = (
            h[:, j] if problem.residual == "log" else np.exp(h[:, j]))
        j += 1
    if problem.offset_fixed is None:
        scale = (np.exp(h[:, p]) if problem.scale_fixed is None
                 else np.full(h.shape[0], float(problem.scale_fixed)))
        columns["offset"] = h[:, j] - problem.offset_gap(k, theta, scale)
    columns["cost"] = h[:, -1]
    keys = list(columns)
    values = np.column_stack([columns[k] for k in keys]).tolist()
    return tuple(dict(zip(keys, row, strict=True)) for row in values)


# --------------------------------------------------------------------------- public API
def _x0_number(value: Any, name: str) -> float:
    """One starting value as a float; a ValueError naming x0 and the entry otherwise."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"x0: {name} = {value!r} is not a number") from None


def _x0_array(x0: Any) -> Array:
    """The starting values as a float array; a ValueError naming x0 otherwise."""
    try:
        return np.asarray(x0, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"x0: {x0!r} is not a number, a sequence of numbers, a mapping of "
                         "parameter names to numbers nor a model") from None


def _start_theta(model: Model | type[Model], x0: Mapping[str, float] | Model | ArrayLike | None
                 ) -> tuple[type[Model], Array | None, dict[str, float]]:
    """Model class, starting parameters (None: automatic) and extra start values (C, offset)."""
    extras: dict[str, float] = {}
    if isinstance(model, Model):
        cls: type[Model] = type(model)
        theta: Array | None = model.values
    elif isinstance(model, type) and issubclass(model, Model):
        cls, theta = model, None
    else:
        raise TypeError(
            "model must be a model instance (a starting guess, e.g. Kelvin(k0=4, m=1, c1=0.2, "
            f"k1=4)) or a model class (automatic start), got {model!r}")
    if x0 is None:
        return cls, theta, extras
    if isinstance(x0, Model):
        if type(x0) is not cls:
            raise TypeError(f"x0 is a {type(x0).__name__}, the model a {cls.__name__}")
        return cls, x0.values, extras
    if isinstance(x0, Mapping):
        names = cls.param_names()
        unknown = set(x0) - set(names) - {"C", "D", "offset"}
        if unknown:
            raise ValueError(f"x0: unknown names {sorted(unknown)}; parameters are {names}")
        values = []
        for i, name in enumerate(names):
            if name in x0:
                values.append(_x0_number(x0[name], name))
            elif theta is not None:
                values.append(float(theta[i]))
            else:
                raise ValueError(f"x0: missing {name!r} (give all of {names} or a model)")
        for key in ("C", "D", "offset"):
            if key in x0:
                extras[key] = _x0_number(x0[key], key)
        return cls, np.array(values), extras
    arr = _x0_array(x0).ravel()
    return cls, cls.from_values(arr).values, extras


def fit(
    model: Model | type[Model],
    t: ArrayLike,
    load: ArrayLike,
    displacement: ArrayLike,
    *,
    method: Method = "lm",
    integrator: str = "exact",
    scale: float | str = 1.0,
    residual: str = "linear",
    x0: Mapping[str, float] | Model | ArrayLike | None = None,
    observe: str | None = None,
    initial_state: Any = "rest",
    offset: bool | float = False,
    period: float | None = None,
    fixed: Mapping[str, float] | None = None,
    units: Units | None = None,
    solver: LevenbergMarquardt | PaperNewton | None = None,
    multistart: bool | Literal["auto"] = "auto",
    tol: float | None = None,
    max_nfev: int | None = None,
    eps0: float | None = None,
    max_iter: int | None = None,
    rel_step: float | None = None,
    min_r2: float | None = None,
) -> FitResult:
    """Identify a model's parameters from a load record and the measured displacement.

    Parameters
    ----------
    model : Model instance or Model class
        An instance is the starting guess (e.g. ``Kelvin(k0=4, m=1, c1=0.2, k1=4)``); a class
        asks for the automatic start.
    t, load, displacement : array_like, shape (N,)
        Time (s, strictly increasing, N >= 10), the input (load) and the measured output
        (displacement) in the user's units.
    method : {"lm", "newton-fd"}
        ``lm``: exact sensitivities, log-parameters, Levenberg-Marquardt. ``newton-fd``:
        the paper's Newton-Raphson with central differences.
    integrator : {"exact", "euler"}
        Forward model: exact first-order-hold discretization, or the paper's explicit Euler.
    scale : float or "free"
        The output scale factor C (fixed, default 1) or ``"free"``. For models with the scale
        symmetry started from a load-driven state a free C is not identifiable: the gauge
        C = 1 is fixed and a warning says so.
    residual : {"linear", "log"}
        ``linear``: C y + offset - data (eq. 14). ``log``: D + ln y - ln data (eq. 25).
    x0 : mapping, Model or array, optional
        Starting values (overrides the instance's); may include ``C``/``D`` and ``offset``.
    observe : str, optional
        Observed state (default: the model's).
    initial_state : {"rest", "equilibrium", "periodic"} or numbers
        See :func:`pumpid.simulate`.
    offset : bool or float
        Fit an additive position offset (True), or subtract a fixed one (float).
    period : float, optional
        Stroke period (s) for ``initial_state="periodic"``.
    fixed : mapping, optional
        Model parameters held at given values; the others are fitted.
    units : Units, optional
        Units of load and position, recorded in the result.
    solver : LevenbergMarquardt or PaperNewton, optional
        A configured solver (default: ``LevenbergMarquardt()``, or ``PaperNewton()`` for
        ``method="newton-fd"``).
    multistart : {"auto", True, False}
        Guard a user's guess against local minima with the automatic start's multistart:
        ``"auto"`` runs from the guess first and falls back to the multistart when that fit
        failed, explains less than 99 % of the data's variance, or stays above the data's
        noise level; ``True`` always, ``False`` never.
    tol, max_nfev, eps0, max_iter, rel_step
        Shorthands for the solver's settings (``LevenbergMarquardt(tol, max_nfev)``,
        ``PaperNewton(eps0, max_iter, rel_step)``).
    min_r2 : float, optional
        The quality gate (default :data:`MIN_R2`, 0.95): an answer whose R^2 is below it has
        status ``poor-fit``, the reason and a warning in words (its numbers are kept).

    Returns
    -------
    FitResult
        Never raises for a failed or divergent fit: its status is ``failed`` and ``reason``
        says why. Bad input raises ``ValueError`` naming the problem.
    """
    if method not in ("lm", "newton-fd"):
        raise ValueError(f"method must be 'lm' or 'newton-fd', got {method!r}")
    if multistart not in ("auto", True, False):
        raise ValueError(f"multistart must be 'auto', True or False, got {multistart!r}")
    cls, theta0, extras = _start_theta(model, x0)
    warnings: list[str] = []
    problem = build_problem(cls, [CardData(t, load, displacement, initial_state, period)],
                            observe=observe, integrator=integrator, residual=residual,
                            scale=scale, offset=offset, fixed=fixed, warnings=warnings)
    options = _options(method, solver, multistart, tol, max_nfev, eps0, max_iter, rel_step,
                       workers=1, history=True, min_r2=min_r2)
    guess = None
    c_start = off_start = None
    if theta0 is not None:
        theta0 = np.array(theta0, dtype=float)
        if problem.gauge_fixed and ("C" in extras or "D" in extras):
            # Keep the user's start on the same curve: move it onto the gauge C = 1.
            c = extras.pop("C", None) or math.exp(extras.pop("D", 0.0))
            theta0 = theta0 / c
        for i, value in problem.fixed:
            theta0[i] = value
        guess = theta0[None]
        if "C" in extras or "D" in extras:
            c_start = np.array([extras.get("C", math.exp(extras.get("D", 0.0)))])
        if "offset" in extras:
            off_start = np.array([extras["offset"]])
    batch = _run_batch(problem, guess=guess, c_start=c_start, offset_start=off_start,
                       options=options, units=units or Units(), warnings=warnings)
    return batch.result(0)


def _options(method: str, solver: Any, multistart: Any, tol: float | None,
             max_nfev: int | None, eps0: float | None, max_iter: int | None,
             rel_step: float | None, *, workers: int | None, history: bool,
             min_r2: float | None = None) -> JobOptions:
    lm_solver = solver if isinstance(solver, LevenbergMarquardt) else LevenbergMarquardt(
        tol=1e-12 if tol is None else tol, max_evaluations=max_nfev)
    newton = solver if isinstance(solver, PaperNewton) else PaperNewton(
        eps0=1e-10 if eps0 is None else eps0, max_iter=200 if max_iter is None else max_iter,
        rel_step=1e-3 if rel_step is None else rel_step)
    if solver is not None and not isinstance(solver, LevenbergMarquardt | PaperNewton):
        raise TypeError(f"solver must be LevenbergMarquardt or PaperNewton, got {solver!r}")
    if isinstance(solver, PaperNewton):
        method = "newton-fd"
    if min_r2 is None:
        min_r2 = MIN_R2
    if not (isinstance(min_r2, int | float) and min_r2 <= 1):
        raise ValueError(f"min_r2 must be a number at most 1, got {min_r2!r}")
    return JobOptions(method=method, solver=lm_solver, newton=newton,  # type: ignore[arg-type]
                      multistart=multistart, workers=workers, history=history,
                      min_r2=float(min_r2))


def fit_many(
    model: Model | type[Model],
    t: ArrayLike,
    loads: ArrayLike,
    displacements: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: Any = "rest",
    integrator: str = "exact",
    scale: float | str = 1.0,
    residual: str = "linear",
    offset: bool | float = False,
    period: float | None = None,
    fixed: Mapping[str, float] | None = None,
    x0: ArrayLike | None = None,
    units: Units | None = None,
    solver: LevenbergMarquardt | None = None,
    multistart: bool | Literal["auto"] = "auto",
    tol: float | None = None,
    max_nfev: int | None = None,
    workers: int | None = None,
    min_r2: float | None = None,
) -> FitBatch:
    """Fit one model structure to many cards: the main job of :func:`fit` for each.

    Parameters
    ----------
    model : Model instance or Model class
        An instance is the shared starting guess; a class asks for the automatic start.
    t : array_like, shape (N,) or (cards, N)
        Sample times (s) shared by all cards, or one row per card.
    loads, displacements : array_like, shape (cards, N)
        One card per row (a single 1-D record counts as one card).
    observe, initial_state, integrator, scale, residual, offset, period, fixed, units,
    solver, multistart, tol, max_nfev, min_r2
        As for :func:`fit`, applied to every card.
    x0 : array_like, shape (cards, p) or (p,), optional
        Starting parameters per card (or shared), canonical order; overrides the model's.
    workers : int, optional
        Threads (default: every core this process may use). Results do not depend on it.

    Returns
    -------
    FitBatch
        Each card's result, exactly what :func:`fit` returns for it alone. A card that fails
        validation (non-finite values, a constant record, ...) is a row with status
        ``invalid-input`` and the reason; it does not stop the others.
    """
    _batch_model(model)
    f_all = _rows("loads", loads)
    d_all = _rows("displacements", displacements)
    if len(f_all) != len(d_all):
        raise ValueError(f"loads has {len(f_all)} cards but displacements has {len(d_all)}")
    n_cards = len(f_all)
    if isinstance(t, list | tuple) and t and np.ndim(t[0]) == 1:
        t_rows = [np.asarray(row, dtype=float) for row in t]
        if len(t_rows) != n_cards:
            raise ValueError(f"t: {len(t_rows)} time rows for {n_cards} cards")
    else:
        t_arr = np.asarray(t, dtype=float)
        if t_arr.ndim == 1:
            t_rows = [t_arr] * n_cards
        elif t_arr.ndim == 2 and t_arr.shape[0] == n_cards:
            t_rows = list(t_arr)
        else:
            raise ValueError(f"t: expected shape (N,) or ({n_cards}, N), got {t_arr.shape}")
    records = [CardData(t_rows[i], f_all[i], d_all[i], initial_state, period)
               for i in range(n_cards)]
    return fit_records(model, records, observe=observe, integrator=integrator, scale=scale,
                       residual=residual, offset=offset, fixed=fixed, x0=x0, units=units,
                       solver=solver, multistart=multistart, tol=tol, max_nfev=max_nfev,
                       workers=workers, min_r2=min_r2)


def fit_records(
    model: Model | type[Model],
    records: Sequence[CardData],
    *,
    observe: str | None = None,
    integrator: str = "exact",
    scale: float | str = 1.0,
    residual: str = "linear",
    offset: bool | float = False,
    fixed: Mapping[str, float] | None = None,
    x0: ArrayLike | None = None,
    units: Units | Sequence[Units] | None = None,
    solver: LevenbergMarquardt | None = None,
    multistart: bool | Literal["auto"] = "auto",
    tol: float | None = None,
    max_nfev: int | None = None,
    workers: int | None = None,
    invalid: Sequence[str] | None = None,
    min_r2: float | None = None,
) -> FitBatch:
    """Fit one model structure to records that each carry their own time, initial state
    and period: the main job of :func:`fit` for each, in one batch.

    Parameters
    ----------
    model : Model instance or Model class
        An instance is the shared starting guess; a class asks for the automatic start.
    records : sequence of CardData
        One record per card (its own time, load, displacement, initial state and period).
    units : Units or sequence of Units, optional
        Shared, or one per record.
    invalid : sequence of str, optional
        A reason per record that is known to be unusable ("" for the others): such a record
        becomes an ``invalid-input`` row with that reason.
    observe, integrator, scale, residual, offset, fixed, x0, solver, multistart, tol,
    max_nfev, workers, min_r2
        As for :func:`fit_many`.

    Returns
    -------
    FitBatch
        Each record's result, exactly what :func:`fit` returns for it alone.
    """
    cls, shared = _batch_model(model)
    n_cards = len(records)
    if units is None or isinstance(units, Units):
        unit_rows: Units | list[Units] = units or Units()
    else:
        unit_rows = list(units)
        if len(unit_rows) != n_cards:
            raise ValueError(f"units: {len(unit_rows)} entries for {n_cards} records")
    warnings: list[str] = []
    problem = build_problem(cls, records, observe=observe, integrator=integrator,
                            residual=residual, scale=scale, offset=offset, fixed=fixed,
                            strict=False, warnings=warnings, invalid=invalid)
    p = len(cls.param_names())
    guess = None
    if x0 is not None:
        arr = _x0_array(x0)
        if arr.ndim == 1:
            arr = np.broadcast_to(arr, (n_cards, arr.size))
        if arr.shape != (n_cards, p):
            raise ValueError(f"x0: expected shape ({n_cards}, {p}) or ({p},), got {arr.shape}")
        if not (np.isfinite(arr).all() and (arr > 0).all()):
            raise ValueError("x0: starting parameters must be positive and finite")
        guess = np.array(arr)
    elif shared is not None:
        guess = np.tile(shared, (n_cards, 1))
    if guess is not None:
        for i, value in problem.fixed:
            guess[:, i] = value
    options = _options("lm", solver, multistart, tol, max_nfev, None, None, None,
                       workers=default_workers() if workers is None else workers,
                       history=False, min_r2=min_r2)
    return _run_batch(problem, guess=guess, options=options, units=unit_rows,
                      warnings=warnings)


def _batch_model(model: Model | type[Model]) -> tuple[type[Model], Array | None]:
    """The model class and the shared starting guess (None: automatic start per card)."""
    if isinstance(model, Model):
        return type(model), model.values
    if isinstance(model, type) and issubclass(model, Model):
        return model, None
    raise TypeError(
        "model must be a model instance (a shared starting guess, e.g. Kelvin(k0=4, m=1, "
        f"c1=0.2, k1=4)) or a model class (automatic start per card), got {model!r}")


def _rows(name: str, values: ArrayLike) -> list[Array]:
    if isinstance(values, list | tuple) and values and np.ndim(values[0]) == 1:
        return [np.asarray(v) for v in values]
    arr = np.asarray(values)
    if arr.ndim == 1:
        return [arr]
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected one card per row (cards, N), got shape {arr.shape}")
    return list(arr)
