"""Reports of fits: figures (matplotlib, never pyplot) and one self-contained HTML file."""

from __future__ import annotations

import importlib
from typing import Any

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

# The figures and the page need matplotlib; the output module and the units do not. Names
# are loaded on first use so that ``pumpid.report.output`` stays light for the CLI.
_WHERE = {
    "render_html": "html", "write_outputs": "html", "write_report": "html",
    "DEFAULT_DPI": "plots", "FIGURE_NAMES": "plots", "figure_to_png": "plots",
    "make_figures": "plots", "plot_card": "plots", "plot_displacement": "plots",
    "plot_history": "plots", "plot_prediction": "plots", "plot_residuals": "plots",
    "save_figures": "plots", "save_png": "plots",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        module = importlib.import_module(f".{_WHERE[name]}", __name__)
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
