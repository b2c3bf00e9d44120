"""Diagnostics of every fitted card: uncertainty that holds, identifiability in words.

Each card's analysis (:func:`pumpid.inference.uncertainty.numbers`, one compiled pass over
the cards) gives the covariances; where the residuals are serially correlated (or too few to
test) the errors shown are the robust ones, with an AR(1) floor
(:mod:`pumpid.inference.serial`). Then the findings in words, the derived quantities, the
echo of the pumping speed and the offset's gauge.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..cards import record_stroke
from ..engine import drive
from ..engine.problem import WINDOW, Problem
from ..engine.solvers import LevenbergMarquardt
from ..engine.spectrum import SEARCH_HARMONICS
from ..engine.start import flat_spans, inertia_index
from ..inference.derived import derived_of
from ..inference.echo import alias_of, echo_of
from ..inference.identifiability import findings_of, whiteness_warning
from ..inference.serial import (
    Errors,
    Robust,
    robust_covariance,
    robust_of,
    shown_errors,
    unbounded,
    widening,
)
from ..inference.uncertainty import (
    Numbers,
    Uncertainty,
    numbers,
    t_quantile,
    uncertainty_of,
    widened,
)
from ..models.base import Limit
from ..result import Limiting, Units, squared
from .options import START_SAMPLES
from .state import CardState, numbers_for_true_offset, scale_offset, theta_of

__all__ = ["Assessment", "assess", "diagnose", "interior_sentence", "reach_limits"]

Array = NDArray[np.float64]

#: Evaluations of the solve that takes a card to one of its model's limits (on the card's
#: harmonics where they apply).
LIMIT_EVALUATIONS = 100


@dataclass(frozen=True)
class Assessment:
    """One fit's errors and findings, as every path reports them."""

    numbers: Numbers
    serial: bool
    findings: tuple[str, ...]
    determined: dict[str, Any]
    uncertainty: Errors | None
    #: The numbers before ``floors`` raised any error (the local analysis): what a
    #: quantity computed from the parameters takes its own local error from.
    local: Numbers | None = None

    @property
    def warning(self) -> str:
        """The residuals' whiteness warning in words ("" when they pass)."""
        return self.warning_for(self.uncertainty)

    def warning_for(self, unc: Uncertainty | None) -> str:
        """The whiteness warning with the errors of ``unc`` (the assessment's, or a later
        change of them): it names how much wider the errors shown are, as the card's other
        lines do, so it is made from the errors finally reported."""
        if unc is None or unc.whiteness is None or unc.whiteness["white"]:
            return ""
        return whiteness_warning(dict(unc.whiteness), self.numbers.n, len(self.numbers.names),
                                 getattr(unc, "shown", "white") == "robust", widening(unc))


def assess(num: Numbers, rows_of: Callable[[], Array | None], offset_col: int, *,
           model_names: Sequence[str], gauge_fixed: bool, initial_state: Any, residual: str,
           limits: Sequence[Limiting], unit: str,
           transform: Callable[[Numbers], Numbers] | None = None,
           floors: Mapping[int, tuple[float, float]] | None = None,
           robust: Robust | None = None) -> Assessment:
    """The errors that hold and the identifiability in words for one fit's numbers.

    Where the residuals are serially correlated, or too few to tell, the robust errors are
    calibrated, floored by an AR(1) fit to the residuals and shown by default
    (:func:`~pumpid.inference.serial.robust_of`); the independent-noise ones are kept under
    their own names.

    Parameters
    ----------
    num : Numbers
        The fit's analysis (covariances in the solver's scaled coordinates).
    rows_of : callable
        Returns the (q + 1, N) rows (Jacobian columns, then the residual), or None.
    offset_col : int
        The offset's coordinate (-1: none).
    model_names, gauge_fixed, initial_state, residual
        What :func:`pumpid.inference.identifiability.findings_of` needs to speak.
    limits : sequence of Limiting
        Values at a boundary (left out of the errors).
    unit : str
        The unit of the residual variance.
    transform : callable, optional
        Applied to the numbers before the findings (a change of reported coordinates).
    floors : mapping of int to (float, float), optional
        Coordinates whose errors are raised to at least these (scaled coordinates) after
        the transform: the errors a point elsewhere within the noise implies, the
        independent-noise errors to the first, the robust ones to the second (the reach of
        the noise they describe).
    robust : Robust, optional
        :func:`~pumpid.inference.serial.robust_of`'s answer for these numbers, where it was
        needed earlier.
    """
    robust = robust or robust_of(num, rows_of, offset_col)
    num, serial, calibration = robust.numbers, robust.serial, dict(robust.calibration)
    if transform is not None:
        num = transform(num)
    local = num
    for index, (se, se_robust) in (floors or {}).items():
        num = widened(num, index, se)
        num = widened(num, index, se_robust, robust_only=True)
    f = findings_of(num, model_names=model_names, gauge_fixed=gauge_fixed,
                    initial_state=initial_state, residual=residual,
                    boundaries=[(b.name, b.direction, b.limit) for b in limits], serial=serial)
    unc = uncertainty_of(num, f.undetermined, f.notes, unit)
    unc = shown_errors(unc, serial, robust_covariance(num, f.undetermined), calibration)
    return Assessment(num, serial, f.sentences, f.determined, unc, local)


def diagnose(problem: Problem, cards: NDArray[np.int64], fits: list[CardState],
              units: Sequence[Units], workers: int | None = 1) -> None:
    """Identifiability, uncertainty and whiteness of every fitted card.

    Parameters
    ----------
    problem : Problem
    cards : array of int
        The problem's cards that ``fits`` hold, in order.
    fits : list of CardState
        Updated in place: findings, what is determined, uncertainty, derived quantities and
        warnings.
    units : sequence of Units
        One per card of the problem (the units the errors and combinations are said in).
    workers : int or None
        Threads for the compiled scan along the inertia.
    """
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
    done = [fits[i] for i in idx]
    offset_col = problem.q - 1 if problem.offset_fixed is None else -1

    def rows_for(z: Array, k: int) -> Callable[[], Array | None]:
        def rows_of() -> Array | None:
            rows = np.empty((problem.q + 1, problem.n_samples(k)))
            return rows if drive.rows_at(z, k, data, model_code, settings, rows) else None
        return rows_of

    rows_fns = [rows_for(fits[i].z, int(cards[i])) for i in idx]
    robust = [robust_of(nums[j], rows_fns[j], offset_col) for j in range(len(idx))]
    tq, limits = _thresholds(problem, cards[idx], done, nums)
    flats = _flat_inertia(problem, cards[idx], done, tq, limits, workers)
    opens = _open_limits(problem, cards[idx], done, nums, tq, limits, workers)
    # How far a boundary fit's limit reaches back, for the robust errors, is judged on the
    # noise they describe: with serially correlated residuals the threshold made for
    # independent noise stops short, and the intervals of the other values missed the truth
    # (c1 held it on 0-10 % of the boundary fits of stat_coverage.py's short card at rho
    # 0.5-0.8, against 87-88 % with the threshold raised by the errors' inflation).
    wider, times = _robust_limits(done, nums, robust, limits)
    white, farther = _interior_reach(problem, cards[idx], done, nums, tq, (limits, wider),
                                     (np.ones(len(done)), times), workers)
    white_opens = [[*o, *n] for o, n in zip(opens, white, strict=True)]
    # The same list where the robust errors have no reach of their own (nothing to redo).
    robust_opens = [[*o, *f] if f else w for o, w, f in zip(opens, white_opens, farther,
                                                         strict=True)]
    for j, i in enumerate(idx):
        card = fits[i]
        k = int(cards[i])
        rows_of = rows_fns[j]
        flat = flats[j]

        def transform(n: Numbers, z: Array = card.z, k: int = k,
                      flat: tuple[int, float, float, float] | None = flat) -> Numbers:
            n = numbers_for_true_offset(problem, k, z, n)
            return n if flat is None else widened(n, flat[0], flat[1])

        said = assess(nums[j], rows_of, offset_col, robust=robust[j],
                      model_names=model_names, gauge_fixed=problem.gauge_fixed,
                      initial_state=problem.initial_states[k], residual=problem.residual,
                      limits=card.limits,
                      unit=("(ln of position)^2, dimensionless" if problem.residual == "log"
                            else squared(units[k].position)),
                      transform=transform,
                      floors=_floors(_largest_reach(white_opens[j]),
                                     _largest_reach(robust_opens[j])))
        serial, unc = said.serial, said.uncertainty
        card.findings, card.determined = said.findings, said.determined
        card.uncertainty = unc
        if flat is not None and flat[1] > _local_error(nums[j], flat[0]):
            card.findings = (*card.findings, _flat_words(problem, names[flat[0]], flat[2],
                                                         flat[3], units[k]))
        # The interior reach said is the one behind the errors shown.
        said_opens = robust_opens[j] if serial else white_opens[j]
        card.findings = (*card.findings, *(_open_words(problem, o, units[k]) for o in opens[j]),
                         *(_interior_words(problem, o, units[k]) for o in said_opens
                           if o.interior))
        if problem.model.input_map is None:
            z = card.z
            scale = scale_offset(problem, z)[0]
            # A quantity's error is its own local one, at least its reach to each open
            # limit's point (not the parameters' errors the open limits widened, carried
            # through its gradient: a natural frequency the limit leaves where it was stays
            # determined). The flat span along the inertia is part of the local analysis
            # (the transform): the minima within the noise along it move the quantities
            # the inertia sets, and their errors carry it.
            card.derived = derived_of(
                problem.model, theta_of(problem, z), observe=problem.observe, scale=scale,
                nums=said.local, units=(units[int(cards[i])].load, units[int(cards[i])].position),
                serial=serial, limits=[(b.name, b.direction) for b in card.limits],
                floor=_derived_reach(problem, z, scale, white_opens[j]),
                robust_floor=(None if robust_opens[j] is white_opens[j] else
                              _derived_reach(problem, z, scale, robust_opens[j])))
            _offset_gauge(problem, int(cards[i]), card, units[int(cards[i])])
            period = _stroke_of(problem, int(cards[i]))
            card.derived, echo = echo_of(card.derived, period)
            card.derived, alias = alias_of(card.derived, _step_of(problem, int(cards[i])))
            found = [w for w in (echo, alias) if w is not None]
            if found:
                card.warnings.extend(found)
                card.determined["not_well_property"] = [
                    n for n, d in card.derived.items() if not d.well_property]
        warning = said.warning_for(card.uncertainty)
        if warning:
            card.warnings.append(warning)


def _step_of(problem: Problem, k: int) -> float | None:
    """Card k's sampling step (s): the median of its steps, None for fewer than two
    samples."""
    t = problem.card(k)[0]
    return float(np.median(np.diff(t))) if t.size >= 2 else None


def _stroke_of(problem: Problem, k: int) -> float | None:
    """Card k's stroke period (s): a periodic card's period, a record's time between two
    rises of its observation through mid-stroke (a record of several strokes fitted from
    rest had its resonance on the stroke frequency called a property of the well), else
    None."""
    if problem.initial_states[k] == "periodic":
        return float(problem.period[k])
    t, _load, d = problem.card(k)
    return record_stroke(d, t)


def reach_limits(cost: float, dof: int, inflation: float = 1.0
                 ) -> tuple[float, float, float, float]:
    """The t quantile, the profile's 95 % cost threshold for independent noise, the one for
    the noise the robust errors describe, and that noise in independent-noise variances.

    The second threshold's excess over the answer's cost is the first's times the errors'
    inflation (:attr:`~pumpid.inference.serial.Robust.inflation`), at most the degrees of
    freedom: the noise is never taken as worth less than one independent sample, so
    nothing costing more than about 1 + t^2 times the answer is within it. On a real card
    whose robust variances are 5,000-10,000 times the independent-noise ones (residuals
    whose lag-1 autocorrelation is 1.00), an uncapped threshold stood at 800 times the
    answer's cost, above that of a flat line.
    """
    tq = t_quantile(0.975, dof)
    white = cost * (1.0 + tq * tq / dof)
    times = min(inflation, max(float(dof), 1.0))
    return tq, white, cost + times * (white - cost), times


def _thresholds(problem: Problem, cards: NDArray[np.int64], fits: Sequence[CardState],
                nums: Sequence[Numbers]) -> tuple[Array, Array]:
    """Each card's t quantile and the cost threshold of the profile's 95 % likelihood-ratio
    interval (pumpid.profile_of's): NaN where the card's numbers do not allow it, the fit is
    exact, or the card is longer than the start looks at (a line of costs along a million
    samples would cost as much as the fit)."""
    limits = np.full(len(fits), math.nan)
    tq = np.full(len(fits), math.nan)
    for i, (card, num) in enumerate(zip(fits, nums, strict=True)):
        if (num.usable and not num.exact and num.dof > 0
                and problem.n_samples(int(cards[i])) <= START_SAMPLES):
            tq[i], limits[i] = reach_limits(card.cost, num.dof)[:2]
    return tq, limits


def _flat_inertia(problem: Problem, cards: NDArray[np.int64], fits: Sequence[CardState],
                  tq: Array, limits: Array,
                  workers: int | None) -> list[tuple[int, float, float, float] | None]:
    """How far each card's answer leaves the model's inertia free: (its coordinate, the
    standard error (relative) its span reaches at the 95 % level, the span's lowest and
    highest values), or None without a free inertia, at a limit, or without a threshold
    (``tq`` and ``limits`` from :func:`_thresholds`). The costs are spread over ``workers``
    threads.

    The inertia only: on the 60 synthetic cards spread over x100 of the best-optimum
    benchmark, the same scan along k0, c1 and k1 too (four times the price) left one more
    value undetermined; their errors fail along combinations, not along one of them."""
    j = inertia_index(problem)
    if j is None:
        return [None] * len(fits)
    limits = np.where([problem.free_names[j] in {b.name for b in card.limits}
                       for card in fits], math.nan, limits)
    spans = flat_spans(problem, cards, np.array([card.z for card in fits]), limits, j,
                       workers=workers, known=[card.inertia_line for card in fits])
    out: list[tuple[int, float, float, float] | None] = []
    for i, (card, span) in enumerate(zip(fits, spans, strict=True)):
        if span is None:
            out.append(None)
            continue
        # Another local minimum within the threshold lies within the profile's interval too.
        # In logs: an inertia far out (ln m > 709 on a card of absurd options) overflowed.
        others = [float(v) for v, c in card.inertia_minima if c <= limits[i]]
        with np.errstate(divide="ignore", over="ignore"):
            log_low = min([float(np.log(span[0])), *others])
            log_high = max([float(np.log(span[1])), *others])
            low, high = float(np.exp(log_low)), float(np.exp(log_high))
        z = float(card.z[j])
        reach = max(z - log_low, log_high - z)
        out.append((j, reach / float(tq[i]), low, high))
    return out


@dataclass(frozen=True)
class OpenLimit:
    """A limit of the model that a card's cost reaches within its noise threshold: the
    limit, the point there (the parameter at the search window's edge, the others refitted),
    the card's t quantile and the error (relative, per analysed coordinate) each value's
    reach to the point implies (the reach over the quantile)."""

    limit: Limit
    z: Array
    tq: float
    errors: dict[int, float]
    #: A boundary fit's point the other way: the limit's parameter held as far from its
    #: limit as the noise allows (:func:`_interior_reach`).
    interior: bool = False
    #: The noise judged against, in independent-noise variances (:func:`_robust_limits`).
    inflation: float = 1.0


def _items(problem: Problem, cards: NDArray[np.int64], fits: Sequence[CardState],
           rows: Sequence[tuple[int, Limit, int]]
           ) -> tuple[NDArray[np.int64], NDArray[np.int64], Array, Array, Array]:
    """The solves of (card position, limit, free index) rows: each row's card position and
    card, its answer and the search window around it."""
    owner = np.array([i for i, _lim, _f in rows], dtype=np.int64)
    on = cards[owner]
    z0 = np.array([fits[i].z for i in owner])
    lo, hi = problem.window(on, z0)
    return owner, on, z0, lo, hi


def _open_limits(problem: Problem, cards: NDArray[np.int64], fits: Sequence[CardState],
                 nums: Sequence[Numbers], tq: Array, limits: Array,
                 workers: int | None) -> list[list[OpenLimit]]:
    """The model's limits each card's answer reaches within the profile's 95 % threshold.

    A parameter the fit depends on at its answer can still run to a limit within the
    noise: the cost rises, then falls back toward the limiting model. Its local error is
    then no interval: on the 60 synthetic periodic cards spread over x100 of the
    best-optimum benchmark (1 % white noise), 20 converged fits gave k0 an error of a few
    per cent while k0 -> infinity fitted within the threshold, and the intervals of the
    converged fits held the truth for 36 of the 47 k0, 36 of 42 c1 and 39 of 46 k1 called
    determined. Each limit with a reduced model is tried by one solve on the card's
    harmonics with the parameter held at the search window's edge (at most
    ``LIMIT_EVALUATIONS``), the point reached then costed exactly:
    a point within the threshold lies within every value's likelihood-ratio interval (its
    cost is at or above the profile's), so each value's error is at least its reach to
    that point, and the limit's parameter is not bounded on that side. The model's other
    limits (those without a reduced model; five of Kelvin's seven) were reached on 3 of
    those 60 cards and changed no interval's hold on the truth, at six times the price.
    """
    out: list[list[OpenLimit]] = [[] for _ in fits]
    names = problem.model.param_names()
    free = list(problem.free_idx)
    p = problem.n_free
    rows: list[tuple[int, Limit, int]] = []
    for i, card in enumerate(fits):
        if not math.isfinite(limits[i]):
            continue
        held = {b.name for b in card.limits}
        rows.extend((i, lim, free.index(names.index(lim.param))) for lim in problem.model.limits
                    if names.index(lim.param) in free and lim.param not in held
                    and lim.reduced is not None)
    if not rows:
        return out
    _owner, on, z0, lo, hi = _items(problem, cards, fits, rows)
    for r, (_i, lim, f) in enumerate(rows):
        edge = hi[r, f] if lim.direction == "infinity" else lo[r, f]
        z0[r, f] = lo[r, f] = hi[r, f] = edge
    # Cards the harmonic cost does not apply to are solved on the exact one.
    solved = LevenbergMarquardt(harmonics=SEARCH_HARMONICS).solve(
        problem, on, z0, bounds=(lo, hi), budget=LIMIT_EVALUATIONS, workers=workers)
    ends = np.where(np.all(np.isfinite(solved.z), axis=1)[:, None], solved.z, z0)
    costs = drive.cost_items(on, ends, *problem.arrays)
    for r, (i, lim, f) in enumerate(rows):
        if not costs[r] <= limits[i]:
            continue
        reach = {b: abs(float(ends[r, b] - fits[i].z[b])) for b in nums[i].inner if b < p}
        # The window's edge stands for the limit itself, however near the answer lies to it:
        # the parameter's error is at least the window's half-width (a factor 1e6).
        reach[f] = max(reach.get(f, 0.0), WINDOW)
        out[i].append(OpenLimit(lim, ends[r].copy(), float(tq[i]),
                                {b: v / float(tq[i]) for b, v in reach.items()}))
    return out


def _robust_limits(fits: Sequence[CardState], nums: Sequence[Numbers],
                   robust: Sequence[Robust], limits: Array) -> tuple[Array, Array]:
    """Each card's threshold for the noise its robust errors describe (:func:`reach_limits`),
    where they are shown and it differs (NaN elsewhere), and that noise in
    independent-noise variances."""
    wider = np.full(len(fits), math.nan)
    times = np.ones(len(fits))
    for j, (card, num, r) in enumerate(zip(fits, nums, robust, strict=True)):
        if not (math.isfinite(limits[j]) and r.inflation > 1.0):
            continue
        _tq, _white, wide, times[j] = reach_limits(card.cost, num.dof, r.inflation)
        if times[j] > 1.0:
            wider[j] = wide
    return wider, times


#: Halvings of the distance from a boundary fit's limit to the search window's far end.
INTERIOR_STEPS = 7


def _interior_reach(problem: Problem, cards: NDArray[np.int64], fits: Sequence[CardState],
                    nums: Sequence[Numbers], tq: Array, thresholds: Sequence[Array],
                    inflations: Sequence[Array], workers: int | None
                    ) -> list[list[list[OpenLimit]]]:
    """How far from its limit a boundary fit's parameter goes within the noise threshold.

    A boundary fit reports its limiting model's values, with errors that hold with the
    parameter at its limit. But the limit is accepted because it fits as well, not because
    the model's interior fits worse: with k0 -> infinity accepted on a 30-sample Kelvin card
    whose true k0 is 400 (k1 = 80), c1 came out 26.1 +- 0.9 against a true 40, and the
    interval held the truth on 2-6 of 27 boundary fits per setting of
    ``stat_coverage.py``'s short card. Here the parameter is held at points from the
    limit toward the search window's far end (bisection, ``INTERIOR_STEPS`` halvings; each
    point one solve on the card's harmonics from the last point within the threshold, the
    point reached then costed exactly); the farthest point within the profile's 95 %
    threshold (each of ``thresholds``, with its ``inflations``: the independent-noise one,
    and one raised for the noise the robust errors describe, :func:`_robust_limits`; their
    bisections share each step's solve) lies within every value's likelihood-ratio
    interval, so each other value's interval spans its intervals along the way: its error
    is at least its largest reach to a point within the threshold plus its own error at
    the limit. On that short card at rho 0-0.5 the boundary fits' intervals of m then held
    the truth on 14 of 14 and 20 of 23 (its reach alone: 3 and 8); with the threshold made
    for independent noise, c1's held it on 0-10 % of the boundary fits at rho 0.5-0.8, and
    with it raised, on 87-88 % (k1 88-91 %, m all; 400 replicates).

    Returns, for each threshold, each card's points.
    """
    out: list[list[list[OpenLimit]]] = [[[] for _ in fits] for _ in thresholds]
    names = problem.model.param_names()
    free = list(problem.free_idx)
    rows: list[tuple[int, Limit, int]] = []
    # Every threshold's bisections in one batch: one solve a step for all of them.
    which: list[int] = []
    for k_set, limits in enumerate(thresholds):
        for i, card in enumerate(fits):
            if not math.isfinite(limits[i]):
                continue
            for b in card.limits:
                lim = next((m for m in problem.model.limits
                            if m.param == b.name and m.direction == b.direction), None)
                if lim is not None and names.index(lim.param) in free:
                    rows.append((i, lim, free.index(names.index(lim.param))))
                    which.append(k_set)
    if not rows:
        return out
    owner, on, best, lo, hi = _items(problem, cards, fits, rows)
    threshold = np.array([thresholds[k_set][i] for k_set, i in zip(which, owner, strict=True)])
    z_fit = best.copy()
    start = np.array([best[r, f] for r, (_i, _lim, f) in enumerate(rows)])
    far = np.array([lo[r, f] if lim.direction == "infinity" else hi[r, f]
                    for r, (_i, lim, f) in enumerate(rows)])
    near, away = np.zeros(len(rows)), np.ones(len(rows))
    found = np.zeros(len(rows), dtype=bool)
    # The farthest point is not where every value has moved most (c1 can go out and come
    # back along k0): each value's reach is the largest of every point within the threshold.
    moved = np.zeros_like(best)
    solver = LevenbergMarquardt(harmonics=SEARCH_HARMONICS)
    for _ in range(INTERIOR_STEPS):
        t = 0.5 * (near + away)
        z0 = best.copy()
        b_lo, b_hi = lo.copy(), hi.copy()
        for r, (_i, _lim, f) in enumerate(rows):
            z0[r, f] = b_lo[r, f] = b_hi[r, f] = start[r] + t[r] * (far[r] - start[r])
        solved = solver.solve(problem, on, z0, bounds=(b_lo, b_hi), budget=LIMIT_EVALUATIONS,
                              workers=workers)
        ends = np.where(np.all(np.isfinite(solved.z), axis=1)[:, None], solved.z, z0)
        costs = drive.cost_items(on, ends, *problem.arrays)
        within = costs <= threshold
        best[within] = ends[within]
        moved[within] = np.fmax(moved[within], np.abs(ends[within] - z_fit[within]))
        found |= within
        near = np.where(within, t, near)
        away = np.where(within, away, t)
    p = problem.n_free
    for r, (i, lim, f) in enumerate(rows):
        if not found[r]:
            continue
        reach = {b: float(moved[r, b]) for b in nums[i].inner if b < p and b != f}
        # Each value's interval is the union of its intervals along the way: its largest
        # reach plus its own error there (taken as the one at the limit).
        out[which[r]][i].append(OpenLimit(
            lim, best[r].copy(), float(tq[i]),
            {b: v / float(tq[i]) + _local_error(nums[i], b) for b, v in reach.items()},
            interior=True, inflation=float(inflations[which[r]][i])))
    return out


def interior_sentence(name: str, direction: str, held: str, others: Sequence[str],
                      inflation: float) -> str:
    """The sentence of a boundary fit whose parameter ``name`` comes back from its limit
    (``direction``: "infinity" or "zero") within the noise to ``held`` (value and unit),
    the other values refitted (``others``: each "name value unit", or none to name) on a
    threshold ``inflation`` times the independent-noise one's (:func:`reach_limits`)."""
    side = "down" if direction == "infinity" else "up"
    noise = ("the noise" if inflation <= 1.0 else
             f"the noise the robust errors describe ({inflation:.3g} times the "
             "independent-noise variance)")
    values = f" ({', '.join(others)})" if others else ""
    return (f"{name} fits within {noise} from its limit {side} to {held}, the other values "
            f"refitted{values}: the limit fits as well, not better, so every other value's "
            "error reaches its value there, not only its error with the limit taken.")


def _interior_words(problem: Problem, point: OpenLimit, units: Units) -> str:
    """:func:`interior_sentence` for a lumped fit's point, its values with their units."""
    lim = point.limit
    names = problem.model.param_names()
    infos = problem.model.param_info()
    theta = theta_of(problem, point.z)
    i_lim = names.index(lim.param)
    others = [f"{names[i]} {theta[i]:.3g} {infos[i].unit_for(units.load, units.position)}"
              for i in problem.free_idx if i != i_lim]
    unit = infos[i_lim].unit_for(units.load, units.position)
    return interior_sentence(lim.param, lim.direction, f"{theta[i_lim]:.3g} {unit}", others,
                             point.inflation)


def _open_words(problem: Problem, open_limit: OpenLimit, units: Units) -> str:
    """The sentence of a limit the card's cost reaches within the noise."""
    lim = open_limit.limit
    names = problem.model.param_names()
    theta = theta_of(problem, open_limit.z)
    side = "above" if lim.direction == "infinity" else "below"
    others = []
    for i in problem.free_idx:
        name = names[i]
        if name == lim.param:
            continue
        info = problem.model.param_info()[i]
        others.append(f"{name} {theta[i]:.3g} {info.unit_for(units.load, units.position)}")
    return (f"{lim.param} is not bounded {side}: with {lim.param} at its limit "
            f"({lim.description.split(':')[0]}) and the other values refitted "
            f"({', '.join(others)}), the cost stays within its 95 % noise threshold. "
            f"{lim.param}'s error reaches that limit and every other value's error reaches "
            "its value there, not only the cost's curvature at the answer.")


def _flat_words(problem: Problem, name: str, low: float, high: float, units: Units) -> str:
    """The sentence of a parameter whose error the scan along it widened."""
    info = problem.model.param_info()[problem.model.param_names().index(name)]
    unit = info.unit_for(units.load, units.position)
    why = ("; the card sees the resonance only through weak harmonics, where the cost "
           "along it is flat and rippled" if name == problem.model.resonance else "")
    return (f"{name} fits the card from {low:.3g} to {high:.3g} {unit}: the cost stays "
            "within its 95 % noise threshold there, every other value held or refitted from "
            f"another dip{why}. The error shown for it is at least that span's, not only "
            "the cost's curvature at the answer.")


def _derived_reach(problem: Problem, z: Array, scale: float,
                   opens: Sequence[OpenLimit]) -> Array | None:
    """Each derived quantity's smallest error implied by the card's open limits: its change
    between the answer and each limit's point, over the t quantile (None without any).

    A positive quantity's change is also taken on the log scale, the parameters' (times its
    value), and the larger counts: a static stiffness that falls from 17.2 lbf/in to 2.6e-5
    within the noise (a real stroke's, where k1 does so beside it) changed by less than its
    value, and was called determined beside the k1 it equals at that limit, which was not.
    """
    if not opens:
        return None
    cls = problem.model
    here = cls.derived_values(theta_of(problem, z), problem.observe, scale)
    floor = np.zeros(here.size)
    for o in opens:
        there = cls.derived_values(theta_of(problem, o.z), problem.observe,
                                   scale_offset(problem, o.z)[0])
        with np.errstate(all="ignore"):
            ratio = np.where((here > 0) & (there > 0), np.abs(np.log(there / here)), 0.0)
            step = np.fmax(np.abs(there - here), np.abs(here) * ratio) / o.tq
        floor = np.fmax(floor, np.where(np.isfinite(step), step, math.inf))
    return floor


def _largest_reach(opens: Sequence[OpenLimit]) -> dict[int, float]:
    """Each coordinate's largest error over a card's open limits."""
    out: dict[int, float] = {}
    for o in opens:
        for b, se in o.errors.items():
            out[b] = max(out.get(b, 0.0), se)
    return out


def _floors(white: Mapping[int, float],
            robust: Mapping[int, float]) -> dict[int, tuple[float, float]]:
    """Each coordinate's (independent-noise, robust) error floor from the two reaches."""
    return {b: (white.get(b, 0.0), max(white.get(b, 0.0), robust.get(b, 0.0)))
            for b in {*white, *robust}}


def _local_error(num: Numbers, index: int) -> float:
    """The larger of the white and the robust local errors of one analysed coordinate."""
    inner = list(num.inner)
    if index not in inner:
        return math.inf
    a = inner.index(index)
    variances = [float(c[a, a]) for c in (num.cov_scaled, num.hac_scaled)]
    return math.sqrt(max((v for v in variances if math.isfinite(v)), default=math.inf))


def _offset_gauge(problem: Problem, k: int, card: CardState, units: Units) -> None:
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
    level = scale_offset(problem, card.z)[1]
    card.determined.setdefault("combinations", []).append(
        f"the position at the card's mean load, offset + mean load / static stiffness = "
        f"{level:.6g} {units.position}")
    card.determined["offset_at_mean_load"] = level
    if stiff.determined:
        return
    card.determined["parameters"].remove("offset")
    card.determined["not_determined"].append("offset")
    # Its local error was the level's: the offset itself moves with the undetermined
    # stiffness without bound (it read "45.9 ± 4.1 in (not determined)").
    if card.uncertainty is not None:
        card.uncertainty = unbounded(card.uncertainty, "offset")
    card.findings = (*card.findings,
                     "The offset (the position at zero load) is not determined: the card "
                     "fixes only the position at its mean load, offset + mean load / static "
                     f"stiffness = {level:.6g} {units.position}, and the static stiffness "
                     "is not determined, so the offset trades off with it.")
