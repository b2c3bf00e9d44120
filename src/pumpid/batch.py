"""Fit one model to many cards at once: :func:`fit_many`.

A field sends thousands of dynamometer cards; fitting them one by one with
:func:`pumpid.fit` pays Python and solver overhead per card. :func:`fit_many` fits a whole
array of cards (cards x samples, on a shared time grid) with one Levenberg-Marquardt
iteration *vectorized across cards* (:mod:`pumpid.lm`, the loop the single fit uses too):

* every iteration makes one batched simulation with exact sensitivities for all the cards
  still iterating (log-parameters, like the single fit, so parameters stay positive);
* each card has its own trust radius, accept/reject decision and convergence test;
  converged cards leave the active set, so stragglers do not make the others pay;
* the output scale C (when free) and the position offset (when fitted) are extra columns
  of the same least-squares problem, exactly as in the single fit (``C y + offset - data``);
* cards are processed in chunks, so the working memory is bounded by the chunk size and does
  not grow with the number of cards (only the inputs and the per-card outputs do).

Why vectorized numpy rather than compiled code: pumpid's runtime dependencies are numpy and
scipy only. No library offers a *batched* Levenberg-Marquardt (scipy's ``least_squares``
solves one problem per call), so the loop (:mod:`pumpid.lm`) is hand-written; its
per-iteration work is a handful of array operations over the chunk, so the Python overhead is
paid once per chunk and iteration, not per card.

Simulation. On a uniform grid the outputs and their exact sensitivities come from the
frequency domain (:func:`pumpid.simulate.observed_blocks`, :mod:`pumpid.spectral`): per
card, transfer-function polynomials of the discretized sensitivity system, evaluated on a
DFT grid shared by all cards, and one inverse FFT. Other grids (and a periodic state with an
unusual period) fall back to :func:`~pumpid.simulate.propagate`'s scan.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import lm
from .blas import single_threaded
from .models import Model
from .problem import (
    MIN_SAMPLES,
    SPECTRAL_RANGE,
    Problem,
    _is_zero_state,
    _unit_size,
    build_problem,
)
from .simulate import (
    Grid,
    InitialState,
    Integrator,
    _initial_state_vector,
    _spectral_applies,
    make_grid,
    observed,
    observed_blocks,
    propagate,
)

__all__ = ["BatchResult", "fit_many"]

Array = NDArray[np.float64]

#: Working-memory budget of one chunk (bytes). The arrays of one LM iteration (states,
#: sensitivities, Jacobian, scan temporaries) are sized per card; the chunk is chosen so that
#: they stay around this size whatever the number of cards.
_CHUNK_BYTES = 64 * 2**20
#: Cards per chunk when the working set is small: beyond ~256 cards the per-iteration Python
#: overhead is already negligible, and smaller chunks stay closer to the CPU caches.
_CHUNK_MAX = 256
#: Number of samples the automatic start's shape grid is evaluated on (decimated record).
_START_SAMPLES = 128
STATUSES = ("converged", "boundary", "max_iter", "failed")


# =========================================================================== result
@dataclass
class BatchResult:
    """Per-card outcome of :func:`fit_many`; every array has one entry per card.

    Attributes
    ----------
    model_name : str
        The fitted model class.
    param_names : tuple of str
        Parameter names in canonical order.
    params : dict of str -> ndarray
        Fitted parameters by name (on the gauge C = 1 when ``gauge_fixed``).
    scale, offset : ndarray
        Output scale C and position offset (fixed or fitted).
    converged : ndarray of bool
        True when the card's iteration met a convergence test at an interior point.
    status : ndarray of str
        ``converged``; ``boundary`` (a parameter ran to the edge of the search window: the
        data want a limiting model); ``max_iter`` (iteration budget exhausted); ``failed``
        (non-finite simulation at the start, or no usable start).
    iterations : ndarray of int
        Simulations with sensitivities made for the card after the start (accepted and
        rejected LM trial points).
    rmse, r2, cost : ndarray
        Root-mean-square error (position units), coefficient of determination and
        0.5 * sum of squared residuals of the fitted displacement.
    start : ndarray, shape (cards, p)
        The starting parameters used.
    gauge_fixed : bool
        True when a free scale was fixed to C = 1 because of the scale symmetry.
    """

    model_name: str
    param_names: tuple[str, ...]
    params: dict[str, Array]
    scale: Array
    offset: Array
    converged: NDArray[np.bool_]
    status: NDArray[np.str_]
    iterations: NDArray[np.int64]
    rmse: Array
    r2: Array
    cost: Array
    start: Array
    gauge_fixed: bool = False
    options: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.scale.size)

    @property
    def theta(self) -> Array:
        """Fitted parameters as an array (cards, p) in canonical order."""
        return np.column_stack([self.params[n] for n in self.param_names])

    def result(self, i: int) -> dict[str, Any]:
        """Card ``i`` as a plain dictionary (parameters, scale, offset, status, statistics)."""
        return {
            "card": int(i),
            "model": self.model_name,
            "params": {n: float(self.params[n][i]) for n in self.param_names},
            "scale": float(self.scale[i]),
            "offset": float(self.offset[i]),
            "converged": bool(self.converged[i]),
            "status": str(self.status[i]),
            "iterations": int(self.iterations[i]),
            "rmse": float(self.rmse[i]),
            "r2": float(self.r2[i]),
            "cost": float(self.cost[i]),
        }

    def to_records(self) -> list[dict[str, Any]]:
        """One flat dictionary per card (parameters as top-level keys), e.g. for a table."""
        out = []
        for i in range(len(self)):
            row = self.result(i)
            params = row.pop("params")
            out.append({**params, **row})
        return out

    def summary(self) -> str:
        """One line: cards per status and the median R^2."""
        counts = ", ".join(f"{s} {int(np.sum(self.status == s))}" for s in STATUSES
                           if np.any(self.status == s))
        r2 = float(np.nanmedian(self.r2)) if len(self) else math.nan
        return f"{self.model_name}: {len(self)} cards ({counts}); median R^2 = {r2:.6g}"


# =========================================================================== simulation
@dataclass(frozen=True)
class _Engine:
    """Everything a chunk needs to simulate its cards: model, grid and options."""

    model_cls: type[Model]
    grid: Grid
    integrator: Integrator
    initial_state: InitialState
    period: float | None
    k_obs: int

    @property
    def n(self) -> int:
        return self.model_cls.n_states()

    @property
    def p(self) -> int:
        return len(self.model_cls.param_names())

    @property
    def spectral(self) -> bool:
        """The frequency-domain evaluation applies (see :mod:`pumpid.spectral`)."""
        return _spectral_applies(self.grid, self.model_cls, self.initial_state, self.period)

    def evaluate(
        self, theta: Array, f: Array, far: NDArray[np.bool_] | None = None
    ) -> tuple[Array, Array]:
        """Observed output y (b, N) and dy/dtheta (b, p, N) for cards theta (b, p), f (b, N).

        ``far`` marks cards whose parameters are far from their natural scales: they are
        simulated by the state scan (see :data:`pumpid.problem.SPECTRAL_RANGE`).
        """
        if not self.spectral:
            return self._scan(theta, f)
        if far is not None and far.any():
            y = np.empty(f.shape)
            dy = np.empty((f.shape[0], self.p, f.shape[1]))
            near = ~far
            if near.any():
                y[near], dy[near] = self.evaluate(theta[near], f[near])
            y[far], dy[far] = self._scan(theta[far], f[far])
            return y, dy
        out = observed_blocks(self.model_cls, theta, self.grid, f,
                              np.array([self.k_obs]), np.arange(self.p),
                              initial_state=self.initial_state, integrator=self.integrator)
        return out[:, 0, 0], out[:, 1:, 0]

    def _scan(self, theta: Array, f: Array) -> tuple[Array, Array]:
        x = propagate(self.model_cls, theta, self.grid, f, initial_state=self.initial_state,
                      integrator=self.integrator, sensitivities=True, period=self.period)
        n, k = self.n, self.k_obs
        dy = x[..., [n * (i + 1) + k for i in range(self.p)]]
        return x[..., k], np.swapaxes(dy, 1, 2)

    def outputs(self, theta: Array, f: Array, grid: Grid | None = None) -> Array:
        """Observed output only; ``theta`` (..., p) broadcasts against ``f`` (..., N)."""
        y = observed(self.model_cls, theta, grid or self.grid, f, [self.k_obs],
                     initial_state=self.initial_state, integrator=self.integrator,
                     sensitivities=False, period=self.period)
        return y[..., 0]


# =========================================================================== validation
def _as_cards(name: str, values: ArrayLike, n_samples: int) -> Array:
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: not an array of numbers ({exc})") from None
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected an array (cards, samples), got shape {arr.shape}")
    if arr.shape[1] != n_samples:
        raise ValueError(
            f"{name}: {arr.shape[1]} samples per card do not match the time vector's "
            f"length {n_samples}"
        )
    if arr.shape[0] == 0:
        raise ValueError(f"{name}: no cards")
    return arr


def _chunks(total: int, size: int) -> Iterator[slice]:
    for start in range(0, total, size):
        yield slice(start, min(start + size, total))


def _first_cards(mask: NDArray[np.bool_], offset: int = 0, limit: int = 5) -> str:
    idx = np.flatnonzero(mask)[:limit] + offset
    more = " ..." if mask.sum() > limit else ""
    return ", ".join(str(int(i)) for i in idx) + more


def _check_cards(loads: Array, data: Array, zero_state: bool, block: int) -> None:
    """Finite values, non-constant displacement and (for load-driven states) varying load.

    Checked block by block so that no temporary of the full size is made.
    """
    for sl in _chunks(loads.shape[0], block):
        for name, arr in (("loads", loads[sl]), ("displacements", data[sl])):
            bad = ~np.isfinite(arr).all(axis=1)
            if bad.any():
                raise ValueError(
                    f"{name}: non-finite values (NaN or inf) in card(s) "
                    f"{_first_cards(bad, sl.start)}"
                )
        const = np.ptp(data[sl], axis=1) == 0
        if const.any():
            raise ValueError(
                f"displacements: constant in card(s) {_first_cards(const, sl.start)}; "
                "nothing to fit"
            )
        if zero_state:
            f = loads[sl]
            flat = np.ptp(f, axis=1) <= 1e-12 * np.maximum(1.0, np.max(np.abs(f), axis=1))
            if flat.any():
                raise ValueError(
                    f"loads: constant in card(s) {_first_cards(flat, sl.start)}; a load-driven "
                    "initial state then carries no information on the dynamics"
                )


def _default_chunk(engine: _Engine, n_samples: int) -> int:
    """Cards per chunk from the memory budget (bytes per card of one LM iteration)."""
    n, p = engine.n, engine.p
    if engine.spectral:
        # Complex spectra of (p + 1) outputs for up to four forcing groups (twice as many
        # frequencies without a periodic state), the time signals, residual and Jacobian.
        bins = 1 if engine.initial_state == "periodic" else 2
        per_card = 8 * n_samples * (16 * bins * (p + 1) + 3 * (p + 3))
    else:
        # propagate's dense augmented recursion: (N, n(p+1)) states plus forcing and
        # temporaries, and per-step transitions on a non-uniform grid.
        size = n * (p + 1)
        per_card = 8 * n_samples * (5 * size + (3 * size * size if not engine.grid.uniform
                                                else 0))
    return int(max(1, min(_CHUNK_MAX, _CHUNK_BYTES // per_card)))


# =========================================================================== starts
def _reference_logs(problem: Problem, loads: Array, data: Array, scale: float) -> Array:
    """Log of each card's natural parameter scales (cards, p), as the single fit uses."""
    load_span = np.ptp(loads, axis=1)
    load_span = np.where(load_span > 0, load_span, np.max(np.abs(loads), axis=1))
    load_span = np.where(load_span > 0, load_span, 1.0)
    out_span = np.ptp(data, axis=1) / scale
    span = float(problem.grid.t[-1] - problem.grid.t[0])
    if problem.period is not None:
        span = problem.period
    base = {"{load}": load_span, "{position}": out_span, "s": span / (2 * math.pi)}
    cols = [np.broadcast_to(np.asarray(_unit_size(info.unit, base), dtype=float),
                            load_span.shape) for info in problem.model_cls.param_info()]
    return np.log(np.column_stack(cols))


def _shapes(problem: Problem) -> Array:
    """Dimensionless candidate shapes: the automatic start's grid (see pumpid.start)."""
    from .start import _shape_grid

    return _shape_grid(problem)


def _grid_starts(
    engine: _Engine, problem: Problem, loads: Array, data: Array, keep: int
) -> Array:
    """The ``keep`` best grid shapes per card, amplitude-matched: (keep, cards, p).

    Every shape is simulated against every card's load and scored by its least-squares
    amplitude (and offset); the scale symmetry turns the amplitude into an overall parameter
    level. A start need not be exact, so the shapes are evaluated cheaply: for a periodic
    stroke on a uniform grid, per harmonic (Y = H(i k w) F, shared H for all cards, scores by
    Parseval as two matrix products); otherwise by one batched simulation on a decimated copy
    of the record, a few cards at a time so memory stays bounded.
    """
    shapes = _shapes(problem)
    symmetric = engine.model_cls.scale_symmetric and _is_zero_state(
        problem.initial_state, engine.model_cls)
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    free_amp = symmetric or problem.scale_fixed is None
    if problem.initial_state == "periodic" and problem.grid.uniform:
        num, den, sst = _harmonic_scores(engine, problem, shapes, loads, data)
    else:
        num, den, sst = _time_scores(engine, problem, shapes, loads, data)
    with np.errstate(all="ignore"):
        amp = num / den
        if free_amp:
            cost = sst[:, None] - amp * num
        else:
            amp = np.full_like(amp, scale)
            cost = sst[:, None] - 2 * scale * num + scale**2 * den
    usable = np.isfinite(cost) & np.isfinite(amp) & (amp > 0) & (den > 0)
    cost = np.where(usable, cost, np.inf)
    order = np.argsort(cost, axis=1)[:, :keep]
    picked = shapes[order]  # (b, keep, p)
    if symmetric:
        # y(lambda theta) = y(theta) / lambda: the fitted amplitude fixes the level.
        level = scale / np.take_along_axis(amp, order, axis=1)
        level = np.where(np.isfinite(level) & (level > 0), level, 1.0)
        picked = picked * level[..., None]
    return np.moveaxis(picked, 1, 0)


def _harmonic_scores(
    engine: _Engine, problem: Problem, shapes: Array, loads: Array, data: Array
) -> tuple[Array, Array, Array]:
    """<y_s, d>, <y_s, y_s> and <d, d> per card and shape from the harmonics (periodic)."""
    grid = problem.grid
    n_samples = grid.n
    period = problem.period if problem.period is not None else n_samples * grid.dt
    n_harm = n_samples // 2 + 1
    omega = 2 * math.pi * np.arange(n_harm) / period
    a, b, _, _ = engine.model_cls.system_batch(shapes)
    size = a.shape[-1]
    with np.errstate(all="ignore"):
        resolvent = 1j * omega[None, :, None, None] * np.eye(size) - a[:, None]
        h = np.linalg.solve(resolvent, np.broadcast_to(b[:, None, :, None],
                                                       (*resolvent.shape[:-1], 1)))
    h = h[..., engine.k_obs, 0]  # (S, K)
    weight = np.full(n_harm, 2.0)  # one-sided spectrum: count +-k
    weight[0] = 1.0
    if n_samples % 2 == 0:
        weight[-1] = 1.0
    rhs = data - (problem.offset_fixed or 0.0)
    f_hat = np.fft.rfft(loads, axis=1)
    d_hat = np.fft.rfft(rhs, axis=1)
    if problem.offset_fixed is None:
        weight[0] = 0.0  # the mean is absorbed by the fitted offset
    num = np.real((f_hat * np.conj(d_hat) * weight) @ h.T) / n_samples
    den = ((np.abs(f_hat) ** 2 * weight) @ (np.abs(h) ** 2).T) / n_samples
    sst = np.sum(np.abs(d_hat) ** 2 * weight, axis=1) / n_samples
    bad = ~np.isfinite(h).all(axis=1)
    num[:, bad], den[:, bad] = np.nan, np.nan
    return num, den, sst


def _time_scores(
    engine: _Engine, problem: Problem, shapes: Array, loads: Array, data: Array
) -> tuple[Array, Array, Array]:
    """The same scores from batched simulations of a decimated record."""
    n_samples = loads.shape[1]
    stride = max(1, n_samples // _START_SAMPLES)
    sub_grid = make_grid(problem.grid.t[::stride])
    if not sub_grid.uniform or not problem.grid.uniform:
        stride, sub_grid = 1, problem.grid
    period = problem.period
    if problem.initial_state == "periodic" and period is None:
        period = float(problem.grid.t[-1] - problem.grid.t[0] + problem.grid.dt)
    sub = _Engine(engine.model_cls, sub_grid, engine.integrator, engine.initial_state,
                  period, engine.k_obs)
    f = loads[:, ::stride]
    rhs = data[:, ::stride] - (problem.offset_fixed or 0.0)
    if problem.offset_fixed is None:
        rhs = rhs - rhs.mean(axis=1, keepdims=True)
    n_cards, n_shapes = f.shape[0], shapes.shape[0]
    num = np.empty((n_cards, n_shapes))
    den = np.empty((n_cards, n_shapes))
    per_card = 8 * n_shapes * sub_grid.n * engine.n * 6
    for sl in _chunks(n_cards, max(1, _CHUNK_BYTES // per_card)):
        with np.errstate(all="ignore"):
            ys = sub.outputs(shapes[None, :, :], f[sl, None, :], sub_grid)  # (b, S, N')
        if problem.offset_fixed is None:
            ys -= ys.mean(axis=2, keepdims=True)
        num[sl] = np.einsum("bsn,bn->bs", ys, rhs[sl])
        den[sl] = np.einsum("bsn,bsn->bs", ys, ys)
    return num, den, np.sum(rhs**2, axis=1)


# =========================================================================== LM core
@dataclass
class _Spec:
    """Static layout of the free vector z = (log theta, [log C], [offset])."""

    p: int
    scale_fixed: float | None
    offset_fixed: float | None
    tol: float
    max_iter: int

    @property
    def q(self) -> int:
        return self.p + (self.scale_fixed is None) + (self.offset_fixed is None)


def _linear_start(spec: _Spec, y: Array, d: Array) -> tuple[Array, Array]:
    """Starting C and offset per card: the best ones for the start (like the single fit)."""
    b = y.shape[0]
    scale = np.full(b, spec.scale_fixed if spec.scale_fixed is not None else 1.0)
    offset = np.full(b, spec.offset_fixed if spec.offset_fixed is not None else 0.0)
    with np.errstate(all="ignore"):
        if spec.scale_fixed is None:
            if spec.offset_fixed is None:
                yc = y - y.mean(axis=1, keepdims=True)
                dc = d - d.mean(axis=1, keepdims=True)
                c = np.sum(yc * dc, axis=1) / np.sum(yc * yc, axis=1)
            else:
                dd = d - spec.offset_fixed
                c = np.sum(y * dd, axis=1) / np.sum(y * y, axis=1)
            scale = np.where(np.isfinite(c) & (c > 0), c, 1.0)
        if spec.offset_fixed is None:
            off = np.mean(d - scale[:, None] * y, axis=1)
            offset = np.where(np.isfinite(off), off, 0.0)
    return scale, offset


def _reduced(
    spec: _Spec, z: Array, y: Array, dy: Array, d: Array
) -> tuple[Array, Array, Array]:
    """Cost 0.5 |r|^2 and the triangular factor (R, Q^T r) of the residual ``C y + offset - d``
    (see :func:`pumpid.lm.reduce`).

    The LM iteration needs nothing else, so the (b, q, N) Jacobian lives only here.
    """
    p, q = spec.p, spec.q
    scale = np.exp(z[:, p]) if spec.scale_fixed is None else np.full(z.shape[0],
                                                                       spec.scale_fixed)
    offset = z[:, -1] if spec.offset_fixed is None else spec.offset_fixed
    # Jacobian rows per free variable and the residual as one more row (b, q + 1, N): the
    # layout lm.reduce factors in one QR per card.
    rows = np.empty((y.shape[0], q + 1, y.shape[1]))
    np.multiply(dy, (scale[:, None] * np.exp(z[:, :p]))[:, :, None], out=rows[:, :p])
    col = p
    if spec.scale_fixed is None:
        np.multiply(y, scale[:, None], out=rows[:, col])
        col += 1
    if spec.offset_fixed is None:
        rows[:, col] = 1.0
    r = rows[:, q]
    np.multiply(y, scale[:, None], out=r)
    r += (offset[:, None] if np.ndim(offset) else offset) - d
    return lm.reduce_rows(rows)


def _lm_chunk(
    engine: _Engine, spec: _Spec, theta0: Array, f: Array, d: Array, lo: Array, hi: Array,
    ref: Array,
) -> dict[str, Array]:
    """Levenberg-Marquardt (:func:`pumpid.lm.solve`) over the cards of one chunk.

    ``lo``/``hi`` bound the log-parameters (the search window); each trial point is one
    batched simulation with sensitivities, reduced at once to the triangular factor of
    ``[J r]`` (:func:`pumpid.lm.reduce_rows`).
    """
    b = theta0.shape[0]
    p, q = spec.p, spec.q
    def far(z_log: Array, idx: NDArray[np.intp]) -> NDArray[np.bool_]:
        return np.any(np.abs(z_log - ref[idx]) > SPECTRAL_RANGE, axis=1)

    with np.errstate(all="ignore"):
        y, dy = engine.evaluate(theta0, f, far(np.log(theta0), np.arange(b)))
    scale0, offset0 = _linear_start(spec, y, d)
    z = np.empty((b, q))
    z[:, :p] = np.log(theta0)
    z_lo = np.full((b, q), -np.inf)
    z_hi = np.full((b, q), np.inf)
    z_lo[:, :p], z_hi[:, :p] = lo, hi
    col = p
    if spec.scale_fixed is None:
        z[:, col] = np.log(scale0)
        z_lo[:, col], z_hi[:, col] = -lm.LOG_MAX, lm.LOG_MAX
        col += 1
    if spec.offset_fixed is None:
        z[:, col] = offset0
    with np.errstate(all="ignore"):
        first = _reduced(spec, z, y, dy, d)

    def evaluate(z_try: Array, idx: NDArray[np.intp]) -> tuple[Array, Array, Array]:
        y, dy = engine.evaluate(np.exp(z_try[:, :p]), f[idx], far(z_try[:, :p], idx))
        return _reduced(spec, z_try, y, dy, d[idx])

    res = lm.solve(evaluate, z, first, z_lo, z_hi, n_capped=p, tol=spec.tol,
                   max_evaluations=spec.max_iter)
    # code: 0 converged, 2 max_iter, 3 failed
    return {"z": res.z, "r_ss": 2.0 * res.cost, "iterations": res.evaluations,
            "code": res.code}


# =========================================================================== entry point
@single_threaded
def fit_many(
    model: Model | type[Model],
    t: ArrayLike,
    loads: ArrayLike,
    displacements: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
    scale: float | str = 1.0,
    offset: bool | float = False,
    period: float | None = None,
    x0: ArrayLike | None = None,
    tol: float = 1e-12,
    max_iter: int = 100,
    chunk: int | None = None,
    workers: int = 1,
) -> BatchResult:
    """Fit one model structure to many cards sharing a time grid.

    Parameters
    ----------
    model : Model instance or Model class
        An instance is the shared starting guess for every card; a class asks for an
        automatic start per card (the best of a grid of dimensionless model shapes, each
        amplitude-matched to the card; the two best are tried when the first does not
        converge).
    t : array_like, shape (N,)
        Shared sample times (s), strictly increasing, N >= 10.
    loads, displacements : array_like, shape (cards, N)
        One card per row (a single 1-D record counts as one card).
    observe, initial_state, integrator, scale, offset, period
        As for :func:`pumpid.fit` (``scale`` a positive number or ``"free"``; with the scale
        symmetry and a load-driven state, a free scale is fixed to the gauge C = 1).
    x0 : array_like, shape (cards, p) or (p,), optional
        Starting parameters per card (or shared), canonical order; overrides the model's.
    tol : float
        Relative tolerance of the stop tests (step, cost reduction, gradient cosine).
    max_iter : int
        Maximum LM trial points per card.
    chunk : int, optional
        Cards per vectorized chunk; by default chosen so that one chunk's working arrays
        stay around 64 MB (memory does not grow with the number of cards).
    workers : int
        Threads working on different chunks (numpy releases the GIL in its array
        operations, so two workers use two cores). Results do not depend on it.

    Returns
    -------
    BatchResult
        Per-card parameters, scale, offset, status and fit quality. A card whose fit fails
        (including one the model cannot simulate) does not raise: its status is "failed"
        and its values are NaN, and the other cards are fitted as usual. Bad input (shapes,
        non-finite values, constant records, options) raises ``ValueError`` naming the
        offending cards.
    """
    if isinstance(model, Model):
        cls: type[Model] = type(model)
        shared: Array | None = model.values
    elif isinstance(model, type) and issubclass(model, Model):
        cls, shared = model, None
    else:
        raise TypeError(
            "model must be a model instance (a shared starting guess, e.g. Kelvin(k0=4, m=1, "
            f"c1=0.2, k1=4)) or a model class (automatic start per card), got {model!r}"
        )
    grid = make_grid(t, min_samples=1)
    if grid.n < MIN_SAMPLES:
        raise ValueError(f"t: {grid.n} samples; a fit needs at least {MIN_SAMPLES}")
    f_all = _as_cards("loads", loads, grid.n)
    d_all = _as_cards("displacements", displacements, grid.n)
    if f_all.shape != d_all.shape:
        raise ValueError(
            f"loads has {f_all.shape[0]} cards but displacements has {d_all.shape[0]}"
        )
    if not (isinstance(max_iter, int | np.integer) and max_iter >= 1):
        raise ValueError(f"max_iter must be a positive integer, got {max_iter!r}")
    if not (math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be positive, got {tol!r}")
    n_cards = f_all.shape[0]
    x0_state = _initial_state_vector(cls, initial_state)
    _check_cards(f_all, d_all, x0_state is None, 1024)
    # The options are validated (and the gauge decided) exactly as for a single fit.
    problem = build_problem(cls, grid.t, f_all[0], d_all[0], observe=observe,
                            initial_state=initial_state, integrator=integrator, scale=scale,
                            offset=offset, period=period)
    p = len(cls.param_names())
    theta_start: Array | None = None
    if x0 is not None:
        arr = np.asarray(x0, dtype=float)
        if arr.ndim == 1:
            arr = np.broadcast_to(arr, (n_cards, arr.size))
        if arr.shape != (n_cards, p):
            raise ValueError(f"x0: expected shape ({n_cards}, {p}) or ({p},), got {arr.shape}")
        if not (np.isfinite(arr).all() and (arr > 0).all()):
            raise ValueError("x0: starting parameters must be positive and finite")
        theta_start = arr
    elif shared is not None:
        theta_start = np.broadcast_to(shared, (n_cards, p))

    engine = _Engine(cls, grid, integrator, problem.initial_state, period,
                     cls.output_index(problem.observe))
    spec = _Spec(p, problem.scale_fixed, problem.offset_fixed, float(tol), int(max_iter))
    size = int(chunk) if chunk is not None else _default_chunk(engine, grid.n)
    if size < 1:
        raise ValueError(f"chunk must be a positive integer, got {chunk!r}")

    out_z = np.full((n_cards, spec.q), np.nan)
    out_ss = np.full(n_cards, np.nan)
    out_it = np.zeros(n_cards, dtype=np.int64)
    out_code = np.full(n_cards, 3, dtype=np.int8)
    out_edge = np.zeros(n_cards, dtype=bool)
    out_start = np.full((n_cards, p), np.nan)
    ref_scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0

    def work(sl: slice) -> None:
        f, d = f_all[sl], d_all[sl]
        ref = _reference_logs(problem, f, d, ref_scale)
        if theta_start is not None:
            starts = [np.array(theta_start[sl], dtype=float)]
        else:
            starts = list(_grid_starts(engine, problem, f, d, keep=2))
        best: dict[str, Array] | None = None
        best_edge = np.zeros(f.shape[0], dtype=bool)
        for theta0 in starts:
            todo = np.arange(f.shape[0]) if best is None else np.flatnonzero(
                (best["code"] != 0) | best_edge)
            if todo.size == 0:
                break
            z0 = np.log(theta0[todo])
            lo = np.minimum(ref[todo] - lm.WINDOW, z0 - 1.0)
            hi = np.maximum(ref[todo] + lm.WINDOW, z0 + 1.0)
            res = _lm_chunk(engine, spec, theta0[todo], f[todo], d[todo], lo, hi, ref[todo])
            zt = res["z"][:, :p]
            edge = ((zt <= lo) | (zt >= hi)).any(axis=1)
            if best is None:
                best, best_edge = res, edge
                best["start"] = theta0
                continue
            # A later start replaces the earlier result only where it is better.
            old_cost = np.where(np.isfinite(best["r_ss"][todo]), best["r_ss"][todo], np.inf)
            better = (res["code"] != 3) & (np.nan_to_num(res["r_ss"], nan=np.inf) < old_cost
                                           * (1 - 1e-9)) | ((best["code"][todo] == 3)
                                                            & (res["code"] != 3))
            tgt = todo[better]
            for key in ("z", "r_ss", "iterations", "code"):
                best[key][tgt] = res[key][better]
            best["iterations"][todo[~better]] += res["iterations"][~better]
            best_edge[tgt] = edge[better]
            best["start"][tgt] = theta0[tgt]
        assert best is not None
        out_z[sl] = best["z"]
        out_ss[sl] = best["r_ss"]
        out_it[sl] = best["iterations"]
        out_code[sl] = best["code"]
        out_edge[sl] = best_edge
        out_start[sl] = best["start"]

    def guarded(sl: slice) -> None:
        # One card the model cannot simulate (a singular solve deep in numpy) must not sink
        # the others: its chunk is redone card by card, and that card alone is "failed".
        try:
            work(sl)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            if sl.stop - sl.start > 1:
                for i in range(sl.start, sl.stop):
                    guarded(slice(i, i + 1))
            else:
                out_z[sl], out_ss[sl], out_code[sl] = np.nan, np.nan, 3

    slices = list(_chunks(n_cards, size))
    n_workers = max(1, min(int(workers), len(slices), os.cpu_count() or 1))
    if n_workers == 1:
        for sl in slices:
            guarded(sl)
    else:
        with ThreadPoolExecutor(n_workers) as pool:
            list(pool.map(guarded, slices))

    theta = np.exp(out_z[:, :p])
    col = p
    if spec.scale_fixed is None:
        scale_arr = np.exp(out_z[:, col])
        col += 1
    else:
        scale_arr = np.full(n_cards, spec.scale_fixed)
    offset_arr = out_z[:, col] if spec.offset_fixed is None else np.full(n_cards,
                                                                          spec.offset_fixed)
    status = np.array(STATUSES, dtype=object)[
        np.where(out_code == 0, np.where(out_edge, 1, 0), np.where(out_code == 2, 2, 3))
    ].astype(str)
    failed = status == "failed"
    theta[failed] = np.nan
    scale_arr = np.where(failed, np.nan, scale_arr)
    offset_arr = np.where(failed, np.nan, offset_arr)
    out_ss = np.where(failed, np.nan, out_ss)
    sst = np.empty(n_cards)
    for sl in _chunks(n_cards, 1024):
        dd = d_all[sl]
        sst[sl] = np.sum((dd - dd.mean(axis=1, keepdims=True)) ** 2, axis=1)
    with np.errstate(all="ignore"):
        r2 = 1.0 - out_ss / sst
    return BatchResult(
        model_name=cls.__name__,
        param_names=cls.param_names(),
        params={name: theta[:, i].copy() for i, name in enumerate(cls.param_names())},
        scale=scale_arr,
        offset=offset_arr,
        converged=status == "converged",
        status=status,
        iterations=out_it,
        rmse=np.sqrt(out_ss / grid.n),
        r2=r2,
        cost=0.5 * out_ss,
        start=out_start,
        gauge_fixed=problem.gauge_fixed,
        options={"observe": problem.observe, "initial_state": initial_state,
                 "integrator": integrator, "scale": scale, "offset": offset, "period": period,
                 "tol": tol, "max_iter": max_iter, "chunk": size, "workers": n_workers},
    )
