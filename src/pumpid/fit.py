"""Identification: one entry point, two methods, one result type.

``method="lm"`` (default)
    Levenberg-Marquardt (:mod:`pumpid.lm`) on log-parameters, so every physical parameter
    stays positive, with the exact Jacobian from the sensitivity system.
``method="newton-fd"``
    The paper's inverse-optimization method exactly as eqs. (16)-(22) and (25)-(27) describe
    it: Newton-Raphson on the gradient of E, with the model output's first and second
    derivatives (including the mixed ones) by central differences at 0.1 % of each parameter,
    the scale's and offset's derivatives exact, and the stop test ||dx|| / ||x0|| <= eps0.
    No library implements this particular scheme, hence the hand-written loop.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import lm
from .blas import single_threaded
from .boundaries import SUSPICION, Boundary, find_boundaries, nested_candidates
from .diagnostics import diagnose
from .models import Model
from .problem import Problem, build_problem, initial_state_label
from .result import FitResult, Units
from .simulate import InitialState, Integrator

__all__ = ["fit"]

Method = Literal["lm", "newton-fd"]


def _start_theta(
    model: Model | type[Model], x0: Mapping[str, float] | Model | ArrayLike | None
) -> tuple[type[Model], NDArray[np.float64] | None, dict[str, float]]:
    """Model class, starting parameters (None: automatic) and extra start values (C, offset)."""
    extras: dict[str, float] = {}
    if isinstance(model, Model):
        cls: type[Model] = type(model)
        theta: NDArray[np.float64] | None = model.values
    elif isinstance(model, type) and issubclass(model, Model):
        cls, theta = model, None
    else:
        raise TypeError(
            "model must be a model instance (a starting guess, e.g. Kelvin(k0=4, m=1, c1=0.2, "
            f"k1=4)) or a model class (automatic start), got {model!r}"
        )
    if x0 is None:
        return cls, theta, extras
    if isinstance(x0, Model):
        if type(x0) is not cls:
            raise TypeError(f"x0 is a {type(x0).__name__}, the model a {cls.__name__}")
        return cls, x0.values, extras
    if isinstance(x0, Mapping):
        names = cls.param_names()
        unknown = set(x0) - set(names) - {"C", "D", "offset"}
        if unknown:
            raise ValueError(f"x0: unknown names {sorted(unknown)}; parameters are {names}")
        base = theta if theta is not None else None
        values = []
        for i, name in enumerate(names):
            if name in x0:
                values.append(float(x0[name]))
            elif base is not None:
                values.append(float(base[i]))
            else:
                raise ValueError(f"x0: missing {name!r} (give all of {names} or a model)")
        for key in ("C", "D", "offset"):
            if key in x0:
                extras[key] = float(x0[key])
        return cls, np.array(values), extras
    arr = np.asarray(x0, dtype=float).ravel()
    return cls, cls.from_values(arr).values, extras


def _initial_linear(
    problem: Problem, theta: NDArray[np.float64], extras: Mapping[str, float]
) -> tuple[float, float]:
    """Starting C and offset: given ones, else the best ones for the starting parameters."""
    scale = problem.scale_fixed if problem.scale_fixed is not None else None
    offset = problem.offset_fixed
    if scale is None:
        if "C" in extras:
            scale = extras["C"]
        elif "D" in extras:
            scale = math.exp(extras["D"])
    if scale is None or (offset is None and "offset" not in extras):
        y = problem.outputs(theta)
        if problem.residual == "log":
            with np.errstate(divide="ignore", invalid="ignore"):
                d = float(np.mean(np.log(problem.data) - np.log(y)))
            scale = math.exp(d) if math.isfinite(d) else 1.0
        else:
            cols = [y] if scale is None else []
            rhs = problem.data - (0.0 if scale is None else scale * y)
            if offset is None:
                cols.append(np.ones_like(y))
            if cols:
                coef, *_ = np.linalg.lstsq(np.column_stack(cols), rhs, rcond=None)
                if scale is None:
                    scale = float(coef[0]) if coef[0] > 0 and np.isfinite(coef[0]) else 1.0
                if offset is None:
                    offset = float(coef[-1]) if np.isfinite(coef[-1]) else 0.0
    if offset is None:
        offset = extras.get("offset", 0.0)
    return float(scale), float(offset)


# --------------------------------------------------------------------------- lm
_REASONS = {
    "gtol": "converged: the gradient fell below gtol = {tol:g}",
    "ftol": ("converged: the relative cost reduction (actual or predicted) fell below "
             "ftol = {tol:g}"),
    "xtol": "converged: the relative step fell below xtol = {tol:g}",
    "zero": "converged: the residual is exactly zero",
}


def _solve_lm(
    problem: Problem, theta0: NDArray[np.float64], scale0: float, offset0: float, tol: float,
    max_nfev: int | None,
) -> dict[str, Any]:
    """Levenberg-Marquardt (:func:`pumpid.lm.solve`) on z = (ln theta_free, [ln C], [offset]).

    Every trial point is one simulation with exact sensitivities, reduced to the normal
    equations; the log-parameters live in a wide window around the data's natural scales
    (widened to contain the start), and one at the window's edge is a boundary (0 or
    infinity), recognised afterwards.
    """
    p = problem.n_free
    idx = problem.free_idx
    log_res = problem.residual == "log"
    ref = np.log(problem.reference_scales()[idx])
    z0 = list(np.log(theta0[idx]))
    lo = list(np.minimum(ref - lm.WINDOW, np.log(theta0[idx]) - 1.0))
    hi = list(np.maximum(ref + lm.WINDOW, np.log(theta0[idx]) + 1.0))
    if problem.scale_fixed is None:
        z0.append(math.log(scale0))
        lo.append(-lm.LOG_MAX)
        hi.append(lm.LOG_MAX)
    if problem.offset_fixed is None:
        z0.append(offset0)
        lo.append(-math.inf)
        hi.append(math.inf)
    q = len(z0)
    history: list[dict[str, float]] = []
    best = {"cost": math.inf}
    counter = {"nfev": 0}

    def unpack(z: NDArray[np.float64]) -> tuple[NDArray[np.float64], float, float]:
        theta = problem.full_theta(np.exp(z[:p]))
        scale = problem.scale_fixed if problem.scale_fixed is not None else math.exp(z[p])
        offset = problem.offset_fixed if problem.offset_fixed is not None else float(z[-1])
        return theta, float(scale), float(offset)

    def rejected() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        return np.array([math.nan]), np.full((1, q, q), math.nan), np.full((1, q), math.nan)

    def evaluate(z_try: NDArray[np.float64], _idx: NDArray[np.intp]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        counter["nfev"] += 1
        z = z_try[0]
        theta, scale, offset = unpack(z)
        with np.errstate(all="ignore"):
            try:
                y, dy = problem.output_and_sensitivities(theta)
            except (ValueError, np.linalg.LinAlgError):
                if counter["nfev"] == 1:
                    raise  # the start itself cannot be simulated: the fit fails, with why
                return rejected()  # a trial point the model cannot simulate
            r = problem.residual_vector(y, scale, offset)
            if not np.isfinite(r).all():
                return rejected()  # a non-physical trial point: the damping grows
            # Jacobian rows, then the residual, as lm.reduce_rows factors them.
            rows = np.empty((1, q + 1, y.size))
            jac = rows[0, :q]
            th = theta[idx]
            if log_res:
                np.multiply(dy.T, th[:, None] / y, out=jac[:p])
            else:
                np.multiply(dy.T, scale * th[:, None], out=jac[:p])
            if problem.scale_fixed is None:
                jac[p] = 1.0 if log_res else scale * y
            if problem.offset_fixed is None:
                jac[-1] = 1.0
            rows[0, q] = r
            reduced = lm.reduce_rows(rows, overwrite=True)
            cost = float(reduced[0][0])
        if cost < best["cost"]:
            best.update(cost=cost, z=z.copy(), y=y, dy=dy)
            row: dict[str, float] = {"iteration": float(len(history))}
            row.update(zip(problem.model_cls.param_names(), theta.tolist(), strict=True))
            if problem.scale_fixed is None:
                row["D" if log_res else "C"] = math.log(scale) if log_res else scale
            if problem.offset_fixed is None:
                row["offset"] = offset
            row["cost"] = cost
            history.append(row)
        return reduced

    z_start = np.array([z0])
    z_lo, z_hi = np.array([lo]), np.array([hi])
    budget = max_nfev if max_nfev is not None else 100 * q
    try:
        first = evaluate(z_start, np.array([0]))
        res = lm.solve(evaluate, z_start, first, z_lo, z_hi, n_capped=p, tol=tol,
                       max_evaluations=max(1, budget - 1))
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
        # A trial point where the model cannot be evaluated at all (a singular equilibrium,
        # say): the fit fails with the reason instead of raising from deep inside numpy.
        return {"ok": False, "reason": f"solver error: {exc}", "history": history,
                "nfev": counter["nfev"], "iterations": max(len(history) - 1, 0)}
    code = int(res.code[0])
    if code == lm.FAILED:
        return {"ok": False, "history": history, "nfev": counter["nfev"], "iterations": 0,
                "reason": "the model's response is not finite at the starting point"}
    z = res.z[0]
    theta, scale, offset = unpack(z)
    edges = [(int(idx[i]), "infinity" if z[i] >= z_hi[0, i] else "zero") for i in range(p)
             if not z_lo[0, i] < z[i] < z_hi[0, i]]
    if code == lm.CONVERGED:
        reason = _REASONS[lm.TESTS[int(res.test[0])]].format(tol=tol)
    else:
        reason = "stopped: the maximum number of function evaluations was reached"
    simulated = None
    if "z" in best and np.array_equal(best["z"], z):
        simulated = (best["y"], best["dy"])  # the solver's own run at this point
    return {
        "ok": code == lm.CONVERGED,
        "simulated": simulated,
        "stopped_early": code == lm.EXHAUSTED,
        "reason": reason,
        "theta": theta, "scale": scale, "offset": offset, "edges": edges,
        "history": history,
        "nfev": counter["nfev"],
        "iterations": int(res.accepted[0]),
    }


# --------------------------------------------------------------------------- newton-fd
def _fd_points(theta: NDArray[np.float64], h: NDArray[np.float64]) -> NDArray[np.float64]:
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


def _fd_derivatives(
    g: NDArray[np.float64], h: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """First (N, p) and second (N, p, p) derivatives of g from the :func:`_fd_points` runs.

    Eq. (22) and the four-point mixed formula that follows it.
    """
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


def _solve_newton_fd(
    problem: Problem, theta0: NDArray[np.float64], scale0: float, offset0: float,
    eps0: float, max_iter: int, rel_step: float,
) -> dict[str, Any]:
    p = problem.n_free
    idx = problem.free_idx
    log_res = problem.residual == "log"
    free_scale = problem.scale_fixed is None
    free_offset = problem.offset_fixed is None
    names = [problem.model_cls.param_names()[i] for i in idx]
    x0 = problem.join(theta0, scale0, offset0)
    x = x0.copy()
    norm_x0 = float(np.linalg.norm(x0)) or 1.0
    history: list[dict[str, float]] = []
    nfev = 0
    q = x.size

    def row(it: int, xv: NDArray[np.float64], eps: float) -> dict[str, float]:
        out: dict[str, float] = {"iteration": float(it)}
        out.update(zip(names, xv[:p].tolist(), strict=True))
        if free_scale:
            out["D" if log_res else "C"] = float(xv[p])
        if free_offset:
            out["offset"] = float(xv[-1])
        out["epsilon"] = eps
        return out

    history.append(row(0, x, math.nan))
    for it in range(1, max_iter + 1):
        theta, scale, offset = problem.split(x)
        if np.any(theta <= 0):
            bad = problem.model_cls.param_names()[int(np.flatnonzero(theta <= 0)[0])]
            return _nfd_fail(history, nfev, it - 1,
                             f"Newton step {it - 1} made {bad} non-positive; the paper's "
                             "method has no safeguard (start closer, or use method='lm')")
        h = rel_step * np.abs(theta[idx])
        with np.errstate(all="ignore"):
            y_all = problem.outputs(problem.full_theta(_fd_points(theta[idx], h)))
            nfev += y_all.shape[0]
            g = np.log(y_all) if log_res else y_all
        if not np.all(np.isfinite(g)):
            what = "a non-positive model output (log residual)" if log_res else "overflow"
            return _nfd_fail(history, nfev, it - 1,
                             f"iteration {it}: the model runs gave {what}")
        d1, d2 = _fd_derivatives(g, h)
        r = problem.residual_vector(y_all[0], scale, offset)
        history[-1]["cost"] = 0.5 * float(r @ r)
        # Derivatives of the residual with respect to the free values (theta, C|D, offset).
        jr = np.zeros((r.size, q))
        hr = np.zeros((q, q))
        c_theta = 1.0 if log_res else scale
        jr[:, :p] = c_theta * d1
        hr[:p, :p] = c_theta * np.einsum("n,nij->ij", r, d2)
        col = p
        if free_scale:
            jr[:, col] = 1.0 if log_res else g[0]
            if not log_res:
                # d2 r / dtheta_i dC = dy/dtheta_i: exact in C, central difference in theta.
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
            return _nfd_fail(history, nfev, it - 1,
                             f"iteration {it}: the Hessian of eq. (18) is singular")
        if not np.all(np.isfinite(dx)):
            return _nfd_fail(history, nfev, it - 1,
                             f"iteration {it}: the Newton step is not finite (singular Hessian)")
        x = x + dx
        eps = float(np.linalg.norm(dx)) / norm_x0
        history.append(row(it, x, eps))
        if eps <= eps0:
            theta, scale, offset = problem.split(x)
            if np.any(theta <= 0):
                return _nfd_fail(history, nfev, it, "converged to non-physical parameters")
            if np.linalg.eigvalsh(0.5 * (hess + hess.T)).min() <= 0:
                # Newton-Raphson finds any stationary point of E; a saddle or maximum is not
                # an answer even though the step test is met.
                return _nfd_fail(history, nfev, it,
                                 "the iteration stopped at a stationary point of E that is not "
                                 "a minimum (the Hessian of eq. 18 is not positive definite)")
            r = problem.residual_vector(problem.outputs(theta), scale, offset)
            nfev += 1
            history[-1]["cost"] = 0.5 * float(r @ r)
            return {"ok": True, "theta": theta, "scale": scale, "offset": offset,
                    "history": history, "nfev": nfev, "iterations": it,
                    "reason": f"converged: relative step ||dx||/||x0|| = {eps:.3g} <= "
                              f"eps0 = {eps0:g} (eq. 21)"}
    theta, scale, offset = problem.split(x)
    res = _nfd_fail(history, nfev, max_iter,
                    f"stopped: {max_iter} iterations without meeting eps0 = {eps0:g}")
    return res


def _nfd_fail(history: list[dict[str, float]], nfev: int, iterations: int,
              reason: str) -> dict[str, Any]:
    return {"ok": False, "reason": reason, "history": history, "nfev": nfev,
            "iterations": iterations}


# --------------------------------------------------------------------------- entry point
@single_threaded
def fit(
    model: Model | type[Model],
    t: ArrayLike,
    load: ArrayLike,
    displacement: ArrayLike,
    *,
    method: Method = "lm",
    integrator: Integrator = "exact",
    scale: float | str = 1.0,
    residual: Literal["linear", "log"] = "linear",
    x0: Mapping[str, float] | Model | ArrayLike | None = None,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    offset: bool | float = False,
    period: float | None = None,
    fixed: Mapping[str, float] | None = None,
    units: Units | None = None,
    eps0: float = 1e-10,
    max_iter: int = 200,
    rel_step: float = 1e-3,
    tol: float = 1e-12,
    max_nfev: int | None = None,
    multistart: bool | Literal["auto"] = "auto",
    _restart: bool = True,
) -> FitResult:
    """Identify a model's parameters from a load record and the measured displacement.

    Parameters
    ----------
    model : Model instance or Model class
        An instance is the starting guess (e.g. ``Kelvin(k0=4, m=1, c1=0.2, k1=4)``).
    t, load, displacement : array_like, shape (N,)
        Time (s, strictly increasing, N >= 10), the input (load) and the measured output
        (displacement) in the user's units.
    method : {"lm", "newton-fd"}
        ``lm``: exact sensitivities, log-parameters, Levenberg-Marquardt (:mod:`pumpid.lm`).
        ``newton-fd``: the paper's Newton-Raphson with central differences.
    integrator : {"exact", "euler"}
        Forward model: exact first-order-hold discretization, or the paper's explicit Euler.
    scale : float or "free"
        The output scale factor C (fixed, default 1) or ``"free"``. For models with the scale
        symmetry (MSD, Kelvin, Maxwell) started from a load-driven state, a free C is not
        identifiable: the gauge C = 1 is fixed and a warning says so.
    residual : {"linear", "log"}
        ``linear``: C y + offset - data (eq. 14). ``log``: D + ln y - ln data (eq. 25),
        D = ln C; needs positive data.
    x0 : mapping, Model or array, optional
        Starting values (overrides the instance's); may include ``C``/``D`` and ``offset``.
    observe : str, optional
        Observed state (default: the model's; ``u2`` for Kelvin).
    initial_state : {"rest", "equilibrium", "periodic"} or numbers
        See :func:`pumpid.simulate`.
    offset : bool or float
        Fit an additive position offset (True), or subtract a fixed one (float).
    period : float, optional
        Stroke period (s) for ``initial_state="periodic"``.
    fixed : mapping, optional
        Model parameters held at given values (``{"m": 2.0}``); the others are fitted. A fixed
        parameter also fixes the gauge of the scale symmetry, so C can then be free.
    units : Units, optional
        Units of load and position, recorded in the result (default N and m).
    eps0, max_iter, rel_step : float, int, float
        The paper's method: stop at ||dx||/||x0|| <= eps0; at most ``max_iter`` iterations;
        finite-difference step as a fraction of each parameter (0.1 %).
    tol, max_nfev : float, int
        The lm method's tolerances (xtol = ftol = gtol) and evaluation budget.
    multistart : {"auto", True, False}
        Guard a user's guess against local minima with the automatic start's small
        multistart (the guess joins the candidates). ``"auto"`` (default) first runs lm from
        the guess alone -- the fast path -- and falls back to the multistart only when that
        fit failed, stopped on a boundary, explains less than 99 % of the data's variance, or
        does not come down to the data's noise level (estimated from second differences);
        ``True`` always, ``False`` never. Only for ``method="lm"``: the paper's method runs
        from the given guess, as the paper does.

    Returns
    -------
    FitResult
        Never raises for a failed or divergent fit: ``converged`` is False and ``reason``
        says why. Bad input raises ``ValueError`` naming the problem.
    """
    if method not in ("lm", "newton-fd"):
        raise ValueError(f"method must be 'lm' or 'newton-fd', got {method!r}")
    cls, theta0, extras = _start_theta(model, x0)
    warnings: list[str] = []
    problem = build_problem(
        cls, t, load, displacement, observe=observe, initial_state=initial_state,
        integrator=integrator, residual=residual, scale=scale, offset=offset, period=period,
        fixed=dict(fixed) if fixed else None, warnings=warnings,
    )
    start_note = None
    if theta0 is None:
        from .start import initial_estimate

        theta0, start_note = initial_estimate(problem)
    if problem.gauge_fixed and ("C" in extras or "D" in extras):
        # Keep the user's start on the same curve: move it onto the gauge C = 1.
        c_start = extras.pop("C", None) or math.exp(extras.pop("D", 0.0))
        theta0 = theta0 / c_start
    theta0 = np.array(theta0, dtype=float)
    for i, value in problem.fixed:
        theta0[i] = value
    if multistart not in ("auto", True, False):
        raise ValueError(f"multistart must be 'auto', True or False, got {multistart!r}")
    guarded = method == "lm" and start_note is None and multistart is True
    if guarded:
        from .start import initial_estimate

        theta0, start_note = initial_estimate(problem, guess=theta0)
    scale0, offset0 = _initial_linear(problem, theta0, extras)
    if method == "lm":
        raw = _solve_lm(problem, theta0, scale0, offset0, tol, max_nfev)
    else:
        raw = _solve_newton_fd(problem, theta0, scale0, offset0, eps0, max_iter, rel_step)
    result = assemble_result(problem, raw, method, units or Units(), warnings)
    if (method == "lm" and multistart == "auto" and start_note is None and _restart
            and _doubtful(result, problem)):
        # The fast path from the user's guess looks wrong: run the guarded fit and keep the
        # better of the two (the guarded one also reports its boundaries itself).
        guarded_res = fit(
            cls.from_values(theta0), t, load, displacement, method=method,
            integrator=integrator, scale=scale, residual=residual, x0=x0 if isinstance(
                x0, Mapping) else None, observe=observe, initial_state=initial_state,
            offset=offset, period=period, fixed=fixed, units=units, eps0=eps0,
            max_iter=max_iter, rel_step=rel_step, tol=tol, max_nfev=max_nfev,
            multistart=True, _restart=True,
        )
        if np.isfinite(guarded_res.cost) and not (guarded_res.cost >= result.cost):
            guarded_res.warnings.append(
                "the fit from the given guess looked wrong (status "
                f"{result.status}, R^2 = {result.r2:.4g}); the automatic multistart found "
                f"a better solution (cost {result.cost:.6g} -> {guarded_res.cost:.6g})"
            )
            return guarded_res
    result.context = {
        "problem": problem, "model_cls": cls,
        "options": {"method": method, "integrator": integrator, "scale": scale,
                    "residual": residual, "observe": observe, "initial_state": initial_state,
                    "offset": offset, "period": period, "units": units, "eps0": eps0,
                    "max_iter": max_iter, "rel_step": rel_step, "tol": tol,
                    "max_nfev": max_nfev, "multistart": False},
    }
    if start_note:
        result.extra["start"] = start_note
    if raw.get("edges"):
        result.extra["edges"] = raw["edges"]
    if not raw["ok"]:
        result.status = "failed"
    if result.model is not None and np.isfinite(result.cost) and not problem.fixed:
        _check_boundaries(result, problem, {
            "method": method, "integrator": integrator, "residual": residual,
            "offset": offset, "period": period, "units": units, "eps0": eps0,
            "max_iter": max_iter, "rel_step": rel_step, "tol": tol, "max_nfev": max_nfev,
        }, scale, stopped_early=bool(raw.get("stopped_early")))
        restart = result.extra.pop("restart_from", None)
        result.extra.pop("_best_red", None)
        if restart is not None and _restart:
            again = fit(cls(**restart), t, load, displacement, method=method,
                        integrator=integrator, scale=scale, residual=residual, observe=observe,
                        initial_state=initial_state, offset=offset, period=period, fixed=fixed,
                        units=units, eps0=eps0, max_iter=max_iter, rel_step=rel_step, tol=tol,
                        max_nfev=max_nfev, multistart=False, _restart=False)
            if np.isfinite(again.cost) and again.cost < result.cost:
                again.warnings.append(
                    "restarted next to a limiting model that fitted better than the first "
                    f"solution (cost {result.cost:.6g} -> {again.cost:.6g})"
                )
                return again
    diagnose(result)
    return result


def _median(x: NDArray[np.float64]) -> float:
    """Median by one partition (np.median's checks cost more than the work here)."""
    k = x.size // 2
    part = np.partition(x, [k - 1, k] if x.size % 2 == 0 else k)
    return float(part[k] if x.size % 2 else 0.5 * (part[k - 1] + part[k]))


def _doubtful(result: FitResult, problem: Problem) -> bool:
    """A fit from a user's guess that deserves the multistart guard.

    Failed, boundary or poor (R^2 < 0.99) fits, and fits whose RMSE stays above twice the
    data's noise level (a wrong local minimum, or a model that does not match the data).
    """
    if (result.model is None or result.status != "converged" or not np.isfinite(result.r2)
            or result.r2 < 0.99):
        return True
    # A fit that does not come down to the noise floor may sit in a wrong local minimum.
    # Robust noise estimate from second differences (white noise: var(diff2) = 6 sigma^2);
    # smooth signal content only raises it, so a good fit is never called doubtful.
    diff2 = np.diff(problem.data, 2)
    sigma = 1.4826 * _median(np.abs(diff2 - _median(diff2))) / math.sqrt(6.0)
    return result.rmse > 2.0 * sigma + 1e-9 * float(np.ptp(problem.data))


def _check_boundaries(
    result: FitResult, problem: Problem, options: dict[str, Any], scale_option: float | str,
    stopped_early: bool,
) -> None:
    """Mark a boundary solution and fit the limiting model the data want (when pumpid has it).

    Two tests: pushing one parameter further leaves the cost unchanged (see
    :func:`pumpid.boundaries.find_boundaries`), or -- for limits pumpid can fit -- the reduced
    model fits as well as the full one by a likelihood-ratio test at the 95 % level
    (SSR_reduced - SSR_full <= 3.84 sigma^2, sigma^2 = SSR_full / (N - p)).
    """

    assert result.model is not None
    theta = result.model.values
    jac = result.jacobian
    spread = float(np.linalg.norm(problem.data - problem.data.mean()))
    if problem.residual == "log":
        spread = float(np.linalg.norm(np.log(problem.data) - np.log(problem.data).mean()))
    log_sens = (np.linalg.norm(jac[:, : problem.n_params], axis=0) * theta / spread
                if jac is not None else np.zeros_like(theta))
    interior = (not result.extra.get("edges") and not stopped_early
                and bool(np.all(log_sens >= SUSPICION)))
    # A parameter whose push could leave the fit unchanged has a small log-sensitivity;
    # when every one is clearly influential the push test cannot fire and is skipped.
    found = [] if interior else find_boundaries(
        problem, theta, result.scale, result.offset, result.cost,
        result.extra.get("edges", []))
    reduced_fit: FitResult | None = None
    reduced_limit = None
    n_free = len(problem.free_names)
    sigma2 = 2.0 * result.cost / max(problem.data.size - n_free, 1)
    sst = float(np.sum((problem.data - problem.data.mean()) ** 2))
    if isinstance(problem.initial_state, str):
        candidates = nested_candidates(problem, theta, log_sens, result.extra.get("edges"),
                                       stopped_early)
        known = {b.name for b in found}
        for name, direction, limit in candidates:
            red = _fit_reduced(result, problem, limit, options, scale_option)
            if red is None or not np.isfinite(red.cost):
                continue
            excess = 2.0 * (red.cost - result.cost)
            if excess < -3.84 * sigma2 - 1e-12 * sst and limit.from_reduced is not None:
                # The reduced model fits clearly better: the full fit is stuck, not at a
                # boundary. Hand back a full-model start next to the reduced solution.
                if "restart_from" not in result.extra or red.cost < result.extra["_best_red"]:
                    result.extra["restart_from"] = limit.from_reduced(red.params)
                    result.extra["_best_red"] = red.cost
                continue
            if excess <= 3.84 * sigma2 + 1e-12 * sst:
                if name not in known:
                    i = problem.model_cls.param_names().index(name)
                    found.append(Boundary(name, direction, float(theta[i]), limit, "nested"))
                if reduced_fit is None or red.cost < reduced_fit.cost:
                    reduced_fit, reduced_limit = red, limit
    if not found or "restart_from" in result.extra:
        return
    result.status = "boundary"
    result.converged = False
    result.reason = (
        f"{result.reason}; {', '.join(b.name for b in found)} ran to a bound: "
        "the solution is a limiting model, not an interior optimum"
    )
    result.warnings.extend(b.describe() for b in found)
    result.extra["boundaries"] = [
        {"name": b.name, "direction": b.direction, "limit": b.limit.description} for b in found
    ]
    if reduced_fit is None:
        target = next((b for b in found if b.limit.reduced is not None), None)
        if target is not None and isinstance(problem.initial_state, str):
            reduced_limit = target.limit
            reduced_fit = _fit_reduced(result, problem, target.limit, options, scale_option)
    if reduced_fit is None or reduced_limit is None:
        return
    result.extra["reduced"] = {
        "model": reduced_fit.model_name, "params": reduced_fit.params,
        "scale": reduced_fit.scale, "offset": reduced_fit.offset,
        "units": reduced_fit.param_units(), "rmse": reduced_fit.rmse, "r2": reduced_fit.r2,
        "converged": reduced_fit.converged, "status": reduced_fit.status,
        "reason": reduced_fit.reason,
    }
    result.warnings.append(
        f"reduced model {reduced_fit.model_name} ({reduced_limit.description.split(':')[0]}) "
        f"fitted: R^2 = {reduced_fit.r2:.6g}, RMSE = {reduced_fit.rmse:.4g} "
        f"{result.units.position}"
    )


def _fit_reduced(
    result: FitResult, problem: Problem, limit: Any, options: dict[str, Any],
    scale_option: float | str,
) -> FitResult | None:
    """Fit the limiting model, started from the full model's parameters mapped onto it."""
    start, gain = limit.to_reduced(result.params)
    reduced_cls = limit.reduced
    reduced_scale: float | str = scale_option
    if not math.isclose(gain, 1.0) and not reduced_cls.scale_symmetric:
        reduced_scale = "free"
    x0 = {**start, "C": gain * result.scale} if reduced_scale == "free" else None
    try:
        return fit(
            reduced_cls(**start), problem.grid.t, problem.load, problem.data,
            observe=limit.observe, initial_state=problem.initial_state, scale=reduced_scale,
            x0=x0, **options,
        )
    except ValueError:
        return None


def assemble_result(
    problem: Problem, raw: Mapping[str, Any], method: str, units: Units, warnings: list[str]
) -> FitResult:
    """Turn a solver's raw output into a :class:`FitResult` with fit statistics."""
    cls = problem.model_cls
    theta = raw.get("theta")
    model: Model | None = None
    converged = bool(raw["ok"])
    reason = str(raw["reason"])
    scale = float(raw.get("scale", math.nan))
    offset = float(raw.get("offset", math.nan))
    jac = None
    if theta is not None and np.all(np.isfinite(theta)) and np.all(np.asarray(theta) > 0):
        try:
            model = cls.from_values(theta)
        except ValueError as exc:
            converged = False
            reason = f"{reason}; final parameters invalid: {exc}"
    if model is not None:
        if raw.get("simulated") is not None:
            y, dy = raw["simulated"]  # the solver's own run at this point
        else:
            with np.errstate(all="ignore"):
                y, dy = problem.output_and_sensitivities(model.values)
        fitted = scale * y + offset
        jac = _physical_jacobian(problem, y, dy, scale)
    else:
        converged = False
        fitted = np.full_like(problem.data, np.nan)
    if not np.all(np.isfinite(fitted)):
        converged = False
        reason = f"{reason}; the fitted response is not finite"
    res = fitted - problem.data
    finite = bool(np.all(np.isfinite(res)))
    rmse = float(np.sqrt(np.mean(res**2))) if finite else math.nan
    sst = float(np.sum((problem.data - problem.data.mean()) ** 2))
    r2 = 1.0 - float(np.sum(res**2)) / sst if finite and sst > 0 else math.nan
    if model is not None:
        rr = problem.residual_vector(y, scale, offset)
        cost = 0.5 * float(rr @ rr)
    else:
        cost = math.nan
    params = model.as_dict() if model is not None else dict.fromkeys(cls.param_names(), math.nan)
    return FitResult(
        model=model,
        params=params,
        scale=scale if model is not None else math.nan,
        offset=offset if model is not None else math.nan,
        converged=converged,
        reason=reason,
        iterations=int(raw.get("iterations", 0)),
        nfev=int(raw.get("nfev", 0)),
        history=list(raw.get("history", [])),
        rmse=rmse,
        r2=r2,
        warnings=warnings,
        method=method,
        integrator=problem.integrator,
        residual=problem.residual,
        observe=problem.observe,
        initial_state=initial_state_label(problem.initial_state),
        units=units,
        free=problem.free_names,
        cost=cost,
        t=problem.grid.t,
        load=problem.load,
        data=problem.data,
        fitted=fitted,
        jacobian=jac,
        extra={"model_name": cls.__name__, "gauge": "C = 1" if problem.gauge_fixed else None},
    )


def _physical_jacobian(
    problem: Problem, y: NDArray[np.float64], dy: NDArray[np.float64], scale: float
) -> NDArray[np.float64]:
    """Exact d(residual)/d(free values) in physical coordinates (theta, C or D, offset)."""
    log_res = problem.residual == "log"
    cols = [dy / y[:, None] if log_res else scale * dy]
    if problem.scale_fixed is None:
        cols.append((np.ones_like(y) if log_res else y)[:, None])
    if problem.offset_fixed is None:
        cols.append(np.ones((y.size, 1)))
    return np.hstack(cols)
