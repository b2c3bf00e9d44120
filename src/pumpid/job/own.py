"""The main job for a model that brings its own simulator (:class:`~pumpid.models.OwnModel`).

The same solver (the compiled Levenberg-Marquardt state machine, stepped from Python around
the model's simulator, :func:`pumpid.engine.solvers.run_python`), the same statuses and
gates, the same diagnostics (:func:`pumpid.job.diagnose.assess`: errors that hold under
correlated residuals, identifiability in words) and the same :class:`~pumpid.result.FitResult`
as the lumped models. What differs is only where residuals and sensitivities come from.

Coordinates: a positive parameter is searched on the log scale within a factor
:data:`WINDOW_FACTOR` of its start (and its declared bounds), a signed one on its own scale
within its declared bounds. A positive parameter is at a boundary when pushing it a further
factor 1000 either way leaves the cost within the likelihood-ratio test's 95 % point (the
data cannot tell it from its limit; where only one way is, a factor 10 the other way too,
for a value pushed past what the simulation resolves), or when it ends on the edge of its
window; a signed one when it ends on a declared bound. Flat both ways, its limit is the way
the fit went when it went more than a factor 10 from its start, else the way the cost falls
(for every own model: joint fits, pump identification, a user's). As for the lumped models,
a parameter at such a limit is then held back from it as far as the noise allows, and every
other value's error reaches its value there (:func:`_reach_floors`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..engine import lm
from ..engine.solvers import LevenbergMarquardt, PaperNewton, SolverOutcome, Stop, run_python
from ..inference.identifiability import findings_of
from ..inference.serial import robust_of
from ..inference.uncertainty import Numbers, analyse_rows
from ..models.own import OwnModel
from ..result import (
    BoundaryInfo,
    FitBatch,
    FitResult,
    Limiting,
    StartInfo,
    Status,
    Units,
    squared,
)
from .assemble import determination_gate, quality_gate
from .boundary import LR_95
from .diagnose import assess, interior_sentence, reach_limits
from .options import FitOptions

__all__ = ["WINDOW_FACTOR", "fit_own"]

Array = NDArray[np.float64]
#: A positive parameter is searched within this factor of its start either way.
WINDOW_FACTOR = 1e6
#: The push test's factor.
PUSH = 1000.0
#: Halvings of the way from a boundary fit's limit toward its window's far end, and each
#: solve's evaluations along it (as the lumped models' reach, :mod:`pumpid.job.diagnose`).
REACH_STEPS = 7
REACH_EVALUATIONS = 100
#: Options that mean something only for the lumped models, with their neutral values.
_LUMPED_ONLY = {"observe": None, "integrator": "exact", "residual": "linear", "scale": 1.0,
                "offset": False, "initial_state": None, "period": None}


def fit_own(model: OwnModel, items: Sequence[Any], *, single: bool, options: FitOptions,
            solver: LevenbergMarquardt | PaperNewton | None, x0: Any,
            workers: int | None = None) -> FitResult | FitBatch:
    """Fit an own model to each data item (see the module's text).

    Parameters
    ----------
    model : OwnModel
    items : sequence
        The data items, each passed to the model's methods as given.
    single : bool
        Return the one item's :class:`FitResult` (its problems raise) rather than a
        :class:`FitBatch` (an item the model refuses is an ``invalid-input`` row).
    options : FitOptions
        ``fixed``, ``multistart``, ``min_r2`` and ``boundaries`` apply; the lumped models'
        options (observe, integrator, residual, scale, offset, initial state, period) must
        keep their defaults: an own model states those itself.
    solver : LevenbergMarquardt, optional
    x0 : mapping or array, optional
        Starting values (a mapping by name, or (p,) in the parameters' order).
    workers : int, optional
        Accepted for the verb's sake; an own model's simulator runs in Python, one item after
        another.
    """
    _check_options(model, options, solver)
    lm_solver = solver if isinstance(solver, LevenbergMarquardt) else LevenbergMarquardt()
    results: list[FitResult | None] = []
    invalid: list[str] = []
    for item in items:
        try:
            results.append(_fit_item(model, item, options, lm_solver, x0))
            invalid.append("")
        except (ValueError, TypeError) as exc:
            if single:
                raise
            results.append(None)
            invalid.append(str(exc))
    if single:
        res = results[0]
        assert res is not None
        return res
    return FitBatch(model_name=model.name, param_names=model.param_names(),
                    results=tuple(results), invalid=tuple(invalid))


def _check_options(model: OwnModel, options: FitOptions, solver: Any) -> None:
    if not isinstance(model.parameters, tuple | list) or not model.parameters:
        raise TypeError(f"{type(model).__name__}.parameters must be a non-empty tuple of "
                        "pumpid.models.Parameter")
    for key, neutral in _LUMPED_ONLY.items():
        if getattr(options, key) != neutral:
            raise ValueError(f"FitOptions.{key} does not apply to an own model ({model.name} "
                             "defines its own output, initial state and offsets); leave it "
                             f"at {neutral!r}")
    unknown = sorted(set(options.fixed) - set(model.param_names()))
    if unknown:
        raise ValueError(f"FitOptions.fixed: unknown parameter(s) {unknown}; {model.name} has "
                         f"{list(model.param_names())}")
    for info in model.param_info():
        if info.name in options.fixed:
            value = float(options.fixed[info.name])
            # As the lumped models refuse them: a value held outside its declared bounds
            # was fitted and reported (tau = 50 beside an upper bound of 5, converged).
            if not (math.isfinite(value) and info.lower <= value <= info.upper
                    and (value > 0 or not info.positive)):
                upper = "" if math.isinf(info.upper) else f" and at most {info.upper:g}"
                lower = (f"above {info.lower:g}" if info.positive and info.lower == 0
                         else f"at least {info.lower:g}")
                raise ValueError(f"FitOptions.fixed: {info.name} = {value:g} is outside its "
                                 f"bounds: {model.name} declares it {lower}{upper}")
    if isinstance(solver, PaperNewton):
        raise TypeError("the paper's Newton method fits the lumped models only; an own model "
                        "is fitted with LevenbergMarquardt")


class _Item:
    """One item's problem: the coordinates, the residual rows and the cost."""

    def __init__(self, model: OwnModel, item: Any, options: FitOptions) -> None:
        self.model = model
        self.item = item
        self.names = model.param_names()
        self.y = model.observed(item)
        if self.y.ndim != 1 or self.y.size < 3 or not np.all(np.isfinite(self.y)):
            raise ValueError(f"{model.name}: the observation must be a finite 1-D series of "
                             f"at least 3 samples (got shape {self.y.shape}, "
                             f"{int(np.sum(~np.isfinite(self.y)))} non-finite)")
        p = len(self.names)
        self.fixed = {self.names.index(n): v for n, v in options.fixed.items()}
        free = [i for i in range(p) if i not in self.fixed]
        # Positive (log) coordinates first: the solver caps the steps of the first ones.
        self.free = ([i for i in free if model.parameters[i].positive]
                     + [i for i in free if not model.parameters[i].positive])
        self.n_log = sum(model.parameters[i].positive for i in self.free)
        self.q = len(self.free)
        self.base = np.zeros(p)
        # The last sensitivities, by their coordinates: the answer's analysis asks again
        # for those of the solver's last accepted point, five perturbed simulations for a
        # model that differentiates by finite differences.
        self._rows_at: tuple[bytes, Array | None] | None = None

    def theta(self, z: Array) -> Array:
        th = self.base.copy()
        for i, v in self.fixed.items():
            th[i] = v
        zz = np.asarray(z, dtype=float)
        th[self.free[: self.n_log]] = np.exp(np.clip(zz[: self.n_log], -700.0, 700.0))
        th[self.free[self.n_log:]] = zz[self.n_log:]
        return th

    def chain(self, theta: Array) -> Array:
        """d value / d coordinate of each free parameter: the value on the log scale, 1 on
        its own scale (the analysis' scales, and the Jacobian's chain rule)."""
        return np.concatenate([theta[self.free[: self.n_log]], np.ones(self.q - self.n_log)])

    def to_z(self, theta: Array) -> Array:
        v = np.asarray(theta, dtype=float)[self.free]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.concatenate([np.log(v[: self.n_log]), v[self.n_log:]])

    def simulate(self, z: Array, sens: bool) -> tuple[Array, Array | None] | None:
        th = self.theta(z)
        try:
            with np.errstate(all="ignore"):
                pred, dy = self.model.simulate(th, self.item, sens)
        except (ValueError, ArithmeticError):
            return None
        pred = np.asarray(pred, dtype=float)
        if pred.shape != self.y.shape:
            raise ValueError(f"{self.model.name}.simulate returned shape {pred.shape} for an "
                             f"observation of {self.y.size} samples")
        if sens:
            if dy is None:
                raise ValueError(f"{self.model.name}.simulate returned no sensitivities when "
                                 f"asked for them (sensitivities=True): return the "
                                 f"{(self.y.size, len(self.names))} derivatives of the "
                                 "output by the parameters (finite differences will do)")
            dy = np.asarray(dy, dtype=float)
            if dy.shape != (self.y.size, len(self.names)):
                raise ValueError(f"{self.model.name}.simulate returned sensitivities of shape "
                                 f"{dy.shape}, expected {(self.y.size, len(self.names))}")
        return pred, dy

    def cost(self, z: Array) -> float:
        got = self.simulate(z, False)
        if got is None:
            return math.nan
        r = got[0] - self.y
        return 0.5 * float(r @ r) if np.all(np.isfinite(r)) else math.nan

    def rows(self, z: Array) -> Array | None:
        """``[J r]`` at ``z`` with the Jacobian's columns as rows (a new array each call)."""
        key = np.asarray(z, dtype=float).tobytes()
        if self._rows_at is None or self._rows_at[0] != key:
            self._rows_at = (key, self._compute_rows(z))
        kept = self._rows_at[1]
        return None if kept is None else kept.copy()

    def _compute_rows(self, z: Array) -> Array | None:
        got = self.simulate(z, True)
        if got is None:
            return None
        pred, dy = got
        assert dy is not None
        th = self.theta(z)
        rows = np.empty((self.q + 1, self.y.size))
        rows[: self.q] = (dy[:, self.free] * self.chain(th)).T
        rows[self.q] = pred - self.y
        return rows if np.all(np.isfinite(rows)) else None

    def evaluate(self, z: Array) -> tuple[float, Array, Array]:
        r_fac = np.zeros((self.q, self.q))
        c = np.zeros(self.q)
        rows = self.rows(z)
        if rows is None:
            return math.nan, r_fac, c
        return lm.householder(rows, self.q, r_fac, c), r_fac, c

    def window(self, z0: Array) -> tuple[Array, Array]:
        lo = np.empty(self.q)
        hi = np.empty(self.q)
        span = math.log(WINDOW_FACTOR)
        for a, i in enumerate(self.free):
            par = self.model.parameters[i]
            if par.positive:
                lo[a] = max(z0[a] - span, math.log(par.lower) if par.lower > 0 else -700.0)
                hi[a] = min(z0[a] + span, math.log(par.upper) if math.isfinite(par.upper)
                            else 700.0)
            else:
                lo[a] = par.lower if math.isfinite(par.lower) else -1e300
                hi[a] = par.upper if math.isfinite(par.upper) else 1e300
        return lo, hi


def _starts(model: OwnModel, item: Any, x0: Any) -> Array:
    names = model.param_names()
    if x0 is None:
        got = np.asarray(model.start(item), dtype=float)
    elif isinstance(x0, Mapping):
        unknown = sorted(set(x0) - set(names))
        if unknown:
            raise ValueError(f"x0: unknown parameter(s) {unknown}; {model.name} has "
                             f"{list(names)}")
        if all(n in x0 for n in names):
            got = np.array([float(x0[n]) for n in names])
        else:
            base = np.asarray(model.start(item), dtype=float)
            base = base[0] if base.ndim == 2 else base
            got = np.array([float(x0.get(n, base[i])) for i, n in enumerate(names)])
    else:
        got = np.asarray(x0, dtype=float)
    got = np.atleast_2d(got)
    if got.shape[1] != len(names) or not np.all(np.isfinite(got)):
        raise ValueError(f"{model.name}: a start must be {len(names)} finite values "
                         f"({list(names)}), got shape {got.shape}")
    return got


def _fit_item(model: OwnModel, item: Any, options: FitOptions, solver: LevenbergMarquardt,
              x0: Any) -> FitResult:
    prob = _Item(model, item, options)
    model.hold(frozenset(options.fixed))
    starts = _starts(model, item, x0)
    prob.base = starts[0].copy()
    bad = [model.parameters[i].name for i in prob.free[: prob.n_log]
           if not np.all(starts[:, i] > 0)]
    if bad:
        raise ValueError(f"{model.name}: the start of positive parameter(s) {bad} must be > 0")
    zs = [prob.to_z(s) for s in starts]
    costs = np.array([prob.cost(z) for z in zs])
    if not np.any(np.isfinite(costs)):
        raise ValueError(f"{model.name} cannot be simulated at any of its {len(zs)} "
                         "starting point(s)")
    order = np.argsort(np.where(np.isfinite(costs), costs, np.inf))
    finite = [int(k) for k in order if np.isfinite(costs[k])]
    # "auto" and False solve from the best start; True from every start, keeping the best.
    tries = finite[:1] if options.multistart is not True else list(finite)
    best: tuple[SolverOutcome, Array, Array, Array] | None = None
    solved = 0
    while solved < len(tries):
        k = tries[solved]
        solved += 1
        z0 = zs[k]
        lo, hi = prob.window(z0)
        out = run_python(prob.evaluate, z0, lo, hi, tol=solver.tol,
                         max_evaluations=solver.budget(prob.q), n_capped=prob.n_log,
                         noise_tol=solver.noise_tol, dof=prob.y.size - prob.q,
                         cost=prob.cost)
        if best is None or (math.isfinite(out.cost[0])
                            and not out.cost[0] >= best[0].cost[0]):
            best = (out, z0, lo, hi)
        if (out.stops[0] is Stop.NOT_FINITE and int(out.evaluations[0]) <= 1
                and len(tries) < len(finite)):
            # The start's cost was finite but its sensitivities were not (a simulator that
            # differentiates by perturbing can fail there): the next start instead.
            tries.append(finite[len(tries)])
    assert best is not None
    out, z0, lo, hi = best
    note = (f"start: {'the given x0' if x0 is not None else model.name + '.start()'}"
            f"{f', best of {len(zs)} by cost' if len(zs) > 1 else ''}"
            f"{f', solved from {solved}' if solved > 1 else ''}")
    return _result(prob, out, z0, lo, hi, options, StartInfo(note, len(zs), solved))


def _limits(prob: _Item, z: Array, z0: Array, cost: float, lo: Array, hi: Array,
            sigma2: float) -> tuple[Limiting, ...]:
    """The parameters at a boundary (see the module's text)."""
    found: list[Limiting] = []
    tol = LR_95 * sigma2 / 2.0 + 1e-12 * max(cost, 1e-300)

    def pushed_by(a: int, step: float) -> float:
        """The cost's change with coordinate a (a log-value) moved by ``step``."""
        zz = z.copy()
        zz[a] += step
        return prob.cost(zz) - cost

    for a, i in enumerate(prob.free):
        par = prob.model.parameters[i]
        value = float(prob.theta(z)[i])
        edge_lo = z[a] <= lo[a] + 1e-9 * (1.0 + abs(lo[a]))
        edge_hi = z[a] >= hi[a] - 1e-9 * (1.0 + abs(hi[a]))
        # A positive parameter stopped on a finite bound it declares is at that bound, as a
        # signed one is: tau held at its upper bound of 5 s was said to run to infinity, its
        # value "arbitrary", while pushing it further lowered the cost 5-fold.
        declared_lo = par.lower > 0 and value <= par.lower * (1.0 + 1e-9)
        declared_hi = math.isfinite(par.upper) and value >= par.upper * (1.0 - 1e-9)
        if not par.positive or (edge_lo and declared_lo) or (edge_hi and declared_hi):
            if edge_lo or edge_hi:
                side = "lower" if edge_lo else "upper"
                found.append(Limiting(par.name, side, value,
                                      f"{par.name} = {getattr(par, side):g} {par.unit}", "bound"))
            continue
        # Pushed a factor PUSH each way; where only one way is flat, a factor 10 the other
        # way too: a value already deep in a limit can be pushed past what the simulation
        # resolves (a stiffness of 3e14 pushed to 3e17 rose by 3e5 in cost, pushed to 3e15
        # fell by 900). The common cases (flat neither way, or both) cost two simulations.
        change: dict[str, float] = {}
        for direction, sign, at_edge in (("zero", -1.0, edge_lo), ("infinity", 1.0, edge_hi)):
            delta = -math.inf if at_edge else pushed_by(a, sign * math.log(PUSH))
            if delta <= tol:
                change[direction] = delta
        far = set(change)
        if len(change) == 1:
            other, sign = (("infinity", 1.0) if "zero" in change else ("zero", -1.0))
            delta = pushed_by(a, sign * math.log(10.0))
            if delta <= tol:
                change[other] = delta
        if change:
            # Flat both ways (a value deep in a limit stays there pushed back a factor 1000:
            # k0 = 3e14 pushed down to 3e11 is still rigid): the limit is the way the fit
            # went from its start when it went far, else the way the cost falls. Deep in a
            # limit the push outward can cost more than the push back, from rounding alone
            # (a joint fit's k0 = 6e12, 20x its start, rose by 17 pushed to 6e15 and by 0.015
            # pushed to 6e9, within the noise both: taken as k0 -> 0).
            if len(change) == 1:
                direction = next(iter(change))
            elif abs(z[a] - z0[a]) > math.log(10.0):
                direction = "infinity" if z[a] > z0[a] else "zero"
            elif change["zero"] != change["infinity"]:
                direction = min(change, key=lambda d: change[d])
            else:
                direction = "infinity" if z[a] >= z0[a] else "zero"
            found.append(Limiting(par.name, direction, value,
                                  f"{par.name} -> {'0' if direction == 'zero' else 'inf'}",
                                  "push" if direction in far else "push10"))
    return tuple(found)


def _reach(prob: _Item, z: Array, lo: Array, hi: Array, limit: Limiting,
           threshold: float, tol: float) -> tuple[Array, Array | None]:
    """How far a boundary fit's parameter comes back from its limit within ``threshold``
    (a cost): held at points from the limit toward its window's far end (bisection,
    :data:`REACH_STEPS` halvings), the others refitted from the last point within it.
    Returns each coordinate's largest move over the points within it, and the farthest
    point (None: none within)."""
    a = [prob.names[i] for i in prob.free].index(limit.name)
    far = lo[a] if limit.direction == "infinity" else hi[a]
    near, away = 0.0, 1.0
    best: Array | None = None
    moved = np.zeros(prob.q)
    for _ in range(REACH_STEPS):
        t = 0.5 * (near + away)
        z_start = (z if best is None else best).copy()
        z_start[a] = z[a] + t * (far - z[a])
        b_lo, b_hi = lo.copy(), hi.copy()
        b_lo[a] = b_hi[a] = z_start[a]
        got = run_python(prob.evaluate, z_start, b_lo, b_hi, tol=tol,
                         max_evaluations=REACH_EVALUATIONS, n_capped=prob.n_log,
                         dof=prob.y.size - prob.q, cost=prob.cost)
        end = got.z[0] if np.all(np.isfinite(got.z[0])) else z_start
        if prob.cost(end) <= threshold:
            best, near = end, t
            moved = np.fmax(moved, np.abs(end - z))
        else:
            away = t
    return moved, best


def _reach_floors(prob: _Item, z: Array, lo: Array, hi: Array, limits: Sequence[Limiting],
                  nums: Numbers, inflation: float, cost: float, tol: float
                  ) -> tuple[dict[int, tuple[float, float]], list[str]]:
    """A boundary fit's errors as far as its limits come back within the noise (the lumped
    models' interior reach, :mod:`pumpid.job.diagnose`): each other value's error is at
    least its largest move over the points within the threshold, over the t quantile,
    plus its local error; for the independent-noise errors on the independent-noise
    threshold, for the robust ones on that threshold's excess times ``inflation`` (at most
    the degrees of freedom). Without it a joint fit's errors were those with the limit
    taken: on two Sandia surface cards c1's independent-noise error was 0.19 lbf*s/in, and
    1.4 with k0 held back to 389 lbf/in, as far as the noise allows.

    Returns the floors by coordinate (independent-noise, robust) and a sentence a limit.
    """
    floors: dict[int, tuple[float, float]] = {}
    words: list[str] = []
    if nums.dof <= 0 or not math.isfinite(cost):
        return floors, words
    tq, white, wide, times = reach_limits(cost, nums.dof, inflation)
    # A signed coordinate is analysed in units of the data's range.
    per = np.where(np.arange(prob.q) >= prob.n_log, float(np.ptp(prob.y)) or 1.0, 1.0)
    inner = list(nums.inner)
    for limit in limits:
        if limit.direction not in ("zero", "infinity"):
            continue
        moved_w, point = _reach(prob, z, lo, hi, limit, white, tol)
        moved_r = moved_w
        if times > 1.0:
            moved_r, point = _reach(prob, z, lo, hi, limit, wide, tol)
        for a, b in enumerate(inner):
            local = math.sqrt(max(float(nums.cov_scaled[a, a]), float(nums.hac_scaled[a, a]),
                                  0.0))
            w = moved_w[b] / per[b] / tq + local
            r = max(moved_w[b], moved_r[b]) / per[b] / tq + local
            old = floors.get(b, (0.0, 0.0))
            floors[b] = (max(old[0], w), max(old[1], r))
        if point is not None:
            i_lim = prob.names.index(limit.name)
            held = f"{prob.theta(point)[i_lim]:.3g} {prob.model.parameters[i_lim].unit}"
            words.append(interior_sentence(limit.name, limit.direction, held, (), times))
    return floors, words


def _result(prob: _Item, out: SolverOutcome, z0: Array, lo: Array, hi: Array,
            options: FitOptions, start: StartInfo) -> FitResult:
    model = prob.model
    z = out.z[0]
    theta = prob.theta(z)
    status = Status.CONVERGED if out.stops[0].converged else Status.FAILED
    reason = out.messages[0]
    y = prob.y
    # Without the analysis (a search's fit) the sensitivities at the answer are not needed:
    # its prediction is the stroke the solver kept.
    rows = prob.rows(z) if model.analyse else None
    got = None if model.analyse else prob.simulate(z, False)
    if rows is not None:
        fitted = rows[prob.q] + y
    elif got is not None:
        fitted = got[0]
    else:
        status = Status.FAILED
        reason += "; the model cannot be simulated at the final values"
        fitted = np.full_like(y, np.nan)
    res = fitted - y
    finite = bool(np.all(np.isfinite(res)))
    sst = float(np.sum((y - y.mean()) ** 2))
    rmse = float(np.sqrt(np.mean(res**2))) if finite else math.nan
    r2 = 1.0 - float(res @ res) / sst if finite and sst > 0 else math.nan
    cost = float(out.cost[0]) if finite else math.nan
    free_names = tuple(prob.names[i] for i in prob.free)
    warnings: list[str] = []
    limits: tuple[Limiting, ...] = ()
    n = y.size
    if options.boundaries and finite and n > prob.q:
        limits = _limits(prob, z, z0, cost, lo, hi, 2.0 * cost / (n - prob.q))
    closed = {p.name for p in model.parameters if p.closed}
    open_limits = [b for b in limits if b.name not in closed]
    if open_limits and status is Status.CONVERGED:
        status = Status.BOUNDARY
        reason = (f"{', '.join(b.name for b in open_limits)} ran to a bound: the solution "
                  f"is a limiting model, not an interior optimum (the solver's stop: "
                  f"{reason})")
        warnings.extend(b.describe() for b in open_limits)
    for b in limits:
        if b.name in closed:
            reason = f"{reason}; {b.name} at its bound {b.value:g} (a state the model allows)"
    uncertainty = None
    findings: tuple[str, ...] = ()
    determined: dict[str, Any] = {}
    derived: Mapping[str, Any] = {}
    names = prob.model.param_names()
    if rows is not None:
        inner = np.array([n not in {b.name for b in limits} for n in free_names])
        # A signed parameter is analysed in units of the data's range, as the lumped models'
        # offset is: its error then reads as a fraction, like the log coordinates' (on its
        # own scale a level's 19 in error read as "1934 %").
        spread = float(np.ptp(y)) or 1.0
        signed = np.arange(prob.q) >= prob.n_log
        scaled = rows.copy()
        scaled[: prob.q][signed] *= spread
        s, vt, cov, hac, dse, stats = analyse_rows(scaled.copy(), inner, -1, 1.0,
                                                   bool(model.periodic))
        scales = prob.chain(theta) * np.where(signed, spread, 1.0)
        nums = Numbers(names=free_names, inner=tuple(int(i) for i in np.flatnonzero(inner)),
                       values=theta[prob.free], scales=scales, singular=s, vt=vt,
                       cov_scaled=cov, hac_scaled=hac, direction_se_hac=dse,
                       rms=float(stats[1]), rho=float(stats[2]), bandwidth=float(stats[3]),
                       persistence=float(stats[4]), capped=bool(stats[5] == 1.0), n=n,
                       cost=0.5 * float(stats[1]) ** 2 * n, usable=bool(stats[0] == 1.0),
                       spread=spread, circular=bool(model.periodic),
                       additive=tuple(nm for i, nm in zip(prob.free, free_names, strict=True)
                                      if not model.parameters[i].positive))
        robust = robust_of(nums, lambda: scaled, -1)
        floors, reached = _reach_floors(prob, z, lo, hi, open_limits, nums, robust.inflation,
                                        cost, LevenbergMarquardt().tol)
        said = assess(nums, lambda: scaled, -1, model_names=names, gauge_fixed=False,
                      initial_state=model.name, residual="linear", limits=limits,
                      unit=squared(model.output_unit), floors=floors or None, robust=robust)
        uncertainty, findings, determined = said.uncertainty, said.findings, said.determined
        findings = (*findings, *reached)
        derived = model.derived(theta, said.numbers, said.serial,
                                [(b.name, b.direction) for b in limits])
        if said.warning:
            warnings.append(said.warning)
    else:
        f = findings_of(None, model_names=names, gauge_fixed=False, initial_state=model.name,
                        residual="linear")
        findings, determined = f.sentences, f.determined
        if not model.analyse:
            findings = ("not analysed: the model asks for its optimum alone (a search whose "
                        "answer starts another fit), without errors or identifiability",)
    t = model.time(prob.item)
    drive_in = model.driving(prob.item)
    history = tuple(
        {"iteration": float(it), **dict(zip(names, prob.theta(h[:-1]).tolist(), strict=True)),
         "cost": float(h[-1])} for it, h in enumerate(out.history))
    jac = None
    if rows is not None:
        jac = (rows[: prob.q] / prob.chain(theta)[:, None]).T
    result = FitResult(
        model=model, model_name=model.name, status=status, reason=reason,  # type: ignore[arg-type]
        params=dict(zip(names, theta.tolist(), strict=True)), scale=1.0, offset=0.0,
        iterations=int(out.accepted[0]), nfev=int(out.evaluations[0]), history=history,
        rmse=rmse, r2=r2, cost=cost, warnings=tuple(warnings), method="lm",
        integrator=model.integrator, residual="linear", observe=model.output,
        initial_state=model.initial_state,
        units=Units(load=model.input_unit, position=model.output_unit), free=free_names,
        t=np.arange(n, dtype=float) if t is None else t,
        load=np.full(n, np.nan) if drive_in is None else drive_in, data=y, fitted=fitted,
        jacobian=jac, uncertainty=uncertainty, identifiability=findings,
        determined=determined, derived=derived,
        boundary=BoundaryInfo(tuple(open_limits)) if open_limits else None, start=start)
    return quality_gate(determination_gate(result), options.min_r2)
