"""A periodic card's residual on its first harmonics: a cheap cost for searches.

On one uniformly sampled period (``N`` samples, period ``T = N h``) the exact periodic
response of a linear model to a load taken linear between samples has the discrete Fourier
coefficients

    U_k = F_k * sum_l H(i w_{k + l N}) sinc^2(pi (k + l N) / N),    w_j = 2 pi j / T,

with ``H`` the model's continuous transfer function to the observed state (the hold's
triangle has the Fourier coefficients ``sinc^2``). The term ``l = 0`` carries it: the
others are at most ``sin^2(pi k / N) / pi^2`` times ``|H|`` beyond the sampling frequency,
where a card's model has long rolled off. By Parseval, the time-domain cost
``0.5 sum_j r_j^2`` is ``0.5 / N (|R_0|^2 + 2 sum_{k >= 1} |R_k|^2)`` (``R`` the residual's
coefficients, the Nyquist term aside), so :func:`harmonic_rows` returns the Jacobian and
residual as ``1 + 2 K`` real rows (``R_0 / sqrt N``, then ``sqrt(2 / N)`` times the real
and imaginary parts of ``R_1 .. R_K``) whose cost is that sum cut at harmonic ``K``.

Why: an evaluation is then ``K + 1`` small complex solves. The exact simulation needs a
matrix exponential with its sensitivities, a transition over the period and two passes over
the samples; on 200-sample field cards a harmonic evaluation on 24 harmonics costs a
fraction of it (see :class:`pumpid.engine.solvers.LevenbergMarquardt`'s ``harmonics``). The
cut cost differs from the exact one by the residual's higher harmonics, which move little
with the parameters: good enough to tell basins apart, never used for an answer.
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import jit
from .kernel import system

__all__ = ["MAX_STATES", "SEARCH_HARMONICS", "card_spectrum", "harmonic_rows",
           "harmonic_width"]

#: Harmonics the searches look at: those that carry a field card (above them its model's
#: response is small, and the hold's aliases grow).
SEARCH_HARMONICS = 24
#: The largest model the harmonic residual takes (every built-in model has at most three
#: states): its small systems are solved by the adjugate of a 3 x 3 matrix.
MAX_STATES = 3


@jit
def harmonic_width(harmonics, n_samples):
    """Rows of the harmonic residual on ``n_samples`` samples: ``1 + 2 K``, with ``K`` the
    requested harmonics kept below the Nyquist frequency."""
    kmax = min(harmonics, (n_samples - 1) // 2)
    return 1 + 2 * kmax


@jit
def card_spectrum(f, d, kmax, fk, dk):
    """Discrete Fourier coefficients of the load and data at harmonics 0..kmax, into
    ``fk`` and ``dk`` (kmax + 1,), with the convention ``X_k = sum_j x_j exp(-2 pi i j k /
    N)``."""
    n = f.size
    # One table of the N roots of unity; harmonic k steps through it k at a time, so every
    # factor is a table entry (no drift from repeated products).
    cos_t = np.empty(n)
    sin_t = np.empty(n)
    for j in range(n):
        angle = 2.0 * math.pi * j / n
        cos_t[j] = math.cos(angle)
        sin_t[j] = math.sin(angle)
    for k in range(kmax + 1):
        sf = 0.0 + 0.0j
        sd = 0.0 + 0.0j
        at = 0
        for j in range(n):
            e = complex(cos_t[at], -sin_t[at])
            sf += f[j] * e
            sd += d[j] * e
            at += k
            if at >= n:
                at -= n
        fk[k] = sf
        dk[k] = sd


@jit
def _inverse3(m, inv):
    """inv = m^-1 for a complex 3 x 3 matrix by its adjugate; False when singular.

    The model's small system (up to three states, padded with an identity) is solved about
    twenty-five times an evaluation: the adjugate costs a third of a pivoted elimination,
    the solves after it are products, and it compiles in a fraction of the time a complex
    elimination does (a fresh install compiles this into the solver). The harmonic
    residual is a search's cost, not an answer's (see the module's docstring).
    """
    inv[0, 0] = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]
    inv[0, 1] = m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2]
    inv[0, 2] = m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]
    inv[1, 0] = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]
    inv[1, 1] = m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0]
    inv[1, 2] = m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]
    inv[2, 0] = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]
    inv[2, 1] = m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1]
    inv[2, 2] = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
    det = m[0, 0] * inv[0, 0] + m[0, 1] * inv[1, 0] + m[0, 2] * inv[2, 0]
    if det == 0.0 or not abs(det) < math.inf:
        return False
    for r in range(3):
        for c in range(3):
            inv[r, c] /= det
    return True


@jit
def harmonic_rows(lz, free, code, n, obs, period, n_samples, scale, scale_free, offset,
                  offset_free, fk, dk, rows):
    """Jacobian columns and residual on the first harmonics, as rows (q + 1, 1 + 2 K).

    ``lz`` (p,) log-parameters, differentiated along ``free``; ``scale`` and ``offset``
    the output's factor and offset (columns for them when free: d/d ln C and d/d offset);
    ``fk``, ``dk`` the load's and data's coefficients at harmonics 0..K
    (:func:`card_spectrum`) of a card of ``n_samples`` samples over ``period`` s; a model of
    at most three states (:data:`MAX_STATES`). False when the model has no finite response
    at some harmonic (a singular ``i w I - A``).
    """
    nf = free.size
    p_count = nf + 1
    q = rows.shape[0] - 1
    a = np.empty((p_count, n, n))
    b = np.empty((p_count, n))
    system(lz, free, code, a, b)
    pad = np.zeros((3, 3), np.complex128)
    inv = np.empty((3, 3), np.complex128)
    x = np.empty(n, np.complex128)
    dx = np.empty(nf, np.complex128)
    w0 = 2.0 * math.pi / period
    root = math.sqrt(n_samples)
    for k in range(fk.size):
        s = 1j * (w0 * k)
        # (i w I - A) x = B, then the observed state's derivatives: d x = (i w I - A)^-1
        # (dA x + dB).
        for r in range(3):
            for c in range(3):
                pad[r, c] = (s if r == c else 0.0) - (a[0, r, c] if (r < n and c < n)
                                                       else 0.0)
            if r >= n:
                pad[r, r] = 1.0
        if not _inverse3(pad, inv):
            return False
        for r in range(n):
            v = 0.0j
            for c in range(n):
                v += inv[r, c] * b[0, c]
            x[r] = v
        for i in range(nf):
            v = 0.0j
            for r in range(n):
                w = b[i + 1, r] + 0.0j
                for c in range(n):
                    w += a[i + 1, r, c] * x[c]
                v += inv[obs, r] * w
            dx[i] = v
        hold = 1.0
        if k > 0:
            arg = math.pi * k / n_samples
            hold = (math.sin(arg) / arg) ** 2
        base = hold * fk[k]
        u = x[obs] * base
        res = scale * u - dk[k]
        if k == 0:
            res += offset * n_samples
            weight = 1.0 / root
            parts = 1
        else:
            weight = math.sqrt(2.0) / root
            parts = 2
        col = 0 if k == 0 else 2 * k - 1
        for part in range(parts):
            c = col + part
            for i in range(nf):
                v = weight * scale * dx[i] * base
                rows[i, c] = v.real if part == 0 else v.imag
            j = nf
            if scale_free:
                v = weight * scale * u
                rows[j, c] = v.real if part == 0 else v.imag
                j += 1
            if offset_free:
                rows[j, c] = weight * n_samples if (k == 0 and part == 0) else 0.0
            v = weight * res
            rows[q, c] = v.real if part == 0 else v.imag
    for c in range(rows.shape[1]):
        if not math.isfinite(rows[q, c]):
            return False
        for i in range(q):
            if not math.isfinite(rows[i, c]):
                return False
    return True
