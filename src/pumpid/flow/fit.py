"""The flow main job: fit a first-order surrogate to one record, or one to several.

The paper's second application replaces a CFD model of a viscous delivery system by a
first-order ODE with a time constant and a gain (:mod:`pumpid.flow.surrogates`), identified
from a transient record with the same engine as the cards:

* a linear or Hammerstein surrogate on one record is :func:`pumpid.fit` itself (the compiled
  kernel, the main job's start guard, boundaries and diagnostics);
* the nonlinear :class:`~pumpid.flow.surrogates.ShearThinningLag`, and joint fits of one
  parameter set to several records, are an own model (:class:`pumpid.models.OwnModel`)
  whose simulator integrates each record with its exact forward sensitivities, fitted by
  :func:`pumpid.fit` too: the same solver, stop tests, statuses, gates, boundaries and
  errors that hold under correlated residuals as every fit.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..engine.simulate import simulate, simulate_sensitivities
from ..job import FitOptions, LevenbergMarquardt, fit, solver_for
from ..models import Model, OwnModel, Parameter
from ..result import FitResult, Units
from .pipeflow import Pipe, PowerLawFluid, simulate_pipe_flow
from .records import FlowRecord, starts_near_zero
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
    at_rest = starts_near_zero(y)
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
    # Only where n shapes a static map of the input (the power-law model): the
    # shear-thinning model's n shapes the transient itself, and a ramp visits every level
    # (n = 0.40005 +- 6e-5 was fitted beside "any n fits equally").
    if ("n" in cls.param_names() and not cls.nonlinear and not (fixed and "n" in fixed)):
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
        warnings=(*warnings, *res.warnings), derived=_in_flow_terms(res.derived, direction),
        application={"flow": {
            "source": record.source, "direction": direction,
            "input": "pressure drop" if direction == "dp->q" else "flow rate",
            "output": "flow rate" if direction == "dp->q" else "pressure drop",
            "initial_state": why, "notes": list(record.notes),
            "dp_ref": getattr(cls, "dp_ref", None) if "n" in cls.param_names() else None,
        }})


def _in_flow_terms(derived: Mapping[str, Any], direction: str) -> dict[str, Any]:
    """The derived quantities said of a pipe, not of a rod-pumped well: the static
    stiffness of a dp -> q fit is a hydraulic resistance (it read "load per unit
    displacement", "a property of the well")."""
    out = dict(derived)
    static = out.get("static_stiffness")
    if static is not None:
        meaning = ("pressure drop per unit flow rate at steady state (1 / static gain): the "
                   "line's hydraulic resistance" if direction == "dp->q" else
                   "flow rate per unit pressure drop at steady state (1 / static gain)")
        out["static_stiffness"] = dataclasses.replace(static, meaning=meaning)
    return out


def _distinct_levels(u: FloatArray, rel: float = 0.05) -> int:
    """Number of non-zero pressure-drop levels the record visits: its values (above 5 % of
    the largest) in runs split where sorted neighbours lie over 5 % of the largest apart,
    a run spanning more than 10 % of it counted as a sweep of two levels or more. A step
    visits one (its noise included: fixed bins split a noisy level in two), a ramp or a
    staircase several."""
    mag = np.abs(u)
    top = float(mag.max()) or 1.0
    values = np.sort(mag[mag > rel * top])
    if values.size < 2:
        return int(values.size)
    runs = np.split(values, np.flatnonzero(np.diff(values) > rel * top) + 1)
    return sum(2 if run[-1] - run[0] > 2 * rel * top else 1 for run in runs if run.size >= 2)


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


class _Records(OwnModel):
    """A surrogate over one or several records end to end, each record's residuals weighted
    (the engine's own-model path: :mod:`pumpid.job.own`)."""

    def __init__(self, cls: type[Model], records: Sequence[FlowRecord],
                 states: Sequence[Any], weights: FloatArray, units: Units,
                 unit: str, label: Any) -> None:
        self.cls = cls
        self.records = list(records)
        self.states = list(states)
        self.pairs = [_orient(r, "dp->q")[:2] for r in records]
        self.weights = weights
        self.name = cls.__name__
        self.parameters = tuple(Parameter(p.name, p.unit_for(units.load, units.position),
                                          lower=max(p.lower, 0.0), upper=p.upper, doc=p.doc)
                                for p in cls.param_info())
        self.output, self.output_unit, self.input_unit = "q", unit, units.load
        self.integrator = "solve_ivp (LSODA)" if cls.nonlinear else "exact"
        self.initial_state = label

    def simulate(self, values: FloatArray, data: Any, sensitivities: bool
                 ) -> tuple[FloatArray, FloatArray | None]:
        """Each record integrated with its exact forward sensitivities, weighted."""
        ys, dys = [], []
        for rec, (u, _), st in zip(self.records, self.pairs, self.states, strict=True):
            got = _simulate_any(self.cls, values, rec.t, u, st, sensitivities)
            y, dy = got if sensitivities else (got, None)
            ys.append(np.asarray(y, dtype=float))
            dys.append(dy)
        y_all = self.weights * np.concatenate(ys)
        if not sensitivities:
            return y_all, None
        return y_all, self.weights[:, None] * np.vstack(dys)

    def observed(self, data: Any) -> FloatArray:
        """The records' flow rates end to end, weighted."""
        return self.weights * np.concatenate([y for _, y in self.pairs])


def _fit_records(
    start: Model, records: Sequence[FlowRecord], states: Sequence[Any], *,
    fixed: Mapping[str, float] | None, units: Units, tol: float = 1e-10,
    max_nfev: int | None = None, direction: str = "dp->q",
    weights: Sequence[float] | None = None,
) -> FitResult:
    """One parameter set for one or several records (dp -> q), through :func:`pumpid.fit`.

    The surrogate is an own model over the records end to end (each record integrated with
    its exact forward sensitivities, its residuals weighted by ``weights``), so it gets the
    solver, statuses, gates, boundaries and errors that hold of every fit; the result holds
    the unweighted data and fit.
    """
    cls = type(start)
    w = np.concatenate([np.full(r.n, 1.0 if weights is None else float(wk))
                        for r, wk in zip(records, weights or [1.0] * len(records),
                                         strict=True)])
    label = states[0] if len(set(map(str, states))) == 1 else "per record"
    if isinstance(label, tuple):
        label = list(label)
    own = _Records(cls, records, states, w, units,
                   units.position if weights is None else "(relative)", label)
    theta0 = start.values.copy()
    names = cls.param_names()
    for nm, v in (fixed or {}).items():
        theta0[names.index(nm)] = float(v)
    got = fit(own, tuple(records), options=FitOptions(fixed=dict(fixed or {})),
              solver=LevenbergMarquardt(tol=tol, max_evaluations=max_nfev),
              x0=dict(zip(names, theta0.tolist(), strict=True)))
    assert isinstance(got, FitResult)
    data = np.concatenate([y for _, y in own.pairs])
    fitted = np.asarray(got.fitted) / w
    res = fitted - data
    finite = bool(np.all(np.isfinite(res)))
    sst = float(np.sum((data - data.mean()) ** 2))
    # Records placed end to end on one time axis (display only; each starts from its own
    # initial state).
    t_all, shift = [], 0.0
    for rec in records:
        t_all.append(rec.t - rec.t[0] + shift)
        step = float(rec.t[-1] - rec.t[0])
        shift += step + step / max(rec.n - 1, 1)
    theta = np.array([got.params[n] for n in names])
    return got.with_parts(
        model=cls.from_values(theta) if np.all(np.isfinite(theta)) else None,
        units=units, t=np.concatenate(t_all), load=np.concatenate([u for u, _ in own.pairs]),
        data=data, fitted=fitted,
        rmse=float(np.sqrt(np.mean(res**2))) if finite else math.nan,
        r2=1.0 - float(res @ res) / sst if finite and sst > 0 else math.nan,
        jacobian=None if got.jacobian is None else np.asarray(got.jacobian) / w[:, None])


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
    return res.with_parts(derived=_in_flow_terms(res.derived, "dp->q"), application={
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
        Passed to ``simulate_pipe_flow`` (``numerics=PipeNumerics(n_radial=...)``,
        ``initial_velocity``, ``breakpoints``, ...).
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


