"""Long-run covariance of a score series: the meat of autocorrelation-robust (HAC) errors.

The intervals of :mod:`pumpid.diagnostics` assume independent errors. A dynamometer card's
residuals are rarely that: a load cell is low-pass filtered, and what the model misses moves
slowly over the stroke. The sandwich ``B Omega B`` with ``B = (J^T J)^-1`` and ``Omega`` the
long-run covariance of the scores ``u_t = J_t r_t`` stays valid when the errors follow one
another (heteroscedasticity and autocorrelation consistent, HAC).

``Omega`` is estimated the way the econometrics literature recommends for strongly
autocorrelated series (Andrews & Monahan 1992): the scores are prewhitened by a VAR(1) fit,
the whitened series gets a Bartlett-kernel (Newey-West) estimate with the bandwidth of
Andrews (1991) from per-column AR(1) fits, and the result is recoloured by ``(I - A)^-1``.
numpy and scipy have no HAC estimator (statsmodels has one, without prewhitening, and is a
heavy dependency for a few dozen lines), hence this module.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["PREWHITEN_CAP", "long_run_covariance", "long_run_rows"]

Array = NDArray[np.float64]

#: The VAR(1) prewhitening matrix's singular values are capped here: near 1 the recolouring
#: ``(I - A)^-1`` would blow up on an estimation error (Andrews & Monahan's 0.97). Singular
#: values depend on the basis; they are taken for the series scaled to unit RMS.
PREWHITEN_CAP = 0.97
#: Andrews (1991) optimal Bartlett bandwidth: 1.1447 (alpha(1) n)^(1/3).
_ANDREWS_BARTLETT = 1.1447


def _andrews_width(e: Array) -> float:
    """Andrews' AR(1) plug-in bandwidth for the Bartlett kernel; e is (q, n), rows alike."""
    x0 = e[:, :-1]
    den = np.einsum("ij,ij->i", x0, x0).tolist()
    num = np.einsum("ij,ij->i", x0, e[:, 1:]).tolist()
    top = bottom = 0.0
    # A handful of rows: Python floats beat numpy's per-call cost on arrays of length q.
    for d, c in zip(den, num, strict=True):
        if d > 0:
            rho = min(max(c / d, -PREWHITEN_CAP), PREWHITEN_CAP)
            # Weights 1/sigma_a^4 make alpha(1) independent of each row's scale.
            top += 4.0 * rho**2 / ((1.0 - rho) ** 6 * (1.0 + rho) ** 2)
            bottom += 1.0 / (1.0 - rho) ** 4
    if bottom == 0.0:
        return 1.0
    return _ANDREWS_BARTLETT * (top / bottom * e.shape[1]) ** (1.0 / 3.0)


def _var1(x: Array) -> Array:
    """Least-squares A of x_t = A x_{t-1} + e_t, for x of shape (q, n)."""
    x0, x1 = x[:, :-1], x[:, 1:]
    gram = x0 @ x0.T
    cross = x1 @ x0.T
    try:
        a = np.linalg.solve(gram, cross.T).T
    except np.linalg.LinAlgError:
        a = cross @ np.linalg.pinv(gram)
    if not np.all(np.isfinite(a)):
        a = cross @ np.linalg.pinv(gram)
    return a


def long_run_covariance(
    scores: ArrayLike, *, prewhiten: bool = True, bandwidth: int | None = None
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
        ``1 - |l|/m`` for ``|l| < m``; ``m = 1`` keeps lag 0 only (with ``prewhiten=False``,
        White's heteroscedasticity-robust estimate; with prewhitening, the autocorrelation
        is then carried by the VAR(1) alone). At most the length of the (prewhitened)
        series: larger values are cut to it. Default: Andrews' (1991) AR(1) plug-in rule on
        the prewhitened series.

    Returns
    -------
    omega : ndarray, shape (q, q)
        The estimate, on the scale of the sum (not the mean) of the scores; symmetric and
        positive semi-definite.
    info : dict
        ``bandwidth`` (m), ``prewhitening`` (largest singular value of A, for columns
        scaled to unit RMS, after the cap; 0 without prewhitening) and ``capped`` (whether
        the cap was applied).
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
    # Series along the last axis: a few long rows are what numpy's reductions do fastest.
    # Each row is divided by its peak first, so that squaring overflows for no magnitude.
    x = u.T
    peak = np.max(np.abs(x), axis=1) if x.size else np.ones(x.shape[0])
    peak[~(peak > 0)] = 1.0
    omega, info = long_run_rows(x / peak[:, None], prewhiten=prewhiten,
                                bandwidth=None if bandwidth is None else int(bandwidth))
    return omega * np.outer(peak, peak), info


def long_run_rows(
    x: Array, *, prewhiten: bool = True, bandwidth: int | None = None
) -> tuple[Array, dict[str, Any]]:
    """:func:`long_run_covariance` of finite, moderately scaled series in rows (q, N).

    The unchecked core, for callers that have built such rows themselves (the fit's
    diagnostics do, once per fit: the checks and the overflow guard would be repeated work).

    Parameters
    ----------
    x : ndarray, shape (q, N)
        The series, one per row, finite, N >= 3, of magnitudes whose squares cannot overflow.
    prewhiten : bool, optional
        As in :func:`long_run_covariance`.
    bandwidth : int, optional
        As in :func:`long_run_covariance`, already validated (a whole number >= 1).

    Returns
    -------
    omega, info
        As :func:`long_run_covariance` returns them.
    """
    q, n = x.shape
    # Rows of very different sizes make A's singular values (the cap's measure) reflect
    # their ratio rather than any persistence: work on unit-RMS series, rescale at the end.
    size = np.sqrt(np.einsum("ij,ij->i", x, x) / n)
    size[~(size > 0)] = 1.0
    x = x / size[:, None]
    a = np.zeros((q, q))
    capped = False
    persistence = 0.0
    e = x
    if prewhiten and q:
        a = _var1(x)
        left, sv, right = np.linalg.svd(a)
        persistence = float(sv[0])
        if persistence > PREWHITEN_CAP:
            capped = True
            persistence = PREWHITEN_CAP
            a = (left * np.minimum(sv, PREWHITEN_CAP)) @ right
        e = x[:, 1:] - a @ x[:, :-1]
    n_e = e.shape[1]
    if bandwidth is None:
        width = _andrews_width(e) if q else 1.0
        m = int(min(max(1, round(width)), n_e)) if math.isfinite(width) else n_e
    else:
        m = min(bandwidth, n_e)
    if m == 1:
        omega = e @ e.T
    else:
        # Bartlett weights (m - |l|)/m are the self-convolution of a length-m box: m * Omega
        # is W W^T, with W the sums of e over every window of m samples (partial windows at
        # the ends included): one cumulative sum, O(N q), positive semi-definite by
        # construction.
        csum = np.cumsum(e, axis=1)
        padded = np.concatenate(
            [np.zeros((q, m)), csum, np.repeat(csum[:, -1:], m - 1, axis=1)], axis=1)
        windows = padded[:, m:] - padded[:, :-m]
        omega = windows @ windows.T / m
    if prewhiten and q:
        recolour = np.linalg.inv(np.eye(q) - a)
        omega = recolour @ omega @ recolour.T
    omega = 0.5 * (omega + omega.T) * np.outer(size, size)
    info = {
        "bandwidth": m,
        "prewhitening": persistence,
        "capped": capped,
    }
    return omega, info
