"""Levenberg-Marquardt over many independent least-squares problems at once.

Both :func:`pumpid.fit` (one problem) and :func:`pumpid.fit_many` (one problem per card) use
this loop. The caller supplies the problems through one callback that returns, for a batch
of trial points, the cost ``0.5 |r|^2`` and the triangular factor of the Jacobian:
``[J r] = Q [[R, Q^T r], ...]`` (see :func:`reduce`). Nothing of size N (samples) crosses
the interface, and one simulation with exact sensitivities per trial point gives both.

Why by hand: scipy's ``least_squares`` solves one problem per call and drives it through
Python callbacks (residual, then Jacobian) whose overhead is a large part of a
millisecond fit, and no library offers a batched LM. The algorithm follows MINPACK's
``lmder`` (Moré's trust-region Levenberg-Marquardt):

* scaled coordinates ``D dz`` with ``D`` the running maximum of the Jacobian's column norms;
* a trust radius in those coordinates: the Gauss-Newton step when it fits, otherwise the
  Levenberg-Marquardt step whose length is the radius (the damping found by Newton's method
  on the secular equation, from an SVD of the q x q factor -- the small singular values of
  ill-conditioned problems stay accurate, as they would not in the normal equations);
* the radius halves on poor steps (gain ratio < 1/4) and grows to twice the step on good ones;
* box bounds on selected coordinates (the log-parameter search window): a coordinate at a
  bound that the step would push outward is held there for the step (an active set);
* a cap on the step of the log-parameters (a factor ``e`` per iteration), so a step along a
  flat direction cannot fling a parameter into a region where the model degenerates;
* MINPACK's stop tests: trust radius <= tol * |D z| (xtol), relative actual and predicted
  cost reductions <= tol (ftol), cosine between residual and Jacobian columns <= tol (gtol).
  A full Gauss-Newton step that is already below xtol, or predicted to gain less than ftol
  right after a reliable step, ends the iteration without one more simulation.

One problem (a single fit) runs the same iteration with its per-problem scalars as Python
floats (:func:`_solve_one`): the batched bookkeeping on one-element arrays would cost a
quarter of a millisecond-scale fit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dgeqrf, dtrtrs

Array = NDArray[np.float64]

#: The lm search window: each parameter's natural scale times or divided by 1e6. A parameter
#: that runs to the window's edge is reported as a boundary (0 or infinity).
WINDOW = math.log(1e6)
#: Keeps exp() of a log-coordinate finite during wild trial steps.
LOG_MAX = 700.0
#: Largest change of a log-parameter in one step.
MAX_LOG_STEP = 1.0
#: Initial trust radius as a multiple of |D z0| (MINPACK's ``factor``).
FACTOR = 100.0

#: Outcome codes.
CONVERGED, EXHAUSTED, FAILED = 0, 2, 3
#: Which stop test fired, for converged problems.
TESTS = ("gtol", "ftol", "xtol", "zero")

Evaluate = Callable[[Array, NDArray[np.intp]], tuple[Array, Array, Array]]


@dataclass
class Outcome:
    """Per-problem results of :func:`solve` (arrays over problems)."""

    z: Array
    cost: Array
    evaluations: NDArray[np.int64]
    accepted: NDArray[np.int64]
    code: NDArray[np.int8]
    test: NDArray[np.int8]  # index into TESTS when converged, -1 otherwise


def reduce(jac: Array, r: Array) -> tuple[Array, Array, Array]:
    """Cost, R and Q^T r of residuals ``r`` (b, N) with Jacobian rows ``jac`` (b, q, N).

    One QR of ``[J r]`` per problem: ``R`` (b, q, q) is J's triangular factor and the last
    column gives ``Q^T r`` (b, q), so ``J^T J = R^T R`` and ``J^T r = R^T Q^T r``.
    """
    return reduce_rows(np.concatenate([jac, r[:, None, :]], axis=1))


#: Smallest pivot ratio of the column-scaled Cholesky factor for which the Gram route is used;
#: below it (condition number around 1e4 or more) the factor comes from a QR of [J r].
_CHOLESKY_MIN_PIVOT = 1e-4


def reduce_rows(rows: Array, overwrite: bool = False) -> tuple[Array, Array, Array]:
    """:func:`reduce` for ``rows`` (b, q + 1, N): the Jacobian's rows, then the residual.

    In a batch, well-conditioned problems take the cheaper route: Cholesky of the column-scaled
    Gram matrix ``J^T J`` and ``Q^T r = R^-T J^T r`` (four times cheaper than a QR of a tall
    matrix, and accurate while ``cond(J)`` is small); the others, and any problem whose Gram
    matrix is not numerically positive definite, get the QR of ``[J r]``. With ``overwrite``
    a single problem's C-contiguous rows may be used as the factorization's workspace.
    """
    q = rows.shape[1] - 1
    r = rows[:, q]
    cost = 0.5 * np.einsum("bn,bn->b", r, r)
    if rows.shape[0] == 1:
        # One problem: LAPACK's geqrf straight on the transposed rows (a Fortran-ordered view,
        # no copy when it may be overwritten): a third of a stacked numpy QR's cost.
        factor, _tau, _work, info = dgeqrf(rows[0].T, overwrite_a=overwrite)
        if info == 0:
            upper = np.triu(factor[:q + 1, :q + 1])
            return cost, upper[None, :q, :q], upper[None, :q, q]
    if rows.shape[0] < 8:
        # A single fit: one QR is fewer operations than the guarded Gram route.
        factor = np.linalg.qr(np.swapaxes(rows, 1, 2), mode="r")
        return cost, factor[:, :q, :q], factor[:, :q, q]
    jac = rows[:, :q]
    gram = jac @ np.swapaxes(jac, 1, 2)
    jtr = (jac @ r[:, :, None])[:, :, 0]
    d = np.sqrt(np.einsum("bii->bi", gram))
    d = np.where(d > 0, d, 1.0)
    r_fac = np.empty_like(gram)
    qtr = np.empty_like(jtr)
    use_qr = ~np.isfinite(gram).all(axis=(1, 2))
    good = ~use_qr
    if good.any():
        scaled = gram[good] / (d[good][:, :, None] * d[good][:, None, :])
        try:
            low = np.linalg.cholesky(scaled)
        except np.linalg.LinAlgError:
            use_qr[:] = True
        else:
            pivots = np.einsum("bii->bi", low)
            fine = np.min(pivots, axis=1) >= _CHOLESKY_MIN_PIVOT * np.max(pivots, axis=1)
            idx = np.flatnonzero(good)[fine]
            # J^T J = (D L)(D L)^T, so R = L^T D and Q^T r solves R^T c = J^T r.
            upper = np.swapaxes(low[fine], 1, 2) * d[idx][:, None, :]
            r_fac[idx] = upper
            qtr[idx] = np.linalg.solve(np.swapaxes(upper, 1, 2), jtr[idx][:, :, None])[:, :, 0]
            use_qr[np.flatnonzero(good)[~fine]] = True
    if use_qr.any():
        factor = np.linalg.qr(np.swapaxes(rows[use_qr], 1, 2), mode="r")
        r_fac[use_qr] = factor[:, :q, :q]
        qtr[use_qr] = factor[:, :q, q]
    return cost, r_fac, qtr


def _steps(r_s: Array, c: Array, delta: Array) -> tuple[Array, Array]:
    """Trust-region steps ``s`` (b, q) for ``min |R_s s + c|`` with ``|s| <= delta``.

    Returns the steps and a flag for "the Gauss-Newton step fitted" (no damping).
    """
    # Fast path, problem by problem (MINPACK's too): with no tiny pivot the Gauss-Newton step
    # is one solve with the triangular factor; where it fits in the radius, that is the step.
    # The others (damping needed, or rank deficient) take the SVD route below.
    piv = np.abs(np.diagonal(r_s, axis1=1, axis2=2))
    easy = np.all(piv > 1e-12 * np.max(piv, axis=1, keepdims=True), axis=1)
    step = np.zeros_like(c)
    fits = np.zeros(c.shape[0], dtype=bool)
    if easy.any():
        gn = np.linalg.solve(r_s[easy], -c[easy][:, :, None])[:, :, 0]
        ok = np.sqrt(np.einsum("bi,bi->b", gn, gn)) <= 1.1 * delta[easy]
        step[easy] = gn
        fits[easy] = ok
    rest = ~fits
    if rest.any():
        step[rest], fits[rest] = _svd_steps(r_s[rest], c[rest], delta[rest])
    return step, fits


def _svd_steps(r_s: Array, c: Array, delta: Array) -> tuple[Array, Array]:
    """:func:`_steps` by an SVD of the factor: minimum-norm Gauss-Newton steps, and the
    damped steps of length ``delta`` where those do not fit."""
    u, sig, vt = np.linalg.svd(r_s)
    ct = (c[:, None, :] @ u)[:, 0]
    # Minimum-norm Gauss-Newton step: singular values at rounding level count as zero.
    keep = sig > sig[:, :1] * 1e-14
    coef = np.where(keep, ct / np.where(keep, sig, 1.0), 0.0)
    gn_norm = np.sqrt(np.einsum("bi,bi->b", coef, coef))
    fits = gn_norm <= 1.1 * delta
    lam = np.zeros(sig.shape[0])
    todo = ~fits
    if todo.any():
        # Newton on 1/|s(lambda)| - 1/delta = 0 (Moré), from lambda = 0 where |s| > delta.
        a = (sig * ct)[todo]
        s2 = (sig * sig)[todo]
        d = delta[todo]
        lam_t = np.zeros(a.shape[0])
        for _ in range(30):
            den = s2 + lam_t[:, None]
            # Zero singular values (held or empty columns) carry no step: a / den = 0 there.
            ratio = np.divide(a, den, out=np.zeros_like(a), where=den > 0)
            norm2 = np.sum(ratio**2, axis=1)
            norm = np.sqrt(norm2)
            if np.all(np.abs(norm - d) <= 0.1 * d):
                break
            dnorm2 = -2.0 * np.sum(np.divide(ratio**2, den, out=np.zeros_like(a),
                                             where=den > 0), axis=1)
            # g = 1/|s| - 1/d, g' = -0.5 |s|^-3 (|s|^2)'
            g = 1.0 / norm - 1.0 / d
            gp = -0.5 * dnorm2 / (norm2 * norm)
            lam_t = np.maximum(lam_t - g / gp, 0.0)
        lam[todo] = lam_t
    damped = sig * sig + lam[:, None]
    shrink = np.divide(sig, damped, out=np.zeros_like(sig), where=damped > 0)
    coef = np.where(fits[:, None], coef, ct * shrink)
    step = -(coef[:, None, :] @ vt)[:, 0]
    return step, fits


def _next_radius(delta: Array, rho: Array, p_norm: Array, gauss_newton: Array) -> Array:
    """MINPACK's radius update: halve (at least) on poor steps (gain ratio < 1/4); on good
    ones (>= 3/4) or after a Gauss-Newton step, at least twice the step (MINPACK sets it to
    twice the step; keeping a larger radius only saves damping)."""
    poor = np.asarray(rho) < 0.25
    good = ~poor & (np.asarray(gauss_newton) | (np.asarray(rho) >= 0.75))
    new = np.where(poor, 0.5 * np.minimum(delta, 10.0 * p_norm),
                   np.where(good, np.maximum(delta, 2.0 * p_norm), delta))
    # A non-finite step (a failed trial) must not poison the radius.
    return np.where(np.isfinite(new) & (new > 0), new, 0.5 * np.asarray(delta))


def _next_radius_one(delta: float, rho: float, p_norm: float, gauss_newton: bool) -> float:
    """:func:`_next_radius` for one problem, on floats."""
    if rho < 0.25:
        new = 0.5 * min(delta, 10.0 * p_norm)
    elif gauss_newton or rho >= 0.75:
        new = max(delta, 2.0 * p_norm)
    else:
        new = delta
    return new if math.isfinite(new) and new > 0 else 0.5 * delta


def solve(
    evaluate: Evaluate,
    z0: Array,
    first: tuple[Array, Array, Array],
    lo: Array,
    hi: Array,
    *,
    n_capped: int,
    tol: float,
    max_evaluations: int,
) -> Outcome:
    """Minimize ``0.5 |r_b(z_b)|^2`` for every problem b.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(z, idx) -> (cost, R, qtr)`` (see :func:`reduce`) for trial points ``z``
        (m, q) of the problems ``idx`` (m,); non-finite values mark a trial point unusable.
        ``R`` must be upper triangular (only that triangle is read), as :func:`reduce` and
        :func:`reduce_rows` return it.
    z0 : ndarray, shape (b, q)
        Starting points.
    first : (cost, R, qtr)
        ``evaluate(z0, all)``, which the caller has usually computed already.
    lo, hi : ndarray, shape (b, q)
        Bounds (``-inf``/``inf`` where a coordinate is free).
    n_capped : int
        The first ``n_capped`` coordinates are log-parameters whose step is capped.
    tol : float
        Relative tolerance of the stop tests.
    max_evaluations : int
        Trial points per problem.
    """
    b, q = z0.shape
    if b == 1:
        return _solve_one(evaluate, z0, first, lo, hi, n_capped=n_capped, tol=tol,
                          max_evaluations=max_evaluations)
    cost, r_fac, qtr = first
    out = Outcome(
        z=np.array(z0, dtype=float), cost=np.full(b, np.nan),
        evaluations=np.zeros(b, dtype=np.int64), accepted=np.zeros(b, dtype=np.int64),
        code=np.full(b, FAILED, dtype=np.int8), test=np.full(b, -1, dtype=np.int8),
    )
    ok = (np.isfinite(cost) & np.isfinite(r_fac).all(axis=(1, 2))
          & np.isfinite(qtr).all(axis=1))
    m = int(ok.sum())
    cols = np.sqrt(np.sum(r_fac[ok] ** 2, axis=1))
    diag = np.where(cols > 0, cols, 1.0)
    delta = FACTOR * np.linalg.norm(diag * out.z[ok], axis=1)
    # Per-problem state of the problems still iterating (filtered together when some stop).
    st = {
        "idx": np.flatnonzero(ok), "z": out.z[ok], "cost": cost[ok], "r": r_fac[ok],
        "c": qtr[ok], "lo": lo[ok], "hi": hi[ok], "diag": diag,
        "delta": np.where(delta > 0, delta, FACTOR),
        "evals": np.zeros(m, dtype=np.int64), "accepted": np.zeros(m, dtype=np.int64),
        "trusted": np.zeros(m, dtype=bool),
    }

    def retire(mask: NDArray[np.bool_], code: NDArray[np.int8], test: NDArray[np.int8]) -> None:
        i = st["idx"][mask]
        out.z[i], out.cost[i] = st["z"][mask], st["cost"][mask]
        out.evaluations[i], out.accepted[i] = st["evals"][mask], st["accepted"][mask]
        out.code[i], out.test[i] = code[mask], test[mask]
        keep = ~mask
        for key in st:
            st[key] = st[key][keep]

    with np.errstate(all="ignore"):
        while st["idx"].size:
            z, cost, c, delta = st["z"], st["cost"], st["c"], st["delta"]
            cols = np.sqrt(np.einsum("bij,bij->bj", st["r"], st["r"]))
            st["diag"] = diag = np.maximum(st["diag"], cols)
            r_s = st["r"] / diag[:, None, :]
            grad0 = (c[:, None, :] @ r_s)[:, 0]  # scaled J^T r
            r_norm = np.sqrt(2.0 * cost)
            # gtol: cosine between r and the Jacobian's columns at their current norms.
            cosine = (c[:, None, :] @ st["r"])[:, 0] / np.where(cols > 0, cols, np.inf)
            g_cos = np.max(np.abs(cosine), axis=1) / np.where(r_norm > 0, r_norm, 1.0)
            # Coordinates at a bound that the step would push outward are held there for
            # this step (an active set): first those whose gradient points outward, then
            # those the step itself pushes out through the correlations, until none is left.
            at_lo, at_hi = z <= st["lo"], z >= st["hi"]
            if not (at_lo.any() or at_hi.any()):
                step, gauss_newton = _steps(r_s, c, delta)
            else:
                held = (at_lo & (grad0 > 0)) | (at_hi & (grad0 < 0))
                for _ in range(q):
                    step, gauss_newton = _steps(r_s * ~held[:, None, :], c, delta)
                    step = np.where(held, 0.0, step)
                    pushed = ((at_lo & (step < 0)) | (at_hi & (step > 0))) & ~held
                    if not pushed.any():
                        break
                    held |= pushed
            dz = step / diag
            if n_capped:
                big = np.max(np.abs(dz[:, :n_capped]), axis=1)
                if np.any(big > MAX_LOG_STEP):
                    dz *= np.minimum(1.0, MAX_LOG_STEP / big)[:, None]
                    step = dz * diag
            z_try = z + dz
            outside = (z_try < st["lo"]) | (z_try > st["hi"])
            if outside.any():
                z_try = np.clip(z_try, st["lo"], st["hi"])
                dz = z_try - z
                step = dz * diag
            p_norm = np.sqrt(np.einsum("bi,bi->b", step, step))
            lin = (r_s @ step[:, :, None])[:, :, 0] + c
            pred = 0.5 * (np.einsum("bi,bi->b", c, c) - np.einsum("bi,bi->b", lin, lin))
            dzz = diag * z
            z_norm = np.sqrt(np.einsum("bi,bi->b", dzz, dzz))
            # Tests that need no new simulation: a negligible gradient (MINPACK checks it
            # before stepping), or a full Gauss-Newton step that is below xtol or predicted
            # to gain less than ftol right after a reliable step.
            early = np.stack([
                g_cos <= tol,
                gauss_newton & st["trusted"] & (pred <= tol * cost),
                gauss_newton & (p_norm <= tol * z_norm),
            ], axis=1)
            stop = early.any(axis=1)
            if stop.any():
                retire(stop, np.full(stop.size, CONVERGED, dtype=np.int8),
                       np.argmax(early, axis=1).astype(np.int8))
                continue  # the others redo this (cheap) step computation
            cost_try, r_try, c_try = evaluate(z_try, st["idx"])
            finite = (np.isfinite(cost_try) & np.isfinite(r_try).all(axis=(1, 2))
                      & np.isfinite(c_try).all(axis=1))
            cost_try = np.where(finite, cost_try, np.inf)
            actual = cost - cost_try
            rho = np.where(pred > 0, actual / pred, np.where(actual > 0, 1.0, -1.0))
            accept = finite & (rho >= 1e-4)
            st["evals"] += 1
            st["accepted"] += accept
            st["trusted"] = accept & (rho >= 0.25)
            st["delta"] = delta = _next_radius(delta, rho, p_norm, gauss_newton)
            z_new = np.where(accept[:, None], z_try, z)
            tests = np.stack([
                g_cos <= tol,
                (np.abs(actual) <= tol * cost) & (pred <= tol * cost) & (rho <= 2.0),
                delta <= tol * np.sqrt(np.einsum("bi,bi->b", diag * z_new, diag * z_new)),
            ], axis=1)
            st["z"] = z_new
            st["r"] = np.where(accept[:, None, None], r_try, st["r"])
            st["c"] = np.where(accept[:, None], c_try, c)
            st["cost"] = np.where(accept, cost_try, cost)
            zero = st["cost"] == 0
            converged = tests.any(axis=1) | zero
            done = converged | (st["evals"] >= max_evaluations)
            if done.any():
                test = np.where(zero, 3, np.where(converged, np.argmax(tests, axis=1), -1))
                retire(done, np.where(converged, CONVERGED, EXHAUSTED).astype(np.int8),
                       test.astype(np.int8))
    return out


def _solve_one(
    evaluate: Evaluate,
    z0: Array,
    first: tuple[Array, Array, Array],
    lo: Array,
    hi: Array,
    *,
    n_capped: int,
    tol: float,
    max_evaluations: int,
) -> Outcome:
    """:func:`solve` for one problem: the same iteration, its scalars as Python floats.

    Why a second loop: in the batched form a single fit's step algebra is ~100 numpy calls
    on one-element arrays per trial point (~130 us, a quarter of a 2001-sample fit); with
    floats it is a third of that. The step itself (:func:`_steps`) and the radius rule
    (:func:`_next_radius`) are shared with :func:`solve`.
    """
    out = Outcome(
        z=np.array(z0, dtype=float), cost=np.full(1, np.nan),
        evaluations=np.zeros(1, dtype=np.int64), accepted=np.zeros(1, dtype=np.int64),
        code=np.full(1, FAILED, dtype=np.int8), test=np.full(1, -1, dtype=np.int8),
    )
    cost, r_fac, c = float(first[0][0]), first[1][0], first[2][0]
    if not (math.isfinite(cost) and np.isfinite(r_fac).all() and np.isfinite(c).all()):
        return out
    z, low, high = out.z[0].copy(), lo[0], hi[0]
    low_l, high_l = low.tolist(), high.tolist()
    everywhere = np.array([0])
    cols = np.sqrt(np.einsum("ij,ij->j", r_fac, r_fac))
    diag = np.where(cols > 0, cols, 1.0)
    delta = FACTOR * float(np.linalg.norm(diag * z)) or FACTOR
    evals = accepted = 0
    trusted = False
    code, test = EXHAUSTED, -1
    with np.errstate(all="ignore"):
        while True:
            cols = np.sqrt(np.einsum("ij,ij->j", r_fac, r_fac))
            diag = np.maximum(diag, cols)
            r_s = r_fac / diag
            r_norm = math.sqrt(2.0 * cost)
            cosine = (c @ r_fac) / np.where(cols > 0, cols, np.inf)
            g_cos = max(map(abs, cosine.tolist())) / (r_norm if r_norm > 0 else 1.0)
            z_l = z.tolist()
            bounded = any(a <= b or a >= h for a, b, h in zip(z_l, low_l, high_l, strict=True))
            piv = np.abs(np.diagonal(r_s)).tolist()
            gauss_newton = False
            if not bounded and min(piv) > 1e-12 * max(piv):
                # _steps' fast path: the Gauss-Newton step by one triangular solve, if it fits.
                step, info = dtrtrs(r_s, -c)
                gauss_newton = info == 0 and math.sqrt(float(step @ step)) <= 1.1 * delta
            if gauss_newton:
                pass
            elif not bounded:
                steps, fits = _steps(r_s[None], c[None], np.array([delta]))
                step, gauss_newton = steps[0], bool(fits[0])
            else:
                at_lo, at_hi = z <= low, z >= high
                grad = c @ r_s
                held = (at_lo & (grad > 0)) | (at_hi & (grad < 0))
                for _ in range(z.size):
                    steps, fits = _steps((r_s * ~held)[None], c[None], np.array([delta]))
                    step = np.where(held, 0.0, steps[0])
                    pushed = ((at_lo & (step < 0)) | (at_hi & (step > 0))) & ~held
                    if not pushed.any():
                        break
                    held |= pushed
                gauss_newton = bool(fits[0])
            dz = step / diag
            if n_capped:
                big = max(map(abs, dz[:n_capped].tolist()))
                if big > MAX_LOG_STEP:
                    dz *= MAX_LOG_STEP / big
            z_try = z + dz
            if any(a < b or a > h for a, b, h in zip(z_try.tolist(), low_l, high_l,
                                                    strict=True)):
                z_try = np.clip(z_try, low, high)
                dz = z_try - z
            step = dz * diag
            p_norm = math.sqrt(float(step @ step))
            lin = r_s @ step + c
            pred = 0.5 * float(c @ c - lin @ lin)
            scaled_z = diag * z
            z_norm = math.sqrt(float(scaled_z @ scaled_z))
            # The stop tests that need no new simulation, as in solve().
            if g_cos <= tol:
                code, test = CONVERGED, 0
                break
            if gauss_newton and trusted and pred <= tol * cost:
                code, test = CONVERGED, 1
                break
            if gauss_newton and p_norm <= tol * z_norm:
                code, test = CONVERGED, 2
                break
            cost_try, r_try, c_try = evaluate(z_try[None], everywhere)
            cost_new = float(cost_try[0])
            finite = (math.isfinite(cost_new) and np.isfinite(r_try).all()
                      and np.isfinite(c_try).all())
            if not finite:
                cost_new = math.inf
            actual = cost - cost_new
            rho = actual / pred if pred > 0 else (1.0 if actual > 0 else -1.0)
            accept = finite and rho >= 1e-4
            evals += 1
            accepted += accept
            trusted = accept and rho >= 0.25
            delta = _next_radius_one(delta, rho, p_norm, gauss_newton)
            f_test = abs(actual) <= tol * cost and pred <= tol * cost and rho <= 2.0
            if accept:
                z, r_fac, c, cost = z_try, r_try[0], c_try[0], cost_new
            scaled_z = diag * z
            x_test = delta <= tol * math.sqrt(float(scaled_z @ scaled_z))
            if cost == 0 or f_test or x_test:
                code, test = CONVERGED, (3 if cost == 0 else 1 if f_test else 2)
                break
            if evals >= max_evaluations:
                break
    out.z[0], out.cost[0] = z, cost
    out.evaluations[0], out.accepted[0] = evals, accepted
    out.code[0], out.test[0] = code, test
    return out
