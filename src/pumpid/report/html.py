"""A single self-contained HTML report of a fit, and the standard set of output files.

The report is one HTML5 file: the figures are embedded as base64 PNG data URIs and the style
sheet is inline, so it can be mailed, archived or opened offline without losing anything. It
contains no JavaScript and loads nothing from the network. Every piece of text that comes from
the result or the caller is escaped, because warnings, notes and reasons may quote file
contents.
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from ..cards import printable
from ..result import FitResult
from .markup import bullet_list, escape, number, section, value_html
from .output import OutputError, atomic_write, safe_name
from .plots import (
    DEFAULT_DPI,
    figure_to_png,
    make_figures,
    plot_prediction,
    status_text,
    unit_text,
)
from .sections import (
    boundary_html,
    correlation_html,
    derived_html,
    history_html,
    identifiability_html,
    input_html,
    model_choice_html,
    params_html,
    prediction_arrays,
    prediction_html,
    prediction_source,
    quality_html,
    status_html,
    summary_html,
)

__all__ = ["render_html", "write_outputs", "write_report"]

#: Caption of each standard figure in the report.
CAPTIONS: dict[str, str] = {
    "displacement": "Measured and fitted displacement over time.",
    "card": "Dynamometer card: the measured load against the measured position and against "
            "the model's fitted position.",
    "residuals": "Residual (fitted minus measured) over time with the ±RMSE band, and its "
                 "distribution.",
    "history": "Convergence: cost per iteration (a log scale when it falls by more than a "
               "factor of 10), and the relative change of each fitted value per iteration.",
    "prediction": "Prediction of a record the model was not fitted on.",
    "flow": "Measured and fitted flow rate over time, with the pressure drop that drives it.",
    "characteristic": "Flow rate against pressure drop: record and surrogate.",
    "tau_vs_step": "Time constant against the size of the pressure-drop step: a linear "
                   "first-order fit per step, and the surrogates with one parameter set.",
}

# Keys of result.extra that have their own section, so the catch-all "other results" section
# leaves them out. "edges" (solver indices that hit the log-parameter clip) is internal: its
# meaning is reported by "boundaries".
_KNOWN_EXTRA = ("model_name", "gauge", "start", "card", "stderr", "ci95", "stderr_hac",
                "ci95_hac", "stderr_white", "ci95_white", "errors_shown", "correlation",
                "identifiability", "boundaries", "reduced", "prediction", "edges",
                "covariance", "sigma2", "uncertainty", "determined", "derived",
                "model_choice")

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 2em auto;
       max-width: 72em; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
th { background: #f2f2f2; }
td.num { text-align: right; font-family: ui-monospace, Menlo, Consolas, monospace;
         white-space: nowrap; }
table.history td { text-align: right; font-family: ui-monospace, Menlo, Consolas, monospace; }
.ok { color: #176a2c; font-weight: bold; }
.warn { color: #9a5b00; font-weight: bold; }
.bad { color: #b00020; font-weight: bold; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { color: #555; font-size: 0.92em; }
pre { white-space: pre-wrap; background: #f7f7f7; padding: 0.6em; border: 1px solid #e4e4e4; }
footer { margin-top: 2em; color: #777; font-size: 0.85em; }
"""


# --------------------------------------------------------------------------- page parts
def _version() -> str:
    try:
        return metadata.version("pumpid")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


def _figures_html(pngs: Mapping[str, bytes]) -> str:
    out = []
    for name, png in pngs.items():
        data = base64.b64encode(png).decode("ascii")
        caption = CAPTIONS.get(name, name)
        out.append(
            f'<figure id="fig-{escape(name)}">\n'
            f'<img src="data:image/png;base64,{data}" alt="{escape(name)}: {escape(caption)}">\n'
            f"<figcaption>{escape(caption)}</figcaption>\n</figure>"
        )
    return "\n".join(out)


def _extra_sections_html(
    sections: Mapping[str, Any] | Iterable[tuple[str, Any]],
) -> list[str]:
    items = sections.items() if isinstance(sections, Mapping) else sections
    out = []
    for heading, body in items:
        if isinstance(body, str):
            # Plain text, often preformatted (tables from result.report()): keep the layout.
            html_body = f"<pre>{escape(body)}</pre>"
        else:
            html_body = value_html(body)
        out.append(section(str(heading), html_body))
    return out


def _to_pngs(figures: Mapping[str, Figure | bytes], dpi: float) -> dict[str, bytes]:
    out = {}
    for name, fig in figures.items():
        if isinstance(fig, bytes | bytearray):
            if not bytes(fig).startswith(b"\x89PNG\r\n\x1a\n"):
                raise ValueError(f"figure {name!r}: bytes given are not a PNG image")
            out[name] = bytes(fig)
        elif isinstance(fig, Figure):
            out[name] = figure_to_png(fig, dpi)
        else:
            raise TypeError(f"figure {name!r}: expected a matplotlib Figure or PNG bytes, "
                            f"got {type(fig).__name__}")
    return out


def _default_figures(
    result: FitResult, prediction: Mapping[str, Any] | None = None
) -> dict[str, Figure]:
    figs: dict[str, Figure] = dict(make_figures(result))
    pred = prediction_arrays(prediction_source(result, prediction))
    if pred is not None:
        figs["prediction"] = plot_prediction(result, pred["t"], pred["load"], pred["measured"],
                                             pred["predicted"], label=pred["label"])
    return figs


def _all_notes(result: FitResult, notes: str | Sequence[str] | None) -> list[str]:
    """The caller's notes, then the card's own notes not already among them."""
    out = [notes] if isinstance(notes, str) else [str(n) for n in notes or ()]
    card = result.extra.get("card")
    if isinstance(card, Mapping) and isinstance(card.get("notes"), list | tuple):
        out += [str(n) for n in card["notes"] if str(n) not in out]
    return out


# --------------------------------------------------------------------------- public API
def render_html(
    result: FitResult,
    *,
    title: str | None = None,
    figures: Mapping[str, Figure | bytes] | None = None,
    extra_sections: Mapping[str, Any] | Iterable[tuple[str, Any]] | None = None,
    notes: str | Sequence[str] | None = None,
    prediction: Mapping[str, Any] | None = None,
    dpi: float = DEFAULT_DPI,
) -> str:
    """The fit report as one self-contained HTML5 document.

    Parameters
    ----------
    result : FitResult
        The fit to report.
    title : str, optional
        Page title and heading (default ``"pumpid fit: <model> model"``).
    figures : mapping of name to Figure or PNG bytes, optional
        Figures to embed, in order. None renders the standard ones (displacement, card,
        residuals, history, and the prediction when it has arrays); an empty mapping embeds
        none.
    extra_sections : mapping or iterable of (heading, body), optional
        More sections at the end; a string body is shown as preformatted text, anything
        else (list, mapping, numbers) as lists and tables. All text is escaped.
    notes : str or sequence of str, optional
        Notes on the input data (source, cleaning, stroke chosen, ...). Notes stored in
        ``result.extra["card"]["notes"]`` are added when not already given.
    prediction : mapping, optional
        A prediction of another record, as returned by ``identify.predict_card``: arrays
        ``t``, ``load``, ``measured``, ``predicted`` and a ``card`` id or ``label``. Default:
        ``result.extra["prediction"]`` (arrays, or only its ``rmse``/``r2`` scores).
    dpi : float
        Resolution of figures given as Figure objects.

    Returns
    -------
    str
        The HTML document (UTF-8 text, no scripts, no external resources).
    """
    card_id = result.card.id if result.card is not None else None
    default_title = (f"pumpid fit: card {card_id}, {result.model_name} model" if card_id
                     else f"pumpid fit: {result.model_name} model")
    page_title = title if title is not None else default_title
    if figures is None:
        figures = _default_figures(result, prediction)
    pngs = _to_pngs(figures, dpi)
    pos = result.units.position

    body: list[str] = [f"<h1>{escape(page_title)}</h1>"]
    body.append(
        f"<p>{escape(result.model_name)} model, {escape(result.method)} fit: "
        f"{escape(status_text(result))}; RMSE = {escape(number(result.rmse))} "
        f"{escape(unit_text(pos))}, R² = {escape(number(result.r2, 8))}.</p>"
    )
    body.append(section("Summary", summary_html(result), sid="summary"))
    input_part = input_html(result)
    if input_part:
        body.append(section("Input data", input_part, sid="input"))
    all_notes = _all_notes(result, notes)
    if all_notes:
        body.append(section("Notes on the input data", bullet_list(all_notes), sid="notes"))
    body.append(section("Convergence", status_html(result), sid="convergence"))
    body.append(section("Parameters", params_html(result), sid="parameters"))
    body.append(section("Fit quality", quality_html(result), sid="quality"))
    if result.derived:
        body.append(section("Derived quantities", derived_html(result), sid="derived"))
    if result.warnings:
        body.append(section("Warnings", bullet_list(result.warnings), sid="warnings"))
    choice = result.application.get("model_choice")
    if choice:
        # The ranking as a table: "Other results" showed it as a cut-off Python dict.
        body.append(section("Model choice", model_choice_html(choice), sid="choice"))
    boundary_part = boundary_html(result)
    if boundary_part:
        body.append(section("Boundary solution", boundary_part, sid="boundary"))
    if result.model is not None or result.identifiability:
        body.append(section("Identifiability", identifiability_html(result),
                            sid="identifiability"))
    if "correlation" in result.extra:
        body.append(section("Parameter correlation",
                            correlation_html(result, result.extra["correlation"]),
                            sid="correlation"))
    pred_src = prediction_source(result, prediction)
    pred_html = prediction_html(result, pred_src) if pred_src is not None else None
    if pred_html:
        body.append(section("Prediction", pred_html, sid="prediction"))
    if pngs:
        body.append(section("Figures", _figures_html(pngs), sid="figures"))
    other = {k: v for k, v in result.extra.items()
             if k not in _KNOWN_EXTRA or (k == "prediction" and pred_html is None)}
    if other:
        body.append(section("Other results", value_html(other), sid="other"))
    if extra_sections:
        body += _extra_sections_html(extra_sections)
    body.append(section("Iteration history", history_html(result), sid="history"))
    body.append(f"<footer>Generated by pumpid {escape(_version())}.</footer>")

    return "\n".join([
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{escape(page_title)}</title>",
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        *body,
        "</body>",
        "</html>",
        "",
    ])


def _folder(out_dir: str | Path) -> Path:
    """The output folder, created if missing; OutputError when that is impossible."""
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{printable(str(out))}: cannot create the folder "
                          f"({exc.strerror or exc})") from None
    return out


def write_report(
    result: FitResult,
    out_dir: str | Path,
    *,
    name: str = "report.html",
    title: str | None = None,
    figures: Mapping[str, Figure | bytes] | None = None,
    extra_sections: Mapping[str, Any] | Iterable[tuple[str, Any]] | None = None,
    notes: str | Sequence[str] | None = None,
    prediction: Mapping[str, Any] | None = None,
) -> Path:
    """Write :func:`render_html` to ``out_dir/name`` (directory created if missing).

    Returns
    -------
    Path
        The written file.
    """
    out = _folder(out_dir)
    text = render_html(result, title=title, figures=figures, extra_sections=extra_sections,
                       notes=notes, prediction=prediction)
    return atomic_write(out / name, text)


def write_outputs(
    result: FitResult,
    out_dir: str | Path,
    *,
    notes: str | Sequence[str] | None = None,
    prediction: Mapping[str, Any] | None = None,
    title: str | None = None,
    dpi: float = DEFAULT_DPI,
    figures: Mapping[str, Figure | bytes] | None = None,
    extra_sections: Any = None,
) -> dict[str, Path]:
    """Write the figures as PNG files, ``result.json`` and ``report.html`` into ``out_dir``.

    ``figures`` replaces the standard card figures (for other applications, e.g. flow);
    ``extra_sections`` is passed to :func:`render_html`.

    Each figure is rendered once and the same PNG bytes are written to disk and embedded in
    the report.

    Parameters
    ----------
    result : FitResult
    out_dir : str or Path
        Created if missing; existing files of the same names are replaced.
    notes : str or sequence of str, optional
        Notes on the input data, shown in the report.
    prediction : mapping, optional
        See :func:`render_html`; with arrays it also gives ``prediction.png``.
    title : str, optional
        Report title.
    dpi : float
        PNG resolution.

    Returns
    -------
    dict
        Paths by name: the figure names (``displacement``, ``card``, ``residuals``,
        ``history``, and ``prediction`` when there is one with arrays), ``json`` and
        ``report``.
    """
    out = _folder(out_dir)
    chosen = _default_figures(result, prediction) if figures is None else figures
    pngs = _to_pngs(chosen, dpi)
    paths: dict[str, Path] = {}
    for name, png in pngs.items():
        paths[name] = atomic_write(out / f"{safe_name(name)}.png", png)
    doc = result.to_dict()
    if prediction is not None:
        # The file is the report's in machine form: the prediction it shows belongs in it
        # (the scores, as --json gives them; the arrays are the other record's data).
        source = prediction_source(result, prediction)
        # NaN (no fundamental off a whole period) as null, as every other number here.
        doc["prediction"] = {k: (None if isinstance(source[k], float)
                                 and not math.isfinite(source[k]) else source[k])
                             for k in ("card", "rmse", "r2", "r2_fundamental")
                             if k in source}
    paths["json"] = atomic_write(out / "result.json", json.dumps(doc, indent=2) + "\n")
    paths["report"] = write_report(result, out, title=title, figures=pngs, notes=notes,
                                   prediction=prediction, extra_sections=extra_sections)
    return paths
