"""A fast ranking of many parameter shapes on a periodic card, by its harmonics.

The wider search (:mod:`.wider`) draws hundreds of shapes from a model's dense grid and can
polish only a few. Simulating each in time to rank them would cost as much as the polish; on
one uniformly sampled period the response at harmonic k is instead ``H(i k w) F_k``, the
transfer function a ratio of polynomials whose coefficients each shape computes once, so the
whole grid is ranked for the price of a few simulations. Compiled, in a module of its own so
that the cache key (see :mod:`pumpid.engine.compiled`) follows the compiled code only.
"""

from __future__ import annotations

import math

import numpy as np

from .. import kernel
from ..compiled import jit
from ..spectrum import at_frequency, transfer_coefficients

__all__ = ["harmonic_scan"]


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
    bc = np.empty(n, np.complex128)
    top = np.zeros(3)
    bottom = np.zeros(4)
    y = np.empty(nk, np.complex128)
    for s in range(s_count):
        ok = True
        for j in range(shapes.shape[1]):
            if not (shapes[s, j] > 0.0):
                ok = False
        if not ok:
            continue
        kernel.system(np.log(shapes[s]), free, code, a, b)
        if n <= 3:
            transfer_coefficients(a[0], b[0], n, obs, top, bottom)
        else:
            for r in range(n):
                bc[r] = b[0, r]
        for i in range(nk):
            k = first + i
            om = 2.0 * math.pi * k / period
            if n <= 3:
                dn = at_frequency(bottom, om)
                if dn == 0.0:
                    ok = False
                    break
                h = at_frequency(top, om) / dn
                if not math.isfinite(h.real):
                    ok = False
                    break
            else:
                x, good = _complex_solve(1j * om * eye - a[0], bc)
                if not good:
                    ok = False
                    break
                h = x[obs]
            y[i] = h * fk[i]
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
