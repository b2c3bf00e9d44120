"""Automatic starting points: no guess needed.

The physical models are linear ODEs, so their transfer-function coefficients follow from a
*linear* least-squares problem (equation error), as in continuous-time system identification:

* records that start from a state (rest, equilibrium, a given one) are passed through a
  state-variable filter ``lambda^n / (s + lambda)^n``, which gives smooth derivatives of the
  displacement and the load without differentiating noisy data; unknown initial conditions
  and a position offset enter as a few extra regressors (``t^j exp(-lambda t)`` and a filtered
  constant), so the estimate does not depend on knowing them;
* periodic strokes are fitted over their harmonics, where ``s = i k omega`` is exact.

Each model maps its coefficients back to physical parameters in closed form (its
``equation_error`` forms). Several filter bandwidths give several candidates; the model's
shape grid (amplitude-matched to each card) and a heuristic add more. Every candidate is
ranked by its cost with the best linear scale and offset; the best few are polished by a
short Levenberg-Marquardt run (a multistart against local minima) and the best polished
point is the start. All of it runs for every card of a problem at once.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import drive, kernel, lm
from .compiled import jit
from .problem import WINDOW, Problem
from .solvers import LevenbergMarquardt, SolverOutcome
from .threads import run_chunks

__all__ = [
    "StartPlan",
    "Starts",
    "WidePlan",
    "candidates",
    "complete",
    "find_starts",
    "harmonic_scan",
    "search_wider",
    "to_z",
    "walk_valley",
]

Array = NDArray[np.float64]

#: Filter bandwidths of the equation-error candidates, in record fundamentals.
_BANDWIDTHS = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0)
#: Highest harmonic used by the periodic equation error.
_HARMONICS = 40


# --------------------------------------------------------------------------- compiled
@jit
def _svf(t, x, lam, order, uniform):
    """Filtered derivatives ``s^k lam^n / (s + lam)^n x``, k = 0..n, from rest (exact FOH)."""
    n = order
    a = np.zeros((1, n, n))
    b = np.zeros((1, n))
    for r in range(n - 1):
        a[0, r, r + 1] = 1.0
    coeffs = np.empty(n)
    binom = 1.0
    for j in range(n):
        # binom = n choose j, built up as j grows
        coeffs[j] = binom * lam ** (n - j)
        binom = binom * (n - j) / (j + 1)
        a[0, n - 1, j] = -coeffs[j]
    b[0, n - 1] = 1.0
    phi = np.empty((1, n, n))
    g0 = np.empty((1, n))
    g1 = np.empty((1, n))
    w = np.zeros((1, n))
    wn = np.empty((1, n))
    out = np.empty((t.size, n + 1))
    scale = lam**n
    kernel.discretize(a, b, t[1] - t[0], kernel.EXACT, phi, g0, g1)
    for k in range(t.size):
        if k > 0:
            if not uniform:
                kernel.discretize(a, b, t[k] - t[k - 1], kernel.EXACT, phi, g0, g1)
            for r in range(n):
                s = g0[0, r] * x[k - 1] + g1[0, r] * x[k]
                for c in range(n):
                    s += phi[0, r, c] * w[0, c]
                wn[0, r] = s
            w[:] = wn
        top = x[k]
        for j in range(n):
            out[k, j] = w[0, j] * scale
            top -= coeffs[j] * w[0, j]
        out[k, n] = top * scale
    return out


@jit
def _lstsq(mat, target):
    """Least squares with unit-norm columns; NaN when there is nothing to solve."""
    ncol = mat.shape[1]
    norms = np.empty(ncol)
    for j in range(ncol):
        s = 0.0
        for i in range(mat.shape[0]):
            s += mat[i, j] * mat[i, j]
        norms[j] = math.sqrt(s)
    keep = norms > 0.0
    coef = np.zeros(ncol)
    if not np.any(keep) or not np.all(np.isfinite(mat)) or not np.all(np.isfinite(target)):
        return np.full(ncol, math.nan)
    cols = np.flatnonzero(keep)
    sub = np.empty((mat.shape[0], cols.size))
    for jj in range(cols.size):
        sub[:, jj] = mat[:, cols[jj]] / norms[cols[jj]]
    sol = np.linalg.lstsq(sub, target)[0]
    for jj in range(cols.size):
        coef[cols[jj]] = sol[jj] / norms[cols[jj]]
    return coef


@jit
def _time_coefs(t, y, f, lam, form, uniform):
    target_f, target_order, y_orders, f_orders, order = form
    n = order
    tt = t - t[0]
    yf = _svf(tt, y, lam, n, uniform)
    ff = _svf(tt, f, lam, n, uniform)
    onesf = _svf(tt, np.ones(t.size), lam, n, uniform)
    ncoef = y_orders.size + f_orders.size
    mat = np.empty((t.size, ncoef + n + 1))
    for j in range(y_orders.size):
        mat[:, j] = yf[:, y_orders[j]]
    for j in range(f_orders.size):
        mat[:, y_orders.size + j] = ff[:, f_orders[j]]
    # Unknown initial conditions (and the filter's start-up) appear as t^j exp(-lam t).
    for j in range(n):
        for k in range(t.size):
            mat[k, ncoef + j] = math.exp(-lam * tt[k]) * (lam * tt[k]) ** j
    mat[:, ncoef + n] = onesf[:, 0]
    # A contiguous copy: _lstsq then has one signature for both equation errors.
    target = (ff[:, target_order] if target_f else yf[:, target_order]).copy()
    return _lstsq(mat, target)[:ncoef]


@jit
def _dft(x, kmax):
    n = x.size
    out = np.empty(kmax + 1, np.complex128)
    for k in range(kmax + 1):
        s = 0.0 + 0.0j
        w = -2.0 * math.pi * k / n
        for j in range(n):
            s += x[j] * complex(math.cos(w * j), math.sin(w * j))
        out[k] = s / n
    return out


@jit
def _harmonic_rows(yk, fk, period, weights, form, first):
    """The equation-error system over harmonics first..K, each weighted by ``weights[k]``:
    real and imaginary parts stacked (2 rows, K + 1 - first); the matrix and the target."""
    target_f, target_order, y_orders, f_orders, _order = form
    kmax = yk.size - 1
    ncoef = y_orders.size + f_orders.size
    rows = kmax + 1 - first
    mat = np.empty((2 * rows, ncoef))
    target = np.empty(2 * rows)
    for i in range(rows):
        k = first + i
        s = 2j * math.pi * k / period
        weight = weights[k]
        for j in range(y_orders.size):
            v = weight * s ** y_orders[j] * yk[k]
            mat[i, j] = v.real
            mat[rows + i, j] = v.imag
        for j in range(f_orders.size):
            v = weight * s ** f_orders[j] * fk[k]
            mat[i, y_orders.size + j] = v.real
            mat[rows + i, y_orders.size + j] = v.imag
        tv = (fk[k] if target_f else yk[k]) * s**target_order * weight
        target[i] = tv.real
        target[rows + i] = tv.imag
    return mat, target


@jit
def _harmonic_coefs(yk, fk, period, lam, form, first):
    """Equation error over the harmonics ``yk``, ``fk`` (k = 0..K) at bandwidth ``lam``."""
    order = form[4]
    weights = np.ones(yk.size, np.complex128)
    for k in range(first, yk.size):
        s = 2j * math.pi * k / period
        weights[k] = (lam / (s + lam)) ** order
    mat, target = _harmonic_rows(yk, fk, period, weights, form, first)
    return _lstsq(mat, target)


@jit
def _denominator(coef, form):
    """The monic denominator D(s) (coefficients by power, D[order] = 1) that an
    equation-error estimate puts on the displacement; NaN when there is none."""
    target_f, target_order, y_orders, _f_orders, order = form
    poly = np.zeros(order + 1)
    if target_f:
        for j in range(y_orders.size):
            poly[y_orders[j]] += coef[j]
    else:
        poly[target_order] += 1.0
        for j in range(y_orders.size):
            poly[y_orders[j]] -= coef[j]
    lead = poly[order]
    if lead == 0.0 or not np.all(np.isfinite(poly)):
        return np.full(order + 1, math.nan)
    return poly / lead


@jit
def _stable(poly):
    """All roots of the monic polynomial (coefficients by power) in the left half-plane."""
    if not np.all(np.isfinite(poly)):
        return False
    roots = np.roots(poly[::-1].astype(np.complex128))
    for r in roots:
        if not r.real < 0.0:
            return False
    return True


@jit
def _filter_den(t, x, poly, uniform):
    """``s^k x / D(s)``, k = 0..n, from rest (exact first-order hold), D monic of order n."""
    n = poly.size - 1
    a = np.zeros((1, n, n))
    b = np.zeros((1, n))
    for r in range(n - 1):
        a[0, r, r + 1] = 1.0
    for j in range(n):
        a[0, n - 1, j] = -poly[j]
    b[0, n - 1] = 1.0
    phi = np.empty((1, n, n))
    g0 = np.empty((1, n))
    g1 = np.empty((1, n))
    w = np.zeros(n)
    wn = np.empty(n)
    out = np.empty((t.size, n + 1))
    kernel.discretize(a, b, t[1] - t[0], kernel.EXACT, phi, g0, g1)
    for k in range(t.size):
        if k > 0:
            if not uniform:
                kernel.discretize(a, b, t[k] - t[k - 1], kernel.EXACT, phi, g0, g1)
            for r in range(n):
                s = g0[0, r] * x[k - 1] + g1[0, r] * x[k]
                for c in range(n):
                    s += phi[0, r, c] * w[c]
                wn[r] = s
            w[:] = wn
        top = x[k]
        for j in range(n):
            out[k, j] = w[j]
            top -= poly[j] * w[j]
        out[k, n] = top
    return out


@jit
def _refine_time(t, y, f, coef, form, uniform, offset_free, iterations):
    """Steiglitz-McBride refinement of a time-domain equation-error estimate.

    The fixed filter ``lam^n / (s + lam)^n`` weights the equation error unevenly; filtering
    by ``1 / D(s)`` of the current estimate instead turns the equation error into the
    output error at convergence (Steiglitz and McBride's iteration, in continuous time).
    The record must start from rest (or from equilibrium, passed as deviations).
    """
    target_f, target_order, y_orders, f_orders, _order = form
    ncoef = y_orders.size + f_orders.size
    best = coef.copy()
    for _ in range(iterations):
        poly = _denominator(best, form)
        if not _stable(poly):
            break
        yf = _filter_den(t, y, poly, uniform)
        ff = _filter_den(t, f, poly, uniform)
        extra = 1 if offset_free else 0
        mat = np.empty((t.size, ncoef + extra))
        for j in range(y_orders.size):
            mat[:, j] = yf[:, y_orders[j]]
        for j in range(f_orders.size):
            mat[:, y_orders.size + j] = ff[:, f_orders[j]]
        if offset_free:
            mat[:, ncoef] = _filter_den(t, np.ones(t.size), poly, uniform)[:, 0]
        target = (ff[:, target_order] if target_f else yf[:, target_order]).copy()
        new = _lstsq(mat, target)[:ncoef]
        if not np.all(np.isfinite(new)):
            break
        change = _largest_relative_change(new, best, ncoef)
        best = new
        if change < 1e-8:
            break
    return best


@jit
def _largest_relative_change(new, old, n):
    """max_j |new_j - old_j| / |old_j| over the first n coefficients."""
    change = 0.0
    for j in range(n):
        change = max(change, abs(new[j] - old[j]) / max(abs(old[j]), 1e-300))
    return change


@jit
def _refine_harmonic(yk, fk, period, coef, form, first, iterations):
    """:func:`_refine_time` over a periodic card's harmonics (weights 1 / D(i k w))."""
    order = form[4]
    ncoef = form[2].size + form[3].size
    best = coef.copy()
    weights = np.ones(yk.size, np.complex128)
    for _ in range(iterations):
        poly = _denominator(best, form)
        if not _stable(poly):
            break
        for k in range(first, yk.size):
            s = 2j * math.pi * k / period
            den = 0.0 + 0.0j
            for j in range(order, -1, -1):
                den = den * s + poly[j]
            weights[k] = 1.0 / den
        mat, target = _harmonic_rows(yk, fk, period, weights, form, first)
        new = _lstsq(mat, target)
        if not np.all(np.isfinite(new)):
            break
        change = _largest_relative_change(new, best, ncoef)
        best = new
        if change < 1e-8:
            break
    return best


def _periodic_cards(cards: NDArray[np.int64], data: tuple[Any, ...]) -> NDArray[np.bool_]:
    """Which cards are one uniformly sampled period (their equation error uses harmonics)."""
    t_all, _f, _d, bounds, mode, _x0, period, uniform = data
    out = np.zeros(cards.size, dtype=bool)
    for i, k in enumerate(cards):
        a, b = int(bounds[k]), int(bounds[k + 1])
        out[i] = bool(b - a >= 2 and mode[k] == kernel.PERIODIC and uniform[k]
                      and abs(period[k] - (b - a) * (t_all[a + 1] - t_all[a]))
                      <= 1e-6 * period[k])
    return out


def equation_error_items(cards: NDArray[np.int64], lams: Array, data: tuple[Any, ...],
                         form: tuple[Any, ...], scale: float, offset_free: bool) -> Array:
    """Equation-error coefficients (m, 2 L, c) for cards (m,) at bandwidths lams (m, L): the
    estimate at each bandwidth, then its Steiglitz-McBride refinement (NaN where none).

    A periodic stroke's estimate works on its harmonics, any other record's in time: two
    compiled functions, so a first run compiles only the one its cards need (the time
    domain's filters were a quarter of a periodic card's compile).
    """
    cards = np.ascontiguousarray(cards, dtype=np.int64)
    lams = np.ascontiguousarray(lams, dtype=float)
    ncoef = form[2].size + form[3].size
    out = np.full((cards.size, 2 * lams.shape[1], ncoef), math.nan)
    periodic = _periodic_cards(cards, data)
    for kind, which in ((_harmonic_items, periodic), (_time_items, ~periodic)):
        if np.any(which):
            out[which] = kind(cards[which], lams[which], data, form, scale, offset_free)
    return out


@jit
def _harmonic_items(cards, lams, data, form, scale, offset_free):
    """:func:`equation_error_items` for periodic strokes (see :func:`_periodic_cards`)."""
    _t_all, f_all, d_all, bounds, _mode, _x0, period, _uniform = data
    ncoef = form[2].size + form[3].size
    m, n_lam = lams.shape
    out = np.full((m, 2 * n_lam, ncoef), math.nan)
    first = 0 if not offset_free else 1
    for i in range(m):
        k = cards[i]
        a, b = bounds[k], bounds[k + 1]
        # Writable copies, like y: one signature of the helpers for both signals.
        f = f_all[a:b].copy()
        y = d_all[a:b] / scale
        # The harmonics once per card; every bandwidth reuses them.
        kmax = min(y.size // 2, _HARMONICS)
        yk = _dft(y, kmax)
        fk = _dft(f, kmax)
        for li in range(n_lam):
            lam = lams[i, li]
            if not lam > 0.0:
                continue
            coef = _harmonic_coefs(yk, fk, period[k], lam, form, first)
            out[i, li] = coef
            if np.all(np.isfinite(coef)):
                out[i, n_lam + li] = _refine_harmonic(yk, fk, period[k], coef, form, first, 8)
    return out


@jit
def _time_items(cards, lams, data, form, scale, offset_free):
    """:func:`equation_error_items` for records that are not one periodic stroke."""
    t_all, f_all, d_all, bounds, mode, _x0, _period, uniform = data
    ncoef = form[2].size + form[3].size
    m, n_lam = lams.shape
    out = np.full((m, 2 * n_lam, ncoef), math.nan)
    for i in range(m):
        k = cards[i]
        a, b = bounds[k], bounds[k + 1]
        t = t_all[a:b]
        f = f_all[a:b].copy()
        y = d_all[a:b] / scale
        # A record from rest (or from equilibrium, as deviations) can be refined in time.
        refine_time = mode[k] == kernel.REST or mode[k] == kernel.EQUILIBRIUM
        y_dev = y - y[0] if mode[k] == kernel.EQUILIBRIUM else y
        f_dev = f - f[0] if mode[k] == kernel.EQUILIBRIUM else f
        tt = t - t[0]
        for li in range(n_lam):
            lam = lams[i, li]
            if not lam > 0.0:
                continue
            coef = _time_coefs(t, y, f, lam, form, uniform[k])
            out[i, li] = coef
            if refine_time and np.all(np.isfinite(coef)):
                out[i, n_lam + li] = _refine_time(
                    tt, y_dev, f_dev, coef, form, uniform[k],
                    offset_free and mode[k] == kernel.REST, 8)
    return out


@jit
def _complex_solve(a, b):
    """x = a^-1 b for a small complex matrix (Gaussian elimination, partial pivoting)."""
    n = a.shape[0]
    m = a.copy()
    x = b.copy()
    for k in range(n):
        p = k
        big = abs(m[k, k])
        for r in range(k + 1, n):
            if abs(m[r, k]) > big:
                big = abs(m[r, k])
                p = r
        if big == 0.0:
            return x, False
        if p != k:
            for c in range(n):
                tmp = m[k, c]
                m[k, c] = m[p, c]
                m[p, c] = tmp
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
        for r in range(k + 1, n):
            f = m[r, k] / m[k, k]
            for c in range(k, n):
                m[r, c] -= f * m[k, c]
            x[r] -= f * x[k]
    for k in range(n - 1, -1, -1):
        s = x[k]
        for c in range(k + 1, n):
            s -= m[k, c] * x[c]
        x[k] = s / m[k, k]
    return x, True


@jit
def harmonic_scan(t, f, d, shapes, code, n, obs, offset_free, symmetric, scale, kmax):
    """Cost of parameter shapes on a periodic card by its harmonics (a fast ranking).

    The card's load and data are taken to their first ``kmax`` harmonics; each shape's
    response at harmonic k is ``H(i k w) F_k`` with H the model's continuous transfer
    function (close to the exact discrete one at the harmonics that carry a card). For a
    scale-symmetric model on a fixed scale the amplitude is free: the best one is solved
    for and the shape rescaled to it (returned as the factor). The offset, when free, takes
    the mean. Returns (costs (S,), factors (S,)).
    """
    n_samples = t.size
    period = (t[n_samples - 1] - t[0]) * n_samples / (n_samples - 1)
    kmax = min(kmax, n_samples // 2)
    first = 1 if offset_free else 0
    nk = kmax + 1 - first
    fk = np.empty(nk, np.complex128)
    dk = np.empty(nk, np.complex128)
    for i in range(nk):
        k = first + i
        sf = 0.0 + 0.0j
        sd = 0.0 + 0.0j
        w = -2.0 * math.pi * k / n_samples
        for j in range(n_samples):
            e = complex(math.cos(w * j), math.sin(w * j))
            sf += f[j] * e
            sd += d[j] * e
        fk[i] = sf
        dk[i] = sd
    s_count = shapes.shape[0]
    costs = np.full(s_count, math.inf)
    factors = np.ones(s_count)
    free = np.zeros(0, np.int64)
    a = np.empty((1, n, n))
    b = np.empty((1, n))
    eye = np.eye(n).astype(np.complex128)
    y = np.empty(nk, np.complex128)
    for s in range(s_count):
        ok = True
        for j in range(shapes.shape[1]):
            if not (shapes[s, j] > 0.0):
                ok = False
        if not ok:
            continue
        kernel.system(np.log(shapes[s]), free, code, a, b)
        bc = b[0].astype(np.complex128)
        for i in range(nk):
            k = first + i
            om = 2.0 * math.pi * k / period
            x, good = _complex_solve(1j * om * eye - a[0], bc)
            if not good:
                ok = False
                break
            y[i] = x[obs] * fk[i]
        if not ok:
            continue
        amp = scale
        if symmetric:
            num = 0.0
            den = 0.0
            for i in range(nk):
                num += (y[i].conjugate() * dk[i]).real
                den += abs(y[i]) ** 2
            if not (den > 0.0 and num > 0.0):
                continue
            amp = num / den
        total = 0.0
        for i in range(nk):
            total += abs(amp * y[i] - dk[i]) ** 2
        if math.isfinite(total):
            costs[s] = total
            factors[s] = scale / amp
    return costs, factors


# --------------------------------------------------------------------------- candidates
def _bandwidths(problem: Problem, cards: NDArray[np.int64]) -> Array:
    """The state-variable filters' bandwidths per card (NaN where a card has fewer)."""
    lams = np.full((cards.size, len(_BANDWIDTHS)), math.nan)
    for i, k in enumerate(cards):
        t, _f, _d = problem.card(int(k))
        base = 2 * math.pi / float(t[-1] - t[0])
        dt_min = float(np.min(np.diff(t)))
        ok = [base * b for b in _BANDWIDTHS if base * b * dt_min < 0.5] or [0.5 / dt_min]
        lams[i, : len(ok)] = ok
    return lams


def _equation_error(problem: Problem, cards: NDArray[np.int64], lams: Array,
                    model: type, observe: str | None) -> Array | None:
    """Parameter rows (cards x bandwidths, p) of a model's equation-error estimates on the
    problem's cards, or None when the model has no form for that output."""
    form = model.equation_error.get(observe or model.default_output)
    if form is None:
        return None
    data, _model, _settings = problem.arrays
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    packed = (form.target[0] == "f", int(form.target[1]),
              np.array(form.y_orders, dtype=np.int64),
              np.array(form.f_orders, dtype=np.int64), int(form.order))
    coefs = equation_error_items(cards, lams, data, packed, float(scale),
                                 problem.offset_fixed is None)
    return form.to_theta(coefs.reshape(-1, form.n_coef))

def _fundamental(problem: Problem, k: int) -> float:
    t, _f, _d = problem.card(k)
    span = float(t[-1] - t[0])
    if np.isfinite(problem.period[k]):
        span = float(problem.period[k])
    return 2 * math.pi / span


def _heuristic(problem: Problem, k: int) -> Array:
    """A rough physical guess from the record's amplitude ratio and length."""
    _t, f, d = problem.card(k)
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    gain = float(np.ptp(d / scale)) / max(float(np.ptp(f)), 1e-300)
    gain = gain if gain > 0 else 1.0
    omega = 3 * _fundamental(problem, k)
    stiff = 1.0 / gain
    shapes = problem.model.shape_grid(omega)
    # The middle shape of the model's grid, at the record's stiffness level.
    mid = shapes[shapes.shape[0] // 2]
    return mid * _stiffness_factor(problem, stiff)


def _stiffness_factor(problem: Problem, stiff: float) -> Array:
    """Multiplier per parameter bringing unit-stiffness shapes to stiffness ``stiff``."""
    out = np.ones(problem.n_params)
    for i, info in enumerate(problem.model.param_info()):
        if info.unit.startswith("{load}"):
            out[i] = stiff
    return out


def candidates(problem: Problem, cards: NDArray[np.int64]
               ) -> tuple[Array, NDArray[np.int64], list[str], NDArray[np.int64]]:
    """Candidate parameter sets for the given cards.

    Returns the candidates (m, p), the card of each (m,), the kinds present and the kind of
    each candidate (m,) as an index into them.
    """
    model = problem.model
    rows: list[Array] = []
    owners: list[NDArray[np.int64]] = []
    kinds: list[str] = []
    kind_of: list[NDArray[np.int64]] = []
    if problem.residual == "linear":
        lams = _bandwidths(problem, cards)
        theta = _equation_error(problem, cards, lams, model, problem.observe)
        if theta is not None:
            kinds.append("equation error")
            good = np.all(np.isfinite(theta) & (theta > 0), axis=1)
            rows.append(theta[good])
            owners.append(np.repeat(cards, 2 * lams.shape[1])[good])
            kind_of.append(np.full(int(good.sum()), len(kinds) - 1, dtype=np.int64))
        # The limiting models: their own equation-error estimates, mapped to a full-model
        # point next to the limit (the model's own map: a factor 1000 toward it). When the
        # data want a limit the fit starts near it instead of crawling toward it, and it can
        # still come back when they do not.
        names = model.param_names()
        for lim in model.limits:
            if lim.reduced is None or not lim.from_reduced or lim.param not in names:
                continue
            from ..models import model_class

            reduced = model_class(lim.reduced)
            red = _equation_error(problem, cards, lams, reduced, lim.observe)
            if red is None:
                continue
            owner = np.repeat(cards, 2 * lams.shape[1])
            mapped = []
            for row, k in zip(red, owner, strict=True):
                if not np.all(np.isfinite(row) & (row > 0)):
                    continue
                point = lim.full_point(dict(zip(reduced.param_names(), row.tolist(),
                                                strict=True)))
                if point is None:
                    continue
                mapped.append((np.array([point[n] for n in names]), k))
            if mapped:
                arrow = "inf" if lim.direction == "infinity" else "0"
                kinds.append(f"limit {lim.param} -> {arrow}")
                rows.append(np.array([m for m, _k in mapped]))
                owners.append(np.array([k for _m, k in mapped], dtype=np.int64))
                kind_of.append(np.full(len(mapped), len(kinds) - 1, dtype=np.int64))
    if problem.residual == "linear":
        kinds.append("shape grid")
        for k in cards:
            shapes = model.shape_grid(_fundamental(problem, int(k)))
            rows.append(shapes)
            owners.append(np.full(shapes.shape[0], k, dtype=np.int64))
            kind_of.append(np.full(shapes.shape[0], len(kinds) - 1, dtype=np.int64))
    kinds.append("heuristic")
    rows.append(np.array([_heuristic(problem, int(k)) for k in cards]))
    owners.append(np.asarray(cards, dtype=np.int64))
    kind_of.append(np.full(cards.size, len(kinds) - 1, dtype=np.int64))
    theta = np.concatenate(rows)
    owner = np.concatenate(owners)
    if problem.fixed:
        for i, value in problem.fixed:
            theta[:, i] = value
    return theta, owner, kinds, np.concatenate(kind_of)


# --------------------------------------------------------------------------- ranking
def to_z(problem: Problem, theta: Array) -> Array:
    """Solver coordinates (m, q) for parameter rows (m, p); scale and offset left at 0/1."""
    m = theta.shape[0]
    z = np.zeros((m, problem.q))
    with np.errstate(divide="ignore", invalid="ignore"):
        z[:, : problem.n_free] = np.log(theta[:, problem.free_idx])
    return z


def complete(problem: Problem, cards: NDArray[np.int64], theta: Array,
             rescale: bool = True, workers: int | None = 1) -> tuple[Array, Array]:
    """Points with their best linear scale and offset, and their costs."""
    z = to_z(problem, theta)
    data, model, settings = problem.arrays
    do_rescale = bool((rescale and problem.gauge_fixed) or (
        rescale and problem.model.scale_symmetric and problem.scale_fixed is not None
        and not problem.fixed and bool(np.all(problem.mode != kernel.GIVEN))))
    mode = drive.RESCALE if do_rescale else drive.BEST_LINEAR
    out = np.empty_like(z)
    cost = np.empty(z.shape[0])
    cards = np.ascontiguousarray(cards, dtype=np.int64)

    def work(a: int, b: int) -> None:
        out[a:b], cost[a:b] = drive.linear_items(cards[a:b], np.ascontiguousarray(z[a:b]),
                                                 mode, data, model, settings)

    run_chunks(work, z.shape[0], workers=workers, chunk=256)
    return out, cost


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


def walk_valley(problem: Problem, k: int, z: Array, cost: float,
                rounds: int = 8) -> tuple[Array, float]:
    """Follow a long, flat, curved valley where Levenberg-Marquardt only crawls.

    When the data hardly constrain one combination (relative singular value of the scaled
    Jacobian below 1e-4), a trust-region step along the valley is cut short by its
    curvature. Jumping along the weakest direction and letting a short polish drop back to
    the floor moves along it in a few long strides; the floor's cost tells which way is
    down. On noisy data the floor is flat at the noise level and the walk stops at once.

    Parameters
    ----------
    problem : Problem
    k : int
        The card.
    z, cost : ndarray, float
        A point on the valley's floor (solver coordinates) and its cost.
    rounds : int
        Longest walk (rounds of probe-and-grow).

    Returns
    -------
    z, cost
        The walked point and its cost (the given ones when nothing was gained).
    """
    data, model, settings = problem.arrays
    span = float(np.ptp(problem.card(k)[2])) or 1.0
    p = problem.n_free
    ref = np.log(problem.reference[k][problem.free_idx])
    polish = LevenbergMarquardt(tol=1e-10)

    def jump(base: Array, step: Array) -> tuple[Array, float] | None:
        znew = base.copy()
        znew[:p] = np.clip(base[:p] + step[:p], ref - WINDOW, ref + WINDOW)
        j = p
        if problem.scale_fixed is None:
            znew[j] = base[j] + step[j]
            j += 1
        if problem.offset_fixed is None:
            znew[j] = base[j] + step[j] * span
        out = polish.solve(problem, np.array([k]), znew[None], budget=40)
        c = float(out.cost[0])
        return (out.z[0], c) if math.isfinite(c) else None

    for _ in range(rounds):
        q = problem.q
        rows = np.empty((q + 1, problem.n_samples(k)))
        if not drive.rows_at(z, k, data, model, settings, rows):
            break
        if problem.offset_fixed is None:
            rows[q - 1] *= span
        r_fac = np.zeros((q, q))
        lm.householder(rows, q, r_fac, np.zeros(q))
        _u, s, vt = np.linalg.svd(r_fac)
        if not (s[0] > 0) or s[-1] / s[0] > 1e-4:
            break
        direction = vt[-1]
        step = 0.25 * 2.5
        probes: list[tuple[float, Array, float]] = []
        for _shrink in range(3):
            step /= 2.5
            probes = []
            for sign in (1.0, -1.0):
                got = jump(z, sign * step * direction)
                if got is not None and got[1] < 0.95 * cost:
                    probes.append((sign, got[0], got[1]))
            if probes:
                break
        if not probes:
            break
        sign, best_z, best_cost = min(probes, key=lambda item: item[2])
        for _grow in range(4):
            step *= 2.5
            got = jump(z, sign * step * direction)
            if got is None or got[1] >= best_cost:
                break
            best_z, best_cost = got
        z, cost = best_z, best_cost
    return z, cost


@dataclass(frozen=True)
class WidePlan:
    """How far the wide search goes when the first answer does not explain the data.

    Each round polishes ``per_round`` new points -- the best-ranked shapes of the model's
    dense grid (ranked by the card's harmonics for a periodic stroke, by its samples
    otherwise) and ``random`` log-uniform points within ``spread`` of the natural scales --
    then runs the solver to convergence from the best distinct ones. The search stops when
    two independent starts agree on the best cost (``agree``, relative), or after
    ``rounds`` rounds.
    """

    rounds: int = 3
    per_round: int = 8
    random: int = 4
    spread: float = 1e3
    polish_evaluations: int = 80
    finals: int = 2
    agree: float = 1e-6
    harmonics: int = 64


def _card_rng(problem: Problem, k: int) -> np.random.Generator:
    """A generator seeded by the card's own samples: its search is the same in any batch."""
    _t, f, d = problem.card(k)
    seed = zlib.crc32(np.ascontiguousarray(f).tobytes() + np.ascontiguousarray(d).tobytes())
    return np.random.default_rng(seed)


def _ranked_shapes(problem: Problem, k: int, plan: WidePlan) -> Array:
    """The model's dense shapes on card k, best first, as rescaled parameter rows."""
    w0 = _fundamental(problem, k)
    shapes = problem.model.shape_grid(w0, dense=True)
    if problem.fixed:
        for i, value in problem.fixed:
            shapes[:, i] = value
    t, f, d = problem.card(k)
    periodic = (problem.mode[k] == kernel.PERIODIC and problem.uniform[k]
                and problem.model.input_map is None
                and abs(problem.period[k] - t.size * (t[1] - t[0])) <= 1e-6 * problem.period[k])
    symmetric = bool(problem.model.scale_symmetric and problem.scale_fixed is not None
                     and not problem.fixed)
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    if periodic:
        code = problem.model.code()
        costs, factors = harmonic_scan(t, f, d, np.ascontiguousarray(shapes), code,
                                       problem.model.n_states(), problem.out_index,
                                       problem.offset_fixed is None, symmetric, float(scale),
                                       plan.harmonics)
        if symmetric:
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
    of the natural scales are polished in rounds; the solver runs to convergence from the
    best distinct polished points. Stops for a card when two independent starts agree on
    its best cost, which then is the global optimum with good confidence.

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
    polish = LevenbergMarquardt(tol=1e-10)
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
            full = solver.solve(problem, np.array(chosen_card, dtype=np.int64),
                                np.array(chosen_z), workers=workers)
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
