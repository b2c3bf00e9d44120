"""Long-run covariance of a score series: the meat of autocorrelation-robust (HAC) errors.

Linearised intervals assume independent errors. A dynamometer card's residuals are rarely
that: a load cell is low-pass filtered, and what the model misses moves slowly over the
stroke. The sandwich ``B Omega B`` with ``B = (J^T J)^-1`` and ``Omega`` the long-run
covariance of the scores ``u_t = J_t r_t`` stays valid when the errors follow one another
(heteroscedasticity and autocorrelation consistent, HAC).

``Omega`` is estimated the way the econometrics literature recommends for strongly
autocorrelated series (Andrews & Monahan 1992): the scores are prewhitened by a VAR(1) fit,
the whitened series gets a Bartlett-kernel (Newey-West) estimate with the bandwidth of
Andrews (1991) from per-column AR(1) fits, and the result is recoloured by ``(I - A)^-1``.
A periodic card (one stroke of a steady state) has no ends: its last sample is the first
one's neighbour, and the prewhitening and the kernel's windows run around the period, so
the estimate is the same wherever the card starts (with two ends, a short card's windows
span half of it and the start moved a real stroke's errors by a factor of two).
numpy and scipy have no HAC estimator (statsmodels has one, without prewhitening, and is a
heavy dependency for a few dozen lines), and the fits need it compiled, once per card.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..engine import lm
from ..engine.compiled import jit

__all__ = ["PREWHITEN_CAP", "long_run_covariance", "long_run_rows", "sandwich"]

Array = NDArray[np.float64]

#: The VAR(1) prewhitening matrix's singular values are capped here: near 1 the recolouring
#: ``(I - A)^-1`` would blow up on an estimation error (Andrews & Monahan's 0.97). Singular
#: values depend on the basis; they are taken for the series scaled to unit RMS.
PREWHITEN_CAP = 0.97
#: Andrews (1991) optimal Bartlett bandwidth: 1.1447 (alpha(1) n)^(1/3).
_ANDREWS_BARTLETT = 1.1447


@jit
def _andrews_width(e, circular):
    """Andrews' AR(1) plug-in bandwidth for the Bartlett kernel; e is (q, n), rows alike,
    ``circular``: the last sample is the first one's neighbour."""
    q, n = e.shape
    pairs = n if circular else n - 1
    top = 0.0
    bottom = 0.0
    for i in range(q):
        den = 0.0
        num = 0.0
        for k in range(n - 1):
            den += e[i, k] * e[i, k]
        den += e[i, n - 1] * e[i, n - 1] if circular else 0.0
        for k in range(pairs):
            num += e[i, k] * e[i, (k + 1) % n]
        if den > 0.0:
            rho = min(max(num / den, -PREWHITEN_CAP), PREWHITEN_CAP)
            # Weights 1/sigma_a^4 make alpha(1) independent of each row's scale.
            top += 4.0 * rho**2 / ((1.0 - rho) ** 6 * (1.0 + rho) ** 2)
            bottom += 1.0 / (1.0 - rho) ** 4
    if bottom == 0.0:
        return 1.0
    return _ANDREWS_BARTLETT * (top / bottom * n) ** (1.0 / 3.0)


@jit
def _outer_sum(x, y):
    """x @ y.T, by hand: for long rows (q, n) no multi-threaded BLAS call is made for a few
    rows of thousands of samples, and for the q x q matrices below (q <= about 8; a @ b is
    ``_outer_sum(a, b.T)``) numba compiles no BLAS wrapper for ``@``, seconds of a fresh
    install's first fit for work that takes microseconds here."""
    q = x.shape[0]
    r = y.shape[0]
    n = x.shape[1]
    out = np.zeros((q, r))
    for i in range(q):
        for j in range(r):
            s = 0.0
            for k in range(n):
                s += x[i, k] * y[j, k]
            out[i, j] = s
    return out


@jit
def sandwich(b, m):
    """b @ m @ b.T for small matrices (a covariance carried through a linear map)."""
    return _outer_sum(_outer_sum(b, m.T), b)


@jit
def _var1(x, circular):
    """Least-squares A of x_t = A x_{t-1} + e_t, for x of shape (q, n); ``circular``: x_0
    follows x_{n-1}. (The inverses and SVDs of q x q matrices here are the solver's Jacobi
    ones, not np.linalg's: numba compiles a LAPACK wrapper for each of those.)"""
    if circular:
        x0 = np.ascontiguousarray(x)
        x1 = np.ascontiguousarray(np.concatenate((x[:, 1:], x[:, :1]), axis=1))
    else:
        x0 = np.ascontiguousarray(x[:, :-1])
        x1 = np.ascontiguousarray(x[:, 1:])
    gram = _outer_sum(x0, x0)
    cross = _outer_sum(x1, x0)
    return _outer_sum(cross, lm.pseudo_inverse(gram, 1e-15).T)


@jit
def long_run_rows(x, prewhiten, bandwidth, circular):
    """Long-run covariance of finite, moderately scaled series in rows (q, N), N >= 3.

    ``bandwidth`` <= 0 selects Andrews' rule. ``circular``: the series is one period of a
    periodic one (its last sample is the first one's neighbour, as on a steady stroke's
    card), so the prewhitening and the kernel's lags run around it; otherwise it has two
    ends. Returns (omega (q, q), bandwidth used, prewhitening persistence, capped).
    """
    q, n = x.shape
    # Rows of very different sizes make A's singular values (the cap's measure) reflect
    # their ratio rather than any persistence: work on unit-RMS series, rescale at the end.
    size = np.empty(q)
    for i in range(q):
        s = 0.0
        for k in range(n):
            s += x[i, k] * x[i, k]
        size[i] = math.sqrt(s / n) if s > 0.0 else 1.0
    xs = np.empty((q, n))
    for i in range(q):
        for k in range(n):
            xs[i, k] = x[i, k] / size[i]
    a = np.zeros((q, q))
    capped = False
    persistence = 0.0
    e = xs
    if prewhiten and q > 0:
        a = _var1(xs, circular)
        left, sv, right = lm.small_svd(a)
        persistence = sv[0]
        if persistence > PREWHITEN_CAP:
            capped = True
            persistence = PREWHITEN_CAP
            for j in range(q):
                sv[j] = min(sv[j], PREWHITEN_CAP)
            a = _outer_sum(left * sv, right.T)
        # Around a period every sample has a predecessor; a series with ends loses its first.
        n_e = n if circular else n - 1
        e = np.empty((q, n_e))
        for i in range(q):
            for k in range(n_e):
                acc = xs[i, (k + 1) % n]
                for j in range(q):
                    acc -= a[i, j] * xs[j, k]
                e[i, k] = acc
    n_e = e.shape[1]
    if bandwidth <= 0:
        width = _andrews_width(e, circular) if q > 0 else 1.0
        if math.isfinite(width):
            m = int(min(max(1.0, float(np.round(width))), float(n_e)))
        else:
            m = n_e
    else:
        m = min(bandwidth, n_e)
    if circular:
        # Around a period a window longer than half of it meets itself from the other
        # side: the estimate fell by (n - m) / m, to 0 at m = n (Andrews' rule chose 16 of
        # 30 samples on smooth short cards).
        m = max(1, min(m, n_e // 2))
    omega = np.zeros((q, q))
    if m == 1:
        omega = _outer_sum(e, e)
    else:
        # Bartlett weights (m - |l|)/m are the self-convolution of a length-m box: m * Omega
        # is W W^T, with W the sums of e over every window of m samples: one cumulative sum,
        # O(N q), positive semi-definite. A series with ends has partial windows at them;
        # around a period every window is whole (the sum over e taken twice in a row).
        total = n_e if circular else n_e + m - 1
        windows = np.empty((q, total))
        for i in range(q):
            csum = np.zeros(2 * n_e + 1)
            for k in range(2 * n_e):
                csum[k + 1] = csum[k] + e[i, k % n_e]
            for j in range(total):
                if circular:
                    hi = j + m
                    lo = j
                else:
                    hi = min(j + 1, n_e)
                    lo = max(j + 1 - m, 0)
                windows[i, j] = csum[hi] - csum[lo]
        omega = _outer_sum(windows, windows) / m
    if prewhiten and q > 0:
        # A's singular values are at most the cap (< 1), so I - A is well conditioned.
        omega = sandwich(lm.pseudo_inverse(np.eye(q) - a, 0.0), omega)
    out = np.empty((q, q))
    for i in range(q):
        for j in range(q):
            out[i, j] = 0.5 * (omega[i, j] + omega[j, i]) * size[i] * size[j]
    return out, m, persistence, capped


def long_run_covariance(
    scores: ArrayLike, *, prewhiten: bool = True, bandwidth: int | None = None,
    circular: bool = False,
) -> tuple[Array, dict[str, Any]]:
    """Long-run covariance ``sum_{t,s} E[u_t u_s^T]`` of a score series (HAC estimate).

    Parameters
    ----------
    scores : array_like, shape (N,) or (N, q)
        The series ``u_t`` (for a least-squares fit, the Jacobian rows times the residuals).
        It is not demeaned: at a least-squares optimum the scores sum to zero.
    prewhiten : bool, optional
        Fit ``u_t = A u_{t-1} + e_t`` first, estimate the whitened series' covariance and
        recolour it by ``(I - A)^-1`` (default True; it makes the estimate far less biased
        when the autocorrelation is strong).
    bandwidth : int, optional
        Bartlett bandwidth ``m`` for the (prewhitened) series: lag ``l`` gets weight
        ``1 - |l|/m`` for ``|l| < m``; ``m = 1`` keeps lag 0 only. At most the length of the
        (prewhitened) series, around a period half of it: larger values are cut to it.
        Default: Andrews' (1991) AR(1) plug-in rule on the prewhitened series.
    circular : bool, optional
        The series is one period of a periodic one (default False): its last sample is the
        first one's neighbour, so the prewhitening and the kernel's lags run around it, and
        the estimate does not depend on which sample comes first.

    Returns
    -------
    omega : ndarray, shape (q, q)
        The estimate, on the scale of the sum (not the mean) of the scores; symmetric and
        positive semi-definite.
    info : dict
        ``bandwidth`` (m), ``prewhitening`` (largest singular value of A, for columns
        scaled to unit RMS, after the cap; 0 without prewhitening) and ``capped``.
    """
    u = np.asarray(scores, dtype=float)
    if u.ndim == 1:
        u = u[:, None]
    if u.ndim != 2 or u.shape[0] < 3:
        raise ValueError("scores must be an (N,) or (N, q) array with N >= 3")
    if not np.all(np.isfinite(u)):
        raise ValueError("scores must be finite")
    if bandwidth is not None and (isinstance(bandwidth, bool)
                                  or not float(bandwidth).is_integer() or bandwidth < 1):
        raise ValueError(f"bandwidth must be a whole number of samples >= 1, got {bandwidth!r}")
    x = np.ascontiguousarray(u.T)
    # Each row is divided by its peak first, so that squaring overflows for no magnitude.
    peak = np.max(np.abs(x), axis=1) if x.size else np.ones(x.shape[0])
    peak[~(peak > 0)] = 1.0
    omega, m, persistence, capped = long_run_rows(
        np.ascontiguousarray(x / peak[:, None]), prewhiten,
        0 if bandwidth is None else int(bandwidth), bool(circular))
    info = {"bandwidth": int(m), "prewhitening": float(persistence), "capped": bool(capped)}
    return omega * np.outer(peak, peak), info
