"""Automatic initial estimates: no guess needed.

The physical models are linear ODEs, so their transfer-function coefficients follow from a
*linear* least-squares problem (equation error), as in continuous-time system identification:

* records that start from a state (rest, equilibrium, a given one) are passed through a
  state-variable filter lambda^n / (s + lambda)^n, which yields smooth derivatives of the
  displacement and the load without differentiating noisy data; unknown initial conditions
  and a position offset enter as a few extra regressors (t^j exp(-lambda t) and a filtered
  constant), so the estimate does not depend on knowing them;
* periodic strokes are fitted over their harmonics, where s = i k omega is exact.

Each model maps its coefficients back to physical parameters in closed form
(MODEL-NOTES section 1). Several filter bandwidths give several candidates; the best ones
are polished by a short Levenberg-Marquardt run and the best of those is the start.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .models import FirstOrder, Kelvin, MassSpringDamper, Maxwell, Model
from .problem import Problem
from .simulate import _discretize, _scan

__all__ = ["candidate_starts", "initial_estimate"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class _Regression:
    """Equation-error form of a model: target = sum coef_j * regressor_j.

    ``y_orders`` / ``f_orders`` are the derivative orders of the displacement and the load used
    as regressors; ``target`` names the left-hand side (("f", 0) or ("y", 1)).
    """

    target: tuple[str, int]
    y_orders: tuple[int, ...]
    f_orders: tuple[int, ...]
    to_theta: Callable[[Array], Array | None]
    order: int


def _positive(*vals: float) -> bool:
    return all(math.isfinite(v) and v > 0 for v in vals)


def _kelvin_u2(c: Array) -> Array | None:
    # F = a3 y''' + a2 y'' + a1 y' + a0 y with a3 = m c1/k0, a2 = m (k0+k1)/k0, a1 = c1, a0 = k1
    a3, a2, a1, a0 = c
    c1, k1 = a1, a0
    if not _positive(a3, c1, k1):
        return None
    m = a2 - k1 * a3 / c1
    k0 = m * c1 / a3
    return np.array([k0, m, c1, k1]) if _positive(k0, m) else None


def _kelvin_u(c: Array) -> Array | None:
    # F = e3 y''' + e2 y'' + e1 y' + e0 y - g1 F'
    # e2 = m, g1 = c1/(k0+k1), e1 = g1 k0, e0 = k0 k1/(k0+k1)
    _e3, e2, e1, e0, neg_g1 = c
    g1, m = -neg_g1, e2
    if not _positive(g1, m, e1, e0):
        return None
    k0 = e1 / g1
    if k0 <= e0:
        return None
    k1 = e0 * k0 / (k0 - e0)
    c1 = g1 * (k0 + k1)
    return np.array([k0, m, c1, k1]) if _positive(k0, m, c1, k1) else None


def _maxwell_u(c: Array) -> Array | None:
    # F = e3 y''' + e2 y'' + e1 y' + e0 y - tau F', tau = c1/k1, e2 = m, e1 = (k0+k1) tau, e0 = k0
    _e3, e2, e1, e0, neg_tau = c
    tau, m, k0 = -neg_tau, e2, e0
    if not _positive(tau, m, k0):
        return None
    k1 = e1 / tau - k0
    c1 = tau * k1
    return np.array([k0, m, c1, k1]) if _positive(k1, c1) else None


def _msd(c: Array) -> Array | None:
    m, cc, k = c
    return np.array([m, cc, k]) if _positive(m, cc, k) else None


def _first_order(c: Array) -> Array | None:
    # y' = gain * f - y / tau (gain = C when the scale is free, else fixed to 1)
    neg_inv_tau = c[-1]
    return np.array([-1.0 / neg_inv_tau]) if _positive(-neg_inv_tau) else None


_FORMS: dict[tuple[type[Model], str], _Regression] = {
    (Kelvin, "u2"): _Regression(("f", 0), (3, 2, 1, 0), (), _kelvin_u2, 3),
    (Kelvin, "u"): _Regression(("f", 0), (3, 2, 1, 0), (1,), _kelvin_u, 3),
    (Maxwell, "u"): _Regression(("f", 0), (3, 2, 1, 0), (1,), _maxwell_u, 3),
    (MassSpringDamper, "u"): _Regression(("f", 0), (2, 1, 0), (), _msd, 2),
    (FirstOrder, "u"): _Regression(("y", 1), (0,), (0,), _first_order, 1),
}


def _svf(signal: Array, grid_t: Array, lam: float, order: int, problem: Problem) -> Array:
    """Filtered derivatives s^k lambda^n/(s+lambda)^n x, k = 0..n, from rest (exact FOH)."""
    n = order
    # Companion form of 1/(s+lambda)^n: w^(n) = -sum binom(n,j) lambda^(n-j) w^(j) + x.
    a = np.zeros((n, n))
    a[:-1, 1:] = np.eye(n - 1)
    coeffs = np.array([math.comb(n, j) * lam ** (n - j) for j in range(n)])
    a[-1, :] = -coeffs
    b = np.zeros(n)
    b[-1] = 1.0
    if problem.grid.uniform:
        phi, g0, g1 = _discretize(a, b, problem.grid.dt, "exact")
        z = np.zeros((signal.size, n))
        z[1:] = g0 * signal[:-1, None] + g1 * signal[1:, None]
        w = _scan(phi, z, varying=False)
    else:
        phi, g0, g1 = _discretize(a[None], b[None], problem.grid.steps, "exact")
        phi = np.concatenate([np.eye(n)[None], phi])
        z = np.zeros((signal.size, n))
        z[1:] = g0 * signal[:-1, None] + g1 * signal[1:, None]
        w = _scan(phi, z, varying=True)
    top = signal - w @ coeffs
    out = np.column_stack([w, top]) * lam**n
    return out  # column k = s^k L(s) x


def _time_rows(problem: Problem, form: _Regression, lam: float, y: Array) -> tuple[Array, Array]:
    t = problem.grid.t - problem.grid.t[0]
    n = form.order
    yf = _svf(y, t, lam, n, problem)
    ff = _svf(problem.load, t, lam, n, problem)
    onesf = _svf(np.ones_like(y), t, lam, n, problem)[:, 0]
    cols = [yf[:, k] for k in form.y_orders] + [ff[:, k] for k in form.f_orders]
    # Unknown initial conditions (and filter start-up) appear as t^j exp(-lambda t) terms.
    decay = np.exp(-lam * t)
    extra = [decay * (lam * t) ** j for j in range(n)] + [onesf]
    target = ff[:, form.target[1]] if form.target[0] == "f" else yf[:, form.target[1]]
    return np.column_stack(cols + extra), target


def _harmonic_rows(
    problem: Problem, form: _Regression, lam: float, y: Array
) -> tuple[Array, Array] | None:
    grid = problem.grid
    if not grid.uniform:
        return None
    n_samples = grid.n
    period = problem.period if problem.period is not None else n_samples * grid.dt
    if not math.isclose(period, n_samples * grid.dt, rel_tol=1e-6):
        return None
    yk = np.fft.rfft(y) / n_samples
    fk = np.fft.rfft(problem.load) / n_samples
    first = 0 if problem.offset_fixed is not None else 1
    kmax = min(yk.size - 1, 40)
    k = np.arange(first, kmax + 1)
    s = 2j * math.pi * k / period
    weight = (lam / (s + lam)) ** form.order
    cols = [weight * s**j * yk[k] for j in form.y_orders]
    cols += [weight * s**j * fk[k] for j in form.f_orders]
    tgt = (fk[k] if form.target[0] == "f" else yk[k]) * s ** form.target[1] * weight
    mat = np.column_stack(cols)
    return np.vstack([mat.real, mat.imag]), np.concatenate([tgt.real, tgt.imag])


def _solve(mat: Array, target: Array) -> Array | None:
    norms = np.linalg.norm(mat, axis=0)
    keep = norms > 0
    if not keep.any():
        return None
    coef = np.zeros(mat.shape[1])
    sol, *_ = np.linalg.lstsq(mat[:, keep] / norms[keep], target, rcond=None)
    coef[keep] = sol / norms[keep]
    return coef if np.all(np.isfinite(coef)) else None


def _heuristic(problem: Problem, y: Array) -> Array:
    """A rough physical guess from the record's amplitude ratio and length."""
    gain = float(np.ptp(y)) / max(float(np.ptp(problem.load)), 1e-300)
    gain = gain if gain > 0 else 1.0
    span = problem.grid.t[-1] - problem.grid.t[0]
    omega = 2 * math.pi * 3 / span
    k = 1.0 / gain
    cls = problem.model_cls
    if cls not in (FirstOrder, MassSpringDamper, Kelvin, Maxwell):
        return problem.reference_scales()
    if cls is FirstOrder:
        return np.array([span / 5])
    if cls is MassSpringDamper:
        return np.array([k / omega**2, k / omega, k])
    return np.array([2 * k, 2 * k / omega**2, 2 * k / omega, 2 * k])


def _shape_grid(problem: Problem) -> Array:
    """Dimensionless parameter shapes (unit stiffness level) spanning plausible dynamics.

    The frequencies are relative to the record's fundamental (the stroke for a periodic
    card); the overall stiffness level is left to :func:`_grid_candidates`, which solves it
    linearly thanks to the scale symmetry.
    """
    span = problem.grid.t[-1] - problem.grid.t[0]
    if problem.initial_state == "periodic" and problem.grid.uniform:
        span = problem.period or span + problem.grid.dt
    w0 = 2 * math.pi / span
    cls = problem.model_cls
    ratios = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)  # natural frequency / fundamental
    rows: list[list[float]] = []
    if cls is FirstOrder:
        return np.array([[span * f] for f in (0.01, 0.03, 0.1, 0.3, 1.0, 3.0)])
    if cls is MassSpringDamper:
        for r in ratios:
            for zeta in (0.05, 0.2, 0.7, 2.0):
                wn = r * w0
                rows.append([1.0 / wn**2, 2 * zeta / wn, 1.0])
        return np.array(rows)
    if cls not in (Kelvin, Maxwell):
        # A model this module has no shapes for: natural scales times 0.1, 1, 10 per parameter.
        import itertools

        ref = problem.reference_scales()
        factors = (0.1, 1.0, 10.0) if ref.size <= 4 else (0.3, 3.0)
        return np.array([ref * np.array(c) for c in itertools.product(factors,
                                                                       repeat=ref.size)])
    for r in ratios:
        for k0_over_k1 in (0.3, 1.0, 3.0, 30.0):
            for tau_w0 in (0.1, 1.0, 10.0):  # dashpot time constant c1/k1 times w0
                k1, k0 = 1.0, k0_over_k1
                k_static = k0 * k1 / (k0 + k1) if cls is Kelvin else k0 + k1
                m = k_static / (r * w0) ** 2
                rows.append([k0, m, k1 * tau_w0 / w0, k1])
    return np.array(rows)


def _grid_candidates(problem: Problem, keep: int = 6) -> list[Array]:
    """Best grid shapes, each scaled to the data's amplitude (one batched simulation)."""
    shapes = _shape_grid(problem)
    with np.errstate(all="ignore"):
        ys = problem.outputs(shapes)
    scale_fixed = problem.scale_fixed if problem.scale_fixed is not None else None
    data = problem.data
    scored: list[tuple[float, Array]] = []
    for theta, y in zip(shapes, ys, strict=True):
        if not np.all(np.isfinite(y)) or np.ptp(y) == 0:
            continue
        symmetric = problem.model_cls.scale_symmetric
        cols = [y] + ([np.ones_like(y)] if problem.offset_fixed is None else [])
        rhs = data - (problem.offset_fixed or 0.0)
        coef, *_ = np.linalg.lstsq(np.column_stack(cols), rhs, rcond=None)
        a = float(coef[0])
        if not (a > 0 and math.isfinite(a)):
            continue
        fitted = np.column_stack(cols) @ coef
        cost = float(np.sum((fitted - rhs) ** 2))
        if symmetric and scale_fixed is not None:
            # y(lambda theta) = y(theta) / lambda, so the fitted amplitude a * C_fixed sets lambda.
            theta = theta * (scale_fixed / a)
        scored.append((cost, theta))
    scored.sort(key=lambda item: item[0])
    return [theta for _cost, theta in scored[:keep]]


def candidate_starts(problem: Problem, grid: bool = True) -> list[Array]:
    """Physical parameter candidates from equation error at several filter bandwidths.

    With ``grid`` (default) the physics-shaped grid and a heuristic guess are added; without
    it only the (cheap: linear least squares) equation-error candidates are returned.
    """
    key = (problem.model_cls, problem.observe)
    form = _FORMS.get(key)
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    y = problem.data / scale
    if problem.residual == "log" or form is None:
        if not grid:
            return []
        shapes = _grid_candidates(problem) if problem.residual != "log" else []
        return [*shapes, _heuristic(problem, y)]
    span = problem.grid.t[-1] - problem.grid.t[0]
    dt_min = float(np.min(problem.grid.steps))
    base = 2 * math.pi / span
    lams = [base * f for f in (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0)]
    lams = [lam for lam in lams if lam * dt_min < 0.5] or [0.5 / dt_min]
    periodic = problem.initial_state == "periodic"
    found: list[Array] = []
    for lam in lams:
        rows = _harmonic_rows(problem, form, lam, y) if periodic else _time_rows(
            problem, form, lam, y
        )
        if rows is None:
            rows = _time_rows(problem, form, lam, y)
        coef = _solve(*rows)
        if coef is None:
            continue
        n_model = len(form.y_orders) + len(form.f_orders)
        theta = form.to_theta(coef[:n_model])
        if theta is not None and np.all(np.isfinite(theta)):
            found.append(theta)
    if not grid:
        return found
    if problem.residual != "log":
        found.extend(_grid_candidates(problem))
    found.append(_heuristic(problem, y))
    return found



@dataclass
class _Point:
    """A polished start: parameters, scale, offset, cost and whether the polish ran out."""

    theta: Array
    scale: float
    offset: float
    cost: float
    stopped_early: bool = False


def _cost_at(problem: Problem, theta: Array, scale: float, offset: float) -> float:
    with np.errstate(all="ignore"):
        r = problem.residual_vector(problem.outputs(theta), scale, offset)
    cost = 0.5 * float(r @ r)
    return cost if math.isfinite(cost) else math.inf


def _polish(
    problem: Problem, theta: Array, max_nfev: int, scale: float | None = None,
    offset: float | None = None,
) -> _Point | None:
    """A short run of the default solver from ``theta`` (best linear C and offset if not given)."""
    from .fit import _initial_linear, _solve_lm  # the polish reuses the default solver

    try:
        if scale is None or offset is None:
            scale, offset = _initial_linear(problem, theta, {})
        raw = _solve_lm(problem, theta, scale, offset, tol=1e-10, max_nfev=max_nfev)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if "theta" not in raw:
        return None
    cost = _cost_at(problem, raw["theta"], raw["scale"], raw["offset"])
    if not math.isfinite(cost):
        return None
    return _Point(raw["theta"], raw["scale"], raw["offset"], cost,
                  bool(raw.get("stopped_early")))


def _weakest_direction(problem: Problem, pt: _Point) -> tuple[Array, float] | None:
    """Weakest direction of the residual in solver coordinates and its relative size.

    Coordinates: ln of the free parameters, ln C when C is free, offset / data range.
    """
    with np.errstate(all="ignore"):
        y, dy = problem.output_and_sensitivities(pt.theta)
    th = pt.theta[problem.free_idx]
    if problem.residual == "log":
        cols = [dy * th / y[:, None]]
    else:
        cols = [pt.scale * dy * th]
    if problem.scale_fixed is None:
        cols.append((np.ones_like(y) if problem.residual == "log" else pt.scale * y)[:, None])
    if problem.offset_fixed is None:
        cols.append(np.full((y.size, 1), float(np.ptp(problem.data)) or 1.0))
    jm = np.hstack(cols)
    if not np.all(np.isfinite(jm)):
        return None
    _u, s, vt = np.linalg.svd(jm, full_matrices=False)
    if s[0] <= 0:
        return None
    return vt[-1], float(s[-1] / s[0])


def _move(problem: Problem, pt: _Point, step: Array) -> tuple[Array, float, float]:
    p = problem.n_free
    theta = pt.theta.copy()
    ref = np.log(problem.reference_scales()[problem.free_idx])
    z = np.log(theta[problem.free_idx]) + step[:p]
    theta[problem.free_idx] = np.exp(np.clip(z, ref - _WINDOW, ref + _WINDOW))
    scale, offset, i = pt.scale, pt.offset, p
    if problem.scale_fixed is None:
        scale = pt.scale * math.exp(step[i])
        i += 1
    if problem.offset_fixed is None:
        offset = pt.offset + float(step[i]) * (float(np.ptp(problem.data)) or 1.0)
    return theta, scale, offset


#: First step (log units) along a valley, and the growth factor of the following ones.
_VALLEY_STEP = 0.25
_VALLEY_GROWTH = 2.5
#: A jump must lower the cost by this fraction to count. On noisy data the valley floor is
#: flat at the noise level, so the walk stops at once (the data cannot choose a point along
#: it, and the diagnostics report it as practically not identifiable); on noiseless data the
#: floor falls by orders of magnitude toward the truth.
_VALLEY_GAIN = 0.05
#: The walk stays inside the solver's window: natural scale times/divided by 1e6.
_WINDOW = math.log(1e6)


def _valley_walk(problem: Problem, pt: _Point, rounds: int = 8) -> _Point:
    """Follow a long, flat, curved valley where Levenberg-Marquardt only crawls.

    When the data hardly constrain one combination of parameters (relative singular value
    of the scaled Jacobian well below 1e-4), a trust-region step along the valley is cut
    short by the valley's curvature and the solver advances by tiny steps. Jumping along the
    weakest direction and letting a short polish drop back to the valley floor moves along
    it in a few long strides; the floor's cost tells which way is down. Each round probes
    both ways with a small jump, then keeps growing the jump while the floor keeps falling.
    """

    def jump(base: _Point, direction: Array, step: float) -> _Point | None:
        theta, scale, offset = _move(problem, base, step * direction)
        if not (np.all(np.isfinite(theta)) and np.all(theta > 0) and scale > 0):
            return None
        return _polish(problem, theta, 40, scale, offset)

    for _ in range(rounds):
        weak = _weakest_direction(problem, pt)
        if weak is None or weak[1] > 1e-4:
            return pt
        direction = weak[0]
        step = _VALLEY_STEP * _VALLEY_GROWTH
        probes: list[tuple[float, _Point]] = []
        for _shrink in range(3):  # near the bottom of the valley a shorter jump is needed
            step /= _VALLEY_GROWTH
            found = [(sign, jump(pt, direction, sign * step)) for sign in (1.0, -1.0)]
            probes = [(sign, q) for sign, q in found
                      if q is not None and q.cost < (1.0 - _VALLEY_GAIN) * pt.cost]
            if probes:
                break
        if not probes:
            return pt
        sign, best = min(probes, key=lambda item: item[1].cost)
        for _grow in range(4):
            step *= _VALLEY_GROWTH
            trial = jump(pt, direction, sign * step)
            if trial is None or trial.cost >= best.cost:
                break
            best = trial
        pt = best
    return pt


def initial_estimate(
    problem: Problem, polish: int = 3, guess: Array | None = None
) -> tuple[Array, str]:
    """Best automatic start for a problem: candidates, ranked by cost, a small multistart.

    The candidates (equation error at several filter bandwidths, the physics grid, a
    heuristic) are ranked by their cost with the best linear C and offset; the best
    ``polish`` of them, plus the best of each kind not among them, are polished by a short
    Levenberg-Marquardt run (a multistart against local minima), and the best polished point
    is walked along a flat valley when the polish ran out of evaluations there.

    Parameters
    ----------
    problem : Problem
        The identification problem.
    polish : int
        How many of the best-ranked candidates are polished.
    guess : ndarray, optional
        A user's starting parameters (canonical order). It joins the multistart: it is
        polished too and wins when it leads to the lowest cost, so a good guess is kept and a
        poor one (a different basin) cannot trap the fit.

    Returns
    -------
    theta : ndarray
        Starting parameters (canonical order).
    note : str
        A sentence for the result saying how the start was found.
    """
    from .fit import _initial_linear

    cands = candidate_starts(problem)
    if problem.fixed:
        # Candidates ignore held parameters; put the held values in before ranking.
        cands = [problem.full_theta(np.asarray(c, dtype=float)[problem.free_idx])
                 for c in cands]
    scored: list[tuple[float, Array]] = []
    for theta in cands:
        try:
            scale, offset = _initial_linear(problem, theta, {})
        except (ValueError, np.linalg.LinAlgError):
            continue
        cost = _cost_at(problem, theta, scale, offset)
        if math.isfinite(cost):
            scored.append((cost, theta))
    if not scored:
        return _heuristic(problem, problem.data), "automatic start: heuristic (no candidate)"
    scored.sort(key=lambda item: item[0])
    points = [pt for _c, theta in scored[:polish]
              if (pt := _polish(problem, theta, 60)) is not None]
    from_guess = None
    if guess is not None:
        from_guess = _polish(problem, np.asarray(guess, dtype=float), 60)
        if from_guess is not None:
            points.append(from_guess)
    if not points:
        if guess is not None:
            return np.asarray(guess, dtype=float), "start: the given guess (nothing better found)"
        return scored[0][1], "automatic start: best unpolished candidate"
    best = min(points, key=lambda pt: pt.cost)
    walked = ""
    if best.stopped_early:
        before = best.cost
        best = _valley_walk(problem, best)
        if best.cost < before:
            walked = ", then walked along a flat valley"
    kind = "automatic start"
    if guess is not None:
        kind = ("start: the given guess, checked against the automatic start"
                if best is from_guess or (from_guess is not None and from_guess.cost <= best.cost)
                else "start: automatic (it reached a lower cost than the given guess)")
    return best.theta, (
        f"{kind}: equation-error and grid estimates ({len(cands)} candidates), "
        f"best {len(points)} polished{walked}"
    )
