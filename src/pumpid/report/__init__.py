"""Reports of fits: figures (matplotlib, never pyplot) and one self-contained HTML file."""

from .html import render_html, write_outputs, write_report
from .plots import (
    DEFAULT_DPI,
    FIGURE_NAMES,
    figure_to_png,
    make_figures,
    plot_card,
    plot_displacement,
    plot_history,
    plot_prediction,
    plot_residuals,
    save_figures,
    save_png,
)

__all__ = [
    "DEFAULT_DPI",
    "FIGURE_NAMES",
    "figure_to_png",
    "make_figures",
    "plot_card",
    "plot_displacement",
    "plot_history",
    "plot_prediction",
    "plot_residuals",
    "render_html",
    "save_figures",
    "save_png",
    "write_outputs",
    "write_report",
]
