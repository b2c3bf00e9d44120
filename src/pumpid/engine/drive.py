"""Compiled drivers: residuals and their factor for one card, and the solver loop over cards.

A problem reaches this module as plain arrays (see :class:`pumpid.engine.problem.Problem`'s
``arrays``): the samples of every card concatenated, with per-card bounds, initial-state
modes and periods; the model's compiled terms; and the fit's settings (which parameters are
free, the fixed ones' values, the residual form, the scale and the offset).

The solver coordinates of a card are ``z = (ln theta_free, [ln C], [offset])``. Each
evaluation simulates the card with exact sensitivities, forms the Jacobian's columns and the
residual as rows of one array, and reduces them to ``0.5 |r|^2``, ``R`` and ``Q^T r`` (one
Householder pass): nothing of the card's length reaches the solver's step algebra.

:func:`solve_items` runs the Levenberg-Marquardt state machine of :mod:`pumpid.engine.lm`
for many (card, start) items; each item iterates to its own end, so no card waits for a
slower one. Every task that simulates (solving, costing, the Jacobian's rows, the outputs)
runs in one compiled function, :func:`items`, which releases the GIL, so the caller spreads
chunks of items over threads (:mod:`pumpid.engine.threads`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from . import lm
from .compiled import copy_into, jit, wait_aside
from .kernel import NO_MAP, PERIODIC, simulate_card
from .spectrum import (
    MAX_STATES,
    card_spectrum,
    harmonic_residual,
    harmonic_rows,
    harmonic_width,
)

__all__ = ["AS_GIVEN", "BEST_LINEAR", "RESCALE", "cost_items", "evaluate", "items",
           "linear_items", "outputs", "rows_items", "solve_items", "solve_one", "summary_rows"]

#: :func:`linear_items`' modes: cost the points as given, complete them with their best
#: scale and offset, or rescale the parameters to the fixed scale.
AS_GIVEN, BEST_LINEAR, RESCALE = 0, 1, 2

@jit(inline=True)
def _card(data, k):
    t, f, d, bounds, mode, x0, period, uniform = data
    a, b = bounds[k], bounds[k + 1]
    return t[a:b], f[a:b], d[a:b], mode[k], x0[k], period[k], uniform[k]


@jit(inline=True)
def _unpack(z, settings, lz):
    """Fill ``lz`` (p,) from z; return (C, offset)."""
    free, lz_base, _log_res, scale_free, scale_fixed, offset_free, offset_fixed = settings
    nf = free.size
    copy_into(lz, lz_base)
    for i in range(nf):
        lz[free[i]] = z[i]
    j = nf
    if scale_free:
        scale = math.exp(z[j])
        j += 1
    else:
        scale = scale_fixed
    offset = z[j] if offset_free else offset_fixed
    return scale, offset


@jit(inline=True)
def simulate_at(z, k, data, model, settings, y, dy):
    """Unscaled output (and sensitivities when dy has rows) of card k at z; (ok, C, offset)."""
    code, n, imap, obs, integrator = model
    t, f, _d, mode, x0, period, uniform = _card(data, k)
    lz = np.empty(settings[1].size)
    scale, offset = _unpack(z, settings, lz)
    ok = simulate_card(lz, settings[0], code, n, imap, t, f, mode, x0, period, uniform,
                       integrator, obs, y, dy, np.empty((0, n)))
    return ok, scale, offset


@jit(inline=True)
def residual_rows(z, k, data, model, settings, rows):
    """Jacobian columns and residual of card k at z, as rows (q + 1, N); False if not finite."""
    free = settings[0]
    log_res = settings[2]
    scale_free = settings[3]
    offset_free = settings[5]
    nf = free.size
    q = rows.shape[0] - 1
    n_samples = rows.shape[1]
    y = np.empty(n_samples)
    dy = rows[:nf]
    ok, scale, offset = simulate_at(z, k, data, model, settings, y, dy)
    if not ok:
        return False
    d = _card(data, k)[2]
    j = nf
    if log_res:
        log_c = math.log(scale)
        for s in range(n_samples):
            if not (y[s] > 0.0):
                return False
            inv = 1.0 / y[s]
            for i in range(nf):
                dy[i, s] *= inv
            rows[q, s] = log_c + math.log(y[s]) - math.log(d[s])
        if scale_free:
            rows[j, :] = 1.0
            j += 1
    else:
        for s in range(n_samples):
            for i in range(nf):
                dy[i, s] *= scale
            rows[q, s] = scale * y[s] + offset - d[s]
        if scale_free:
            for s in range(n_samples):
                rows[j, s] = scale * y[s]
            j += 1
    if offset_free:
        rows[j, :] = 1.0
    for s in range(n_samples):
        if not math.isfinite(rows[q, s]):
            return False
    return True


@jit(inline=True)
def evaluate(z, k, data, model, settings, rows, r_out, c_out):
    """Cost ``0.5 |r|^2`` of card k at z with R and Q^T r of ``[J r]``; NaN when not finite."""
    q = rows.shape[0] - 1
    if not residual_rows(z, k, data, model, settings, rows):
        return math.nan
    return lm.householder(rows, q, r_out, c_out)


@jit(inline=True)
def residual_vector(z, k, data, model, settings, out):
    """The residual of card k at z (no sensitivities) into ``out``; False if not finite."""
    n_samples = out.size
    y = np.empty(n_samples)
    ok, scale, offset = simulate_at(z, k, data, model, settings, y, np.empty((0, n_samples)))
    if not ok:
        return False
    d = _card(data, k)[2]
    if settings[2]:
        log_c = math.log(scale)
        for s in range(n_samples):
            if not (y[s] > 0.0):
                return False
            out[s] = log_c + math.log(y[s]) - math.log(d[s])
    else:
        for s in range(n_samples):
            out[s] = scale * y[s] + offset - d[s]
    for s in range(n_samples):
        if not math.isfinite(out[s]):
            return False
    return True


@jit
def _spectrum(k, harmonics, data, model, settings):
    """Card k's load and data coefficients for the harmonic residual (:mod:`.spectrum`):
    (fk, dk), empty when the card is fitted in time (no harmonics asked, not one uniformly
    sampled period closed by one more step, more states than the harmonic residual takes,
    a mapped input or the log residual)."""
    t, f, d, mode, _x0, period, uniform = _card(data, k)
    n_samples = t.size
    empty = np.zeros(0, np.complex128)
    if harmonics <= 0 or mode != PERIODIC or not uniform or n_samples < 3:
        return empty, empty
    h = t[1] - t[0]
    if (abs(period - n_samples * h) > 1e-9 * period or model[2][0] != NO_MAP or settings[2]
            or model[1] > MAX_STATES):
        return empty, empty
    kmax = (harmonic_width(harmonics, n_samples) - 1) // 2
    fk = np.empty(kmax + 1, np.complex128)
    dk = np.empty(kmax + 1, np.complex128)
    card_spectrum(f, d, kmax, fk, dk)
    return fk, dk


@jit(inline=True)
def _harmonic_args(z, k, data, model, settings):
    """What the harmonic residual needs of card k at z: (log-parameters, the model's terms,
    states, observed state, period, samples, C, offset)."""
    code, n, _imap, obs, _integrator = model
    lz = np.empty(settings[1].size)
    scale, offset = _unpack(z, settings, lz)
    bounds = data[3]
    return (lz, code, n, obs, _card(data, k)[5], bounds[k + 1] - bounds[k], scale, offset)


@jit
def _rows_of(z, k, data, model, settings, fk, dk, rows):
    """:func:`residual_rows`, or its harmonic form when the card has a spectrum."""
    if fk.size == 0:
        return residual_rows(z, k, data, model, settings, rows)
    lz, code, n, obs, period, n_samples, scale, offset = _harmonic_args(z, k, data, model,
                                                                        settings)
    return harmonic_rows(lz, settings[0], code, n, obs, period, n_samples, scale,
                         settings[3], offset, settings[5], fk, dk, rows)


@jit
def _vector_of(z, k, data, model, settings, fk, dk, out):
    """:func:`residual_vector`, or the harmonic residual when the card has a spectrum."""
    if fk.size == 0:
        return residual_vector(z, k, data, model, settings, out)
    lz, code, n, obs, period, n_samples, scale, offset = _harmonic_args(z, k, data, model,
                                                                        settings)
    return harmonic_residual(lz, settings[0], code, n, obs, period, n_samples, scale, offset,
                             fk, dk, out)


@jit
def _scaling(q, k, data, settings):
    """The solver's fixed scaling: 1 for the log-coordinates (relative changes already), and
    1 / range of the data for an offset (a unit step moves it by the data's range)."""
    out = np.ones(q)
    if settings[5]:
        d = _card(data, k)[2]
        span = np.max(d) - np.min(d)
        out[q - 1] = 1.0 / span if span > 0.0 and math.isfinite(span) else 1.0
    return out


@jit(inline=True)
def _solve(z0, lo, hi, tol, max_evals, n_capped, noise_tol, harmonics, k, data, model,
           settings, history):
    """Levenberg-Marquardt from z0 for card k. Returns (z, cost, evaluations, accepted,
    code, test, history rows). ``history`` (H, q + 1) receives the accepted points and their
    costs (pass an array with no rows to skip). ``harmonics`` > 0: the cost is the harmonic
    one (:mod:`.spectrum`) on a card it applies to."""
    q = z0.size
    fk, dk = _spectrum(k, harmonics, data, model, settings)
    bounds = data[3]
    n_samples = bounds[k + 1] - bounds[k]
    if fk.size > 0:
        n_samples = 2 * fk.size - 1
    # The current point's reflections are kept for the acceleration's projection; a trial
    # point is factored into the other buffer and the two swap when it is accepted.
    rows = np.empty((q + 1, n_samples))
    spare = np.empty((q + 1, n_samples))
    v0, beta = np.empty(q), np.empty(q)
    v0_s, beta_s = np.empty(q), np.empty(q)
    r = np.zeros((q, q))
    c = np.zeros(q)
    probe = np.empty(n_samples)
    c_probe = np.empty(q)
    trial = np.empty(n_samples)
    cost = math.nan
    if _rows_of(z0, k, data, model, settings, fk, dk, rows):
        cost = lm.householder_keep(rows, q, r, c, v0, beta)
    dof = n_samples - q
    noise = noise_tol * 2.0 / dof if dof > 0 else 0.0
    state = lm.start(z0, cost, r, c, lo, hi, tol, n_capped, max_evals, True, noise,
                     _scaling(q, k, data, settings))
    n_hist = 0
    if history.shape[0] > 0 and math.isfinite(cost):
        copy_into(history[0, :q], z0)
        history[0, q] = cost
        n_hist = 1
    z_try = state[6]
    ints = state[8]
    while lm.propose(state):
        if lm.probing(state):
            ok = _vector_of(z_try, k, data, model, settings, fk, dk, probe)
            if ok:
                lm.project(rows, q, v0, beta, probe, c_probe)
            lm.accelerate(state, c_probe, ok)
        accepted_before = ints[1]
        cost_try = math.nan
        # Many trial points are refused (on field cards one exact evaluation in four, the
        # acceleration's probes counted, is a step taken), and the sensitivities are most
        # of an evaluation: the residual alone decides (the same cost, summed as
        # householder_keep sums it), the rows follow for a point the step takes.
        if _vector_of(z_try, k, data, model, settings, fk, dk, trial):
            cost_try = 0.0
            for s in range(n_samples):
                cost_try += trial[s] * trial[s]
            cost_try *= 0.5
        if not lm.accepts(state, cost_try):
            going = lm.update(state, cost_try, state[3], state[4])
            if not going:
                break
            continue
        cost_try = math.nan
        if _rows_of(z_try, k, data, model, settings, fk, dk, spare):
            cost_try = lm.householder_keep(spare, q, r, c, v0_s, beta_s)
        going = lm.update(state, cost_try, r, c)
        if ints[1] > accepted_before:
            rows, spare = spare, rows
            v0, v0_s = v0_s, v0
            beta, beta_s = beta_s, beta
            if n_hist < history.shape[0]:
                copy_into(history[n_hist, :q], state[0])
                history[n_hist, q] = state[7][0]
                n_hist += 1
        if not going:
            break
    return (state[0], state[7][0], ints[0] + 1, ints[1], ints[4], ints[5], n_hist)


@jit(inline=True)
def _plain_output(z, i, cards, data, model, settings):
    """Item i's unscaled output, no sensitivities: (ok, y, C, offset)."""
    k = cards[i]
    n_samples = data[3][k + 1] - data[3][k]
    y = np.empty(n_samples)
    ok, scale, offset = simulate_at(z[i], k, data, model, settings, y,
                                    np.empty((0, n_samples)))
    return ok, y, scale, offset


@jit(inline=True)
def _linear(cards, z, mode, data, model, settings):
    """:func:`linear_items`' body: (the completed points, their costs)."""
    rescale = mode == RESCALE
    m, _q = z.shape
    free, _lz_base, log_res, scale_free, scale_fixed, offset_free, offset_fixed = settings
    nf = free.size
    out = z.copy()
    cost = np.full(m, math.inf)
    for i in range(m):
        k = cards[i]
        ok, y, given_scale, given_offset = _plain_output(z, i, cards, data, model, settings)
        n_samples = y.size
        if not ok:
            continue
        d = _card(data, k)[2]
        scale = scale_fixed
        offset = offset_fixed
        if mode == AS_GIVEN:
            scale = given_scale
            offset = given_offset
        elif log_res:
            total = 0.0
            for s in range(n_samples):
                if not (y[s] > 0.0):
                    total = math.nan
                    break
                total += math.log(d[s]) - math.log(y[s])
            if not math.isfinite(total):
                continue
            if scale_free:
                scale = math.exp(total / n_samples)
        else:
            # Normal equations of d ~ a y + b (2 x 2): tiny and well scaled after centring.
            ym = 0.0
            dm = 0.0
            for s in range(n_samples):
                ym += y[s]
                dm += d[s]
            ym /= n_samples
            dm /= n_samples
            syy = 0.0
            syd = 0.0
            for s in range(n_samples):
                syy += (y[s] - ym) * (y[s] - ym)
                syd += (y[s] - ym) * (d[s] - dm)
            if scale_free or rescale:
                if offset_free:
                    a = syd / syy if syy > 0.0 else math.nan
                    b = dm - a * ym
                else:
                    s_yy = 0.0
                    s_yd = 0.0
                    for s in range(n_samples):
                        s_yy += y[s] * y[s]
                        s_yd += y[s] * (d[s] - offset_fixed)
                    a = s_yd / s_yy if s_yy > 0.0 else math.nan
                    b = offset_fixed
                if rescale:
                    if not (a > 0.0 and math.isfinite(a)):
                        continue
                    factor = math.log(scale_fixed / a)
                    for j in range(nf):
                        out[i, j] = z[i, j] + factor
                    for s in range(n_samples):
                        y[s] *= a / scale_fixed
                    offset = b if offset_free else offset_fixed
                else:
                    scale = a if (a > 0.0 and math.isfinite(a)) else 1.0
                    offset = b if offset_free else offset_fixed
                    if offset_free and not (a > 0.0 and math.isfinite(a)):
                        offset = dm - ym
            elif offset_free:
                offset = dm - scale * ym
        total = 0.0
        for s in range(n_samples):
            if log_res:
                e = math.log(scale) + math.log(y[s]) - math.log(d[s])
            else:
                e = scale * y[s] + offset - d[s]
            total += e * e
        if not math.isfinite(total):
            continue
        cost[i] = 0.5 * total
        if mode == AS_GIVEN:
            continue
        j = nf
        if scale_free:
            out[i, j] = math.log(scale)
            j += 1
        if offset_free:
            out[i, j] = offset
    return out, cost


@jit(inline=True)
def _rows(cards, z, data, model, settings):
    """:func:`rows_items`' body: (buffer, starts (m + 1,), ok (m,))."""
    m, q = z.shape
    bounds = data[3]
    starts = np.zeros(m + 1, np.int64)
    for i in range(m):
        k = cards[i]
        starts[i + 1] = starts[i] + (q + 1) * (bounds[k + 1] - bounds[k])
    buffer = np.empty(starts[m])
    ok = np.zeros(m, np.bool_)
    for i in range(m):
        k = cards[i]
        n = bounds[k + 1] - bounds[k]
        rows = np.empty((q + 1, n))
        ok[i] = residual_rows(z[i], k, data, model, settings, rows)
        copy_into(buffer[starts[i]:starts[i + 1]], rows.ravel())
    return buffer, starts, ok


@jit(inline=True)
def _outputs(cards, z, data, model, settings, total):
    """:func:`outputs`' body: (outputs concatenated, ok (m,))."""
    m = z.shape[0]
    bounds = data[3]
    starts = np.zeros(m + 1, np.int64)
    for i in range(m):
        k = cards[i]
        starts[i + 1] = starts[i] + bounds[k + 1] - bounds[k]
    y_all = np.full(total, math.nan)
    ok = np.zeros(m, np.bool_)
    for i in range(m):
        good, y, _scale, _offset = _plain_output(z, i, cards, data, model, settings)
        ok[i] = good
        if good:
            copy_into(y_all[starts[i]:starts[i + 1]], y)
    return y_all, ok


#: :func:`items`' tasks.
_SOLVE, _LINEAR, _ROWS, _OUTPUTS = 0, 1, 2, 3


@jit
def items(task, cards, z, lo, hi, tol, max_evals, n_capped, noise_tol, harmonics, mode,
          history, total, data, model, settings):
    """The one compiled entry point that simulates: every task on many (card, point) items.

    Every compiled function links in and re-optimises all the compiled code it calls, the
    simulation with its sensitivities included (about 14 s on one core, each time): solving,
    costing, the Jacobian's rows and the outputs used to be four entry points and a fresh
    install compiled the simulation into each. The Python functions below pick the task.

    Returns (z (m, q), cost (m,), evaluations, accepted, code, test (m,), accepted points
    in ``history``, buffer, starts (m + 1,), ok (m,)); a task fills the parts it makes.
    """
    m = z.shape[0]
    z_out = z.copy()
    cost = np.full(m, math.inf)
    evals = np.zeros(m, np.int64)
    accepted = np.zeros(m, np.int64)
    code = np.zeros(m, np.int64)
    test = np.zeros(m, np.int64)
    n_hist = 0
    buffer = np.empty(0)
    starts = np.zeros(m + 1, np.int64)
    ok = np.zeros(m, np.bool_)
    if task == _SOLVE:
        for i in range(m):
            out = _solve(z[i], lo[i], hi[i], tol, max_evals[i], n_capped, noise_tol,
                         harmonics, cards[i], data, model, settings, history)
            copy_into(z_out[i], out[0])
            cost[i] = out[1]
            evals[i] = out[2]
            accepted[i] = out[3]
            code[i] = out[4]
            test[i] = out[5]
            n_hist = out[6]
    elif task == _LINEAR:
        z_out, cost = _linear(cards, z, mode, data, model, settings)
    elif task == _ROWS:
        buffer, starts, ok = _rows(cards, z, data, model, settings)
    else:
        buffer, ok = _outputs(cards, z, data, model, settings, total)
    return z_out, cost, evals, accepted, code, test, n_hist, buffer, starts, ok


def _own(a: ArrayLike, dtype: type) -> np.ndarray:
    """``a`` as a writable C-contiguous array of ``dtype``: every call of :func:`items`
    then has the same argument types, so a fresh install compiles it once."""
    out = np.ascontiguousarray(a, dtype=dtype)
    return out if out.flags.writeable else out.copy()


_NO_INT = np.zeros(0, np.int64)


def _call(task: int, cards: ArrayLike, z: ArrayLike, data: tuple, model: tuple,
          settings: tuple, *, lo: ArrayLike | None = None, hi: ArrayLike | None = None,
          tol: float = 0.0, max_evals: ArrayLike | None = None, n_capped: int = 0,
          noise_tol: float = 0.0, harmonics: int = 0, mode: int = AS_GIVEN,
          history: np.ndarray | None = None, total: int = 0) -> tuple:
    # A second process may be compiling items for a fresh install (pumpid.engine.aside).
    wait_aside("drive.items")
    z = _own(z, np.float64)
    q = z.shape[1]
    none = np.zeros((0, q))
    return items(int(task), _own(cards, np.int64), z,
                 none if lo is None else _own(lo, np.float64),
                 none if hi is None else _own(hi, np.float64), float(tol),
                 _NO_INT if max_evals is None else _own(max_evals, np.int64), int(n_capped),
                 float(noise_tol), int(harmonics), int(mode),
                 np.zeros((0, q + 1)) if history is None else history, int(total),
                 data, model, settings)


def solve_items(cards, z0, lo, hi, tol, max_evals, n_capped, noise_tol, data, model,
                settings, harmonics=0):
    """Levenberg-Marquardt for many (card, start) items, each to its own end; on the
    cards' first ``harmonics`` harmonics where that applies (:mod:`.spectrum`; 0: the exact
    cost everywhere).

    Returns z (m, q), cost (m,), evaluations, accepted, code, test (m,) arrays.
    """
    return _call(_SOLVE, cards, z0, data, model, settings, lo=lo, hi=hi, tol=tol,
                 max_evals=max_evals, n_capped=n_capped, noise_tol=noise_tol,
                 harmonics=harmonics)[:6]


def solve_one(z0, lo, hi, tol, max_evals, noise_tol, card, data, model, settings, history,
              harmonics=0):
    """:func:`solve_items` for one item, with the history of accepted points: ``history``
    (H, q + 1), writable, C-contiguous float64, receives them and their costs. Every free
    log-parameter's step is capped. Returns (z, cost, evaluations, accepted, code, test,
    number of history rows)."""
    if not (history.flags.c_contiguous and history.flags.writeable
            and history.dtype == np.float64):
        raise ValueError("history must be a writable C-contiguous float64 array")
    out = _call(_SOLVE, [card], np.atleast_2d(z0), data, model, settings,
                lo=np.atleast_2d(lo), hi=np.atleast_2d(hi), tol=tol, max_evals=[max_evals],
                n_capped=settings[0].size, noise_tol=noise_tol, harmonics=harmonics,
                history=history)
    return (out[0][0], float(out[1][0]), int(out[2][0]), int(out[3][0]), int(out[4][0]),
            int(out[5][0]), int(out[6]))


def linear_items(cards, z, mode, data, model, settings):
    """Best linear values (ln C, offset) for parameter points, and their costs.

    For each item: simulate card ``cards[i]`` at ``z[i]``'s parameters and, with ``mode``
    :data:`BEST_LINEAR`, fill the free scale and offset coordinates with their
    least-squares values. With :data:`RESCALE` (a scale-symmetric model on a fixed scale,
    from a load-driven state) the parameters are multiplied by ``C / a`` instead, ``a`` the
    least-squares amplitude: the same curve with the scale held. With :data:`AS_GIVEN` the
    points are kept and only costed. Returns the completed points (m, q) and their costs
    (inf when the point cannot be simulated or the amplitude is not positive).
    """
    return _call(_LINEAR, cards, z, data, model, settings, mode=mode)[:2]


def rows_items(cards, z, data, model, settings):
    """Jacobian columns and residual of many (card, point) items, as one flat buffer.

    Item ``i``'s rows ``(q + 1, n_i)`` (:func:`residual_rows`) are
    ``buffer[starts[i]:starts[i + 1]].reshape(q + 1, n_i)``. Returns (buffer, starts (m + 1,),
    ok (m,)): ok False where the point cannot be evaluated.
    """
    return _call(_ROWS, cards, z, data, model, settings)[7:]


def outputs(cards, z, data, model, settings, total):
    """Unscaled outputs of many (card, point) items, concatenated (``total`` samples);
    and per item whether the simulation succeeded."""
    out = _call(_OUTPUTS, cards, z, data, model, settings, total=total)
    return out[7], out[9]


def rows_at(z: np.ndarray, k: int, data: tuple, model: tuple, settings: tuple,
            rows: np.ndarray) -> bool:
    """:func:`residual_rows` of card k at z into ``rows`` (q + 1, N), called from Python.

    Through :func:`rows_items`, so that Python callers add no compiled entry point (and no
    compile of the simulation) of their own. False where the point cannot be evaluated.
    """
    buffer, starts, ok = rows_items(np.array([k], dtype=np.int64),
                                    np.ascontiguousarray(z, dtype=np.float64)[None],
                                    data, model, settings)
    rows[...] = item_rows(buffer, starts, 0, rows.shape[0] - 1)
    return bool(ok[0])


def item_rows(buffer: np.ndarray, starts: np.ndarray, i: int, q: int) -> np.ndarray:
    """Item ``i``'s rows ``(q + 1, n_i)`` in :func:`rows_items`' buffer (a view)."""
    part = buffer[starts[i]:starts[i + 1]]
    return part.reshape(q + 1, part.size // (q + 1))


def summary_items(cards, z, data, model, settings):
    """At each item's point: cost, RMSE and R^2 of the fitted displacement, the data's noise
    level (from second differences) and the Jacobian's column norms (m, q).

    Returns (stats (m, 4): cost, rmse, r2, noise; norms (m, q)); NaN where the point cannot
    be evaluated.
    """
    cards = _own(cards, np.int64)
    buffer, starts, ok = rows_items(cards, z, data, model, settings)
    return summary_rows(cards, np.asarray(z).shape[1], buffer, starts, ok, data, settings)


@jit
def summary_rows(cards, q, buffer, starts, ok, data, settings):
    """:func:`summary_items` from :func:`rows_items`' output (no simulation compiled in)."""
    m = cards.size
    stats = np.full((m, 4), math.nan)
    norms = np.full((m, q), math.nan)
    bounds = data[3]
    log_res = settings[2]
    for i in range(m):
        k = cards[i]
        n = bounds[k + 1] - bounds[k]
        d = _card(data, k)[2]
        if n >= 3:
            diff2 = np.empty(n - 2)
            for s in range(n - 2):
                diff2[s] = d[s + 2] - 2.0 * d[s + 1] + d[s]
            med = np.median(diff2)
            stats[i, 3] = 1.4826 * np.median(np.abs(diff2 - med)) / math.sqrt(6.0)
        if not ok[i]:
            continue
        rows = buffer[starts[i]:starts[i + 1]].reshape((q + 1, n))
        for j in range(q):
            acc = 0.0
            for s in range(n):
                acc += rows[j, s] * rows[j, s]
            norms[i, j] = math.sqrt(acc)
        ss = 0.0
        sq = 0.0
        mean = 0.0
        for s in range(n):
            mean += d[s]
        mean /= n
        for s in range(n):
            sq += rows[q, s] * rows[q, s]
            if log_res:
                # the fitted displacement: C y = d exp(r)
                e = d[s] * math.exp(rows[q, s]) - d[s]
            else:
                e = rows[q, s]
            ss += e * e
        sst = 0.0
        for s in range(n):
            sst += (d[s] - mean) * (d[s] - mean)
        stats[i, 0] = 0.5 * sq
        stats[i, 1] = math.sqrt(ss / n)
        stats[i, 2] = 1.0 - ss / sst if sst > 0.0 else math.nan
    return stats, norms


def cost_items(cards, z, data, model, settings):
    """Cost ``0.5 |r|^2`` of many (card, point) items (no sensitivities); inf when not finite.

    :func:`linear_items` with the points kept as given: one compiled function for both, so
    a fresh install compiles the simulation into one caller less.
    """
    return linear_items(cards, z, AS_GIVEN, data, model, settings)[1]
