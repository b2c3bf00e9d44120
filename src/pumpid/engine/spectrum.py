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

Why: an evaluation is then the model's transfer function as a ratio of polynomials
(:func:`transfer_coefficients`, once) evaluated at ``K + 1`` frequencies. The exact
simulation needs a matrix exponential with its sensitivities, a transition over the period
and two passes over the samples; on 200-sample field cards a harmonic evaluation on 24
harmonics costs a fraction of it (see :class:`pumpid.engine.solvers.LevenbergMarquardt`'s
``harmonics``). The cut cost differs from the exact one by the residual's higher harmonics,
which move little with the parameters: good enough to tell basins apart, never used for an
answer.
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import jit
from .kernel import system

__all__ = ["MAX_STATES", "SEARCH_HARMONICS", "at_frequency", "card_spectrum",
           "harmonic_residual", "harmonic_rows", "harmonic_width", "transfer_coefficients"]

#: Harmonics the searches look at: those that carry a field card (above them its model's
#: response is small, and the hold's aliases grow).
SEARCH_HARMONICS = 24
#: The largest model the harmonic residual takes (every built-in model has at most three
#: states): its transfer function is a ratio of polynomials of degree three at most
#: (:func:`transfer_coefficients`).
MAX_STATES = 3
#: The complex step of the coefficients' sensitivities: the coefficients are polynomials in
#: the system's entries, so the step only has to keep its square's terms below rounding
#: (and its cube above underflow).
COMPLEX_STEP = 1e-30


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
def _entry(a, n, i, j):
    """Entry (i, j) of s I - a, padded to 3 x 3 with an identity block, as (s-coefficient,
    constant)."""
    if i < n and j < n:
        return (1.0 if i == j else 0.0), -a[i, j]
    # Times a[0, 0]'s zero: both branches then return a's type, real or complex.
    return 0.0, (1.0 if i == j else 0.0) + 0.0 * a[0, 0]


@jit
def _minor(a, n, r1, r2, c1, c2):
    """A 2 x 2 minor of the padded s I - a: its coefficients of s^2, s, 1."""
    a1, b1 = _entry(a, n, r1, c1)
    a2, b2 = _entry(a, n, r1, c2)
    a3, b3 = _entry(a, n, r2, c1)
    a4, b4 = _entry(a, n, r2, c2)
    return a1 * a4 - a2 * a3, a1 * b4 + b1 * a4 - a2 * b3 - b2 * a3, b1 * b4 - b2 * b3


@jit
def _others(i):
    """The two indices of 0, 1, 2 other than i, in order."""
    if i == 0:
        return 1, 2
    if i == 1:
        return 0, 2
    return 0, 1


@jit
def transfer_coefficients(a, b, n, obs, top, bottom):
    """The observed state's transfer function ((s I - a)^-1 b)[obs] of a model of n <= 3
    states as a ratio of polynomials: ``top`` gets the coefficients of 1, s, s^2 and
    ``bottom`` (det(s I - a)) those of 1, s, s^2, s^3.

    Cramer's rule on the system padded to 3 x 3 with an identity block, each 2 x 2 minor
    expanded as a product of linear polynomials in s. Evaluating the ratio at a harmonic is
    then a few products, where solving the complex system at every harmonic costs several
    times as much. Real or complex arrays (complex ones give sensitivities by the complex
    step: the coefficients are polynomials in the entries).
    """
    for k in range(4):
        bottom[k] = 0.0
    for k in range(3):
        top[k] = 0.0
    r1, r2 = _others(0)
    for c in range(3):
        # The first row's expansion: entry (0, c) times its cofactor.
        c1, c2 = _others(c)
        q2, q1, q0 = _minor(a, n, r1, r2, c1, c2)
        al, be = _entry(a, n, 0, c)
        sign = -1.0 if c == 1 else 1.0
        bottom[3] += sign * al * q2
        bottom[2] += sign * (al * q1 + be * q2)
        bottom[1] += sign * (al * q0 + be * q1)
        bottom[0] += sign * be * q0
    c1, c2 = _others(obs)
    for r in range(n):
        # The column obs replaced by b: b_r times the cofactor (r, obs).
        s1, s2 = _others(r)
        q2, q1, q0 = _minor(a, n, s1, s2, c1, c2)
        sign = -1.0 if (r + obs) % 2 == 1 else 1.0
        top[2] += sign * b[r] * q2
        top[1] += sign * b[r] * q1
        top[0] += sign * b[r] * q0


@jit
def at_frequency(coefficients, om):
    """A polynomial of :func:`transfer_coefficients` (3 or 4 real coefficients, of 1, s,
    s^2[, s^3]) at s = i om."""
    om2 = om * om
    c = coefficients
    if c.size == 4:
        return complex(c[0] - c[2] * om2, om * (c[1] - c[3] * om2))
    return complex(c[0] - c[2] * om2, c[1] * om)


@jit
def _at_harmonic(top, bottom, om, k, n_samples, fk, dk, scale, offset):
    """Harmonic k's part of the residual: (ok, 1 / D, the observed state's response per
    unit load, the held load's coefficient, the model's coefficient, the residual's, its
    row weight); ok False where D is 0. One function for the rows and the residual alone,
    so that both give the same residual to the last bit."""
    den = at_frequency(bottom, om)
    if den == 0.0:
        zero = 0.0 + 0.0j
        return False, zero, zero, zero, zero, zero, 0.0
    inv = 1.0 / den
    x_obs = at_frequency(top, om) * inv
    hold = 1.0
    if k > 0:
        arg = math.pi * k / n_samples
        hold = (math.sin(arg) / arg) ** 2
    base = hold * fk[k]
    u = x_obs * base
    res = scale * u - dk[k]
    root = math.sqrt(n_samples)
    if k == 0:
        res += offset * n_samples
        weight = 1.0 / root
    else:
        weight = math.sqrt(2.0) / root
    return True, inv, x_obs, base, u, res, weight


@jit
def harmonic_residual(lz, free, code, n, obs, period, n_samples, scale, offset, fk, dk, out):
    """The residual row of :func:`harmonic_rows` alone (1 + 2 K,), without the
    sensitivities: a trial point's cost. False when not finite."""
    a = np.empty((1, n, n))
    b = np.empty((1, n))
    system(lz, free[:0], code, a, b)
    top = np.empty(3)
    bottom = np.empty(4)
    transfer_coefficients(a[0], b[0], n, obs, top, bottom)
    w0 = 2.0 * math.pi / period
    for k in range(fk.size):
        ok, _inv, _x, _base, _u, res, weight = _at_harmonic(top, bottom, w0 * k, k, n_samples,
                                                            fk, dk, scale, offset)
        if not ok:
            return False
        v = weight * res
        if k == 0:
            out[0] = v.real
        else:
            out[2 * k - 1] = v.real
            out[2 * k] = v.imag
    for c in range(out.size):
        if not math.isfinite(out[c]):
            return False
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
    top = np.empty(3)
    bottom = np.empty(4)
    transfer_coefficients(a[0], b[0], n, obs, top, bottom)
    # Each free parameter's derivative of the coefficients by the complex step: exact to
    # rounding for polynomials, and one pass per parameter, not one per harmonic.
    d_top = np.empty((nf, 3))
    d_bottom = np.empty((nf, 4))
    ac = np.empty((n, n), np.complex128)
    bc = np.empty(n, np.complex128)
    c_top = np.empty(3, np.complex128)
    c_bottom = np.empty(4, np.complex128)
    for i in range(nf):
        for r in range(n):
            bc[r] = complex(b[0, r], COMPLEX_STEP * b[i + 1, r])
            for c in range(n):
                ac[r, c] = complex(a[0, r, c], COMPLEX_STEP * a[i + 1, r, c])
        transfer_coefficients(ac, bc, n, obs, c_top, c_bottom)
        for j in range(3):
            d_top[i, j] = c_top[j].imag / COMPLEX_STEP
        for j in range(4):
            d_bottom[i, j] = c_bottom[j].imag / COMPLEX_STEP
    dx = np.empty(nf, np.complex128)
    w0 = 2.0 * math.pi / period
    for k in range(fk.size):
        om = w0 * k
        ok, inv, x_obs, base, u, res, weight = _at_harmonic(top, bottom, om, k, n_samples,
                                                            fk, dk, scale, offset)
        if not ok:
            return False
        for i in range(nf):
            # d(N / D) = (dN - (N / D) dD) / D
            dx[i] = (at_frequency(d_top[i], om) - x_obs * at_frequency(d_bottom[i], om)) * inv
        parts = 1 if k == 0 else 2
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
