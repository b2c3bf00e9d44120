"""A card's state while the job works on it, and the solver coordinates' algebra.

The solver works on ``z``: the free parameters' logarithms, then log C (when the scale is
fitted), then the offset of the centred response (when the offset is fitted). The functions
here turn that point back into what a result reports (parameters, scale, the offset at zero
load), record a solver outcome on a card, and summarise a card's fit in one compiled pass.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..engine import drive, kernel
from ..engine.problem import Problem
from ..engine.solvers import SolverOutcome, Stop
from ..engine.start import InertiaLine
from ..inference.structure import low_band_excess
from ..inference.uncertainty import Numbers
from ..result import Limiting, ReducedFit, StartInfo, Status
from .options import START_SAMPLES

__all__ = ["BAND_P", "BAND_RATIO", "CardState", "apply_outcome", "doubt", "doubtful",
           "gap_gradient", "mark_edges", "numbers_for_true_offset", "scale_offset",
           "start_problem", "summarize", "theta_of", "true_offset"]

Array = NDArray[np.float64]

#: The band test of :func:`doubtful`: a p-value below ``BAND_P`` and a band carrying at
#: least ``BAND_RATIO`` times the power per harmonic above it. On 60 synthetic periodic
#: cards with white noise, the fits in their optimum's basin had p-values of 0.03 and more
#: and ratios up to 1.5; the one fit in a wrong basin (83 % above its best cost) 1e-31 and
#: 7.6. Noise on the load as well colours the residual in the band (the model filters it):
#: on 100 controller-like cards with 0.3 % noise on both, 11 had p-values below 1e-4 at
#: ratios up to 6.3 (90th percentile 2.8), 2 at 4 or more. Public field cards that were
#: not doubtful before and reached a lower optimum through the wider search: 4.1-17.
BAND_P = 1e-4
BAND_RATIO = 4.0


@dataclass
class CardState:
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
    band: tuple[float, float] = (math.nan, math.nan)
    norms: Array | None = None
    #: Local minima along the model's inertia the scan met: (ln inertia, cost) pairs.
    inertia_minima: tuple[tuple[float, float], ...] = ()
    #: The scan's first line along the inertia (from the answer it was given): the
    #: diagnostics reuse it when the answer did not move.
    inertia_line: InertiaLine | None = None


def theta_of(problem: Problem, z: Array) -> Array:
    """Every model parameter (fixed ones included) at solver point(s) ``z``."""
    with np.errstate(over="ignore"):
        return problem.full_theta(np.exp(z[..., : problem.n_free]))


def scale_offset(problem: Problem, z: Array) -> tuple[float, float]:
    """The scale C and the solver's offset coordinate at ``z`` (fixed values where fixed)."""
    p = problem.n_free
    j = p
    if problem.scale_fixed is None:
        scale = math.exp(z[j])
        j += 1
    else:
        scale = float(problem.scale_fixed)
    offset = float(z[j]) if problem.offset_fixed is None else float(problem.offset_fixed)
    return scale, offset


def true_offset(problem: Problem, k: int, z: Array) -> float:
    """The reported offset of card k at solver point z (the solver's offset less the mean
    level of the load the engine took off, see :func:`pumpid.engine.problem.load_shift`)."""
    scale, offset = scale_offset(problem, z)
    if problem.offset_fixed is not None or problem.shift_of(k) == 0.0:
        return offset
    return offset - float(problem.offset_gap(k, theta_of(problem, z), scale))


def gap_gradient(problem: Problem, k: int, z: Array) -> tuple[float, Array]:
    """The gap between the solver's and the reported offset at z, and its derivatives
    with respect to the free log-parameters (forward differences)."""
    p = problem.n_free
    scale = scale_offset(problem, z)[0]
    step = 1e-6
    rows = np.repeat(z[None], p, axis=0)
    rows[np.arange(p), np.arange(p)] += step
    gap0 = float(problem.offset_gap(k, theta_of(problem, z), scale))
    grads = (problem.offset_gap(k, theta_of(problem, rows), scale) - gap0) / step
    return gap0, grads


def numbers_for_true_offset(problem: Problem, k: int, z: Array, num: Numbers) -> Numbers:
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
    gap0, grads = gap_gradient(problem, k, z)
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


def apply_outcome(card: CardState, out: SolverOutcome, j: int, problem: Problem) -> None:
    """Record item ``j`` of a solver outcome on ``card`` (evaluations add up)."""
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


def mark_edges(problem: Problem, cards: NDArray[np.int64], z0: Array, fits: list[CardState],
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


def summarize(problem: Problem, cards: NDArray[np.int64], fits: list[CardState]) -> None:
    """Quality, noise level and Jacobian column norms at each card's point (one pass)."""
    idx = [i for i in range(len(fits)) if np.all(np.isfinite(fits[i].z))]
    if not idx:
        return
    data, model, settings = problem.arrays
    at = np.ascontiguousarray(cards[idx], dtype=np.int64)
    buffer, starts, ok = drive.rows_items(at, np.ascontiguousarray([fits[i].z for i in idx]),
                                          data, model, settings)
    stats, norms = drive.summary_rows(at, problem.q, buffer, starts, ok, data, settings)
    for j, i in enumerate(idx):
        card = fits[i]
        card.rmse, card.r2, card.noise = (float(v) for v in stats[j, 1:])
        card.norms = norms[j]
        card.band = (math.nan, math.nan)
        k = int(at[j])
        if ok[j] and problem.one_period(k):
            # The last row of the card's rows is its residual.
            residual = buffer[starts[j]:starts[j + 1]].reshape(problem.q + 1, -1)[-1]
            card.band = low_band_excess(residual)


def doubtful(problem: Problem, k: int, card: CardState) -> bool:
    """Whether a fit deserves a wider search (:func:`doubt` says why)."""
    return bool(doubt(problem, k, card))


def doubt(problem: Problem, k: int, card: CardState) -> str:
    """A fit that deserves a wider search: no finite answer, R^2 < 0.99, an RMSE above
    twice the data's noise level, or (one period of a card) a residual whose first
    harmonics carry clearly more than the harmonics above them (a wrong local minimum, or
    a model that misses part of the response, where other minima compete).

    The noise level is a robust estimate from second differences (white noise:
    var(diff2) = 6 sigma^2); smooth signal content only raises it, so a good fit is never
    called doubtful by it, but its spread lets a wrong basin within a few tenths of the
    noise level pass. The band test (:func:`~pumpid.inference.structure.low_band_excess`,
    at :data:`BAND_P` and :data:`BAND_RATIO`) sees the clear ones.

    Returns the test that sent the fit, in words ("" for a fit that is not doubtful)."""
    # A fit that ran out of evaluations in a flat valley may still explain the data: its
    # quality decides, not the stop.
    if not math.isfinite(card.cost) or card.stop is Stop.NOT_FINITE:
        return "the first answer was not finite"
    if not math.isfinite(card.r2) or card.r2 < 0.99:
        said = f"{card.r2:.4g}" if math.isfinite(card.r2) else "not defined"
        return f"the first answer explained too little (R^2 {said}, below 0.99)"
    d = problem.card(k)[2]
    floor = 1e-9 * float(np.ptp(d))
    if card.rmse > 2.0 * card.noise + floor:
        if card.noise > floor:
            return (f"the first answer's error was {card.rmse / card.noise:.3g} times the "
                    "data's noise (above twice)")
        # "4.01e+14 times the data's noise" on a field card whose positions come in steps
        # of 0.01 m: most second differences vanish, and so does their median.
        return ("the first answer's error was above the data's noise, which the samples "
                "put at or near zero (most of their second differences vanish: values "
                "recorded in steps or straight runs)")
    # A residual at rounding level has no structure worth a search, whatever its shape.
    ratio, p_value = card.band
    if card.rmse > floor and p_value < BAND_P and ratio >= BAND_RATIO:
        return (f"the first answer's residual was carried by the card's first harmonics "
                f"({ratio:.3g} times the power per harmonic above them)")
    return ""


def start_problem(problem: Problem, cards: NDArray[np.int64]) -> Problem | None:
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

