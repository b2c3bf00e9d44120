"""Equation-error estimates: model coefficients from one linear least-squares solve.

The physical models are linear ODEs, so their transfer-function coefficients follow from a
*linear* least-squares problem (equation error), as in continuous-time system
identification; no starting point is needed, which is why it comes first among the
candidates (:mod:`.pool` maps the coefficients to parameters through each model's
``equation_error`` forms):

* records that start from a state (rest, equilibrium, a given one) are passed through a
  state-variable filter ``lambda^n / (s + lambda)^n``, which gives smooth derivatives of the
  displacement and the load without differentiating noisy data; unknown initial conditions
  and a position offset enter as a few extra regressors (``t^j exp(-lambda t)`` and a filtered
  constant), so the estimate does not depend on knowing them;
* periodic strokes are fitted over their harmonics, where ``s = i k omega`` is exact.

The fixed filter weights the error unevenly (the estimate leans away from the least-squares
answer), so each estimate is refined by a few Steiglitz-McBride iterations, which filter by
the current denominator instead. Everything numeric here is compiled; the periodic and the
time-domain paths are separate entry points, so a first run compiles only the one its
cards need.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import kernel, lm
from ..compiled import copy_into, jit
from ..spectrum import card_spectrum

__all__ = ["equation_error_items", "hurwitz_stable", "unit_column_lstsq"]

Array = NDArray[np.float64]

#: Highest harmonic used by the periodic equation error.
_HARMONICS = 40


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
            copy_into(w, wn)
        top = x[k]
        for j in range(n):
            out[k, j] = w[0, j] * scale
            top -= coeffs[j] * w[0, j]
        out[k, n] = top * scale
    return out


#: Relative precision of a float: where np.linalg.lstsq cuts singular values by default.
_MACHINE_EPS = float(np.finfo(np.float64).eps)


@jit
def unit_column_lstsq(mat, target):
    """Least-squares ``x`` of ``mat @ x ~ target`` (the minimum-norm one when ``mat``'s
    columns are dependent), solved with unit-norm columns; all NaN when there is nothing
    to solve (no nonzero column, or a value not finite)."""
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
    nc = cols.size
    # The normalised columns as rows, the target last: Householder QR, then the
    # minimum-norm solution from R's SVD with LAPACK's default cut (machine precision
    # times the largest singular value), as np.linalg.lstsq (compiling it cost seconds).
    rows = np.empty((nc + 1, mat.shape[0]))
    for jj in range(nc):
        for i in range(mat.shape[0]):
            rows[jj, i] = mat[i, cols[jj]] / norms[cols[jj]]
    copy_into(rows[nc], target)
    r = np.zeros((nc, nc))
    c = np.zeros(nc)
    lm.householder(rows, nc, r, c)
    r_pinv = lm.pseudo_inverse(r, _MACHINE_EPS)
    sol = np.zeros(nc)
    for jj in range(nc):
        for i in range(nc):
            sol[jj] += r_pinv[jj, i] * c[i]
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
        copy_into(mat[:, j], yf[:, y_orders[j]])
    for j in range(f_orders.size):
        copy_into(mat[:, y_orders.size + j], ff[:, f_orders[j]])
    # Unknown initial conditions (and the filter's start-up) appear as t^j exp(-lam t).
    for j in range(n):
        for k in range(t.size):
            mat[k, ncoef + j] = math.exp(-lam * tt[k]) * (lam * tt[k]) ** j
    copy_into(mat[:, ncoef + n], onesf[:, 0])
    # A contiguous copy: unit_column_lstsq then has one signature for both equation errors.
    target = (ff[:, target_order] if target_f else yf[:, target_order]).copy()
    return unit_column_lstsq(mat, target)[:ncoef]


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
    return unit_column_lstsq(mat, target)


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
def hurwitz_stable(poly):
    """All roots of the monic polynomial (coefficients by power) in the open left
    half-plane, by the Routh-Hurwitz test: every entry of the Routh array's first column
    positive. (``np.roots`` compiled LAPACK's eigenvalue routine for this sign test.)"""
    if not np.all(np.isfinite(poly)):
        return False
    n = poly.size - 1
    width = n // 2 + 1
    # The array's first two rows: the coefficients of s^n, s^(n-2), ... and of
    # s^(n-1), s^(n-3), ...; each further row from the two above it.
    upper = np.zeros(width + 1)
    lower = np.zeros(width + 1)
    for j in range(width):
        upper[j] = poly[n - 2 * j]
        if n - 1 - 2 * j >= 0:
            lower[j] = poly[n - 1 - 2 * j]
    for _ in range(n):
        if not lower[0] > 0.0:
            return False
        row = np.zeros(width + 1)
        for j in range(width):
            row[j] = upper[j + 1] - upper[0] * lower[j + 1] / lower[0]
        upper = lower
        lower = row
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
            copy_into(w, wn)
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
        if not hurwitz_stable(poly):
            break
        yf = _filter_den(t, y, poly, uniform)
        ff = _filter_den(t, f, poly, uniform)
        extra = 1 if offset_free else 0
        mat = np.empty((t.size, ncoef + extra))
        for j in range(y_orders.size):
            copy_into(mat[:, j], yf[:, y_orders[j]])
        for j in range(f_orders.size):
            copy_into(mat[:, y_orders.size + j], ff[:, f_orders[j]])
        if offset_free:
            copy_into(mat[:, ncoef], _filter_den(t, np.ones(t.size), poly, uniform)[:, 0])
        target = (ff[:, target_order] if target_f else yf[:, target_order]).copy()
        new = unit_column_lstsq(mat, target)[:ncoef]
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
        if not hurwitz_stable(poly):
            break
        for k in range(first, yk.size):
            s = 2j * math.pi * k / period
            den = 0.0 + 0.0j
            for j in range(order, -1, -1):
                den = den * s + poly[j]
            weights[k] = 1.0 / den
        mat, target = _harmonic_rows(yk, fk, period, weights, form, first)
        new = unit_column_lstsq(mat, target)
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
        # (From a table of the roots of unity: a sine and cosine per sample and harmonic
        # cost a third of a millisecond a card.)
        fk = np.empty(kmax + 1, np.complex128)
        yk = np.empty(kmax + 1, np.complex128)
        card_spectrum(f, y, kmax, fk, yk)
        fk /= f.size
        yk /= y.size
        for li in range(n_lam):
            lam = lams[i, li]
            if not lam > 0.0:
                continue
            coef = _harmonic_coefs(yk, fk, period[k], lam, form, first)
            copy_into(out[i, li], coef)
            if np.all(np.isfinite(coef)):
                copy_into(out[i, n_lam + li],
                          _refine_harmonic(yk, fk, period[k], coef, form, first, 8))
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
            copy_into(out[i, li], coef)
            if refine_time and np.all(np.isfinite(coef)):
                copy_into(out[i, n_lam + li], _refine_time(
                    tt, y_dev, f_dev, coef, form, uniform[k],
                    offset_free and mode[k] == kernel.REST, 8))
    return out
