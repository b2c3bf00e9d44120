"""Closed-form responses used as test references (independent of pumpid's simulator).

A linear system ``x' = A x + B F`` with distinct eigenvalues decouples into modes
``z' = lam z + beta F``. For a load that is linear between samples each mode has a closed-form
step: with ``h`` the step, ``F(s) = F_k + slope s`` on it,

    z_{k+1} = exp(lam h) z_k + beta (F_k phi1 + slope phi2),
    phi1 = int_0^h exp(lam (h - s)) ds,  phi2 = int_0^h exp(lam (h - s)) s ds.

Both integrals are evaluated by their power series for small ``|lam h|`` (no cancellation)
and by their closed form otherwise, so the reference is accurate to a few ulps times the
eigenvector basis' condition number (after balancing the matrix): far below any bound a test
sets on pumpid. It uses an eigendecomposition where pumpid uses a matrix exponential, so the
two share no code path.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

_SERIES_TERMS = 30
_SERIES_BELOW = 0.5


def _phi(x: NDArray[np.complex128], h: float) -> tuple[NDArray[np.complex128], ...]:
    small = np.abs(x) < _SERIES_BELOW
    p1 = np.empty_like(x)
    p2 = np.empty_like(x)
    xs = x[small]
    s1 = np.zeros_like(xs)
    s2 = np.zeros_like(xs)
    term = np.ones_like(xs)
    for j in range(_SERIES_TERMS):
        s1 += term * (1.0 / math.factorial(j + 1))
        s2 += term * (1.0 / math.factorial(j + 2))
        term = term * xs
    p1[small] = h * s1
    p2[small] = h * h * s2
    xb = x[~small]
    e = np.exp(xb)
    p1[~small] = h * (e - 1.0) / xb
    p2[~small] = h * h * (e - 1.0 - xb) / xb**2
    return p1, p2


def modal_response(
    a: ArrayLike, b: ArrayLike, t: ArrayLike, load: ArrayLike, x0: ArrayLike
) -> NDArray[np.float64]:
    """States (N, n) of ``x' = A x + B F`` from ``x0``, F linear between the samples.

    Raises
    ------
    ValueError
        When A is not safely diagonalizable (the modal form would lose accuracy).
    """
    a = np.asarray(a, dtype=float)
    t = np.asarray(t, dtype=float)
    f = np.asarray(load, dtype=float)
    # Balance first (a diagonal similarity, exact in floating point): states of very
    # different sizes would otherwise make the eigenvector basis needlessly ill-conditioned.
    a, scaling = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    d = scaling[0]
    b = np.asarray(b, dtype=float) / d
    x0 = np.asarray(x0, dtype=float) / d
    lam, v = np.linalg.eig(a)
    if np.linalg.cond(v) > 1e6:
        raise ValueError("A is (nearly) defective: the modal reference does not apply")
    beta = np.linalg.solve(v, np.asarray(b, dtype=complex))
    z = np.linalg.solve(v, np.asarray(x0, dtype=complex))
    out = np.empty((t.size, lam.size), dtype=complex)
    out[0] = z
    for k in range(t.size - 1):
        h = t[k + 1] - t[k]
        slope = (f[k + 1] - f[k]) / h
        p1, p2 = _phi(lam * h, h)
        z = np.exp(lam * h) * z + beta * (f[k] * p1 + slope * p2)
        out[k + 1] = z
    return (out @ v.T).real * d
