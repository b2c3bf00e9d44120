"""Figures: labelled axes with units, legends, titles, and PNGs that are real images."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys

import matplotlib.image
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure

import pumpid
from pumpid.report import plots
from pumpid.result import FitResult, Status

# Units that cannot be mistaken for anything else in a label.
UNITS = pumpid.Units(load="lbf", position="in")


@pytest.fixture(scope="module")
def result() -> FitResult:
    t = np.linspace(0.0, 8.0, 400)
    load = 9000 + 3000 * np.sin(2 * np.pi * t / 8) + 800 * np.sin(4 * np.pi * t / 8 + 0.4)
    true = pumpid.Kelvin(k0=120, m=2.0, c1=60, k1=90)
    disp = pumpid.simulate(true, t, load, initial_state="periodic")
    disp = disp + 0.2 * np.random.default_rng(0).standard_normal(t.size)
    res = pumpid.fit(pumpid.Kelvin(k0=100, m=2.5, c1=50, k1=80), (t, load, disp),
                     options=pumpid.FitOptions(initial_state="periodic", offset=True),
                     units=UNITS)
    assert res.converged
    return res


@pytest.fixture(scope="module")
def failed(result: FitResult) -> FitResult:
    """A fit that produced no parameters: NaN everywhere, history cut short."""
    nan_params = dict.fromkeys(result.params, math.nan)
    return result.with_parts(
        model=None, params=nan_params, scale=math.nan, offset=math.nan,
        status=Status.FAILED, reason="stopped", rmse=math.nan, r2=math.nan,
        fitted=np.full_like(result.data, np.nan), history=result.history[:1],
        uncertainty=None,
    )


def _axes(fig: Figure) -> list[Axes]:
    return list(fig.axes)


def _check_labels(ax: Axes, x_unit: str, y_unit: str) -> None:
    assert ax.get_xlabel().endswith(f"[{x_unit}]"), ax.get_xlabel()
    assert ax.get_ylabel().endswith(f"[{y_unit}]"), ax.get_ylabel()


def _legend_texts(ax: Axes) -> list[str]:
    legend = ax.get_legend()
    assert legend is not None, "expected a legend"
    return [t.get_text() for t in legend.get_texts()]


def _title(fig: Figure) -> str:
    sup = fig.get_suptitle()
    return sup or fig.axes[0].get_title()


def test_displacement_axes_legend_title(result: FitResult) -> None:
    fig = plots.plot_displacement(result)
    (ax,) = _axes(fig)
    _check_labels(ax, "s", "in")
    assert ax.get_xlabel().startswith("time")
    texts = _legend_texts(ax)
    assert len(texts) == 2 and "measured" in texts
    title = _title(fig)
    assert "Kelvin" in title and "R²" in title
    # The fitted line is the fitted array, not a copy of the data.
    np.testing.assert_array_equal(ax.lines[1].get_ydata(), result.fitted)


def test_card_is_load_against_position(result: FitResult) -> None:
    fig = plots.plot_card(result)
    (ax,) = _axes(fig)
    _check_labels(ax, "in", "lbf")
    assert ax.get_xlabel().startswith("position") and ax.get_ylabel().startswith("load")
    assert len(_legend_texts(ax)) >= 2
    measured, model = ax.lines[0], ax.lines[1]
    np.testing.assert_array_equal(measured.get_xdata(), result.data)
    np.testing.assert_array_equal(model.get_xdata(), result.fitted)
    np.testing.assert_array_equal(model.get_ydata(), result.load)
    assert "R²" in _title(fig)


def test_residuals_panels(result: FitResult) -> None:
    fig = plots.plot_residuals(result)
    ax, axh = _axes(fig)
    _check_labels(ax, "s", "in")
    assert axh.get_xlabel()  # histogram counts are labelled too
    assert "RMSE" in " ".join(_legend_texts(ax))
    assert "in" in ax.get_title() and "RMSE" in ax.get_title()
    (line,) = [ln for ln in ax.lines if ln.get_label() == "residual"]
    np.testing.assert_allclose(line.get_ydata(), result.residuals)


def test_history_log_axes(result: FitResult) -> None:
    fig = plots.plot_history(result)
    ax_cost, ax_step = _axes(fig)
    assert ax_cost.get_yscale() == "log" and ax_step.get_yscale() == "log"
    assert ax_cost.get_ylabel().endswith("[in²]")
    assert ax_step.get_xlabel().startswith("iteration")
    texts = _legend_texts(ax_step)
    for name in result.params:
        assert name in texts
    assert any("offset" in t for t in texts)
    assert "converged" in _title(fig) and "Kelvin" in _title(fig)


def test_history_small_cost_range_is_readable(result: FitResult) -> None:
    """Less than a decade of cost: a linear axis, whose tick labels are distinct."""
    hist = [{"iteration": 0.0, "k0": 1.0, "cost": 4.6024512},
            {"iteration": 1.0, "k0": 1.0 + 1e-8, "cost": 4.6024511}]
    fig = plots.plot_history(dataclasses.replace(result, history=hist))
    ax_cost = fig.axes[0]
    assert ax_cost.get_yscale() == "linear"
    plots.figure_to_png(fig, dpi=40)  # draws, so the tick labels exist
    labels = [t.get_text() for t in ax_cost.get_yticklabels() if t.get_text()]
    assert len(set(labels)) == len(labels) >= 2


def test_history_columns_union_in_order() -> None:
    rows = [{"iteration": 0, "a": 1.0, "cost": 2.0}, {"iteration": 1, "a": 2.0, "eps": 0.1}]
    assert plots.history_columns(rows) == ["iteration", "a", "cost", "eps"]


def test_prediction_title_stats() -> None:
    t = np.linspace(0, 1, 50)
    measured = np.sin(2 * np.pi * t)
    predicted = measured + 0.1
    rmse, r2 = plots.prediction_stats(measured, predicted)
    assert rmse == pytest.approx(0.1)
    assert r2 == pytest.approx(1 - 50 * 0.01 / np.sum((measured - measured.mean()) ** 2))


def test_prediction_figure(result: FitResult) -> None:
    pred = result.fitted + 0.5
    fig = plots.plot_prediction(result, result.t, result.load, result.data, pred,
                                label="stroke 2")
    ax_t, ax_c = _axes(fig)
    _check_labels(ax_t, "s", "in")
    _check_labels(ax_c, "in", "lbf")
    assert len(_legend_texts(ax_t)) == 2 and len(_legend_texts(ax_c)) == 2
    rmse, r2 = plots.prediction_stats(result.data, pred)
    title = _title(fig)
    assert "stroke 2" in title and f"{r2:.6g}" in title and f"{rmse:.4g} in" in title
    with pytest.raises(ValueError, match="same length"):
        plots.plot_prediction(result, result.t, result.load, result.data, pred[:-1])


def test_failed_fit_still_plots(failed: FitResult) -> None:
    figs = plots.make_figures(failed)
    # One history row: no convergence figure (it would show only an axis).
    assert list(figs) == [n for n in plots.FIGURE_NAMES if n != "history"]
    figs["history"] = plots.plot_history(failed)
    texts = [t.get_text() for f in figs.values() for a in f.axes for t in a.texts]
    assert any("fit failed" in t for t in texts)
    assert "n/a" in _title(figs["displacement"])
    for fig in figs.values():
        assert plots.figure_to_png(fig, dpi=40).startswith(b"\x89PNG")


def test_save_figures_writes_real_pngs(result: FitResult, tmp_path) -> None:
    paths = plots.save_figures(result, tmp_path / "figs", dpi=100)
    assert set(paths) == {"displacement", "card", "residuals", "history"}
    for name, path in paths.items():
        assert path.name == f"{name}.png" and path.parent == tmp_path / "figs"
        assert path.stat().st_size > 1000
        img = matplotlib.image.imread(path)
        height, width = img.shape[:2]
        assert 300 <= height <= 1500 and 400 <= width <= 1500, (name, img.shape)
        # A blank canvas has zero variance; a plot with lines and text does not.
        assert float(np.var(img[..., :3])) > 1e-4, name


def test_no_pyplot_import() -> None:
    """The plotting module must not touch pyplot's global state (headless, thread-safe)."""
    code = ("import sys, pumpid.report.plots, pumpid.report; "
            "sys.exit(1 if 'matplotlib.pyplot' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_history_figure_only_for_two_or_more_iterations(result: FitResult) -> None:
    """A fit started at its optimum (one iteration) gets no convergence figure."""
    assert len(result.history) >= 3 and plots.has_history_figure(result)
    assert "history" in plots.make_figures(result)
    one = dataclasses.replace(result, history=result.history[:2])
    assert not plots.has_history_figure(one)
    assert list(plots.make_figures(one)) == ["displacement", "card", "residuals"]


def test_history_title_reads_without_nested_brackets(result: FitResult) -> None:
    at_bound = result.with_parts(status=Status.BOUNDARY)
    title = _title(plots.plot_history(at_bound))
    assert "boundary (limiting model)" in title and "))" not in title
    steps = len(result.history) - 1
    assert f"{steps} iterations" in title


def test_unstated_units_are_labelled_as_such(result: FitResult) -> None:
    """A card whose file states no units: axes say so instead of showing placeholders."""
    bare = result.with_parts(units=pumpid.Units(load="load-unit", position="position-unit"))
    ax = plots.plot_card(bare).axes[0]
    assert ax.get_xlabel() == "position [unit not stated]"
    assert ax.get_ylabel() == "load [unit not stated]"
    assert "unit-" not in ax.get_title()


def test_a_cost_that_moves_in_its_tenth_digit_is_drawn_flat(result: FitResult) -> None:
    # A change of 1.6e-10 of the cost filled the axis as a steep drop, labelled
    # "1e-11+4.28864247e-1".
    hist = [{"iteration": 0.0, "k0": 1.0, "cost": 0.42886424707},
            {"iteration": 1.0, "k0": 1.0 + 1e-9, "cost": 0.42886424700}]
    fig = plots.plot_history(dataclasses.replace(result, history=hist))
    ax_cost = fig.axes[0]
    low, high = ax_cost.get_ylim()
    assert high - low == pytest.approx(2e-3 * 0.428864247, rel=1e-3)
    assert any("the cost changed by 1.6e-10 of itself" in t.get_text() for t in ax_cost.texts)
