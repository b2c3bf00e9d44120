"""Solvers as configured objects, and their typed outcomes.

:class:`LevenbergMarquardt` is the default: the compiled state machine of
:mod:`pumpid.engine.lm` driven over (card, start) items by :mod:`pumpid.engine.drive`,
threads spreading the items. :class:`PaperNewton` is the paper's Newton-Raphson with
central differences (eqs. 16-22 and 25-27), kept to reproduce its tables. Both return a
:class:`SolverOutcome` whose ``stops`` are :class:`Stop` members, each with its message.

:func:`run_python` drives the same Levenberg-Marquardt machine around an evaluator that only
Python can run (a nonlinear model integrated by scipy), so those fits stop by the same tests
and report the same counts.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import drive, lm
from .problem import Problem
from .threads import run_chunks

__all__ = ["LevenbergMarquardt", "PaperNewton", "SolverOutcome", "Stop", "run_python"]

Array = NDArray[np.float64]


class Stop(enum.Enum):
    """Why a solver stopped; ``message`` says it in words, ``converged`` whether that counts
    as meeting a convergence test."""

    GTOL = ("gtol", True, "converged: the gradient fell below gtol = {tol:g}")
    FTOL = ("ftol", True, "converged: the relative cost reduction (actual or predicted) fell "
            "below ftol = {tol:g}")
    XTOL = ("xtol", True, "converged: the relative step fell below xtol = {tol:g}")
    ZERO = ("zero", True, "converged: the residual is exactly zero")
    NOISE = ("noise", True, "converged: a full Gauss-Newton step would gain less than "
             "{noise_tol:g} of the residual variance (the answer is within {within:.2g} "
             "standard errors of the exact optimum)")
    STEP = ("step", True, "converged: relative step ||dx||/||x0|| = {eps:.3g} <= eps0 = "
            "{eps0:g} (eq. 21)")
    # "Of one solve": a card's fit runs several (the search, the limits' checks), and a
    # batch summary listed 3,782 evaluations beside "the maximum (2000) was reached".
    BUDGET = ("budget", False, "stopped: the maximum number of model evaluations of one "
              "solve ({budget}) was reached")
    ITERATIONS = ("iterations", False, "stopped: {iterations} iterations without meeting "
                  "eps0 = {eps0:g}")
    NOT_FINITE = ("not-finite", False, "the model's response is not finite at the starting "
                  "point")
    DIVERGED = ("diverged", False, "{detail}")

    def __init__(self, key: str, converged: bool, template: str) -> None:
        self.key = key
        self.converged = converged
        self.template = template

    def message(self, **values: Any) -> str:
        """The stop in words, with the solver's settings filled in."""
        try:
            return self.template.format(**values)
        except (KeyError, IndexError, ValueError):
            return self.template


_LM_TESTS = (Stop.GTOL, Stop.FTOL, Stop.XTOL, Stop.ZERO, Stop.NOISE)


@dataclass(frozen=True)
class SolverOutcome:
    """Per-item outcome of a solver (arrays over the items).

    Attributes
    ----------
    z : ndarray (m, q)
        Final solver coordinates (ln of the free parameters, ln C, offset).
    cost : ndarray (m,)
        ``0.5 |r|^2`` there (NaN when the start could not be evaluated).
    evaluations : ndarray (m,)
        Model evaluations with sensitivities, the start's included.
    accepted : ndarray (m,)
        Accepted steps (iterations).
    stops : tuple of Stop
        Why each item stopped.
    messages : tuple of str
        The stops in words.
    history : ndarray (h, q + 1)
        Accepted points and their costs (the first item only, when asked for).
    """

    z: Array
    cost: Array
    evaluations: NDArray[np.int64]
    accepted: NDArray[np.int64]
    stops: tuple[Stop, ...]
    messages: tuple[str, ...]
    history: Array = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Items that met a convergence test."""
        return np.array([s.converged for s in self.stops], dtype=bool)


def _lm_stop(code: int, test: int) -> Stop:
    if code == lm.CONVERGED:
        return _LM_TESTS[test]
    if code == lm.EXHAUSTED:
        return Stop.BUDGET
    return Stop.NOT_FINITE


@dataclass(frozen=True)
class LevenbergMarquardt:
    """Levenberg-Marquardt with exact sensitivities on log-parameters (the default).

    Parameters
    ----------
    tol : float
        Relative tolerance of the stop tests (MINPACK's xtol = ftol = gtol).
    max_evaluations : int, optional
        Model evaluations per solve of an item (the start's included, at least 2); each of
        a fit's solves (its start's, the main one, a move to a limit, a wider search's
        polishes) has this budget, so a card's total ``nfev`` can exceed it; default 400 per solver
        coordinate (on noiseless well-like Kelvin records, 100 per coordinate stopped 15 of
        400 fits short of the optimum along a slow valley; 400 per coordinate, 1 of 400).
    noise_tol : float
        Also stop when a full Gauss-Newton step would gain less than this fraction of the
        residual variance: the answer is then within ``sqrt(2 noise_tol)`` standard errors
        of the exact optimum (0 turns the test off).
    harmonics : int
        0 (the default): minimise the exact cost. K > 0: on every card that is one
        uniformly sampled period of a model without an input map (linear residual),
        minimise instead the cost of its first K harmonics (:mod:`pumpid.engine.spectrum`),
        which is cheaper to evaluate and close enough to tell basins apart: a search's
        polish. The costs it returns are then that harmonic cost, comparable only among
        themselves (so are those ``history`` records); other cards are fitted as usual.
    """

    tol: float = 1e-12
    max_evaluations: int | None = None
    noise_tol: float = 1e-6
    harmonics: int = 0

    def __post_init__(self) -> None:
        if not (isinstance(self.tol, float | int) and math.isfinite(self.tol) and self.tol > 0):
            raise ValueError(f"tol must be positive, got {self.tol!r}")
        if not (isinstance(self.noise_tol, float | int) and self.noise_tol >= 0):
            raise ValueError(f"noise_tol must be >= 0, got {self.noise_tol!r}")
        if not (isinstance(self.harmonics, int | np.integer) and self.harmonics >= 0):
            raise ValueError(f"harmonics must be an integer >= 0, got {self.harmonics!r}")
        # A solve is its start and at least one trial step: a budget of 1 ran 2 and said so.
        if self.max_evaluations is not None and not (
                isinstance(self.max_evaluations, int | np.integer) and self.max_evaluations >= 2):
            raise ValueError("max_evaluations must be an integer >= 2 (the start and a step), "
                             f"got {self.max_evaluations!r}")

    def budget(self, q: int) -> int:
        """Evaluations per item for a problem with q solver coordinates."""
        return int(self.max_evaluations) if self.max_evaluations is not None else 400 * q

    def solve(
        self,
        problem: Problem,
        cards: NDArray[np.int64],
        z0: Array,
        *,
        budget: NDArray[np.int64] | int | None = None,
        history: bool = False,
        workers: int | None = 1,
        bounds: tuple[Array, Array] | None = None,
    ) -> SolverOutcome:
        """Minimize from z0 (m, q) on the given cards (m,).

        ``budget`` overrides the evaluations per item. ``history`` records the accepted
        points of a single item. ``workers`` threads share the items. ``bounds`` (lo, hi),
        each (m, q), replace the problem's search window (equal bounds hold a coordinate).
        """
        cards = np.ascontiguousarray(cards, dtype=np.int64)
        z0 = np.ascontiguousarray(z0, dtype=float)
        m, q = z0.shape
        if bounds is None:
            lo, hi = problem.window(cards, z0)
        else:
            lo = np.ascontiguousarray(bounds[0], dtype=float)
            hi = np.ascontiguousarray(bounds[1], dtype=float)
        limit = self.budget(q) if budget is None else budget
        # The start is one evaluation; the state machine counts the trial points after it.
        trials = np.maximum(np.broadcast_to(np.asarray(limit, dtype=np.int64), (m,)) - 1, 1)
        data, model, settings = problem.arrays
        n_cap = problem.n_free
        if history and m == 1:
            rows = np.zeros((int(trials[0]) + 1, q + 1))
            out = drive.solve_one(z0[0], lo[0], hi[0], float(self.tol), int(trials[0]),
                                  float(self.noise_tol), int(cards[0]), data, model, settings,
                                  rows, harmonics=int(self.harmonics))
            z, cost = out[0][None], np.array([out[1]])
            evals, acc = np.array([out[2]]), np.array([out[3]])
            codes, tests = np.array([out[4]]), np.array([out[5]])
            hist = rows[: int(out[6])]
        else:
            z = np.empty((m, q))
            cost = np.empty(m)
            evals = np.empty(m, dtype=np.int64)
            acc = np.empty(m, dtype=np.int64)
            codes = np.empty(m, dtype=np.int64)
            tests = np.empty(m, dtype=np.int64)

            def work(a: int, b: int) -> None:
                res = drive.solve_items(cards[a:b], z0[a:b], lo[a:b], hi[a:b],
                                        float(self.tol), trials[a:b], n_cap,
                                        float(self.noise_tol), data, model, settings,
                                        harmonics=int(self.harmonics))
                z[a:b], cost[a:b], evals[a:b], acc[a:b], codes[a:b], tests[a:b] = res

            run_chunks(work, m, workers=workers, chunk=16)
            hist = np.zeros((0, q + 1))
        stops = tuple(_lm_stop(int(c), int(t)) for c, t in zip(codes, tests, strict=True))
        within = math.sqrt(2.0 * self.noise_tol)
        messages = tuple(s.message(tol=self.tol, budget=int(lim), noise_tol=self.noise_tol,
                                   within=within)
                         for s, lim in zip(stops, np.broadcast_to(trials + 1, (m,)),
                                           strict=True))
        cost = np.where(codes == lm.FAILED, math.nan, cost)
        return SolverOutcome(z=z, cost=cost, evaluations=evals, accepted=acc, stops=stops,
                             messages=messages, history=hist)


def run_python(
    evaluate: Callable[[Array], tuple[float, Array, Array]],
    z0: Array,
    lo: Array,
    hi: Array,
    *,
    tol: float,
    max_evaluations: int,
    n_capped: int,
    noise_tol: float = 0.0,
    dof: int = 0,
    cost: Callable[[Array], float] | None = None,
) -> SolverOutcome:
    """The Levenberg-Marquardt machine around a Python evaluator of one problem.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(z) -> (cost, R, Q^T r)`` (NaN cost when the point cannot be evaluated).
    z0, lo, hi : ndarray
        Start and the coordinates' box.
    tol : float
        The stop tests' relative tolerance.
    max_evaluations : int
        Evaluations allowed, the start's included.
    n_capped : int
        Leading coordinates whose steps are capped (the log-parameters).
    noise_tol, dof : float, int
        The noise test (:class:`LevenbergMarquardt`'s ``noise_tol``) and the residual's
        degrees of freedom N - q it is judged on; 0 for either turns the test off.
    cost : callable, optional
        ``cost(z) -> float`` without sensitivities. When given, a trial point is costed
        first and ``evaluate`` runs only where the step can be accepted: a rejected step
        (about half of them near the optimum) then costs no sensitivities, which is most of
        an evaluation for a simulator that differentiates by finite differences.
    """
    first, r, c = evaluate(z0)
    state = lm.start(np.asarray(z0, dtype=float), float(first), r, c, np.asarray(lo, float),
                     np.asarray(hi, float), float(tol), int(n_capped),
                     max(int(max_evaluations) - 1, 1), False,
                     noise_tol * 2.0 / dof if dof > 0 else 0.0, np.zeros(0))
    q = np.asarray(z0).size
    unused_r, unused_c = np.zeros((q, q)), np.zeros(q)
    history = [np.append(z0, first)] if math.isfinite(first) else []
    while lm.propose(state):
        z_try = state[6].copy()
        before = int(state[8][1])
        trial = math.nan if cost is None else float(cost(z_try))
        if cost is not None and not lm.accepts(state, trial):
            # The machine refuses it whatever the sensitivities would be.
            going = lm.update(state, trial if math.isfinite(trial) else math.inf,
                              unused_r, unused_c)
        else:
            cost_try, r_try, c_try = evaluate(z_try)
            going = lm.update(state, float(cost_try), np.asarray(r_try, float),
                              np.asarray(c_try, float))
        if int(state[8][1]) > before:
            history.append(np.append(state[0], state[7][0]))
        if not going:
            break
    ints = state[8]
    stop = _lm_stop(int(ints[4]), int(ints[5]))
    final = float(state[7][0]) if stop is not Stop.NOT_FINITE else math.nan
    return SolverOutcome(
        z=state[0][None].copy(), cost=np.array([final]),
        evaluations=np.array([int(ints[0]) + 1]), accepted=np.array([int(ints[1])]),
        stops=(stop,), messages=(stop.message(tol=tol, budget=max_evaluations,
                                              noise_tol=noise_tol,
                                              within=math.sqrt(2.0 * noise_tol)),),
        history=np.array(history) if history else np.zeros((0, z0.size + 1)))


# --------------------------------------------------------------------------- the paper's method
def _fd_points(theta: Array, h: Array) -> Array:
    """Parameter sets for central differences: base, +-e_i, and the four corners of each pair."""
    p = theta.size
    pts = [theta.copy()]
    for i in range(p):
        for s in (1.0, -1.0):
            q = theta.copy()
            q[i] += s * h[i]
            pts.append(q)
    for i in range(p):
        for j in range(i + 1, p):
            for si, sj in ((1.0, 1.0), (-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0)):
                q = theta.copy()
                q[i] += si * h[i]
                q[j] += sj * h[j]
                pts.append(q)
    return np.array(pts)


def _fd_derivatives(g: Array, h: Array) -> tuple[Array, Array]:
    """First (N, p) and second (N, p, p) derivatives of g from the :func:`_fd_points` runs
    (eq. 22 and the four-point mixed formula that follows it)."""
    p = h.size
    n = g.shape[1]
    g0 = g[0]
    d1 = np.empty((n, p))
    d2 = np.empty((n, p, p))
    for i in range(p):
        gp, gm = g[1 + 2 * i], g[2 + 2 * i]
        d1[:, i] = (gp - gm) / (2 * h[i])
        d2[:, i, i] = (gp - 2 * g0 + gm) / h[i] ** 2
    k = 1 + 2 * p
    for i in range(p):
        for j in range(i + 1, p):
            gpp, gmm, gmp, gpm = g[k], g[k + 1], g[k + 2], g[k + 3]
            k += 4
            d2[:, i, j] = d2[:, j, i] = (gpp + gmm - gmp - gpm) / (4 * h[i] * h[j])
    return d1, d2


def outputs(problem: Problem, card: int, theta: Array) -> tuple[Array, NDArray[np.bool_]]:
    """Unscaled outputs (m, N) of one card for parameter sets theta (m, p); NaN rows where
    the model cannot be simulated."""
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    m = theta.shape[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        lz = np.log(theta[:, problem.free_idx])
    z = np.zeros((m, problem.q))
    z[:, : problem.n_free] = lz
    data, model, settings = problem.arrays
    n_samples = problem.n_samples(card)
    y, ok = drive.outputs(np.full(m, card, dtype=np.int64), np.ascontiguousarray(z), data,
                          model, settings, m * n_samples)
    return y.reshape(m, n_samples), ok


@dataclass(frozen=True)
class PaperNewton:
    """The paper's Newton-Raphson with central differences, exactly as its eqs. (16)-(22).

    The gradient ``sum r dy/dx_i`` and Hessian ``sum dy/dx_i dy/dx_j + sum r d2y/dx_i dx_j``
    with the model output's derivatives (mixed ones included) by central differences at
    ``rel_step`` of each parameter, the scale's and offset's derivatives exact, and the stop
    test ``||dx|| / ||x0|| <= eps0``. No library implements this scheme, hence by hand.

    Parameters
    ----------
    eps0 : float
        Stop at ``||dx|| / ||x0|| <= eps0``.
    max_iter : int
        At most this many iterations.
    rel_step : float
        Finite-difference step as a fraction of each parameter (the paper's 0.1 %).
    """

    eps0: float = 1e-10
    max_iter: int = 200
    rel_step: float = 1e-3

    def solve(self, problem: Problem, card: int, theta0: Array, scale0: float,
              offset0: float) -> tuple[SolverOutcome, list[dict[str, float]]]:
        """Iterate from (theta0, C, offset) on one card; the outcome and the history rows
        (iteration, values, epsilon, cost)."""
        p = problem.n_free
        idx = problem.free_idx
        log_res = problem.residual == "log"
        free_scale = problem.scale_fixed is None
        free_offset = problem.offset_fixed is None
        names = [problem.model.param_names()[i] for i in idx]
        _t, _f, data = problem.card(card)
        parts = list(np.asarray(theta0, dtype=float)[idx])
        if free_scale:
            parts.append(math.log(scale0) if log_res else scale0)
        if free_offset:
            parts.append(offset0)
        x0 = np.array(parts, dtype=float)
        x = x0.copy()
        norm_x0 = float(np.linalg.norm(x0)) or 1.0
        q = x.size
        history: list[dict[str, float]] = []
        nfev = 0

        def split(xv: Array) -> tuple[Array, float, float]:
            theta = problem.full_theta(xv[:p])
            i = p
            if free_scale:
                scale = math.exp(xv[i]) if log_res else float(xv[i])
                i += 1
            else:
                scale = float(problem.scale_fixed)  # type: ignore[arg-type]
            offset = float(xv[i]) if free_offset else float(problem.offset_fixed)  # type: ignore
            return theta, scale, offset

        def residual(y: Array, scale: float, offset: float) -> Array:
            if log_res:
                with np.errstate(divide="ignore", invalid="ignore"):
                    return math.log(scale) + np.log(y) - np.log(data)
            return scale * y + offset - data

        def row(it: int, xv: Array, eps: float) -> dict[str, float]:
            out: dict[str, float] = {"iteration": float(it)}
            out.update(zip(names, xv[:p].tolist(), strict=True))
            if free_scale:
                out["D" if log_res else "C"] = float(xv[p])
            if free_offset:
                out["offset"] = float(xv[-1])
            out["epsilon"] = eps
            return out

        def finish(stop: Stop, it: int, xv: Array | None, cost: float,
                   **values: Any) -> tuple[SolverOutcome, list[dict[str, float]]]:
            z = np.full((1, problem.q), math.nan)
            if xv is not None:
                theta, scale, offset = split(xv)
                if np.all(theta > 0):
                    z[0, :p] = np.log(theta[idx])
                    j = p
                    if free_scale:
                        z[0, j] = math.log(scale)
                        j += 1
                    if free_offset:
                        z[0, j] = offset
            msg = stop.message(eps0=self.eps0, iterations=self.max_iter, **values)
            return SolverOutcome(z=z, cost=np.array([cost]), evaluations=np.array([nfev]),
                                 accepted=np.array([it]), stops=(stop,), messages=(msg,)), \
                history

        history.append(row(0, x, math.nan))
        for it in range(1, self.max_iter + 1):
            theta, scale, offset = split(x)
            if np.any(theta <= 0):
                bad = problem.model.param_names()[int(np.flatnonzero(theta <= 0)[0])]
                return finish(Stop.DIVERGED, it - 1, None, math.nan,
                              detail=f"Newton step {it - 1} made {bad} non-positive; the "
                              "paper's method has no safeguard (start closer, or use "
                              "method='lm')")
            h = self.rel_step * np.abs(theta[idx])
            y_all, _ok = outputs(problem, card, problem.full_theta(_fd_points(theta[idx], h)))
            nfev += y_all.shape[0]
            with np.errstate(all="ignore"):
                g = np.log(y_all) if log_res else y_all
            if not np.all(np.isfinite(g)):
                what = "a non-positive model output (log residual)" if log_res else "overflow"
                return finish(Stop.DIVERGED, it - 1, None, math.nan,
                              detail=f"iteration {it}: the model runs gave {what}")
            d1, d2 = _fd_derivatives(g, h)
            r = residual(y_all[0], scale, offset)
            history[-1]["cost"] = 0.5 * float(r @ r)
            jr = np.zeros((r.size, q))
            hr = np.zeros((q, q))
            c_theta = 1.0 if log_res else scale
            jr[:, :p] = c_theta * d1
            hr[:p, :p] = c_theta * np.einsum("n,nij->ij", r, d2)
            col = p
            if free_scale:
                jr[:, col] = 1.0 if log_res else y_all[0]
                if not log_res:
                    cross = r @ d1
                    hr[:p, col] += cross
                    hr[col, :p] += cross
                col += 1
            if free_offset:
                jr[:, col] = 1.0
            grad = jr.T @ r
            hess = jr.T @ jr + hr
            try:
                dx = np.linalg.solve(hess, -grad)
            except np.linalg.LinAlgError:
                return finish(Stop.DIVERGED, it - 1, None, math.nan,
                              detail=f"iteration {it}: the Hessian of eq. (18) is singular")
            if not np.all(np.isfinite(dx)):
                return finish(Stop.DIVERGED, it - 1, None, math.nan,
                              detail=f"iteration {it}: the Newton step is not finite "
                              "(singular Hessian)")
            x = x + dx
            eps = float(np.linalg.norm(dx)) / norm_x0
            history.append(row(it, x, eps))
            if eps <= self.eps0:
                theta, scale, offset = split(x)
                if np.any(theta <= 0):
                    return finish(Stop.DIVERGED, it, None, math.nan,
                                  detail="converged to non-physical parameters")
                if np.linalg.eigvalsh(0.5 * (hess + hess.T)).min() <= 0:
                    return finish(Stop.DIVERGED, it, None, math.nan,
                                  detail="the iteration stopped at a stationary point of E "
                                  "that is not a minimum (the Hessian of eq. 18 is not "
                                  "positive definite)")
                y_end, _ok = outputs(problem, card, theta)
                nfev += 1
                r = residual(y_end[0], scale, offset)
                cost = 0.5 * float(r @ r)
                history[-1]["cost"] = cost
                return finish(Stop.STEP, it, x, cost, eps=eps)
        return finish(Stop.ITERATIONS, self.max_iter, None, math.nan)
