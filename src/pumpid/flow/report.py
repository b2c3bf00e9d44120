"""Figures and report files of flow fits and of the step study."""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..report import write_outputs
from ..report.plots import plot_history, plot_residuals
from ..result import FitResult, jsonable
from .study import StepStudy

__all__ = [
    "flow_figures",
    "plot_flow_characteristic",
    "plot_flow_fit",
    "plot_tau_vs_step",
    "write_flow_outputs",
    "write_study_outputs",
]


def _new_figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _names(result: FitResult) -> tuple[str, str]:
    """(input name, output name) of a flow fit."""
    info = result.application.get("flow", {})
    return info.get("input", "pressure drop"), info.get("output", "flow rate")


def plot_flow_fit(result: FitResult) -> Figure:
    """Measured and fitted output over time, with the input below it.

    Returns
    -------
    Figure
        Two axes sharing time: output (flow rate for dp -> q) measured and fitted, and the
        input (pressure drop), each labelled with its unit.
    """
    u = result.units
    inp, outp = _names(result)
    fig = _new_figure(8.0, 6.0)
    ax, axi = fig.subplots(2, 1, sharex=True, height_ratios=[2.2, 1.0])
    ax.plot(result.t, result.data, color="0.35", linewidth=2.4, alpha=0.75,
            label="measured / reference")
    if np.any(np.isfinite(result.fitted)):
        ax.plot(result.t, result.fitted, color="tab:red", linewidth=1.3,
                label=f"fitted {result.model_name}")
    ax.set_ylabel(f"{outp} [{u.position}]")
    ax.set_title(f"{result.model_name}: {inp} -> {outp}, R² = {result.r2:.6g}")
    ax.legend(loc="best")
    axi.plot(result.t, result.load, color="tab:blue", linewidth=1.2)
    axi.set_ylabel(f"{inp} [{u.load}]")
    axi.set_xlabel("time [s]")
    for a in (ax, axi):
        a.grid(True, alpha=0.3)
    return fig


def plot_flow_characteristic(result: FitResult) -> Figure:
    """Output against input: the measured trajectory, the fitted one and the steady map."""
    u = result.units
    inp, outp = _names(result)
    fig = _new_figure(6.8, 5.2)
    ax = fig.add_subplot()
    ax.plot(result.load, result.data, ".", color="0.35", markersize=3,
            label="measured / reference")
    if np.any(np.isfinite(result.fitted)):
        ax.plot(result.load, result.fitted, ".", color="tab:red", markersize=2,
                label=f"fitted {result.model_name}")
    if result.model is not None and np.ptp(result.load) > 0:
        grid = np.linspace(min(0.0, result.load.min()), result.load.max(), 200)
        steady = getattr(result.model, "steady_flow", None)
        level = steady(grid) if steady is not None else result.params["gain"] * grid
        ax.plot(grid, level, "--", color="tab:green", label="fitted steady state")
    ax.set_xlabel(f"{inp} [{u.load}]")
    ax.set_ylabel(f"{outp} [{u.position}]")
    ax.set_title(f"{result.model_name}: {outp} against {inp}")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return fig


def flow_figures(result: FitResult) -> dict[str, Figure]:
    """The standard figures of a flow fit: time series, characteristic, residuals, history."""

    return {"flow": plot_flow_fit(result), "characteristic": plot_flow_characteristic(result),
            "residuals": plot_residuals(result), "history": plot_history(result)}


def plot_tau_vs_step(study: StepStudy) -> Figure:
    """Time constant against the pressure-drop step, log-log, with per-step R^2.

    The markers are FirstOrderLag fits to each reference start-up (what a linear surrogate
    reports at each step); the lines are the apparent time constants of the surrogates fitted
    with ONE parameter set to all steps; the dashed line is the self-similar slope
    (1 - n)/n through the middle point.
    """
    fig = _new_figure(8.5, 7.0)
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2.0, 1.0])
    st = study.steps
    ax.loglog(st, study.tau_linear, "o", color="black", markersize=7,
              label="linear first-order fit to each reference start-up")
    styles = {"power-law": ("tab:blue", "s-"), "shear-thinning": ("tab:red", "^-")}
    for key, res in study.joint.items():
        color, mk = styles.get(key, ("tab:green", "d-"))
        ax.loglog(st, study.apparent_tau[key], mk, color=color, linewidth=1.3,
                  label=f"{res.model_name}, one parameter set (apparent tau)")
    mid = len(st) // 2
    guide = study.tau_linear[mid] * (st / st[mid]) ** study.predicted_exponent
    ax.loglog(st, guide, "--", color="0.5",
              label=f"self-similar slope (1-n)/n = {study.predicted_exponent:.3g}")
    ax.set_ylabel("time constant tau [s]")
    ax.set_title(f"Start-up of a power-law fluid (n = {study.fluid.n:g}): time constant vs "
                 f"pressure-drop step")
    ax.legend(loc="best", fontsize=8.5)
    one_minus = 1.0 - np.array([r.r2 for r in study.linear])
    ax2.semilogy(st, np.maximum(one_minus, 1e-16), "o", color="black",
                 label="linear, fitted per step")
    for key, res in study.joint.items():
        color, mk = styles.get(key, ("tab:green", "d-"))
        ax2.semilogy(st, np.maximum(1.0 - study.joint_r2(key), 1e-16), mk, color=color,
                     label=f"{res.model_name}, one set")
    ax2.set_xscale("log")
    ax2.set_xlabel("pressure-drop step dp [Pa]")
    ax2.set_ylabel("1 - R² [-]")
    ax2.legend(loc="best", fontsize=8.5)
    for a in (ax, ax2):
        a.grid(True, which="both", alpha=0.3)
    return fig


# --------------------------------------------------------------------------- outputs
def _title(result: FitResult) -> str:
    inp, outp = _names(result)
    return f"pumpid flow fit: {result.model_name}, {inp} in, {outp} out"


def _flow_notes(result: FitResult, notes: str | Sequence[str] | None) -> list[str]:
    out = [notes] if isinstance(notes, str) else [str(n) for n in notes or ()]
    info = result.application.get("flow", {})
    if info.get("source"):
        out.append(f"record: {info['source']}")
    out += [str(n) for n in info.get("notes", []) if str(n) not in out]
    if info.get("initial_state"):
        out.append(f"initial state: {info['initial_state']}")
    if info.get("dp_ref"):
        out.append(f"pressure reference of the power-law map: dp_ref = {info['dp_ref']:g} Pa "
                   "(gain = steady q/dp there)")
    out.append("report wording: 'load' is the model input and 'position' the model output "
               f"({info.get('input', 'pressure drop')} and {info.get('output', 'flow rate')}); "
               "the scale C and offset are fixed (1 and 0)")
    return out


def write_flow_outputs(
    result: FitResult,
    out_dir: str | os.PathLike[str],
    *,
    notes: str | Sequence[str] | None = None,
    title: str | None = None,
    extra_figures: Mapping[str, Figure] | None = None,
    extra_sections: Mapping[str, Any] | None = None,
) -> dict[str, Path]:
    """Write the figures (PNG), ``result.json`` and ``report.html`` of a flow fit.

    The files are those of :func:`pumpid.report.write_outputs`, with figures labelled for
    pressure drop and flow rate (``flow.png``, ``characteristic.png``, ``residuals.png``,
    ``history.png``) instead of the card figures.
    """

    figs = {**flow_figures(result), **dict(extra_figures or {})}
    return write_outputs(result, out_dir, title=title or _title(result), figures=figs,
                         notes=_flow_notes(result, notes), extra_sections=extra_sections)


def write_study_outputs(study: StepStudy, out_dir: str | os.PathLike[str]) -> dict[str, Path]:
    """Write the step study: ``tau_vs_step.png``, ``study.csv``, ``study.json`` and a report.

    The report is the standard one for the shear-thinning surrogate fitted to all steps at
    once, with the time-constant figure and the table added.
    """

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path] = {}
    rows = study.rows()
    csv_path = out / "study.csv"
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    paths["csv"] = csv_path
    json_path = out / "study.json"
    json_path.write_text(json.dumps(jsonable(study.to_dict()), indent=2) + "\n",
                         encoding="utf-8")
    paths["study_json"] = json_path
    key = "shear-thinning" if "shear-thinning" in study.joint else next(iter(study.joint))
    res = study.joint[key]
    linear_ok = abs(study.exponent() - study.predicted_exponent)
    verdict = [
        f"The linear first-order surrogate fitted step by step gives time constants that grow "
        f"with the step like dp^{study.exponent():.3f} (self-similarity predicts "
        f"dp^{study.predicted_exponent:.3f}, difference {linear_ok:.3f}): one linear model "
        "cannot describe all steps.",
    ]
    for k, r in study.joint.items():
        verdict.append(
            f"{r.model_name} with one parameter set for all steps: apparent time constant "
            f"~ dp^{study.exponent(study.apparent_tau[k]):.3f}, R^2 per step "
            f"{np.min(study.joint_r2(k)):.5f} ... {np.max(study.joint_r2(k)):.5f}"
            + (" -- it captures the step-size dependence." if abs(
                study.exponent(study.apparent_tau[k]) - study.predicted_exponent) < 0.1
               else " -- it does NOT capture the step-size dependence (its time constant does "
                    "not depend on the step)."))
    paths.update(write_flow_outputs(
        res, out, title=f"pumpid flow study: time constant vs pressure-drop step "
                        f"(n = {study.fluid.n:g})",
        notes=[f"{len(study.records)} reference start-ups from rest (pumpid.flow.pipeflow), "
               f"window '{study.window}'; the time-series figures show them end to end on one "
               "axis, each starting from rest", *verdict],
        extra_figures={"tau_vs_step": plot_tau_vs_step(study)},
        extra_sections={"Time constant against step size": study.table(),
                        "Conclusion": "\n".join(verdict)},
    ))
    return paths
