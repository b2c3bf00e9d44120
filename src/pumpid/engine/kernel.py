"""The compiled kernel: exact simulation of a linear model with its parameter sensitivities.

A model is ``x' = A(theta) x + B(theta) g(F)`` with the measured load ``F`` taken linear
between samples (first-order hold). Every entry of ``A`` and ``B`` is a sum of monomials
``c * prod(theta_j ** e_j)`` (see :mod:`pumpid.models.base`), so the derivatives with respect
to ``ln theta`` come for free: ``d/d ln theta_j`` of a monomial is ``e_j`` times the monomial.

Sensitivities are carried as *dual matrices*: an array ``X`` of shape ``(P, m, m)`` holds a
matrix ``X[0]`` and its derivatives ``X[1 + i]`` along the free log-parameters. Products,
solves, the matrix exponential and powers act on the value and propagate first-order
derivatives exactly (forward-mode differentiation of each operation), so the one-step map

    x[k+1] = Phi x[k] + G0 g[k] + G1 g[k+1]

(``Phi, G0, G1`` from one exponential of an augmented matrix; explicit Euler for the paper's
scheme) and its exact derivatives come out together, and the recursion over the samples
carries each state's derivatives beside it. Initial states: rest, the static equilibrium under
the first load sample, a given state, or the periodic steady state (``(I - Phi_T) x0 = x_T``
with ``Phi_T`` the transition over one period, differentiated like the rest).

Why by hand: scipy's ``expm`` and ``lsim`` are Python-level calls per parameter set (their
overhead dominates a millisecond fit) and cannot be called from compiled code; no library
offers the exact discrete sensitivities of a first-order-hold recursion. The matrix
exponential is the standard scaling-and-squaring Pade algorithm (Higham 2005) written for
dual matrices.

Everything here is compiled by numba once and cached on disk; nothing allocates per sample.
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import copy_into, jit

__all__ = [
    "EQUILIBRIUM",
    "EULER",
    "EXACT",
    "GIVEN",
    "PERIODIC",
    "REST",
    "simulate_card",
]

#: Initial-state modes.
REST, EQUILIBRIUM, PERIODIC, GIVEN = 0, 1, 2, 3
#: Integrators.
EXACT, EULER = 0, 1
#: Input maps: none, or the power law g = ref * sign(F) * |F / ref|^(1/n) of one parameter.
NO_MAP, POWER_LAW = 0, 1

# Pade coefficients b_k of the [m/m] approximants of exp (Higham 2005, table 2.3) and the
# 1-norm bounds theta_m up to which degree m keeps the backward error below 2^-53.
_B3 = np.array([120.0, 60.0, 12.0, 1.0])
_B5 = np.array([30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0])
_B7 = np.array([17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0])
_B9 = np.array([17643225600.0, 8821612800.0, 2075673600.0, 302702400.0, 30270240.0,
                2162160.0, 110880.0, 3960.0, 90.0, 1.0])
_B13 = np.array([64764752532480000.0, 32382376266240000.0, 7771770303897600.0,
                 1187353796428800.0, 129060195264000.0, 10559470521600.0, 670442572800.0,
                 33522128640.0, 1323241920.0, 40840800.0, 960960.0, 16380.0, 182.0, 1.0])
_THETA = np.array([1.495585217958292e-2, 2.539398330063230e-1, 9.504178996162932e-1,
                   2.097847961257068, 5.371920351148152])


# --------------------------------------------------------------------------- dual algebra
@jit
def dual_mul(x, y, z):
    """z = x y for dual matrices (P, m, m); z must not alias x or y."""
    p_count, m, _ = x.shape
    for r in range(m):
        for c in range(m):
            s = 0.0
            for k in range(m):
                s += x[0, r, k] * y[0, k, c]
            z[0, r, c] = s
    for i in range(1, p_count):
        for r in range(m):
            for c in range(m):
                s = 0.0
                for k in range(m):
                    s += x[i, r, k] * y[0, k, c] + x[0, r, k] * y[i, k, c]
                z[i, r, c] = s


@jit
def lu_factor(a, piv):
    """In-place LU with partial pivoting of a small square matrix; False when singular."""
    m = a.shape[0]
    for k in range(m):
        p = k
        big = abs(a[k, k])
        for r in range(k + 1, m):
            if abs(a[r, k]) > big:
                big = abs(a[r, k])
                p = r
        piv[k] = p
        if p != k:
            for c in range(m):
                tmp = a[k, c]
                a[k, c] = a[p, c]
                a[p, c] = tmp
        d = a[k, k]
        if d == 0.0 or not math.isfinite(d):
            return False
        for r in range(k + 1, m):
            a[r, k] /= d
            f = a[r, k]
            if f != 0.0:
                for c in range(k + 1, m):
                    a[r, c] -= f * a[k, c]
    return True


@jit
def lu_solve(lu, piv, b):
    """Solve in place for the columns of b (m, k) with a factor from :func:`lu_factor`."""
    m = lu.shape[0]
    nc = b.shape[1]
    for k in range(m):
        p = piv[k]
        if p != k:
            for c in range(nc):
                tmp = b[k, c]
                b[k, c] = b[p, c]
                b[p, c] = tmp
    for k in range(m):
        for r in range(k + 1, m):
            f = lu[r, k]
            if f != 0.0:
                for c in range(nc):
                    b[r, c] -= f * b[k, c]
    for k in range(m - 1, -1, -1):
        d = lu[k, k]
        for c in range(nc):
            b[k, c] /= d
        for r in range(k):
            f = lu[r, k]
            if f != 0.0:
                for c in range(nc):
                    b[r, c] -= f * b[k, c]


@jit
def dual_solve(q, rhs):
    """Solve ``Q X = RHS`` for dual ``Q`` (P, m, m) and ``RHS`` (P, m, k), in place in rhs.

    ``X0 = Q0^-1 RHS0`` and ``Xi = Q0^-1 (RHSi - Qi X0)``. Returns False when Q0 is singular.
    """
    p_count, m, _ = q.shape
    nc = rhs.shape[2]
    lu = q[0].copy()
    piv = np.empty(m, np.int64)
    if not lu_factor(lu, piv):
        return False
    lu_solve(lu, piv, rhs[0])
    for i in range(1, p_count):
        for r in range(m):
            for c in range(nc):
                s = 0.0
                for k in range(m):
                    s += q[i, r, k] * rhs[0, k, c]
                rhs[i, r, c] -= s
        lu_solve(lu, piv, rhs[i])
    return True


@jit
def dual_expm(a, out):
    """exp of a dual matrix ``a`` (P, m, m) into ``out``; False when not finite.

    Scaling and squaring with the Pade degree chosen from the value's 1-norm (Higham 2005);
    the derivative parts follow every product and the final solve exactly.
    """
    _p_count, m, _ = a.shape
    norm = 0.0
    for c in range(m):
        s = 0.0
        for r in range(m):
            s += abs(a[0, r, c])
        if s > norm:
            norm = s
    if not math.isfinite(norm):
        return False
    squarings = 0
    if norm <= _THETA[0]:
        b = _B3
    elif norm <= _THETA[1]:
        b = _B5
    elif norm <= _THETA[2]:
        b = _B7
    elif norm <= _THETA[3]:
        b = _B9
    else:
        b = _B13
        if norm > _THETA[4]:
            squarings = math.ceil(math.log2(norm / _THETA[4]))
    degree = b.size - 1
    x = a * (0.5 ** squarings)
    x2 = np.empty_like(x)
    dual_mul(x, x, x2)
    u = np.zeros_like(x)
    v = np.zeros_like(x)
    tmp = np.empty_like(x)
    if degree < 13:
        odd = np.zeros_like(x)
        for r in range(m):
            odd[0, r, r] = b[1]
            v[0, r, r] = b[0]
        power = x2.copy()
        half = degree // 2
        for j in range(1, half + 1):
            odd += b[2 * j + 1] * power
            v += b[2 * j] * power
            if j < half:
                dual_mul(power, x2, tmp)
                copy_into(power, tmp)
        dual_mul(x, odd, u)
    else:
        x4 = np.empty_like(x)
        dual_mul(x2, x2, x4)
        x6 = np.empty_like(x)
        dual_mul(x4, x2, x6)
        inner = b[13] * x6 + b[11] * x4 + b[9] * x2
        dual_mul(x6, inner, tmp)
        odd = tmp + b[7] * x6 + b[5] * x4 + b[3] * x2
        for r in range(m):
            odd[0, r, r] += b[1]
        dual_mul(x, odd, u)
        inner = b[12] * x6 + b[10] * x4 + b[8] * x2
        dual_mul(x6, inner, tmp)
        v = tmp + b[6] * x6 + b[4] * x4 + b[2] * x2
        for r in range(m):
            v[0, r, r] += b[0]
    copy_into(out, v + u)
    if not dual_solve(v - u, out):
        return False
    for _ in range(squarings):
        dual_mul(out, out, tmp)
        copy_into(out, tmp)
    return bool(np.all(np.isfinite(out)))


@jit
def balance(a, d):
    """Diagonal scaling by powers of 2 that balances row and column norms of ``a`` (in place).

    Parlett and Reinsch's iteration (LAPACK's ``gebal`` without permutations): on return
    ``a`` is ``D^-1 A D`` with ``D = diag(d)``. The similarity is exact in floating point;
    it keeps the exponential of a matrix with entries of very different sizes (a soft and a
    stiff spring, a gain of 1e10) from needing dozens of squarings.
    """
    m = a.shape[0]
    for i in range(m):
        d[i] = 1.0
    done = False
    while not done:
        done = True
        for i in range(m):
            c = 0.0
            r = 0.0
            for j in range(m):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c == 0.0 or r == 0.0:
                continue
            g = r / 2.0
            f = 1.0
            total = c + r
            while c < g:
                f *= 2.0
                c *= 4.0
            g = r * 2.0
            while c >= g:
                f /= 2.0
                c /= 4.0
            if (c + r) / f < 0.95 * total:
                done = False
                d[i] *= f
                for j in range(m):
                    a[i, j] /= f
                    a[j, i] *= f


@jit
def dual_power(x, e, out):
    """``out = x ** e`` for a dual matrix and an integer ``e >= 0`` (binary powering)."""
    _p_count, m, _ = x.shape
    out[:] = 0.0
    for r in range(m):
        out[0, r, r] = 1.0
    base = x.copy()
    tmp = np.empty_like(x)
    while e > 0:
        if e & 1:
            dual_mul(out, base, tmp)
            copy_into(out, tmp)
        e >>= 1
        if e:
            dual_mul(base, base, tmp)
            copy_into(base, tmp)


# --------------------------------------------------------------------------- the model
@jit
def system(lz, free, code, a, b):
    """A and B of the model at log-parameters ``lz`` (p,), dual along ``free`` (nf,).

    ``code`` is the model's compiled form (:meth:`pumpid.models.base.Model.code`): term
    positions, coefficients and exponent rows for A and for B.
    """
    a_pos, a_coef, a_exp, b_pos, b_coef, b_exp = code
    p = lz.size
    a[:] = 0.0
    b[:] = 0.0
    for t in range(a_coef.size):
        e = 0.0
        for j in range(p):
            e += a_exp[t, j] * lz[j]
        val = a_coef[t] * math.exp(e)
        r = a_pos[t, 0]
        c = a_pos[t, 1]
        a[0, r, c] += val
        for i in range(free.size):
            a[1 + i, r, c] += a_exp[t, free[i]] * val
    for t in range(b_coef.size):
        e = 0.0
        for j in range(p):
            e += b_exp[t, j] * lz[j]
        val = b_coef[t] * math.exp(e)
        r = b_pos[t]
        b[0, r] += val
        for i in range(free.size):
            b[1 + i, r] += b_exp[t, free[i]] * val


@jit
def discretize(a, b, h, integrator, phi, g0, g1):
    """One step of length h: Phi, G0, G1 (dual); False when not finite."""
    p_count, n, _ = a.shape
    if integrator == EULER:
        for i in range(p_count):
            for r in range(n):
                for c in range(n):
                    phi[i, r, c] = a[i, r, c] * h
                g0[i, r] = b[i, r] * h
                g1[i, r] = 0.0
        for r in range(n):
            phi[0, r, r] += 1.0
        return True
    m = n + 2
    big = np.zeros((p_count, m, m))
    for i in range(p_count):
        for r in range(n):
            for c in range(n):
                big[i, r, c] = a[i, r, c] * h
            big[i, r, n] = b[i, r] * h
    # The extra state is the load increment over the step (not its rate), so G1 is read off
    # directly instead of dividing by a possibly tiny h.
    big[0, n, n + 1] = 1.0
    if not np.all(np.isfinite(big[0])):
        return False
    # exp(D^-1 M D) = D^-1 exp(M) D: find a diagonal D that balances the value, apply the
    # same similarity to every part, and undo it on the exponential. D starts by scaling
    # the input (whose blocks are linear in B) to the size of one, which the row and column
    # balancing cannot do through the input's empty last row; the balancing then evens out
    # states of very different sizes.
    b_size = 0.0
    for r in range(n):
        b_size = max(b_size, abs(big[0, r, n]))
    b_scale = 1.0 / b_size if (b_size > 0.0 and math.isfinite(b_size)) else 1.0
    d0 = np.ones(m)
    d0[n] = b_scale
    d0[n + 1] = b_scale
    trial = big[0].copy()
    for r in range(m):
        for c in range(m):
            trial[r, c] *= d0[c] / d0[r]
    d = np.empty(m)
    balance(trial, d)
    for r in range(m):
        d[r] *= d0[r]
    for i in range(p_count):
        for r in range(m):
            for c in range(m):
                big[i, r, c] *= d[c] / d[r]
    e = np.empty_like(big)
    if not dual_expm(big, e):
        return False
    for i in range(p_count):
        for r in range(n):
            for c in range(n):
                phi[i, r, c] = e[i, r, c] * d[r] / d[c]
            g1[i, r] = e[i, r, n + 1] * d[r] / d[n + 1]
            g0[i, r] = (e[i, r, n] * d[r] / d[n] - g1[i, r])
    return True


@jit
def input_signal(f, lz, free, imap, g, dg):
    """The input seen by the linear part, and its derivative along the mapped parameter.

    ``imap`` = (kind, parameter index, reference). Returns the position of that parameter
    among the free ones, or -1 when the input does not depend on a free parameter.
    """
    kind = int(imap[0])
    if kind == NO_MAP:
        copy_into(g, f)
        return -1
    par = int(imap[1])
    ref = imap[2]
    inv_n = math.exp(-lz[par])
    for k in range(f.size):
        x = abs(f[k]) / ref
        if x > 0.0:
            lx = math.log(x)
            gk = ref * math.copysign(math.exp(lx * inv_n), f[k])
            g[k] = gk
            dg[k] = -gk * lx * inv_n  # d g / d ln n
        else:
            g[k] = 0.0
            dg[k] = 0.0
    for i in range(free.size):
        if free[i] == par:
            return i
    return -1


# --------------------------------------------------------------------------- recursion
@jit
def _advance(phi, g0, g1, x, ga, gb, xn, mapped, dga, dgb):
    """One step of the dual state: xn = Phi x + G0 ga + G1 gb (with derivatives)."""
    p_count, n, _ = phi.shape
    for r in range(n):
        s = g0[0, r] * ga + g1[0, r] * gb
        for c in range(n):
            s += phi[0, r, c] * x[0, c]
        xn[0, r] = s
    for i in range(1, p_count):
        for r in range(n):
            s = g0[i, r] * ga + g1[i, r] * gb
            for c in range(n):
                s += phi[0, r, c] * x[i, c] + phi[i, r, c] * x[0, c]
            xn[i, r] = s
    if mapped >= 0:
        i = mapped + 1
        for r in range(n):
            xn[i, r] += g0[0, r] * dga + g1[0, r] * dgb


@jit
def _pass3(phi, g0, g1, x, g, dg, mapped, obs, y, dy, store):
    """The uniform recursion for three states, unrolled (the common case: Kelvin, Maxwell).

    Runs samples 1..N-1 from the state ``x`` at sample 0 (left at the last sample); with
    ``store`` writes the observed state and its derivatives at samples 1..N-1.
    """
    p_count = phi.shape[0]
    n_samples = g.size
    p00, p01, p02 = phi[0, 0, 0], phi[0, 0, 1], phi[0, 0, 2]
    p10, p11, p12 = phi[0, 1, 0], phi[0, 1, 1], phi[0, 1, 2]
    p20, p21, p22 = phi[0, 2, 0], phi[0, 2, 1], phi[0, 2, 2]
    a0, a1, a2 = g0[0, 0], g0[0, 1], g0[0, 2]
    b0, b1, b2 = g1[0, 0], g1[0, 1], g1[0, 2]
    x0, x1, x2 = x[0, 0], x[0, 1], x[0, 2]
    for k in range(n_samples - 1):
        ga = g[k]
        gb = g[k + 1]
        # Derivative blocks first: they need the value state before it advances.
        for i in range(1, p_count):
            d0, d1, d2 = x[i, 0], x[i, 1], x[i, 2]
            e0 = (p00 * d0 + p01 * d1 + p02 * d2 + phi[i, 0, 0] * x0 + phi[i, 0, 1] * x1
                  + phi[i, 0, 2] * x2 + g0[i, 0] * ga + g1[i, 0] * gb)
            e1 = (p10 * d0 + p11 * d1 + p12 * d2 + phi[i, 1, 0] * x0 + phi[i, 1, 1] * x1
                  + phi[i, 1, 2] * x2 + g0[i, 1] * ga + g1[i, 1] * gb)
            e2 = (p20 * d0 + p21 * d1 + p22 * d2 + phi[i, 2, 0] * x0 + phi[i, 2, 1] * x1
                  + phi[i, 2, 2] * x2 + g0[i, 2] * ga + g1[i, 2] * gb)
            if i == mapped + 1:
                e0 += a0 * dg[k] + b0 * dg[k + 1]
                e1 += a1 * dg[k] + b1 * dg[k + 1]
                e2 += a2 * dg[k] + b2 * dg[k + 1]
            x[i, 0] = e0
            x[i, 1] = e1
            x[i, 2] = e2
            if store:
                dy[i - 1, k + 1] = x[i, obs]
        n0 = p00 * x0 + p01 * x1 + p02 * x2 + a0 * ga + b0 * gb
        n1 = p10 * x0 + p11 * x1 + p12 * x2 + a1 * ga + b1 * gb
        n2 = p20 * x0 + p21 * x1 + p22 * x2 + a2 * ga + b2 * gb
        x0, x1, x2 = n0, n1, n2
        if store:
            y[k + 1] = n0 if obs == 0 else (n1 if obs == 1 else n2)
    x[0, 0] = x0
    x[0, 1] = x1
    x[0, 2] = x2


@jit
def _pass_any(phi, g0, g1, x, g, dg, mapped, obs, y, dy, store):
    """:func:`_pass3` for any number of states."""
    xn = np.empty_like(x)
    for k in range(g.size - 1):
        _advance(phi, g0, g1, x, g[k], g[k + 1], xn, mapped, dg[k], dg[k + 1])
        copy_into(x, xn)
        if store:
            y[k + 1] = x[0, obs]
            for i in range(dy.shape[0]):
                dy[i, k + 1] = x[1 + i, obs]


@jit
def _uniform_pass(phi, g0, g1, x, g, dg, mapped, obs, y, dy, store):
    if phi.shape[1] == 3:
        _pass3(phi, g0, g1, x, g, dg, mapped, obs, y, dy, store)
    else:
        _pass_any(phi, g0, g1, x, g, dg, mapped, obs, y, dy, store)


@jit
def _store(x, k, obs, y, dy, states):
    y[k] = x[0, obs]
    for i in range(dy.shape[0]):
        dy[i, k] = x[1 + i, obs]
    if states.shape[0] > 0:
        for r in range(x.shape[1]):
            states[k, r] = x[0, r]


@jit
def simulate_card(lz, free, code, n, imap, t, f, mode, x0, period, uniform, integrator, obs,
                  y, dy, states):
    """Simulate one card: observed output ``y`` (N,), its derivatives ``dy`` (nf, N) along
    the free log-parameters (pass a (0, N) array to skip them) and, when ``states`` has N
    rows, every state. Returns False when the model cannot be simulated there (a singular
    equilibrium or periodic system, or a non-finite response).

    Parameters
    ----------
    lz : (p,) log-parameters. free : (nf,) indices of the differentiated ones.
    code : the model's compiled terms. n : number of states.
    imap : (3,) input map (kind, parameter, reference).
    t, f : (N,) times and loads. mode : initial-state mode; x0 : (n,) the given state.
    period : the period for PERIODIC. uniform : the grid's steps are equal (one Phi).
    integrator : EXACT or EULER. obs : observed state.
    """
    n_samples = t.size
    nf = dy.shape[0]
    p_count = nf + 1
    sub = free[:nf]
    a = np.empty((p_count, n, n))
    b = np.empty((p_count, n))
    system(lz, sub, code, a, b)
    g = np.empty(n_samples)
    dg = np.zeros(n_samples)
    mapped = input_signal(f, lz, sub, imap, g, dg)
    phi = np.empty((p_count, n, n))
    g0 = np.empty((p_count, n))
    g1 = np.empty((p_count, n))
    x = np.zeros((p_count, n))
    xn = np.empty((p_count, n))
    h = t[1] - t[0] if n_samples > 1 else 1.0
    if not discretize(a, b, h, integrator, phi, g0, g1):
        return False
    if mode == GIVEN:
        for r in range(n):
            x[0, r] = x0[r]
    elif mode == EQUILIBRIUM:
        # A x = -B g0 (dual): the derivative of the equilibrium comes with it.
        rhs = np.empty((p_count, n, 1))
        for i in range(p_count):
            for r in range(n):
                rhs[i, r, 0] = -b[i, r] * g[0]
        if mapped >= 0:
            for r in range(n):
                rhs[mapped + 1, r, 0] -= b[0, r] * dg[0]
        if not dual_solve(a, rhs):
            return False
        for i in range(p_count):
            for r in range(n):
                x[i, r] = rhs[i, r, 0]
    elif mode == PERIODIC:
        # One pass from rest to the end of the period, then (I - Phi_T) x0 = x_T.
        phi_t = np.zeros((p_count, n, n))
        tmp = np.empty((p_count, n, n))
        for r in range(n):
            phi_t[0, r, r] = 1.0
        closing = period - (t[n_samples - 1] - t[0])
        # A uniform card's closing step is one more step of the grid (period = N h) when
        # the period was inferred from the samples or given as such: the grid's Phi serves
        # it, within the tolerance that made the grid uniform, and saves the second matrix
        # exponential, about a third of a periodic evaluation.
        same_step = uniform and abs(closing - h) <= 1e-9 * h
        if uniform:
            # np.bool_ and np.int64 around constants passed on: numba compiles a callee once
            # per literal value it is given (False and True, 0 and k), a second each time.
            _uniform_pass(phi, g0, g1, x, g, dg, mapped, obs, y, dy, np.bool_(False))
            dual_power(phi, n_samples if same_step else n_samples - 1, phi_t)
        else:
            for k in range(n_samples - 1):
                if not discretize(a, b, t[k + 1] - t[k], integrator, phi, g0, g1):
                    return False
                dual_mul(phi, phi_t, tmp)
                copy_into(phi_t, tmp)
                _advance(phi, g0, g1, x, g[k], g[k + 1], xn, mapped, dg[k], dg[k + 1])
                copy_into(x, xn)
        if same_step:
            _advance(phi, g0, g1, x, g[n_samples - 1], g[0], xn, mapped,
                     dg[n_samples - 1], dg[0])
            copy_into(tmp, phi_t)
        else:
            phi_c = np.empty((p_count, n, n))
            g0_c = np.empty((p_count, n))
            g1_c = np.empty((p_count, n))
            if not discretize(a, b, closing, integrator, phi_c, g0_c, g1_c):
                return False
            _advance(phi_c, g0_c, g1_c, x, g[n_samples - 1], g[0], xn, mapped,
                     dg[n_samples - 1], dg[0])
            dual_mul(phi_c, phi_t, tmp)
        # Q = I - Phi_T; solve Q x0 = x_T.
        for i in range(p_count):
            for r in range(n):
                for c in range(n):
                    tmp[i, r, c] = -tmp[i, r, c]
        for r in range(n):
            tmp[0, r, r] += 1.0
        rhs = np.empty((p_count, n, 1))
        for i in range(p_count):
            for r in range(n):
                rhs[i, r, 0] = xn[i, r]
        if not dual_solve(tmp, rhs):
            return False
        for i in range(p_count):
            for r in range(n):
                x[i, r] = rhs[i, r, 0]
    _store(x, np.int64(0), obs, y, dy, states)
    if uniform and states.shape[0] == 0:
        _uniform_pass(phi, g0, g1, x, g, dg, mapped, obs, y, dy, np.bool_(True))
        for k in range(n_samples):
            if not math.isfinite(y[k]):
                return False
        return True
    for k in range(n_samples - 1):
        if not uniform:
            if not discretize(a, b, t[k + 1] - t[k], integrator, phi, g0, g1):
                return False
        _advance(phi, g0, g1, x, g[k], g[k + 1], xn, mapped, dg[k], dg[k + 1])
        copy_into(x, xn)
        _store(x, k + 1, obs, y, dy, states)
    for k in range(n_samples):
        if not math.isfinite(y[k]):
            return False
    return True
