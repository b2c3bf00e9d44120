"""A card's :class:`~pumpid.result.FitResult` from the job's answer, and the two gates.

The result reports parameters in physical coordinates (the scale C or D, the offset at zero
load), the fitted response and the Jacobian at the optimum from one evaluation. The gates
turn an answer into ``undetermined`` (no parameter fixed by the data) or ``poor-fit`` (R^2
below the quality threshold) without dropping its numbers.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ..cards import open_stroke
from ..engine import drive
from ..engine.problem import Problem
from ..inference.echo import FUNDAMENTAL_ONLY, FUNDAMENTAL_WORSE, fundamental_share
from ..inference.uncertainty import whole_period
from ..models import Model, model_class
from ..result import BoundaryInfo, FitResult, Status, Units
from .options import JobOptions
from .state import CardState, gap_gradient, scale_offset, theta_of, true_offset

__all__ = ["build_result", "determination_gate", "quality_gate"]

Array = NDArray[np.float64]


#: What a card whose position is its fundamental within the noise can tell.
_NOTHING_BEYOND = (
    "the position is the stroke's fundamental within the noise: the card holds two numbers, "
    "the gain and the phase of the position against the load at the stroke frequency, so at "
    "most two combinations of the model's values follow from the data (for a "
    "mass-spring-dashpot, c and k - m (2 pi f)^2); the values called determined are those, "
    "the others rest on the model's form")


def determination_gate(res: FitResult) -> FitResult:
    """``undetermined`` for an answer (converged or at a boundary) that determines none of
    the model's parameters, or that reproduces the stroke's fundamental alone: a converged
    optimum of numbers the data do not fix is not an answer (on real cards: m in the
    millions, damping ratios of 1e-5), and neither is the fundamental, which any load gives
    (a mass-spring-dashpot on a simulated fluid-pound card: m = 1.4e8 lbf*s^2/in and k =
    9.8e7 lbf/in on the stroke frequency, c "determined" as the ratio of the load's and the
    position's fundamentals, R^2 = 0.990099 as for a load of pure noise)."""
    if res.status not in (Status.CONVERGED, Status.BOUNDARY) or res.uncertainty is None:
        return res
    only = bool(res.determined.get("signal_beyond_fundamental")) \
        and FUNDAMENTAL_WORSE < res.r2_beyond < FUNDAMENTAL_ONLY
    none = not any(n in res.params for n in res.determined.get("parameters", ()))
    if res.determined.get("signal_beyond_fundamental") is False and not none:
        # A position that is one sinusoid within the noise holds two numbers: "converged,
        # explains 0.0 % of the rest" beside m = 4.9e6 kN*s^2/m read as a contradiction.
        res = dataclasses.replace(res, warnings=(*res.warnings, _NOTHING_BEYOND))
    if not (only or none):
        return res
    determined = dict(res.determined)
    said = []
    if only:
        said.append(
            f"the fit reproduces only the stroke's fundamental: R^2 = {res.r2:.6g} is about "
            f"the share of the position in its mean and first harmonic "
            f"({res.r2_fundamental:.6g}), which any load gives, and the model explains "
            f"{100 * max(res.r2_beyond, 0.0):.2g} % of the rest; none of its values "
            "describes the well")
        # Whatever the local errors say, no value is a property of the well: the short
        # output printed "c = 42.6 ± 23" unflagged beside this reason.
        shown = list(determined.get("parameters", ()))
        determined["parameters"] = []
        determined["not_determined"] = [*determined.get("not_determined", ()), *shown]
        # The derived quantities too: a natural frequency of 0.1196 Hz "determined" to
        # 3e-11 Hz was the stroke frequency the fit echoes.
        derived = {n: dataclasses.replace(d, determined=False) for n, d in res.derived.items()}
        res = dataclasses.replace(res, derived=derived)
    # A determined quantity that echoes the stroke is said to be one: "determined derived
    # quantities: natural_frequency" read as the well's, beside the warning saying it is not.
    good = [d.name + ("" if d.well_property else " (an echo of the stroke, not the well's)")
            for d in res.derived.values() if d.determined]
    if none:
        said.append("no parameter of the model is determined by these data (each ran to a "
                    "limit, is structurally free or has an error over 100 % of its value): "
                    "the fitted values are one of many that fit as well"
                    + (f"; determined derived quantities: {', '.join(good)}" if good else ""))
    return dataclasses.replace(res, status=Status.UNDETERMINED,
                               reason=f"{'; '.join(said)} ({_verdict(res)})",
                               determined=determined, warnings=(*res.warnings, *said))


def quality_gate(res: FitResult, min_r2: float) -> FitResult:
    """``poor-fit`` for an answer (converged, at a boundary or undetermined) below the R^2
    threshold."""
    if res.status not in (Status.CONVERGED, Status.BOUNDARY, Status.UNDETERMINED):
        return res
    if math.isfinite(res.r2) and res.r2 >= min_r2:
        return res
    # "R^2 = not defined is below the quality threshold" read as garbled.
    shown = ("is not defined (the output's spread is zero or beyond the float range), so "
             "it cannot pass")
    if math.isfinite(res.r2):
        # Enough digits to differ from the threshold: "R^2 = 0.995 is below the quality
        # threshold 0.995" was 0.994994.
        digits = 4
        while digits < 17 and float(f"{res.r2:.{digits}g}") >= min_r2:
            digits += 1
        shown = f"= {res.r2:.{digits}g} is below"
    said = (f"poor fit: R^2 {shown} the quality threshold {min_r2:g} (min_r2); "
            f"the model does not reproduce this record: check the column roles and units, "
            f"the model structure, or the record itself before using these numbers")
    return dataclasses.replace(res, status=Status.POOR_FIT,
                               reason=f"{said} ({_verdict(res)})",
                               warnings=(*res.warnings, said))


def _verdict(res: FitResult) -> str:
    """The status a gate replaces, in words: whose verdict it was, and its reason once (a
    solver's reason already starts with its status: "converged: converged: ..." read as
    garbled)."""
    whose = ("the determination gate's verdict" if res.status is Status.UNDETERMINED
             else "the solver's own verdict")
    key = res.status.key
    reason = res.reason if res.reason.startswith(f"{key}:") else f"{key}: {res.reason}"
    return f"{whose}: {reason}"


def build_result(problem: Problem, k: int, card: CardState, options: JobOptions, units: Units,
                 warnings: Sequence[str] = ()) -> FitResult:
    """One card's :class:`FitResult` from the job's answer."""
    cls = problem.model
    t, f, d = problem.card(k)
    model: Model | None = None
    status, reason = card.status, card.reason
    z = card.z
    if np.all(np.isfinite(z)):
        theta = theta_of(problem, z)
        try:
            model = cls.from_values(theta)
        except ValueError as exc:
            status = Status.FAILED
            reason = f"{reason}; final parameters invalid: {exc}"
    rmse, r2 = card.rmse, card.r2
    jac = None
    if model is not None:
        scale = scale_offset(problem, z)[0]
        offset = true_offset(problem, k, z)
        fitted, jac = _at_optimum(problem, k, z)
        if jac is not None and problem.offset_fixed is None and problem.shift_of(k) != 0.0:
            # In the reported coordinates each parameter also moves the offset's meaning.
            gap0, grads = gap_gradient(problem, k, z)
            p = problem.n_free
            jac[:, :p] += grads / np.exp(z[:p])
            if problem.scale_fixed is None:
                jac[:, p] += gap0 / scale
        if not np.all(np.isfinite(fitted)):
            status = Status.FAILED
            reason = f"{reason}; the fitted response is not finite"
    else:
        fitted = np.full_like(d, np.nan)
        scale = offset = math.nan
        if status is not Status.FAILED:
            status = Status.FAILED
        reason = reason or "the fit gave no finite parameters"
    params = model.as_dict() if model is not None else dict.fromkeys(cls.param_names(),
                                                                      math.nan)
    history = _history(problem, card, k)
    text = tuple(w.replace("{position}", units.position) for w in (*warnings, *card.warnings))
    reduced = card.reduced
    if reduced is not None:
        # The reduced model was fitted inside the job, which knows no units: its parameters'
        # units come from this card's, as the full model's do.
        red_cls = model_class(reduced.model)
        # C's unit too where it has one (a first-order lag's turns load * s into position).
        scale_unit = red_cls.scale_unit_for(units.load, units.position)
        reduced = dataclasses.replace(reduced, units={
            **{p.name: p.unit_for(units.load, units.position) for p in red_cls.param_info()},
            **({"C": scale_unit} if scale_unit != "1" else {})})
    boundary = (BoundaryInfo(card.limits, reduced) if card.limits else None)
    state = problem.initial_states[k]
    one_period = problem.residual == "linear" and whole_period(problem, k)
    r2_fundamental = fundamental_share(d) if one_period else math.nan
    gap = open_stroke(d) if state == "periodic" else None
    if gap is not None:
        steps = f", {gap[1]:.0f} median steps" if math.isfinite(gap[1]) else ""
        text = (*text, (
            f"the card does not close: it ends {float(abs(d[-1] - d[0])):.4g} {units.position} "
            f"({100 * gap[0]:.0f} % of its stroke{steps}) from where it starts, and a card "
            "fitted as one period of a periodic motion is joined end to start: a partial or "
            "mis-cut stroke? The fit must make that jump"))
    if math.isfinite(r2_fundamental):
        # What the fundamental leaves is worth explaining only above the data's noise: a
        # position that is one sinusoid plus noise leaves any model nothing to explain.
        left = math.sqrt((1.0 - r2_fundamental) * float(np.var(d)))
        card.determined["signal_beyond_fundamental"] = bool(
            left > 2.0 * card.noise + 1e-9 * float(np.ptp(d)))
    return FitResult(
        model=model, model_name=cls.__name__, status=status, reason=reason, params=params,
        scale=scale, offset=offset, iterations=card.accepted, nfev=card.evaluations,
        history=history, rmse=rmse, r2=r2, cost=card.cost if model is not None else math.nan,
        warnings=text, method=options.method, integrator=problem.integrator,
        residual=problem.residual, observe=problem.observe, initial_state=state,
        units=units, free=problem.free_names, t=t, load=f, data=d, fitted=fitted,
        jacobian=jac, uncertainty=card.uncertainty, identifiability=card.findings,
        determined=card.determined, derived=card.derived, boundary=boundary,
        start=card.start, r2_fundamental=r2_fundamental,
        gauge="C = 1" if problem.gauge_fixed else None, problem=problem,
        options={"method": options.method, "card": k, "solver": options.solver,
                 "newton": options.newton, "units": units},
    )


def _at_optimum(problem: Problem, k: int, z: Array) -> tuple[Array, Array | None]:
    """The fitted displacement and d(residual)/d(free values) in physical coordinates
    (theta, C or D, offset), from one evaluation."""
    data, model, settings = problem.arrays
    q = problem.q
    d = problem.card(k)[2]
    rows = np.empty((q + 1, problem.n_samples(k)))
    if not drive.rows_at(z, k, data, model, settings, rows):
        y, _ok = drive.outputs(np.array([k], dtype=np.int64), np.ascontiguousarray(z[None]),
                              data, model, settings, d.size)
        scale, offset = scale_offset(problem, z)
        return scale * y + offset, None
    fitted = d * np.exp(rows[q]) if problem.residual == "log" else rows[q] + d
    jac = rows[:q].T.copy()
    p = problem.n_free
    jac[:, :p] /= np.exp(z[:p])
    if problem.scale_fixed is None and problem.residual == "linear":
        jac[:, p] /= math.exp(z[p])
    return fitted, jac


def _history(problem: Problem, card: CardState, k: int) -> tuple[Mapping[str, float], ...]:
    if card.newton_history is not None:
        return tuple(card.newton_history)
    if card.history is None or card.history.size == 0:
        return ()
    # All rows at once: parameters, scale, offset, cost as columns, then one dict per row.
    h = card.history
    p = problem.n_free
    columns: dict[str, Array] = {"iteration": np.arange(h.shape[0], dtype=float)}
    with np.errstate(over="ignore"):
        theta = problem.full_theta(np.exp(h[:, :p]))
    for i, name in enumerate(problem.model.param_names()):
        columns[name] = theta[:, i]
    j = p
    if problem.scale_fixed is None:
        columns["D" if problem.residual == "log" else "C"] = (
            h[:, j] if problem.residual == "log" else np.exp(h[:, j]))
        j += 1
    if problem.offset_fixed is None:
        scale = (np.exp(h[:, p]) if problem.scale_fixed is None
                 else np.full(h.shape[0], float(problem.scale_fixed)))
        columns["offset"] = h[:, j] - problem.offset_gap(k, theta, scale)
    columns["cost"] = h[:, -1]
    keys = list(columns)
    values = np.column_stack([columns[k] for k in keys]).tolist()
    return tuple(dict(zip(keys, row, strict=True)) for row in values)

