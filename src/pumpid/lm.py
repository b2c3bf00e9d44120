"""Levenberg-Marquardt over many independent least-squares problems at once.

Both :func:`pumpid.fit` (one problem) and :func:`pumpid.fit_many` (one problem per card) use
this loop. The caller supplies the problems through one callback that returns, for a batch
of trial points, the cost ``0.5 |r|^2`` with the normal equations ``J^T J`` and ``J^T r``:
nothing of size N (samples) crosses the interface, and one simulation with exact
sensitivities per trial point gives all three.

Why by hand: scipy's ``least_squares`` solves one problem per call and drives it through
Python callbacks (residual, then Jacobian) whose overhead is a large part of a
millisecond fit, and no library offers a batched LM. The algorithm is the textbook one:

* steps in coordinates where the Jacobian's columns have unit norm, damping ``lambda * I``
  there (Marquardt's scaling), Nielsen's update of ``lambda`` from the gain ratio;
* box bounds on selected coordinates (the log-parameter search window): a coordinate at a
  bound that the step would push outward is held there for the step (an active set),
  one that the step moves inward may leave;
* a cap on the step of the log-parameters (a factor ``e`` per iteration), the role MINPACK's
  trust radius plays: a Gauss-Newton step along a flat direction cannot fling a parameter
  into a region where the model degenerates;
* MINPACK's stop tests: relative step <= tol (xtol), relative actual and predicted cost
  reductions <= tol (ftol), cosine between residual and Jacobian columns <= tol (gtol).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: The lm search window: each parameter's natural scale times or divided by 1e6. A parameter
#: that runs to the window's edge is reported as a boundary (0 or infinity).
WINDOW = math.log(1e6)
#: Keeps exp() of a log-coordinate finite during wild trial steps.
LOG_MAX = 700.0
#: Largest change of a log-parameter in one step.
MAX_LOG_STEP = 1.0

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
        ``evaluate(z, idx) -> (cost, jtj, jtr)`` for trial points ``z`` (m, q) of the problems
        ``idx`` (m,); non-finite values mark a trial point as unusable.
    z0 : ndarray, shape (b, q)
        Starting points.
    first : (cost, jtj, jtr)
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
    cost, jtj, jtr = first
    out = Outcome(
        z=np.array(z0, dtype=float), cost=np.full(b, np.nan),
        evaluations=np.zeros(b, dtype=np.int64), accepted=np.zeros(b, dtype=np.int64),
        code=np.full(b, FAILED, dtype=np.int8), test=np.full(b, -1, dtype=np.int8),
    )
    ok = np.isfinite(cost) & np.isfinite(jtj).all(axis=(1, 2)) & np.isfinite(jtr).all(axis=1)
    m = int(ok.sum())
    # Per-problem state of the problems still iterating (filtered together when some stop).
    st = {
        "idx": np.flatnonzero(ok), "z": out.z[ok], "cost": cost[ok], "jtj": jtj[ok],
        "jtr": jtr[ok], "lo": lo[ok], "hi": hi[ok], "lam": np.full(m, 1e-3),
        "nu": np.full(m, 2.0), "evals": np.zeros(m, dtype=np.int64),
        "accepted": np.zeros(m, dtype=np.int64), "trusted": np.zeros(m, dtype=bool),
    }

    def retire(mask: NDArray[np.bool_], code: NDArray[np.int8], test: NDArray[np.int8]) -> None:
        i = st["idx"][mask]
        out.z[i], out.cost[i] = st["z"][mask], st["cost"][mask]
        out.evaluations[i], out.accepted[i] = st["evals"][mask], st["accepted"][mask]
        out.code[i], out.test[i] = code[mask], test[mask]
        keep = ~mask
        for key in st:
            st[key] = st[key][keep]

    eye = np.eye(q)
    with np.errstate(all="ignore"):
        while st["idx"].size:
            z, cost, lam = st["z"], st["cost"], st["lam"]
            # Columns of J scaled to unit norm: J_s = J / norms, so J_s^T J_s and J_s^T r
            # follow from the normal equations without the Jacobian itself.
            norms = np.sqrt(np.diagonal(st["jtj"], axis1=1, axis2=2))
            norms = np.where(norms > 0, norms, 1.0)
            grad0 = st["jtr"] / norms
            hess0 = st["jtj"] / (norms[:, :, None] * norms[:, None, :])
            # Coordinates at a bound that the step would push outward are held there for
            # this step (an active set): first those whose gradient points outward, then
            # those the step itself pushes out through the correlations, until none is left.
            at_lo, at_hi = z <= st["lo"], z >= st["hi"]
            held = (at_lo & (grad0 > 0)) | (at_hi & (grad0 < 0))
            for _ in range(q):
                free = ~held
                hess = hess0 * (free[:, :, None] & free[:, None, :])
                grad = np.where(held, 0.0, grad0)
                step = np.linalg.solve(hess + lam[:, None, None] * eye,
                                       -grad[..., None])[..., 0]
                pushed = ((at_lo & (step < 0)) | (at_hi & (step > 0))) & free
                if not pushed.any():
                    break
                held |= pushed
            r_norm = np.sqrt(2.0 * cost)
            g_cos = np.max(np.abs(grad), axis=1) / np.where(r_norm > 0, r_norm, 1.0)
            dz = step / norms
            if n_capped:
                big = np.max(np.abs(dz[:, :n_capped]), axis=1)
                dz *= np.minimum(1.0, MAX_LOG_STEP / np.where(big > 0, big, 1.0))[:, None]
            z_try = np.clip(z + dz, st["lo"], st["hi"])
            dz = z_try - z
            step = dz * norms
            pred = -(np.einsum("bq,bq->b", grad, step)
                     + 0.5 * np.einsum("bq,bqk,bk->b", step, hess, step))
            # Tests that need no new simulation (MINPACK checks the gradient before
            # stepping): a negligible gradient, a next step below xtol, or a next step
            # predicted to gain less than ftol while the quadratic model has just proved
            # reliable (last step accepted with a gain ratio >= 1/4, damping small). Such
            # problems stop here instead of paying one more simulation to confirm it.
            step_small = np.linalg.norm(dz, axis=1) <= tol * (np.linalg.norm(z, axis=1) + tol)
            early = np.stack([g_cos <= tol, (pred <= tol * cost) & st["trusted"] & (lam <= 1e-2),
                              step_small], axis=1)
            stop = early.any(axis=1)
            if stop.any():
                retire(stop, np.full(stop.size, CONVERGED, dtype=np.int8),
                       np.argmax(early, axis=1).astype(np.int8))
                continue  # the others redo this (cheap) step computation
            cost_try, jtj_try, jtr_try = evaluate(z_try, st["idx"])
            finite = (np.isfinite(cost_try) & np.isfinite(jtj_try).all(axis=(1, 2))
                      & np.isfinite(jtr_try).all(axis=1))
            cost_try = np.where(finite, cost_try, np.inf)
            actual = cost - cost_try
            rho = np.where(pred > 0, actual / pred, np.where(actual > 0, 1.0, -1.0))
            accept = finite & (rho > 1e-4)
            st["evals"] += 1
            st["accepted"] += accept
            st["trusted"] = accept & (rho >= 0.25)
            # Nielsen's update: shrink lambda smoothly on good steps, grow geometrically on
            # bad ones.
            shrink = np.maximum(1 / 3, 1 - (2 * np.minimum(rho, 1.0) - 1) ** 3)
            st["lam"] = np.clip(np.where(accept, lam * shrink, lam * st["nu"]), 1e-12, 1e16)
            st["nu"] = np.where(accept, 2.0, st["nu"] * 2.0)
            z_new = np.where(accept[:, None], z_try, z)
            tests = np.stack([
                g_cos <= tol,
                (np.abs(actual) <= tol * cost) & (pred <= tol * cost) & (rho <= 2.0),
                np.linalg.norm(dz, axis=1) <= tol * (np.linalg.norm(z_new, axis=1) + tol),
            ], axis=1)
            st["z"] = z_new
            st["jtj"] = np.where(accept[:, None, None], jtj_try, st["jtj"])
            st["jtr"] = np.where(accept[:, None], jtr_try, st["jtr"])
            st["cost"] = np.where(accept, cost_try, cost)
            zero = st["cost"] == 0
            converged = tests.any(axis=1) | zero
            done = converged | (st["evals"] >= max_evaluations)
            if done.any():
                test = np.where(zero, 3, np.where(converged, np.argmax(tests, axis=1), -1))
                retire(done, np.where(converged, CONVERGED, EXHAUSTED).astype(np.int8),
                       test.astype(np.int8))
    return out
