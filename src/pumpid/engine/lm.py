"""Levenberg-Marquardt, compiled, as a state machine the drivers step through.

One algorithm for every fit: MINPACK's ``lmder`` scheme (Moré's trust-region
Levenberg-Marquardt) on the triangular factor of ``[J r]``:

* scaled coordinates ``D dz``: ``D`` given by the driver (the compiled drivers give 1 for the
  log-parameters, which are relative already, and 1 / range of the data for an offset), or
  MINPACK's running maximum of the Jacobian's column norms when none is given. Column-norm
  scaling lets a weakly determined parameter (a mass the card barely sees) take most of
  every damped step, and a card whose optimum lies along such a direction then zig-zags
  through hundreds of tiny steps (845 evaluations against 32 with the fixed scaling on one
  periodic card);
* a trust radius in those coordinates: the Gauss-Newton step when it fits, otherwise the
  damped step whose length is the radius (the damping found by Newton's method on the secular
  equation, from an SVD of the small factor: the small singular values of ill-conditioned
  problems stay accurate, as they would not in the normal equations);
* the radius halves on poor steps (gain ratio < 1/4) and grows to twice the step on good ones;
* box bounds on the coordinates (the log-parameters' search window): a coordinate at a bound
  that the step would push outward is held there for the step (an active set);
* a cap on the step of the log-parameters (a factor ``e`` per iteration), so a step along a
  flat direction cannot fling a parameter into a region where the model degenerates;
* MINPACK's stop tests: trust radius <= tol |D z| (xtol), relative actual and predicted cost
  reductions <= tol (ftol), cosine between residual and Jacobian columns <= tol (gtol); and
  a statistical one (noise): the full Gauss-Newton step would gain less than ``noise_tol``
  times the residual variance ``2 cost / (N - q)``. Near the optimum of noisy data the
  Gauss-Newton gain is ``(d / se)^2 sigma^2 / 2`` for a distance ``d`` along a direction of
  standard error ``se``, so the answer is then within ``sqrt(2 noise_tol)`` standard errors
  of the exact optimum, far inside its uncertainty, while a flat, curved valley of a
  weakly determined combination no longer costs hundreds of steps to follow to the last
  digit. Exact data (zero residual) make the test relative to a vanishing cost, so exact
  fits still converge to rounding. A full
  Gauss-Newton step that is already below xtol, or predicted to gain less than ftol right
  after a reliable step, ends the iteration without one more evaluation;
* geodesic acceleration (Transtrum and Sethna's second-order correction) for problems that
  take more than ``ACCEL_AFTER`` evaluations: the residual's second directional derivative
  along the step, from one residual-only evaluation at ``z + h v``, bends the step along a
  curved valley (``v + a/2``, kept when ``2|a|/|v| <= ACCEL_RATIO``). A long curved valley --
  a stiffness trading against a damper on the way from near a limit -- otherwise costs
  hundreds of short steps;
* a restart of the scaling every ``SEGMENT`` evaluations that still made progress: the
  running maximum of the column norms remembers where the iteration came from, and along a
  long curved valley (a parameter on its way back from near a limit) that memory makes the
  steps crawl; ``D`` and the radius are then taken afresh from the current point.

The loop is written as *reverse communication*: :func:`propose` computes the next trial point
(or decides to stop) and :func:`update` takes the evaluation of that point. The compiled
drivers (:mod:`pumpid.engine.drive`) call the two around the compiled simulation; a Python
driver (:func:`pumpid.engine.solvers.run_python`) calls the same two around an evaluator that
only Python can run (a nonlinear model integrated by scipy). So every fit, one card or ten
thousand, steps through the same compiled algorithm.

Why by hand: scipy's ``least_squares`` drives one problem through Python callbacks whose
overhead is most of a millisecond fit, cannot run inside compiled code, and no library offers
a compiled, bounded LM to call per card from a parallel loop.
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import copy_into, jit

__all__ = ["CONVERGED", "EXHAUSTED", "FAILED", "TESTS", "accelerate", "accepts", "householder",
           "householder_keep", "probing", "project", "propose", "pseudo_inverse", "small_svd",
           "start", "update"]

#: Largest change of a log-parameter in one step.
MAX_LOG_STEP = 1.0
#: Initial trust radius as a multiple of |D z0| (MINPACK's ``factor``).
FACTOR = 100.0
#: Evaluations between restarts of the scaling (when the segment still made progress).
SEGMENT = 100
#: Geodesic acceleration from this many evaluations on (easy problems never pay for it).
ACCEL_AFTER = 6
#: Largest 2|a|/|v| for which the accelerated step is taken.
ACCEL_RATIO = 0.75
#: Finite-difference step (in units of the step) of the second directional derivative.
ACCEL_H = 0.1
#: Outcome codes.
RUNNING, CONVERGED, EXHAUSTED, FAILED = -1, 0, 2, 3
#: Which stop test fired, for converged problems.
TESTS = ("gtol", "ftol", "xtol", "zero", "noise")

# Slots of the state's float and integer arrays.
_COST, _DELTA, _PRED, _PNORM, _TOL, _GCOS, _SEGCOST, _LAMBDA, _NOISE = range(9)
_EVALS, _ACCEPTED, _TRUSTED, _GN, _CODE, _TEST, _NCAP, _MAXEV, _ACCEL, _PHASE, _FIXED = range(11)


@jit
def householder(rows, q, r_out, c_out):
    """Cost and triangular factor of ``[J r]`` from its columns stored as rows.

    ``rows`` (q + 1, N): the Jacobian's columns, then the residual; overwritten. Fills
    ``r_out`` (q, q) with R and ``c_out`` (q,) with ``Q^T r``; returns ``0.5 |r|^2``.
    Householder reflections column by column (each column contiguous); Q is never formed.
    """
    return householder_keep(rows, q, r_out, c_out, np.empty(q), np.empty(q))


@jit
def householder_keep(rows, q, r_out, c_out, v0, beta):
    """:func:`householder` that also keeps the reflections for :func:`project`: their
    vectors stay in ``rows[j, j+1:]`` with their first entries in ``v0`` and factors in
    ``beta``."""
    n = rows.shape[1]
    cost = 0.0
    for k in range(n):
        cost += rows[q, k] * rows[q, k]
    cost *= 0.5
    for j in range(q):
        norm = 0.0
        for k in range(j, n):
            norm += rows[j, k] * rows[j, k]
        norm = math.sqrt(norm)
        if norm == 0.0:
            for i in range(q):
                r_out[j, i] = 0.0
            c_out[j] = 0.0
            v0[j] = 0.0
            beta[j] = 0.0
            continue
        alpha = -norm if rows[j, j] >= 0.0 else norm
        v0[j] = rows[j, j] - alpha
        # v = (v0, rows[j, j+1:]); beta = 2 / |v|^2
        vnorm2 = v0[j] * v0[j] + (norm * norm - rows[j, j] * rows[j, j])
        beta[j] = 2.0 / vnorm2 if vnorm2 > 0.0 else 0.0
        rows[j, j] = alpha
        for i in range(j + 1, q + 1):
            s = v0[j] * rows[i, j]
            for k in range(j + 1, n):
                s += rows[j, k] * rows[i, k]
            s *= beta[j]
            rows[i, j] -= s * v0[j]
            for k in range(j + 1, n):
                rows[i, k] -= s * rows[j, k]
        for i in range(q):
            r_out[j, i] = 0.0 if i < j else rows[i, j]
        c_out[j] = rows[q, j]
    return cost


@jit
def project(rows, q, v0, beta, y, out):
    """``out`` (q,) = the first q entries of ``Q^T y`` for the reflections kept by
    :func:`householder_keep` in ``rows``, ``v0``, ``beta``; ``y`` (N,) is overwritten."""
    n = y.size
    for j in range(q):
        s = v0[j] * y[j]
        for k in range(j + 1, n):
            s += rows[j, k] * y[k]
        s *= beta[j]
        y[j] -= s * v0[j]
        for k in range(j + 1, n):
            y[k] -= s * rows[j, k]
        out[j] = y[j]


@jit
def _solve_upper(r, b, x):
    """x = R^-1 b for an upper triangular R; False when a pivot is zero."""
    q = b.size
    for i in range(q - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, q):
            s -= r[i, k] * x[k]
        if r[i, i] == 0.0:
            return False
        x[i] = s / r[i, i]
    return True


@jit
def small_svd(a):
    """``u, sig, vt`` of a small square matrix, singular values descending (as
    ``np.linalg.svd``), by one-sided Jacobi rotations (Hestenes).

    Why by hand: the solver factors a q x q matrix (q <= about 8) once or twice per step.
    LAPACK through numba copies, queries its workspace and allocates on every call (about
    4.4 us for 5 x 5, as long as a short card's evaluation), and its wrapper is compiled
    into the one entry point that simulates. Jacobi rotations take about 2.3 us there and
    keep the small singular values of an ill-conditioned factor to relative accuracy.
    Columns of ``u`` for a zero singular value are zero (every caller weights them by it).
    """
    n = a.shape[0]
    w = a.copy()
    v = np.eye(n)
    for _sweep in range(60):
        rotated = False
        for i in range(n - 1):
            for j in range(i + 1, n):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(n):
                    alpha += w[k, i] * w[k, i]
                    beta += w[k, j] * w[k, j]
                    gamma += w[k, i] * w[k, j]
                if gamma == 0.0 or abs(gamma) <= 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                cs = 1.0 / math.sqrt(1.0 + t * t)
                sn = cs * t
                for k in range(n):
                    wi = w[k, i]
                    wj = w[k, j]
                    w[k, i] = cs * wi - sn * wj
                    w[k, j] = sn * wi + cs * wj
                    vi = v[k, i]
                    vj = v[k, j]
                    v[k, i] = cs * vi - sn * vj
                    v[k, j] = sn * vi + cs * vj
        if not rotated:
            break
    norms = np.empty(n)
    for j in range(n):
        s = 0.0
        for k in range(n):
            s += w[k, j] * w[k, j]
        norms[j] = math.sqrt(s)
    u = np.zeros((n, n))
    sig = np.empty(n)
    vt = np.empty((n, n))
    for jj in range(n):
        # Largest remaining column first (a selection: n is tiny).
        j = 0
        for i in range(n):
            if norms[i] > norms[j]:
                j = i
        sig[jj] = norms[j]
        for k in range(n):
            vt[jj, k] = v[k, j]
            if norms[j] > 0.0:
                u[k, jj] = w[k, j] / norms[j]
        norms[j] = -1.0
    return u, sig, vt


@jit
def pseudo_inverse(a, rcond):
    """Moore-Penrose inverse of a small square matrix by :func:`small_svd`, the singular
    values at or below ``rcond`` times the largest dropped (as ``np.linalg.pinv``).

    Why by hand: numba compiles a LAPACK wrapper for each of ``np.linalg``'s functions,
    seconds of a fresh install's first fit each, for matrices of a few rows here."""
    u, sig, vt = small_svd(a)
    n = a.shape[0]
    out = np.zeros((n, n))
    cut = rcond * sig[0] if n > 0 else 0.0
    for c in range(n):
        if sig[c] > cut:
            for i in range(n):
                w = vt[c, i] / sig[c]
                for j in range(n):
                    out[i, j] += w * u[j, c]
    return out


@jit
def _svd_step(r_s, c, delta, step, lam_out):
    """Minimum-norm Gauss-Newton step if it fits the radius, else the damped step of
    length ``delta`` (Newton on 1/|s| - 1/delta, Moré). Returns True for Gauss-Newton;
    ``lam_out[0]`` receives the damping (0 for Gauss-Newton)."""
    q = c.size
    u, sig, vt = small_svd(r_s)
    ct = np.zeros(q)
    for j in range(q):
        s = 0.0
        for i in range(q):
            s += c[i] * u[i, j]
        ct[j] = s
    coef = np.zeros(q)
    gn2 = 0.0
    for j in range(q):
        if sig[j] > sig[0] * 1e-14:
            coef[j] = ct[j] / sig[j]
            gn2 += coef[j] * coef[j]
    fits = math.sqrt(gn2) <= 1.1 * delta
    lam_out[0] = 0.0
    if not fits:
        lam = 0.0
        for _ in range(30):
            norm2 = 0.0
            dnorm2 = 0.0
            for j in range(q):
                den = sig[j] * sig[j] + lam
                if den > 0.0:
                    ratio = sig[j] * ct[j] / den
                    norm2 += ratio * ratio
                    dnorm2 += -2.0 * ratio * ratio / den
            norm = math.sqrt(norm2)
            if abs(norm - delta) <= 0.1 * delta or norm == 0.0:
                break
            g = 1.0 / norm - 1.0 / delta
            gp = -0.5 * dnorm2 / (norm2 * norm)
            lam = max(lam - g / gp, 0.0)
        for j in range(q):
            den = sig[j] * sig[j] + lam
            coef[j] = ct[j] * sig[j] / den if den > 0.0 else 0.0
        lam_out[0] = lam
    for i in range(q):
        s = 0.0
        for j in range(q):
            s += coef[j] * vt[j, i]
        step[i] = -s
    return fits


@jit
def _trust_step(r_s, c, delta, step, held, lam_out):
    """The step for the trust region, columns in ``held`` fixed at zero (``lam_out[0]``:
    the damping used)."""
    q = c.size
    masked = r_s.copy()
    any_held = False
    for j in range(q):
        if held[j]:
            any_held = True
            for i in range(q):
                masked[i, j] = 0.0
    if not any_held:
        big = 0.0
        small = math.inf
        for j in range(q):
            piv = abs(r_s[j, j])
            big = max(big, piv)
            small = min(small, piv)
        if small > 1e-12 * big:
            neg = -c
            if _solve_upper(r_s, neg, step):
                norm = 0.0
                for j in range(q):
                    norm += step[j] * step[j]
                if math.isfinite(norm) and math.sqrt(norm) <= 1.1 * delta:
                    lam_out[0] = 0.0
                    return True
    fits = _svd_step(masked, c, delta, step, lam_out)
    for j in range(q):
        if held[j]:
            step[j] = 0.0
    return fits


@jit
def start(z0, cost, r, c, lo, hi, tol, n_capped, max_evals, accel, noise, scaling):
    """A new solver state from the first evaluation (cost, R, Q^T r at z0).

    ``accel``: the driver can answer :func:`probing` requests (geodesic acceleration).
    ``noise``: the noise test's threshold as a fraction of the cost, ``noise_tol * 2 / (N -
    q)`` (0: no such test). ``scaling`` (q,): the fixed ``D``, or an empty array for the
    column-norm scaling.
    Returns the state tuple ``(z, lo, hi, r, c, diag, z_try, floats, ints, velocity,
    held)``; its code is FAILED when the first evaluation is not finite.
    """
    q = z0.size
    z = z0.copy()
    diag = np.ones(q)
    fs = np.zeros(9)
    ints = np.zeros(11, np.int64)
    fs[_NOISE] = noise
    fixed = scaling.size == q
    ints[_FIXED] = 1 if fixed else 0
    ints[_ACCEL] = 1 if accel else 0
    ints[_CODE] = RUNNING
    ints[_TEST] = -1
    ints[_NCAP] = n_capped
    ints[_MAXEV] = max_evals
    fs[_TOL] = tol
    fs[_COST] = cost
    finite = math.isfinite(cost)
    for i in range(q):
        finite = finite and math.isfinite(c[i])
        for j in range(q):
            finite = finite and math.isfinite(r[i, j])
    if not finite:
        ints[_CODE] = FAILED
        fs[_COST] = math.nan
    else:
        znorm = 0.0
        for j in range(q):
            diag[j] = scaling[j] if fixed else _column_norm(r, j, q)
            znorm += (diag[j] * z[j]) ** 2
        fs[_DELTA] = FACTOR * math.sqrt(znorm)
        if not fs[_DELTA] > 0.0:
            fs[_DELTA] = FACTOR
        fs[_SEGCOST] = cost
    return (z, lo.copy(), hi.copy(), r.copy(), c.copy(), diag, np.zeros(q), fs, ints,
            np.zeros(q), np.zeros(q))


@jit
def propose(state):
    """The next trial point into the state's ``z_try``; False when the iteration stopped.

    Also applies the stop tests that need no new evaluation (the gradient test, and a full
    Gauss-Newton step below xtol or predicted to gain less than ftol after a reliable step).
    """
    z, lo, hi, r, c, diag, z_try, fs, ints, vel, held_f = state
    if ints[_CODE] != RUNNING:
        return False
    q = z.size
    tol = fs[_TOL]
    cost = fs[_COST]
    delta = fs[_DELTA]
    cols = np.empty(q)
    for j in range(q):
        s = 0.0
        for i in range(q):
            s += r[i, j] * r[i, j]
        cols[j] = math.sqrt(s)
        if cols[j] > diag[j] and ints[_FIXED] == 0:
            diag[j] = cols[j]
    r_s = np.empty((q, q))
    for i in range(q):
        for j in range(q):
            r_s[i, j] = r[i, j] / diag[j]
    r_norm = math.sqrt(2.0 * cost)
    g_cos = 0.0
    for j in range(q):
        if cols[j] > 0.0:
            s = 0.0
            for i in range(q):
                s += c[i] * r[i, j]
            g_cos = max(g_cos, abs(s) / cols[j])
    g_cos /= r_norm if r_norm > 0.0 else 1.0
    fs[_GCOS] = g_cos
    grad = np.empty(q)
    for j in range(q):
        s = 0.0
        for i in range(q):
            s += c[i] * r_s[i, j]
        grad[j] = s
    held = np.zeros(q, np.bool_)
    bounded = False
    for j in range(q):
        if z[j] <= lo[j] or z[j] >= hi[j]:
            bounded = True
            if (z[j] <= lo[j] and grad[j] > 0.0) or (z[j] >= hi[j] and grad[j] < 0.0):
                held[j] = True
    step = np.zeros(q)
    lam = np.zeros(1)
    gauss_newton = _trust_step(r_s, c, delta, step, held, lam)
    if bounded:
        # Coordinates the step itself pushes out through the correlations join the held ones.
        for _ in range(q):
            pushed = False
            for j in range(q):
                if not held[j] and ((z[j] <= lo[j] and step[j] < 0.0)
                                    or (z[j] >= hi[j] and step[j] > 0.0)):
                    held[j] = True
                    pushed = True
            if not pushed:
                break
            gauss_newton = _trust_step(r_s, c, delta, step, held, lam)
    dz = np.empty(q)
    for j in range(q):
        dz[j] = step[j] / diag[j]
    _cap_log_step(dz, ints[_NCAP])
    for j in range(q):
        z_try[j] = min(max(z[j] + dz[j], lo[j]), hi[j])
        dz[j] = z_try[j] - z[j]
        step[j] = dz[j] * diag[j]
    p_norm = 0.0
    z_norm = 0.0
    pred = 0.0
    for i in range(q):
        p_norm += step[i] * step[i]
        z_norm += (diag[i] * z[i]) ** 2
        lin = c[i]
        for j in range(i, q):
            lin += r_s[i, j] * step[j]
        pred += c[i] * c[i] - lin * lin
    p_norm = math.sqrt(p_norm)
    z_norm = math.sqrt(z_norm)
    pred *= 0.5
    fs[_PRED] = pred
    fs[_PNORM] = p_norm
    ints[_GN] = 1 if gauss_newton else 0
    if g_cos <= tol:
        ints[_CODE] = CONVERGED
        ints[_TEST] = 0
        return False
    if fs[_NOISE] > 0.0:
        # The full Gauss-Newton gain 0.5 |Q1^T r|^2 (over the well-conditioned part).
        gain = 0.0
        for i in range(q):
            gain += c[i] * c[i]
        if 0.5 * gain <= fs[_NOISE] * cost:
            ints[_CODE] = CONVERGED
            ints[_TEST] = 4
            return False
    if gauss_newton and ints[_TRUSTED] == 1 and pred <= tol * cost:
        ints[_CODE] = CONVERGED
        ints[_TEST] = 1
        return False
    if gauss_newton and p_norm <= tol * z_norm:
        ints[_CODE] = CONVERGED
        ints[_TEST] = 2
        return False
    if ints[_ACCEL] == 1 and ints[_EVALS] >= ACCEL_AFTER:
        # Ask the driver for the residual at z + h v first (see accelerate).
        fs[_LAMBDA] = lam[0]
        for j in range(q):
            vel[j] = step[j]
            held_f[j] = 1.0 if held[j] else 0.0
            z_try[j] = min(max(z[j] + ACCEL_H * dz[j], lo[j]), hi[j])
        ints[_PHASE] = 1
    return True


@jit
def probing(state):
    """True when :func:`propose` asks for the residual at ``z_try`` projected on the current
    point's ``Q`` (pass it to :func:`accelerate`) before the trial point itself."""
    return state[8][_PHASE] == 1


@jit
def accelerate(state, c_probe, ok):
    """Bend the proposed step with the geodesic acceleration; ``c_probe`` (q,) holds the
    first q entries of ``Q^T r(z + h v)`` (``ok`` False when that point could not be
    evaluated: the plain step is kept). Leaves the trial point in ``z_try``."""
    z, lo, hi, r, c, diag, z_try, fs, ints, vel, held_f = state
    q = z.size
    ints[_PHASE] = 0
    ints[_EVALS] += 1
    h = ACCEL_H
    # Q^T r_vv with r_vv = (2/h) ((r(z + h v) - r(z)) / h - J v): Q^T J v = R v.
    c_vv = np.empty(q)
    finite = ok
    for i in range(q):
        rv = 0.0
        for j in range(i, q):
            rv += r[i, j] * vel[j] / diag[j]
        c_vv[i] = (2.0 / h) * ((c_probe[i] - c[i]) / h - rv)
        finite = finite and math.isfinite(c_vv[i])
    accel = np.zeros(q)
    if finite:
        r_s = np.empty((q, q))
        for i in range(q):
            for j in range(q):
                r_s[i, j] = 0.0 if held_f[j] > 0.0 else r[i, j] / diag[j]
        # The same damped system as the velocity, right-hand side r_vv.
        u, sig, vt = small_svd(r_s)
        lam = fs[_LAMBDA]
        for k in range(q):
            if not sig[k] > sig[0] * 1e-14:
                continue
            ct = 0.0
            for i in range(q):
                ct += c_vv[i] * u[i, k]
            coef = ct * sig[k] / (sig[k] * sig[k] + lam)
            for j in range(q):
                accel[j] -= coef * vt[k, j]
    v_norm = 0.0
    a_norm = 0.0
    for j in range(q):
        if held_f[j] > 0.0:
            accel[j] = 0.0
        v_norm += vel[j] * vel[j]
        a_norm += accel[j] * accel[j]
    use = finite and v_norm > 0.0 and 2.0 * math.sqrt(a_norm) <= ACCEL_RATIO * math.sqrt(
        v_norm)
    dz = np.empty(q)
    for j in range(q):
        dz[j] = (vel[j] + (0.5 * accel[j] if use else 0.0)) / diag[j]
    if use:
        _cap_log_step(dz, ints[_NCAP])
    for j in range(q):
        z_try[j] = min(max(z[j] + dz[j], lo[j]), hi[j])


@jit
def _column_norm(r, j, q):
    """MINPACK's scaling of coordinate j: the norm of its column of R (1 when zero)."""
    col = 0.0
    for i in range(q):
        col += r[i, j] * r[i, j]
    col = math.sqrt(col)
    return col if col > 0.0 else 1.0


@jit
def _cap_log_step(dz, n_cap):
    """Scale the whole step down so that no capped log-coordinate (the first n_cap) moves
    by more than MAX_LOG_STEP."""
    big = 0.0
    for j in range(n_cap):
        big = max(big, abs(dz[j]))
    if big > MAX_LOG_STEP:
        for j in range(dz.size):
            dz[j] *= MAX_LOG_STEP / big


@jit
def _ratio(actual, pred):
    """The gain ratio: the actual decrease of the cost over the predicted one."""
    if pred > 0.0:
        return actual / pred
    return 1.0 if actual > 0.0 else -1.0


@jit
def accepts(state, cost_try):
    """Whether :func:`update` takes a trial point of cost ``cost_try`` (its factor being
    finite): a driver that has the trial's residual alone needs its Jacobian only then."""
    fs = state[7]
    if not math.isfinite(cost_try):
        return False
    return _ratio(fs[_COST] - cost_try, fs[_PRED]) >= 1e-4


@jit
def update(state, cost_try, r_try, c_try):
    """Take the evaluation of ``z_try``; False when the iteration stopped."""
    z, _lo, _hi, r, c, diag, z_try, fs, ints, _vel, _held = state
    q = z.size
    tol = fs[_TOL]
    cost = fs[_COST]
    delta = fs[_DELTA]
    pred = fs[_PRED]
    p_norm = fs[_PNORM]
    finite = math.isfinite(cost_try)
    for i in range(q):
        finite = finite and math.isfinite(c_try[i])
        for j in range(q):
            finite = finite and math.isfinite(r_try[i, j])
    if not finite:
        cost_try = math.inf
    actual = cost - cost_try
    rho = _ratio(actual, pred)
    accept = finite and rho >= 1e-4
    ints[_EVALS] += 1
    if accept:
        ints[_ACCEPTED] += 1
    ints[_TRUSTED] = 1 if (accept and rho >= 0.25) else 0
    if rho < 0.25:
        new = 0.5 * min(delta, 10.0 * p_norm)
    elif ints[_GN] == 1 or rho >= 0.75:
        new = max(delta, 2.0 * p_norm)
    else:
        new = delta
    fs[_DELTA] = new if (math.isfinite(new) and new > 0.0) else 0.5 * delta
    f_test = abs(actual) <= tol * cost and pred <= tol * cost and rho <= 2.0
    if accept:
        copy_into(z, z_try)
        copy_into(r, r_try)
        copy_into(c, c_try)
        fs[_COST] = cost_try
    z_norm = 0.0
    for i in range(q):
        z_norm += (diag[i] * z[i]) ** 2
    x_test = fs[_DELTA] <= tol * math.sqrt(z_norm)
    if fs[_COST] == 0.0:
        ints[_CODE] = CONVERGED
        ints[_TEST] = 3
        return False
    if f_test or x_test:
        ints[_CODE] = CONVERGED
        ints[_TEST] = 1 if f_test else 2
        return False
    if ints[_EVALS] % SEGMENT == 0:
        if fs[_SEGCOST] - fs[_COST] > tol * fs[_COST]:
            znorm = 0.0
            for j in range(q):
                if ints[_FIXED] == 0:
                    diag[j] = _column_norm(r, j, q)
                znorm += (diag[j] * z[j]) ** 2
            fs[_DELTA] = FACTOR * math.sqrt(znorm) if znorm > 0.0 else FACTOR
        fs[_SEGCOST] = fs[_COST]
    if ints[_EVALS] >= ints[_MAXEV]:
        ints[_CODE] = EXHAUSTED
        return False
    return True
