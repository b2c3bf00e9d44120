"""Figures of a fit: displacement, dynamometer card, residuals, convergence, prediction.

Every function takes a :class:`~pumpid.result.FitResult` and returns a
:class:`matplotlib.figure.Figure` bound to the Agg canvas. ``matplotlib.pyplot`` is never
imported: pyplot keeps a global figure registry and picks an interactive backend, so using it
from a library leaks figures, needs a display on some systems and is unsafe when several fits
are plotted from different threads. A figure built here is an ordinary object that is
garbage-collected when dropped.

Axis labels always carry the quantity and its unit taken from ``result.units``.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from ..models import OwnModel
from ..result import FitResult
from .output import atomic_write
from .units import UNSTATED_UNITS, model_param_units, unit_text

__all__ = [
    "DEFAULT_DPI",
    "FIGURE_NAMES",
    "UNSTATED_UNITS",
    "figure_to_png",
    "has_history_figure",
    "history_columns",
    "make_figures",
    "model_param_units",
    "plot_card",
    "plot_displacement",
    "plot_history",
    "plot_prediction",
    "plot_residuals",
    "prediction_stats",
    "save_figures",
    "save_png",
    "status_text",
    "unit_text",
]

#: Resolution of written PNGs: sharp on a normal screen, small enough to embed in a report.
DEFAULT_DPI = 110
#: The standard figures, in report order; the PNG file of each is ``<name>.png``.
FIGURE_NAMES: tuple[str, ...] = ("displacement", "card", "residuals", "history")

# History columns that are not fitted values.
_NOT_PARAMS = ("iteration", "cost", "epsilon")
_MEASURED_STYLE = {"color": "0.35", "linewidth": 2.4, "alpha": 0.75}
_MODEL_STYLE = {"color": "tab:red", "linewidth": 1.3}


# --------------------------------------------------------------------------- helpers
def _label(quantity: str, unit: str) -> str:
    """Axis label ``quantity [unit]`` (unit-less quantities get ``[-]``)."""
    return f"{quantity} [{unit_text(unit) or '-'}]"


def has_history_figure(result: FitResult) -> bool:
    """Whether the iteration history is worth a figure: two or more solver iterations.

    A fit whose start was already at the optimum makes one iteration (or none): its cost
    changes in the last digits and its parameters not at all, so a convergence plot would
    show only an axis; the report's history table says what happened instead.
    """
    iterations = [row.get("iteration") for row in result.history]
    return sum(1 for i in iterations if i is not None and i > 0) >= 2


def _fmt(value: float | None, digits: int = 4) -> str:
    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:.{digits}g}"


def _r2_text(r2: float | None) -> str:
    # An R^2 of 0.99993 printed with 4 digits reads "0.9999"; more digits keep good fits apart.
    return f"R² = {_fmt(r2, 6)}"


def _new_figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)  # binds itself to fig; no global backend state is touched
    return fig


def _finite_any(values: NDArray[np.float64]) -> bool:
    return bool(np.any(np.isfinite(values)))


def _note(ax: Axes, text: str) -> None:
    """Write a short message in the middle of an axes (e.g. why a curve is missing)."""
    # Bottom right: the middle of a card plot is usually crossed by the measured loop.
    ax.text(0.98, 0.03, text, transform=ax.transAxes, ha="right", va="bottom",
            fontsize=10, color="tab:red",
            bbox={"boxstyle": "round", "facecolor": "white", "edgecolor": "tab:red"})


def status_text(result: FitResult) -> str:
    """Short status, the result's own word: "converged", "boundary (limiting model)",
    "undetermined (the data do not determine the parameters)", "poor-fit (the model misses
    the data)" or "failed (NOT converged)" (an undetermined or poor fit is an optimum the
    solver converged to: calling it not converged contradicted the result's status)."""
    status = getattr(result, "status", None) or ("converged" if result.converged else "failed")
    words = {"converged": "converged", "boundary": "boundary (limiting model)",
             "undetermined": "undetermined (the data do not determine the parameters)",
             "poor-fit": "poor-fit (the model misses the data)",
             "failed": "failed (NOT converged)", "invalid-input": "invalid-input (not fitted)"}
    return words.get(str(status), str(status))


def _model_label(result: FitResult) -> str:
    return f"fitted {result.model_name} (output {result.observe})"


# --------------------------------------------------------------------------- figures
def plot_displacement(result: FitResult) -> Figure:
    """Measured and fitted displacement over time.

    Parameters
    ----------
    result : FitResult
        A fit; the measured data are ``result.data``, the model's ``result.fitted``.

    Returns
    -------
    Figure
        One axes: time [s] against displacement in the position unit.
    """
    u = result.units
    fig = _new_figure(8.0, 4.5)
    ax = fig.add_subplot()
    ax.plot(result.t, result.data, label="measured", **_MEASURED_STYLE)
    if _finite_any(result.fitted):
        ax.plot(result.t, result.fitted, label=_model_label(result), **_MODEL_STYLE)
    else:
        _note(ax, "no finite fitted response (the fit failed)")
    ax.set_xlabel(_label("time", u.time))
    # A lumped model's output is the displacement; an own model names its own.
    what = result.observe if isinstance(result.model, OwnModel) else "displacement"
    ax.set_ylabel(_label(what, u.position))
    ax.set_title(f"{result.model_name}: measured vs fitted {what}, {_r2_text(result.r2)}")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return fig


def plot_card(result: FitResult) -> Figure:
    """The dynamometer card: load against position, measured and model loop.

    The model loop is the measured load against the *fitted* displacement, so both loops
    share the load axis and differ only where the model misplaces the rod.

    Parameters
    ----------
    result : FitResult

    Returns
    -------
    Figure
        One axes: position on x, load on y (the usual card orientation).
    """
    u = result.units
    fig = _new_figure(6.8, 5.4)
    ax = fig.add_subplot()
    ax.plot(result.data, result.load, label="measured card", **_MEASURED_STYLE)
    if _finite_any(result.fitted):
        ax.plot(result.fitted, result.load, label=f"model card ({result.model_name})",
                **_MODEL_STYLE)
    else:
        _note(ax, "no finite fitted response (the fit failed)")
    # Mark where the record starts so the direction round the loop can be read off.
    ax.plot(result.data[:1], result.load[:1], "o", color="0.2", markersize=5, label="start")
    ax.set_xlabel(_label("position", u.position))
    ax.set_ylabel(_label("load", u.load))
    ax.set_title(f"{result.model_name}: dynamometer card, {_r2_text(result.r2)}")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return fig


def plot_residuals(result: FitResult) -> Figure:
    """Residual (fitted minus measured) over time, with its histogram beside it.

    Parameters
    ----------
    result : FitResult

    Returns
    -------
    Figure
        Two axes: residual against time with a +-RMSE band, and the residual histogram on
        the same vertical scale (so structure in time and the spread are read together).
    """
    u = result.units
    res = np.asarray(result.residuals, dtype=float)
    finite = res[np.isfinite(res)]
    fig = _new_figure(9.0, 4.2)
    ax, axh = fig.subplots(1, 2, sharey=True, width_ratios=[3.2, 1.0])
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    if finite.size:
        ax.plot(result.t, res, color="tab:blue", linewidth=1.0, label="residual")
        if math.isfinite(result.rmse):
            for sign in (1.0, -1.0):
                ax.axhline(sign * result.rmse, color="tab:orange", linestyle="--",
                           linewidth=1.0, label="± RMSE" if sign > 0 else None)
        axh.hist(finite, bins=min(40, max(5, finite.size // 10)), orientation="horizontal",
                 color="tab:blue", alpha=0.7)
        ax.legend(loc="best")
    else:
        _note(ax, "no finite residuals (the fit failed)")
        if result.t.size > 1:
            ax.set_xlim(float(result.t[0]), float(result.t[-1]))
    ax.set_xlabel(_label("time", u.time))
    ax.set_ylabel(_label("residual (fitted - measured)", u.position))
    ax.set_title(f"{result.model_name}: residuals, RMSE = {_fmt(result.rmse)} "
                 f"{unit_text(u.position)}, {_r2_text(result.r2)}")
    axh.set_xlabel(_label("count", "samples"))
    axh.set_title("distribution")
    for a in (ax, axh):
        a.grid(True, alpha=0.3)
    return fig


def history_columns(history: Sequence[Mapping[str, float]]) -> list[str]:
    """All keys of the history rows in first-seen order.

    Rows may differ: a solver that stops early leaves the cost of its last row unset.
    """
    keys: dict[str, None] = {}
    for row in history:
        keys.update(dict.fromkeys(row))
    return list(keys)


def _history_array(history: Sequence[Mapping[str, float]], key: str) -> NDArray[np.float64]:
    out = []
    for row in history:
        value = row.get(key)
        out.append(math.nan if value is None else float(value))
    return np.array(out, dtype=float)


def _positive(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Values for a log axis: non-positive or non-finite entries become gaps."""
    return np.where(np.isfinite(values) & (values > 0), values, np.nan)


def plot_history(result: FitResult) -> Figure:
    """Convergence history: cost and relative change of every fitted value per iteration.

    The cost is drawn on a log axis when it spans at least a factor 10, else on a linear one.

    The relative change of a parameter at iteration k is ``|x_k - x_(k-1)| / ref`` with
    ``ref`` the size of its final value; the offset can legitimately end near zero, so its
    change is measured against the range of the data instead. Zero changes are not drawn on
    the log axis. For the paper's method the step norm ``epsilon`` (eq. 21) is also shown.

    Parameters
    ----------
    result : FitResult

    Returns
    -------
    Figure
        Two axes sharing the iteration axis.
    """
    hist = result.history
    fig = _new_figure(8.0, 6.4)
    ax_cost, ax_step = fig.subplots(2, 1, sharex=True)
    status = status_text(result)
    counted = [row.get("iteration") for row in hist if row.get("iteration") is not None]
    steps = int(max(counted)) if counted else max(len(hist) - 1, 0)
    fig.suptitle(f"{result.model_name}: convergence of the {result.method} solver, "
                 f"{steps} iteration{'s' if steps != 1 else ''}, {status}, "
                 f"{_r2_text(result.r2)}")
    cost_unit = result.cost_unit("²")
    ax_cost.set_ylabel(_label("cost ½Σr²", cost_unit))
    ax_step.set_ylabel(_label("relative change per iteration", "-"))
    ax_step.set_xlabel(_label("iteration", "-"))
    for a in (ax_cost, ax_step):
        a.grid(True, which="both", alpha=0.3)
    if not hist:
        _note(ax_cost, "no iterations recorded")
        return fig

    it = _history_array(hist, "iteration")
    # Markers show individual iterations of short runs; on long runs they only smear lines.
    marker = "o-" if len(hist) <= 60 else "-"
    cost = _positive(_history_array(hist, "cost"))
    if _finite_any(cost):
        ax_cost.plot(it, cost, marker, color="black", markersize=4, label="cost")
        # A log axis over less than a decade has no major ticks and labels its minor ticks
        # with identical rounded numbers (a fit started at its optimum changes the cost only
        # in the 7th digit); a linear axis with an offset reads correctly there.
        top, bottom = float(np.nanmax(cost)), float(np.nanmin(cost))
        if top >= 10.0 * bottom:
            ax_cost.set_yscale("log")
        elif top - bottom <= 1e-6 * top:
            # A change in the 10th digit filled the axis as a steep drop under an offset
            # label ("1e-11+4.28864247e-1"): drawn flat on a scale of 0.1 % of the cost.
            middle = 0.5 * (top + bottom)
            ax_cost.set_ylim(middle * (1.0 - 1e-3), middle * (1.0 + 1e-3))
            ax_cost.ticklabel_format(axis="y", useOffset=False)
            _note(ax_cost, f"the cost changed by {(top - bottom) / top:.1e} of itself")
        else:
            ax_cost.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4), useOffset=True)
    else:
        _note(ax_cost, "no positive finite cost recorded")

    data_range = float(np.ptp(result.data[np.isfinite(result.data)])) if _finite_any(
        result.data) else 1.0
    drawn = 0
    for key in history_columns(hist):
        if key in _NOT_PARAMS:
            continue
        vals = _history_array(hist, key)
        if vals.size < 2:
            continue
        if key == "offset":
            ref, name = data_range or 1.0, "offset (vs data range)"
        else:
            finite_vals = vals[np.isfinite(vals)]
            ref = abs(float(finite_vals[-1])) if finite_vals.size else math.nan
            name = key
        if not math.isfinite(ref) or ref == 0.0:
            continue
        change = _positive(np.abs(np.diff(vals)) / ref)
        if not _finite_any(change):
            continue
        ax_step.semilogy(it[1:], change, marker, markersize=3, linewidth=1.2, label=name)
        drawn += 1
    if "epsilon" in history_columns(hist):
        eps = _positive(_history_array(hist, "epsilon"))
        if _finite_any(eps):
            ax_step.semilogy(it, eps, "k--", linewidth=1.4, label="step ‖dx‖/‖x0‖ (eq. 21)")
            drawn += 1
    if drawn:
        # Beside the axes: inside, "best" still hid the offset's last iterations.
        ax_step.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
                       frameon=False)
    else:
        _note(ax_step, "fewer than two iterations: no changes to show")
    # Iterations are counts: integer ticks only.
    ax_step.xaxis.get_major_locator().set_params(integer=True)
    return fig


def prediction_stats(measured: ArrayLike, predicted: ArrayLike) -> tuple[float, float]:
    """RMSE and R^2 of a prediction over the samples where both are finite.

    Returns
    -------
    rmse, r2 : float
        NaN when nothing is finite (R^2 also when the measured record is constant).
    """
    m = np.asarray(measured, dtype=float).ravel()
    p = np.asarray(predicted, dtype=float).ravel()
    if m.shape != p.shape:
        raise ValueError(f"measured has {m.size} samples, predicted {p.size}")
    ok = np.isfinite(m) & np.isfinite(p)
    if not ok.any():
        return math.nan, math.nan
    err = p[ok] - m[ok]
    rmse = float(np.sqrt(np.mean(err**2)))
    sst = float(np.sum((m[ok] - m[ok].mean()) ** 2))
    r2 = 1.0 - float(np.sum(err**2)) / sst if sst > 0 else math.nan
    return rmse, r2


def plot_prediction(
    result: FitResult,
    t: ArrayLike,
    load: ArrayLike,
    measured: ArrayLike,
    predicted: ArrayLike,
    *,
    label: str = "another stroke",
) -> Figure:
    """Fit one stroke, predict another: measured vs predicted displacement and card.

    Parameters
    ----------
    result : FitResult
        The fit whose model made the prediction (gives the model name and the units).
    t, load, measured, predicted : array_like, shape (N,)
        Time (s), load, measured and predicted displacement of the held-out record.
    label : str
        What the held-out record is, for the title.

    Returns
    -------
    Figure
        Displacement over time (left) and the card (right); the title gives R^2 and RMSE of
        the prediction with units.
    """
    u = result.units
    t_a, load_a, m_a, p_a = (np.asarray(a, dtype=float).ravel()
                             for a in (t, load, measured, predicted))
    if not (t_a.size == load_a.size == m_a.size == p_a.size):
        raise ValueError("t, load, measured and predicted must have the same length, got "
                         f"{t_a.size}, {load_a.size}, {m_a.size}, {p_a.size}")
    rmse, r2 = prediction_stats(m_a, p_a)
    fig = _new_figure(11.0, 4.6)
    ax_t, ax_c = fig.subplots(1, 2, width_ratios=[1.6, 1.0])
    pred_label = f"predicted ({result.model_name})"
    ax_t.plot(t_a, m_a, label="measured", **_MEASURED_STYLE)
    ax_t.plot(t_a, p_a, label=pred_label, **_MODEL_STYLE)
    ax_t.set_xlabel(_label("time", u.time))
    ax_t.set_ylabel(_label("displacement", u.position))
    ax_t.legend(loc="best")
    ax_c.plot(m_a, load_a, label="measured card", **_MEASURED_STYLE)
    ax_c.plot(p_a, load_a, label="predicted card", **_MODEL_STYLE)
    ax_c.set_xlabel(_label("position", u.position))
    ax_c.set_ylabel(_label("load", u.load))
    ax_c.legend(loc="best")
    for a in (ax_t, ax_c):
        a.grid(True, alpha=0.3)
    fig.suptitle(f"{result.model_name} prediction of {label}: {_r2_text(r2)}, "
                 f"RMSE = {_fmt(rmse)} {unit_text(u.position)}")
    return fig


# --------------------------------------------------------------------------- output
def make_figures(result: FitResult) -> dict[str, Figure]:
    """The standard figures by name (see :data:`FIGURE_NAMES`), in report order.

    The convergence figure is left out when the solver made fewer than two iterations
    (:func:`has_history_figure`): it would have nothing to show.
    """
    makers = {
        "displacement": plot_displacement,
        "card": plot_card,
        "residuals": plot_residuals,
        "history": plot_history,
    }
    return {name: makers[name](result) for name in FIGURE_NAMES
            if name != "history" or has_history_figure(result)}


def figure_to_png(fig: Figure, dpi: float = DEFAULT_DPI) -> bytes:
    """Render a figure to PNG bytes (white background, so it reads on dark pages too)."""
    buf = io.BytesIO()
    # The figure's own canvas is Agg (see _new_figure); savefig(format="png") renders through
    # it, independent of whatever backend pyplot may be configured with elsewhere.
    fig.savefig(buf, format="png", dpi=dpi, facecolor="white")
    return buf.getvalue()


def save_png(fig: Figure, path: str | Path, dpi: float = DEFAULT_DPI) -> Path:
    """Write a figure as a PNG file and return its path."""
    return atomic_write(path, figure_to_png(fig, dpi))


def save_figures(
    result: FitResult, out_dir: str | Path, *, dpi: float = DEFAULT_DPI
) -> dict[str, Path]:
    """Write the standard figures as ``<name>.png`` into ``out_dir`` (created if missing).

    Returns
    -------
    dict
        ``{"displacement": .../displacement.png, "card": ..., "residuals": ...,
        "history": ...}`` (no ``history`` for a fit of fewer than two iterations).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return {name: save_png(fig, out / f"{name}.png", dpi)
            for name, fig in make_figures(result).items()}
