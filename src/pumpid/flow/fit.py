"""The flow main job: fit a first-order surrogate to one record, or one to several.

The paper's second application replaces a CFD model of a viscous delivery system by a
first-order ODE with a time constant and a gain (:mod:`pumpid.flow.surrogates`), identified
from a transient record with the same engine as the cards:

* a linear or Hammerstein surrogate on one record is :func:`pumpid.fit` itself (the compiled
  kernel, the main job's start guard, boundaries and diagnostics);
* the nonlinear :class:`~pumpid.flow.surrogates.ShearThinningLag`, and joint fits of one
  parameter set to several records, run the engine's Levenberg-Marquardt machine
  (:func:`pumpid.engine.solvers.run_python`) around an evaluator that integrates each record
  with its exact forward sensitivities; their uncertainty comes from the same analysis as
  every fit (:func:`pumpid.inference.uncertainty.analyse_rows`), so the same stop tests,
  counts, statuses and intervals mean the same things everywhere.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..engine import lm
from ..engine.simulate import simulate, simulate_sensitivities
from ..engine.solvers import LevenbergMarquardt, run_python
from ..inference.identifiability import findings_of, whiteness_warning
from ..inference.uncertainty import Numbers, analyse_rows, uncertainty_of
from ..job import FitOptions, fit, solver_for
from ..models import Model
from ..result import FitResult, Status, Units
from .pipeflow import Pipe, PowerLawFluid, simulate_pipe_flow
from .records import FlowRecord
from .surrogates import (
    FirstOrderLag,
    PowerLawLag,
    ShearThinningLag,
    reference_pressure,
    simulate_shear_thinning,
    surrogate_class,
)

__all__ = [
    "fit_flow",
    "fit_flow_records",
    "simulate_flow_record",
    "simulate_surrogate",
]

FloatArray = NDArray[np.float64]
Direction = Literal["dp->q", "q->dp"]


def _orient(record: FlowRecord, direction: str) -> tuple[FloatArray, FloatArray, Units]:
    """(input, output, units) for a direction."""
    if direction == "dp->q":
        return record.dp, record.q, Units(load=record.dp_unit, position=record.q_unit)
    if direction == "q->dp":
        return record.q, record.dp, Units(load=record.q_unit, position=record.dp_unit)
    raise ValueError(f"direction must be 'dp->q' or 'q->dp', got {direction!r}")


def _initial_state(u: FloatArray, y: FloatArray, requested: Any) -> tuple[Any, str]:
    """The initial state for a fit and a sentence saying which and why."""
    at_rest = abs(y[0]) <= 1e-6 * float(np.max(np.abs(y)))
    if requested in (None, "auto"):
        if at_rest:
            state: Any = "rest"
            why = "rest (the output starts at zero)"
        else:
            state = "equilibrium"
            why = ("equilibrium (the output starts away from zero: steady state under the "
                   "first input sample is assumed)")
    else:
        state = requested
        why = f"{requested} (as requested)"
    if state == "rest" and np.ptp(u) == 0.0:
        # A step from rest at t[0]: the zero state given as a number, because a *named* rest
        # state with a constant input is refused by pumpid.fit as uninformative.
        state = (0.0,)
        why = "rest (a step from rest at the first sample)"
    return state, why


#: The engine's words for a fit's input and output, and the quantities they are in a flow fit.
_ENGINE_WORDS = ("load", "displacement")


def _quantities(record: FlowRecord, direction: str) -> tuple[str, str]:
    """The names, with units, of a direction's input and output quantities."""
    dp = f"pressure drop dp [{record.dp_unit}]"
    q = f"flow rate q [{record.q_unit}]"
    return (dp, q) if direction == "dp->q" else (q, dp)


def _check_magnitudes(record: FlowRecord, direction: str) -> None:
    """Refuse, naming the file and the quantity, a record whose values floating point cannot
    fit: their time integrals (the equation-error start) or the output's sum of squares (the
    fit's cost) overflow.

    Checked before any linear algebra: LAPACK given an overflowed matrix prints its own
    "illegal value" lines and fails with "SVD did not converge", naming neither the file
    nor the quantity.
    """
    names = dict(zip(("dp", "q"), _quantities(record, "dp->q"), strict=True))
    output = "q" if direction == "dp->q" else "dp"
    t = np.asarray(record.t, dtype=float)
    span = float(t[-1] - t[0])
    for key in ("dp", "q"):
        x = np.asarray(getattr(record, key), dtype=float)
        peak = float(np.max(np.abs(x)))
        with np.errstate(over="ignore", invalid="ignore"):
            integral = np.cumsum(0.5 * np.diff(t) * (x[1:] + x[:-1]))
            squares = float(np.sum((x - x.mean()) ** 2)) if key == output else 0.0
        if np.all(np.isfinite(integral)) and math.isfinite(squares):
            continue
        what = ("their time integral" if not np.all(np.isfinite(integral))
                else "the sum of their squares (the fit's cost)")
        unit = record.dp_unit if key == "dp" else record.q_unit
        raise ValueError(
            f"{record.source}: {names[key]}: values up to {peak:g} {unit} over {span:g} s "
            f"are beyond floating point in the fit ({what} exceeds 1e308); give the record "
            f"in a larger unit (--{key}-unit) or check the column roles")


def _in_flow_words(exc: ValueError, record: FlowRecord, direction: str) -> ValueError:
    """An engine error in the flow record's words: its quantities and its file."""
    text = str(exc)
    for word, name in zip(_ENGINE_WORDS, _quantities(record, direction), strict=True):
        text = re.sub(rf"\b{word}\b", name, text)
    source = record.source
    return ValueError(text if not source or text.startswith(source) else f"{source}: {text}")


def _equation_error_start(t: FloatArray, u: FloatArray, y: FloatArray) -> tuple[float, float]:
    """(tau, gain) of a first-order lag by linear least squares on the integrated ODE.

    ``y(t) - y(t0) = (gain/tau) int u - (1/tau) int y``: no derivative of noisy data needed.
    """
    dt = np.diff(t)
    iu = np.concatenate([[0.0], np.cumsum(0.5 * dt * (u[1:] + u[:-1]))])
    iy = np.concatenate([[0.0], np.cumsum(0.5 * dt * (y[1:] + y[:-1]))])
    mat = np.column_stack([iu, -iy])
    span = float(t[-1] - t[0])
    c_u = c_y = math.nan
    if np.all(np.isfinite(mat)) and np.all(np.isfinite(y)):
        coef, *_ = np.linalg.lstsq(mat, y - y[0], rcond=None)
        c_u, c_y = (float(c) for c in coef)
    if c_y > 0 and math.isfinite(c_u / c_y) and c_u / c_y > 0:
        return min(max(1.0 / c_y, 1e-6 * span), 1e3 * span), c_u / c_y
    top = float(np.max(np.abs(u))) or 1.0
    return span / 5.0, max(float(np.max(np.abs(y))) / top, 1e-300)


def _bind_reference(cls: type[Model], dp_ref: float | None, u: FloatArray) -> type[Model]:
    if issubclass(cls, PowerLawLag | ShearThinningLag):
        ref = reference_pressure(u) if dp_ref is None else float(dp_ref)
        return cls.at_reference(ref)  # type: ignore[attr-defined,no-any-return]
    return cls


def _start_model(cls: type[Model], t: FloatArray, u: FloatArray, y: FloatArray,
                 x0: Mapping[str, float] | None, fixed: Mapping[str, float] | None) -> Model:
    tau0, gain0 = _equation_error_start(t, u, y)
    values = {"tau": tau0, "gain": gain0}
    if "n" in cls.param_names():
        values["n"] = 1.0
        if issubclass(cls, PowerLawLag | ShearThinningLag):
            # The linear estimate is a mean conductance; the reference one is at dp_ref.
            values["gain"] = gain0
    values.update(dict(x0 or {}))
    values.update(dict(fixed or {}))
    return cls(**{k: values[k] for k in cls.param_names()})


def fit_flow(
    record: FlowRecord,
    model: str | type[Model] | Model = "first-order",
    *,
    direction: Direction = "dp->q",
    method: str = "lm",
    initial_state: Any = "auto",
    dp_ref: float | None = None,
    fixed: Mapping[str, float] | None = None,
    x0: Mapping[str, float] | None = None,
    **fit_options: Any,
) -> FitResult:
    """Fit a first-order surrogate to a flow record (the flow main job).

    Parameters
    ----------
    record : FlowRecord
    model : {"first-order", "power-law", "shear-thinning"} or a surrogate class/instance
        ``first-order``: :class:`~pumpid.flow.surrogates.FirstOrderLag` (tau, gain);
        ``power-law``: :class:`~pumpid.flow.surrogates.PowerLawLag` (tau, gain, n);
        ``shear-thinning``: :class:`~pumpid.flow.surrogates.ShearThinningLag` (tau, gain, n),
        whose time constant follows the flow level. An instance is the starting guess.
    direction : {"dp->q", "q->dp"}
        Pressure drop in and flow rate out (default), or the reverse (first-order only).
    method : {"lm", "newton-fd"}
        As :func:`pumpid.fit`. ``shear-thinning`` supports ``lm`` only.
    initial_state : "auto", "rest", "equilibrium" or numbers
        ``auto``: rest when the output starts at zero (a start-up), else the steady state
        under the first input sample; the choice is stated in ``application["flow"]``.
    dp_ref : float, optional
        Pressure reference of the power-law models (default: max |dp|, 3 digits).
    fixed : mapping, optional
        Parameters held fixed, e.g. ``{"n": 0.4}`` (``n`` cannot be identified from a
        record with a single pressure-drop level).
    x0 : mapping, optional
        Starting values (default: a linear equation-error estimate, n = 1).
    **fit_options
        Passed to :func:`pumpid.fit` (tol, max_nfev, eps0, ...).

    Returns
    -------
    FitResult
        Parameters with units (``tau`` in s, ``gain`` in output per input unit), R^2, RMSE,
        standard errors and 95 % intervals, warnings, and ``application["flow"]`` with the
        record's source, notes, direction, initial state and the pressure reference.
    """
    if isinstance(model, Model):
        cls: type[Model] = type(model)
        start: Model | None = model
    else:
        cls, start = surrogate_class(model), None
    u, y, units = _orient(record, direction)
    _check_magnitudes(record, direction)
    if direction == "q->dp" and cls is not FirstOrderLag:
        raise ValueError(
            f"direction 'q->dp' is available for the first-order model only; the power-law "
            f"surrogates take the pressure drop as input (got {cls.__name__})")
    if start is None:
        cls = _bind_reference(cls, dp_ref, u)
    state, why = _initial_state(u, y, initial_state)
    warnings: list[str] = []
    if "n" in cls.param_names() and not (fixed and "n" in fixed):
        levels = _distinct_levels(u)
        if levels < 2:
            warnings.append(
                "the pressure drop visits a single level: the flow index n is not identifiable "
                "from this record (any n fits equally); fix it (fixed={'n': ...}, --fix n=...) "
                "or fit records at several pressure drops")
    if start is None:
        start = _start_model(cls, record.t, u, y, x0, fixed)
    if cls.nonlinear:
        if method != "lm":
            raise ValueError(f"{cls.__name__} is fitted with method 'lm' only (its simulation "
                             "is a nonlinear ODE, not pumpid's linear simulator)")
        res = _fit_records(start, [record], [state], fixed=fixed, units=units,
                           tol=fit_options.get("tol", 1e-10),
                           max_nfev=fit_options.get("max_nfev"))
    else:
        try:
            got = fit(start, (record.t, u, y),
                      options=FitOptions(initial_state=state, fixed=dict(fixed or {})),
                      solver=solver_for(method, **fit_options), units=units)
            assert isinstance(got, FitResult)
            res = got
        except ValueError as exc:
            raise _in_flow_words(exc, record, direction) from None
    return res.with_parts(
        warnings=(*warnings, *res.warnings),
        application={"flow": {
            "source": record.source, "direction": direction,
            "input": "pressure drop" if direction == "dp->q" else "flow rate",
            "output": "flow rate" if direction == "dp->q" else "pressure drop",
            "initial_state": why, "notes": list(record.notes),
            "dp_ref": getattr(cls, "dp_ref", None) if "n" in cls.param_names() else None,
        }})


def _distinct_levels(u: FloatArray, rel: float = 0.05) -> int:
    """Number of pressure-drop levels held for at least 10 % of the record (5 % apart)."""
    mag = np.abs(u)
    top = float(mag.max()) or 1.0
    bins = np.round(mag / (rel * top))
    _, counts = np.unique(bins[mag > rel * top], return_counts=True)
    return int(np.sum(counts >= max(2, 0.1 * u.size)))


# --------------------------------------------------------------------------- records jointly
def _simulate_any(
    model_cls: type[Model], theta: FloatArray, t: FloatArray, u: FloatArray, state: Any,
    sens: bool,
) -> Any:
    """Output (and sensitivities) of any surrogate for one record."""
    if model_cls.nonlinear:
        init = state
        if isinstance(state, tuple | list):
            init = float(state[0])
        return simulate_shear_thinning(theta, t, u, dp_ref=model_cls.dp_ref,  # type: ignore
                                       initial_state=init, sensitivities=sens)
    model = model_cls.from_values(theta)
    if sens:
        return simulate_sensitivities(model, t, u, initial_state=state)
    return simulate(model, t, u, initial_state=state)


def _fit_records(
    start: Model, records: Sequence[FlowRecord], states: Sequence[Any], *,
    fixed: Mapping[str, float] | None, units: Units, tol: float = 1e-10,
    max_nfev: int | None = None, direction: str = "dp->q",
    weights: Sequence[float] | None = None,
) -> FitResult:
    """One parameter set for one or several records (dp -> q), by the engine's solver.

    Levenberg-Marquardt on log-parameters (the engine's state machine, driven from Python
    here because the nonlinear surrogate is integrated by scipy), exact sensitivities, each
    record's residuals weighted by ``weights``.
    """
    cls = type(start)
    names = cls.param_names()
    fixed = dict(fixed or {})
    free = [i for i, nm in enumerate(names) if nm not in fixed]
    theta0 = start.values.copy()
    for nm, v in fixed.items():
        theta0[names.index(nm)] = float(v)
    pairs = [_orient(r, direction)[:2] for r in records]
    data = np.concatenate([y for _, y in pairs])
    w = np.concatenate([np.full(r.n, 1.0 if weights is None else float(wk))
                        for r, wk in zip(records, weights or [1.0] * len(records),
                                         strict=True)])
    q = len(free)

    def theta_of(z: FloatArray) -> FloatArray:
        th = theta0.copy()
        th[free] = np.exp(np.clip(z, -700.0, 700.0))
        return th

    def rows_at(z: FloatArray) -> FloatArray | None:
        th = theta_of(z)
        ys, dys = [], []
        try:
            with np.errstate(all="ignore"):
                for rec, (u, _), st in zip(records, pairs, states, strict=True):
                    y, dy = _simulate_any(cls, th, rec.t, u, st, True)
                    ys.append(y)
                    dys.append(dy)
        except (RuntimeError, ValueError, FloatingPointError):
            return None
        y_all = np.concatenate(ys)
        dy_all = np.vstack(dys)
        rows = np.empty((q + 1, data.size))
        rows[:q] = (w[:, None] * dy_all[:, free] * th[free]).T
        rows[q] = w * (y_all - data)
        return rows if np.all(np.isfinite(rows)) else None

    def evaluate(z: FloatArray) -> tuple[float, FloatArray, FloatArray]:
        rows = rows_at(z)
        r_fac = np.zeros((q, q))
        c = np.zeros(q)
        if rows is None:
            return math.nan, r_fac, c
        cost = lm.householder(rows, q, r_fac, c)
        return cost, r_fac, c

    z0 = np.log(theta0[free])
    # The same default budget as every other fit (the solver's own rule).
    budget = max_nfev if max_nfev is not None else LevenbergMarquardt().budget(q)
    out = run_python(evaluate, z0, np.full(q, -700.0), np.full(q, 700.0), tol=tol,
                     max_evaluations=budget, n_capped=q)
    stop = out.stops[0]
    z = out.z[0]
    theta = theta_of(z)
    model: Model | None = cls.from_values(theta)
    rows = rows_at(z)
    status = Status.CONVERGED if stop.converged else Status.FAILED
    reason = out.messages[0]
    if rows is None:
        model, status = None, Status.FAILED
        reason += "; the fitted model cannot be simulated"
        fitted = np.full_like(data, np.nan)
    else:
        fitted = rows[q] / w + data
    res = fitted - data
    finite = bool(np.all(np.isfinite(res)))
    sst = float(np.sum((data - data.mean()) ** 2))
    rmse = float(np.sqrt(np.mean(res**2))) if finite else math.nan
    r2 = 1.0 - float(res @ res) / sst if finite and sst > 0 else math.nan
    uncertainty = None
    findings: tuple[str, ...] = ()
    determined: dict[str, Any] = {}
    warnings: list[str] = []
    free_names = tuple(names[i] for i in free)
    if rows is not None:
        s, vt, cov, hac, dse, stats = analyse_rows(rows.copy(), np.ones(q, dtype=np.bool_),
                                                   -1, 1.0)
        spread = float(np.ptp(w * data))
        nums = Numbers(names=free_names, inner=tuple(range(q)), values=theta[free],
                       scales=theta[free], singular=s, vt=vt, cov_scaled=cov, hac_scaled=hac,
                       direction_se_hac=dse, rms=float(stats[1]), rho=float(stats[2]),
                       bandwidth=float(stats[3]), persistence=float(stats[4]),
                       capped=bool(stats[5] == 1.0), n=data.size,
                       cost=0.5 * float(stats[1]) ** 2 * data.size,
                       usable=bool(stats[0] == 1.0), spread=spread)
        serial = not nums.exact and not nums.rho <= 2.576 / math.sqrt(data.size)
        found = findings_of(nums, model_names=names, gauge_fixed=False,
                            initial_state=states[0], residual="linear", serial=serial)
        findings, determined = found.sentences, found.determined
        unit = units.position if weights is None else "(relative)"
        uncertainty = uncertainty_of(nums, found.undetermined, (), found.notes, f"{unit}^2")
        if uncertainty is not None and uncertainty.whiteness is not None \
                and not uncertainty.whiteness["white"]:
            warnings.append(whiteness_warning(dict(uncertainty.whiteness), data.size, q))
    # Records placed end to end on one time axis (display only; each starts from its own
    # initial state).
    t_all, u_all, shift = [], [], 0.0
    for rec, (u, _) in zip(records, pairs, strict=True):
        t_all.append(rec.t - rec.t[0] + shift)
        u_all.append(u)
        step = float(rec.t[-1] - rec.t[0])
        shift += step + step / max(rec.n - 1, 1)
    state_label = states[0] if len(set(map(str, states))) == 1 else "per record"
    if isinstance(state_label, tuple):
        state_label = list(state_label)
    history = tuple(
        {"iteration": float(it), **dict(zip(names, theta_of(h[:-1]).tolist(), strict=True)),
         "cost": float(h[-1])} for it, h in enumerate(out.history))
    jac = None if rows is None else (rows[:q] / theta[free][:, None] / w).T
    return FitResult(
        model=model, model_name=cls.__name__, status=status, reason=reason,
        params=dict(zip(names, theta.tolist(), strict=True)), scale=1.0, offset=0.0,
        iterations=int(out.accepted[0]), nfev=int(out.evaluations[0]), history=history,
        rmse=rmse, r2=r2, cost=float(out.cost[0]) if finite else math.nan,
        warnings=tuple(warnings), method="lm",
        integrator="solve_ivp (LSODA)" if cls.nonlinear else "exact", residual="linear",
        observe="q", initial_state=state_label, units=units, free=free_names,
        t=np.concatenate(t_all), load=np.concatenate(u_all), data=data, fitted=fitted,
        jacobian=jac, uncertainty=uncertainty, identifiability=findings,
        determined=determined)


def fit_flow_records(
    records: Sequence[FlowRecord],
    model: str | type[Model] | Model = "shear-thinning",
    *,
    initial_state: Any = "auto",
    dp_ref: float | None = None,
    fixed: Mapping[str, float] | None = None,
    x0: Mapping[str, float] | None = None,
    tol: float = 1e-10,
    max_nfev: int | None = None,
) -> FitResult:
    """One parameter set for several records (pressure drop in, flow rate out).

    Used to test whether a surrogate describes start-ups at several step sizes at once. The
    result's arrays hold the records end to end; ``extra["records"]`` gives each record's
    R^2 and RMSE.
    """
    if not records:
        raise ValueError("no records to fit")
    for record in records:
        _check_magnitudes(record, "dp->q")
    if isinstance(model, Model):
        start: Model = model
        cls: type[Model] = type(model)
    else:
        cls = surrogate_class(model)
        all_dp = np.concatenate([r.dp for r in records])
        cls = _bind_reference(cls, dp_ref, all_dp)
        longest = max(records, key=lambda r: float(np.ptp(r.dp)) + float(np.max(np.abs(r.dp))))
        start = _start_model(cls, longest.t, longest.dp, longest.q, x0, fixed)
        if "n" in cls.param_names() and len(records) > 1 and not (fixed and "n" in fixed):
            start = _two_level_start(cls, records, start)
    states = [_initial_state(r.dp, r.q, initial_state)[0] for r in records]
    units = records[0].units
    # Each record counts equally whatever its flow level (q ~ dp^(1/n) spans decades across
    # steps): residuals are taken relative to the record's largest flow rate.
    weights = [1.0 / float(np.max(np.abs(r.q))) for r in records]
    res = _fit_records(start, records, states, fixed=fixed, units=units, tol=tol,
                       max_nfev=max_nfev, weights=weights)
    per = []
    i = 0
    for rec in records:
        sl = slice(i, i + rec.n)
        err = res.fitted[sl] - rec.q
        sst = float(np.sum((rec.q - rec.q.mean()) ** 2))
        per.append({"source": rec.source, "dp_max": float(np.max(np.abs(rec.dp))),
                    "rmse": float(np.sqrt(np.mean(err**2))),
                    "r2": 1.0 - float(err @ err) / sst if sst > 0 else math.nan})
        i += rec.n
    return res.with_parts(application={
        "records": per,
        "flow": {"direction": "dp->q", "input": "pressure drop", "output": "flow rate",
                 "n_records": len(records), "dp_ref": getattr(cls, "dp_ref", None)}})


def _two_level_start(cls: type[Model], records: Sequence[FlowRecord], start: Model) -> Model:
    """Start n from the steady levels of the records: q_end ~ dp^(1/n) (log-log slope)."""
    dps = np.array([abs(float(r.dp[-1])) for r in records])
    qs = np.array([abs(float(r.q[-1])) for r in records])
    ok = (dps > 0) & (qs > 0)
    if ok.sum() >= 2 and np.ptp(np.log(dps[ok])) > 0:
        slope = float(np.polyfit(np.log(dps[ok]), np.log(qs[ok]), 1)[0])
        if slope > 0.2:
            ref = cls.dp_ref  # type: ignore[attr-defined]
            top = int(np.argmax(dps))
            gain = qs[top] / ref * (ref / dps[top]) ** slope
            return start.replace(n=min(max(1.0 / slope, 0.1), 3.0), gain=gain)
    return start


def simulate_surrogate(
    model: Model, t: ArrayLike, u: ArrayLike, *, initial_state: Any = "rest"
) -> FloatArray:
    """Output of any flow surrogate (linear, Hammerstein or ShearThinningLag) for an input."""
    tt = np.asarray(t, dtype=float)
    uu = np.asarray(u, dtype=float)
    return np.asarray(_simulate_any(type(model), model.values, tt, uu, initial_state, False))


def simulate_flow_record(
    t: ArrayLike,
    dp: ArrayLike | float,
    *,
    fluid: PowerLawFluid,
    pipe: Pipe,
    source: str | None = None,
    **options: Any,
) -> FlowRecord:
    """A reference record from the pipe-flow simulator.

    The simulator is :func:`pumpid.flow.pipeflow.simulate_pipe_flow`.

    Parameters
    ----------
    t : array_like
        Output times (s).
    dp : float or array_like
        A constant pressure drop (a step from rest at ``t[0]``) or samples aligned with ``t``
        (piecewise linear, as the surrogates see them).
    fluid, pipe : PowerLawFluid, Pipe
    **options
        Passed to ``simulate_pipe_flow`` (``n_radial``, ``rtol``, ...).
    """
    tt = np.asarray(t, dtype=float)
    dd = np.broadcast_to(np.asarray(dp, dtype=float), tt.shape).astype(float)
    res = simulate_pipe_flow(tt, dd, fluid=fluid, pipe=pipe, **options)
    desc = source or (f"pipe-flow simulation: K = {fluid.K:g} Pa s^n, n = {fluid.n:g}, "
                      f"rho = {fluid.rho:g} kg/m^3, R = {pipe.radius:g} m, "
                      f"L = {pipe.length:g} m")
    return FlowRecord(t=tt.copy(), dp=dd.copy(), q=np.asarray(res.q, dtype=float), source=desc,
                      notes=("simulated with pumpid.flow.pipeflow (laminar power-law pipe flow "
                             "from rest)",))


