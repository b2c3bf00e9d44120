"""A single self-contained HTML report of a fit, and the standard set of output files.

The report is one HTML5 file: the figures are embedded as base64 PNG data URIs and the style
sheet is inline, so it can be mailed, archived or opened offline without losing anything. It
contains no JavaScript and loads nothing from the network. Every piece of text that comes from
the result or the caller is escaped, because warnings, notes and reasons may quote file
contents.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Iterable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..cards import printable
from ..models import Model, ParamInfo, model_class
from ..result import FitResult, Prediction
from .output import OutputError, atomic_write, safe_name
from .plots import (
    DEFAULT_DPI,
    figure_to_png,
    has_history_figure,
    history_columns,
    make_figures,
    model_param_units,
    plot_prediction,
    prediction_stats,
    status_text,
    unit_text,
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
                "covariance", "sigma2", "uncertainty", "determined", "derived")
_PREDICTION_KEYS = ("t", "load", "measured", "predicted")

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 2em auto;
       max-width: 72em; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
th { background: #f2f2f2; }
td.num { text-align: right; font-family: ui-monospace, Menlo, Consolas, monospace; }
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


# --------------------------------------------------------------------------- formatting
def _e(text: Any) -> str:
    """Escape any value's text for HTML element content and attribute values."""
    return html.escape(str(text), quote=True)


def _num(value: Any, digits: int = 6) -> str:
    """A number as text; None, NaN and infinities read "n/a" (they mean "not available")."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int | np.integer):
        return str(int(value))
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(x):
        return "n/a"
    return f"{x:.{digits}g}"


def _interval(value: Any) -> str:
    """A confidence interval given as (low, high) or {"lower": .., "upper": ..}."""
    if isinstance(value, Mapping):
        lo, hi = value.get("lower", value.get("low")), value.get("upper", value.get("high"))
        if lo is not None or hi is not None:
            return f"[{_num(lo)}, {_num(hi)}]"
    elif isinstance(value, Sequence | np.ndarray) and not isinstance(value, str):
        if len(value) == 2:
            return f"[{_num(value[0])}, {_num(value[1])}]"
    return _num(value)


def _table(headers: Sequence[str], rows: Iterable[Sequence[str]], *, cls: str = "",
           num_cols: Iterable[int] = ()) -> str:
    """An HTML table; ``headers`` and ``rows`` are plain text (escaped here)."""
    num = set(num_cols)
    attr = f' class="{_e(cls)}"' if cls else ""
    out = [f"<table{attr}>", "<thead><tr>"]
    out += [f"<th>{_e(h)}</th>" for h in headers]
    out.append("</tr></thead>")
    out.append("<tbody>")
    for row in rows:
        cells = "".join(
            f'<td class="num">{_e(c)}</td>' if i in num else f"<td>{_e(c)}</td>"
            for i, c in enumerate(row)
        )
        out.append(f"<tr>{cells}</tr>")
    out.append("</tbody></table>")
    return "\n".join(out)


def _section(heading: str, body: str, *, sid: str = "") -> str:
    attr = f' id="{_e(sid)}"' if sid else ""
    return f"<section{attr}>\n<h2>{_e(heading)}</h2>\n{body}\n</section>"


def _list(items: Iterable[Any]) -> str:
    return "<ul>\n" + "\n".join(f"<li>{_e(i)}</li>" for i in items) + "\n</ul>"


def _value_html(value: Any, depth: int = 0) -> str:
    """Render a value of unknown shape from ``result.extra`` readably (escaped).

    Later analyses store their findings in ``extra`` in whatever structure suits them; this
    shows strings as paragraphs, mappings as two-column tables, lists as bullet lists and
    long numeric arrays as a short summary, so the report never breaks on a new key.
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, str):
        return f"<p>{_e(value)}</p>"
    if isinstance(value, Mapping):
        if depth >= 2:
            return f"<p>{_e(_short(value))}</p>"
        rows = []
        for k, v in value.items():
            if isinstance(v, Mapping | list | tuple | np.ndarray) and not _is_numeric_seq(v):
                cell = _value_html(v, depth + 1)
            else:
                cell = _e(_scalar_text(v))
            rows.append(f"<tr><th>{_e(k)}</th><td>{cell}</td></tr>")
        return "<table>\n" + "\n".join(rows) + "\n</table>"
    if isinstance(value, list | tuple):
        if _is_numeric_seq(value):
            return f"<p>{_e(_scalar_text(value))}</p>"
        if depth >= 2:
            return f"<p>{_e(_short(value))}</p>"
        return "<ul>\n" + "\n".join(
            f"<li>{_value_html(v, depth + 1) if isinstance(v, Mapping) else _e(_scalar_text(v))}"
            "</li>" for v in value
        ) + "\n</ul>"
    return f"<p>{_e(_scalar_text(value))}</p>"


def _is_numeric_seq(value: Any) -> bool:
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "biuf"
    return isinstance(value, list | tuple) and all(
        isinstance(v, int | float | np.number) and not isinstance(v, bool) for v in value
    )


def _scalar_text(value: Any) -> str:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple) and _is_numeric_seq(value):
        if len(value) > 12:
            head = ", ".join(_num(v, 4) for v in value[:6])
            return f"{len(value)} values: {head}, ..."
        return "[" + ", ".join(_num(v) for v in value) + "]"
    if isinstance(value, float | int | np.number) and not isinstance(value, bool):
        return _num(value)
    return _short(value)


def _short(value: Any, limit: int = 300) -> str:
    """Text of a nested value of unknown shape, shortened at a word boundary if long.

    Only the catch-all rendering of deep structures uses this; findings, warnings, notes
    and reasons are always shown in full.
    """
    text = str(value)
    if len(text) <= limit:
        return text
    cut = text.rfind(" ", 0, limit)
    cut = cut if cut > limit // 2 else limit
    return f"{text[:cut].rstrip(' ,;:')} ... ({len(text) - cut} more characters)"


# --------------------------------------------------------------------------- result facts
def _model_cls(result: FitResult) -> type[Model] | None:
    """The model class, also for a failed fit whose ``model`` is None."""
    if result.model is not None:
        return type(result.model)
    if result.problem is not None:
        return result.problem.model
    try:
        return model_class(result.model_name)
    except ValueError:
        return None


def _param_infos(result: FitResult) -> dict[str, ParamInfo]:
    cls = _model_cls(result)
    return {p.name: p for p in cls.param_info()} if cls is not None else {}


def _param_unit(result: FitResult, infos: Mapping[str, ParamInfo], name: str) -> str:
    """Unit of any fitted value by name, in the data's units."""
    if name in infos:
        return infos[name].unit_for(result.units.load, result.units.position)
    if name == "offset":
        return result.units.position
    if name in ("C", "D", "epsilon"):
        return "-"
    if name == "cost":
        return f"{result.units.position}²" if result.residual == "linear" else "-"
    return ""


def _prediction_label(pred: Mapping[str, Any]) -> str:
    if pred.get("label"):
        return str(pred["label"])
    if pred.get("card") is not None:
        return f"card {pred['card']}"
    return "another stroke"


def _prediction_arrays(pred: Any) -> dict[str, Any] | None:
    """A prediction with equal-length arrays t, load, measured, predicted, or None."""
    if isinstance(pred, Prediction):
        pred = {**pred.to_dict(), "t": pred.t, "load": pred.load, "measured": pred.measured,
                "predicted": pred.predicted}
    if not isinstance(pred, Mapping) or not all(k in pred for k in _PREDICTION_KEYS):
        return None
    try:
        arrays = {k: np.asarray(pred[k], dtype=float).ravel() for k in _PREDICTION_KEYS}
    except (TypeError, ValueError):
        return None
    sizes = {a.size for a in arrays.values()}
    if len(sizes) != 1 or sizes == {0}:
        return None
    return {**arrays, "label": _prediction_label(pred)}


def _prediction_source(result: FitResult, prediction: Any) -> Any:
    if isinstance(prediction, Prediction):
        return {**prediction.to_dict(), "t": prediction.t, "load": prediction.load,
                "measured": prediction.measured, "predicted": prediction.predicted}
    return prediction


def _version() -> str:
    try:
        return metadata.version("pumpid")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


# --------------------------------------------------------------------------- sections
def _summary_html(result: FitResult) -> str:
    cls = _model_cls(result)
    t = result.t
    duration = float(t[-1] - t[0]) if t.size > 1 else 0.0
    observe = result.observe
    if cls is not None and observe in cls.outputs:
        observe = f"{observe} ({cls.outputs[observe]})"
    rows = [
        ("model", f"{result.model_name}" + (f": {cls.title}" if cls and cls.title else "")),
        ("method", result.method),
        ("integrator", result.integrator),
        ("residual", result.residual),
        ("observed output", observe),
        ("initial state", str(result.initial_state)),
        ("fitted values", ", ".join(result.free) or "none"),
        ("data", f"{t.size} samples over {_num(duration)} {result.units.time}"),
        ("units", f"load {unit_text(result.units.load)}, position "
                  f"{unit_text(result.units.position)}, time {result.units.time}"),
    ]
    if result.extra.get("gauge"):
        rows.append(("gauge fixed", str(result.extra["gauge"])))
    if result.extra.get("start"):
        rows.append(("starting values", str(result.extra["start"])))
    return _table(("item", "value"), rows)


def _status_html(result: FitResult) -> str:
    word = status_text(result)
    cls = {"converged": "ok", "boundary (limiting model)": "warn"}.get(word, "bad")
    rows = [
        ("iterations", str(result.iterations)),
        ("model simulations", str(result.nfev)),
    ]
    return (f'<p>Status: <span class="{cls}">{word}</span> &mdash; {_e(result.reason)}</p>\n'
            + _table(("item", "value"), rows, num_cols=(1,)))


def _residuals_white(result: FitResult) -> bool:
    """False only when the fit's whiteness check ran and failed."""
    unc = result.extra.get("uncertainty")
    check = unc.get("whiteness") if isinstance(unc, Mapping) else None
    return not (isinstance(check, Mapping) and check.get("white") is False)


def _params_html(result: FitResult) -> str:
    infos = _param_infos(result)
    stderr = result.extra.get("stderr")
    ci95 = result.extra.get("ci95")
    stderr = stderr if isinstance(stderr, Mapping) and stderr else None
    ci95 = ci95 if isinstance(ci95, Mapping) and ci95 else None
    # Where the residuals fail the whiteness check the robust errors are the ones shown
    # (stderr, ci95) and the independent-noise interval, known to be too narrow, is the
    # extra column; a result from before that rule shows the robust one as the extra.
    robust = result.extra.get("errors_shown") == "robust"
    extra_key = "ci95_white" if robust else "ci95_hac"
    ci95_hac = result.extra.get(extra_key) if not _residuals_white(result) else None
    ci95_hac = ci95_hac if isinstance(ci95_hac, Mapping) and any(ci95_hac.values()) else None
    headers = ["parameter", "value", "unit"]
    if stderr is not None:
        headers.append("robust std. error (shown)" if robust else "std. error")
    if ci95 is not None:
        headers.append("95 % CI, robust to serial correlation (HAC)" if robust else "95 % CI")
    if ci95_hac is not None:
        headers.append("95 % CI assuming independent noise (too narrow here)" if robust
                       else "95 % CI, robust to serial correlation (HAC)")
    headers += ["status", "description"]
    free = set(result.free)

    def row(name: str, value: float, unit: str, status: str, doc: str) -> list[str]:
        cells = [name, _num(value, 8), unit]
        if stderr is not None:
            cells.append(_num(stderr.get(name)))
        if ci95 is not None:
            cells.append(_interval(ci95[name]) if name in ci95 else "n/a")
        if ci95_hac is not None:
            cells.append(_interval(ci95_hac[name]) if name in ci95_hac else "n/a")
        return [*cells, status, doc]

    rows = []
    for name, value in result.params.items():
        info = infos.get(name)
        rows.append(row(name, value, _param_unit(result, infos, name),
                        "fitted" if name in free else "fixed", info.doc if info else ""))
    scale_status = "fitted" if ({"C", "D"} & free) else "fixed"
    rows.append(row("C", result.scale, "-", scale_status, "output scale factor"))
    if result.residual == "log":
        d = math.log(result.scale) if result.scale > 0 else math.nan
        rows.append(row("D", d, "-", scale_status, "D = ln C (log residual)"))
    rows.append(row("offset", result.offset, result.units.position,
                    "fitted" if "offset" in free else "fixed", "additive position offset"))
    value_cols = range(1, len(headers) - 2)
    return _table(headers, rows, cls="params", num_cols=[i for i in value_cols if i != 2])


def _derived_html(result: FitResult) -> str:
    rows = [[d.name, _num(d.value, 6), d.unit, _num(d.stderr), _num(d.stderr_white),
             ("yes" if d.determined else "no")
             + ("" if d.well_property else "; not a property of the well"),
             d.meaning if d.well_property else f"{d.meaning}. {d.note}"]
            for d in result.derived.values()]
    return (
        "<p>Physical combinations of the parameters, from the model's poles and static gain: "
        "they stay determined where single parameters trade off, so they are the numbers "
        "to trend, except those marked as not a property of the well (a resonance on the "
        "stroke frequency echoes the pumping speed).</p>\n"
        + _table(("quantity", "value", "unit", "std. error (shown: robust where the "
                  "residuals are serially correlated)", "std. error assuming independent "
                  "noise", "determined", "meaning"), rows, num_cols=(1, 3, 4)))


def _quality_html(result: FitResult) -> str:
    pos = result.units.position
    res = result.residuals
    finite = res[np.isfinite(res)]
    max_abs = float(np.max(np.abs(finite))) if finite.size else math.nan
    rows = [
        ("RMSE", _num(result.rmse), pos),
        ("R²", _num(result.r2, 8), "-"),
        ("max |residual|", _num(max_abs), pos),
        ("cost ½Σr²", _num(result.cost), _param_unit(result, {}, "cost")),
        ("samples", str(result.t.size), "-"),
    ]
    return _table(("quantity", "value", "unit"), rows, num_cols=(1,))


def _corr(value: Any) -> str:
    """A correlation with three decimals: 0.9996 must not read as a perfect 1."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return "n/a"
    return f"{x:.3f}" if math.isfinite(x) else "n/a"


def _correlation_html(result: FitResult, value: Any) -> str:
    """A correlation matrix as a table, when its labels can be known; else generic."""
    if isinstance(value, Mapping) and "names" in value and "matrix" in value:
        names = [str(n) for n in value["names"]]
        rows = [[a, *(_corr(x) for x in row)]
                for a, row in zip(names, value["matrix"], strict=True)]
        return _table(["", *names], rows, num_cols=range(1, len(names) + 1))
    if isinstance(value, Mapping) and all(isinstance(v, Mapping) for v in value.values()):
        names = list(value)
        rows = [[str(a), *(_corr(value[a].get(b)) for b in names)] for a in names]
        return _table(["", *map(str, names)], rows, num_cols=range(1, len(names) + 1))
    arr = np.asarray(value, dtype=object)
    if arr.ndim == 2 and arr.shape[0] == arr.shape[1] == len(result.free):
        names = list(result.free)
        rows = [[a, *(_corr(x) for x in arr[i])] for i, a in enumerate(names)]
        return _table(["", *names], rows, num_cols=range(1, len(names) + 1))
    return _value_html(value)


def _identifiability_html(result: FitResult) -> str:
    """Every finding in full (they are sentences), or that everything is determined."""
    if not result.identifiability:
        return "<p>Every fitted value is determined by the data.</p>"
    return _list(result.identifiability)


def _history_html(result: FitResult) -> str:
    if not result.history:
        return ("<p>No iterations recorded (a fit of many cards in one batch keeps no "
                "per-iteration history; fit the card alone to see it).</p>")
    intro = ""
    if not has_history_figure(result):
        steps = sum(1 for row in result.history if (row.get("iteration") or 0) > 0)
        intro = (f"<p>The solver made {steps} iteration{'s' if steps != 1 else ''}: its "
                 "start was already at the optimum, so there is no convergence figure.</p>\n")
    infos = _param_infos(result)
    cols = history_columns(result.history)
    headers = [c if c == "iteration" else f"{c} [{_param_unit(result, infos, c) or '-'}]"
               for c in cols]
    rows = []
    for entry in result.history:
        cells = []
        for c in cols:
            v = entry.get(c)
            if c == "iteration" and v is not None and math.isfinite(v):
                cells.append(str(int(v)))
            else:
                cells.append(_num(v, 8))
        rows.append(cells)
    return intro + _table(headers, rows, cls="history")


def _figures_html(pngs: Mapping[str, bytes]) -> str:
    out = []
    for name, png in pngs.items():
        data = base64.b64encode(png).decode("ascii")
        caption = CAPTIONS.get(name, name)
        out.append(
            f'<figure id="fig-{_e(name)}">\n'
            f'<img src="data:image/png;base64,{data}" alt="{_e(name)}: {_e(caption)}">\n'
            f"<figcaption>{_e(caption)}</figcaption>\n</figure>"
        )
    return "\n".join(out)


def _prediction_html(result: FitResult, pred: Any) -> str | None:
    """Scores of a prediction: computed from its arrays, or as stored (scores only)."""
    arrays = _prediction_arrays(pred)
    if arrays is not None:
        rmse, r2 = prediction_stats(arrays["measured"], arrays["predicted"])
        record = f"{arrays['label']} ({arrays['t'].size} samples)"
    elif isinstance(pred, Mapping) and ("rmse" in pred or "r2" in pred):
        rmse, r2 = pred.get("rmse"), pred.get("r2")
        record = _prediction_label(pred)
    else:
        return None
    rows = [("RMSE", _num(rmse), result.units.position), ("R²", _num(r2, 8), "-")]
    return (f"<p>The fitted parameters (with the same C and offset) applied to the load of a "
            f"record the model was not fitted on: {_e(record)}.</p>\n"
            + _table(("quantity", "value", "unit"), rows, num_cols=(1,)))


def _input_html(result: FitResult) -> str | None:
    """Where the data came from: ``extra["card"]`` as stored by the card fitter."""
    card = result.extra.get("card")
    if not isinstance(card, Mapping):
        return None
    labels = {"id": ("card", ""), "well": ("well", ""), "source": ("source", ""),
              "time_source": ("time axis from", ""), "spm": ("pumping speed", "strokes/min"),
              "period": ("stroke period", result.units.time)}
    rows = []
    for key, (label, unit) in labels.items():
        value = card.get(key)
        if value is None or value == "":
            continue
        text = _num(value) if isinstance(value, int | float) else str(value)
        rows.append((label, text, unit))
    return _table(("item", "value", "unit"), rows) if rows else None


def _boundary_html(result: FitResult) -> str | None:
    """Parameters that ran to 0 or infinity and the reduced (limiting) model fitted instead."""
    bounds = result.extra.get("boundaries")
    reduced = result.extra.get("reduced")
    parts = []
    if isinstance(bounds, list) and bounds:
        rows = [(str(b.get("name", "")), str(b.get("direction", "")), str(b.get("limit", "")))
                for b in bounds if isinstance(b, Mapping)]
        parts.append("<p>These parameters ran to a bound: their fitted values are arbitrary "
                     "and the solution is a limiting model.</p>")
        parts.append(_table(("parameter", "runs to", "limit"), rows))
    if isinstance(reduced, Mapping) and isinstance(reduced.get("params"), Mapping):
        units = model_param_units(str(reduced.get("model", "")), result.units) or (
            reduced.get("units") if isinstance(reduced.get("units"), Mapping) else {})
        rows = [(str(n), _num(v, 8), str(units.get(n, ""))) for n, v in reduced["params"].items()]
        rows.append(("C", _num(reduced.get("scale"), 8), "-"))
        if reduced.get("offset") is not None:
            rows.append(("offset", _num(reduced.get("offset"), 8), result.units.position))
        rows.append(("RMSE", _num(reduced.get("rmse")), result.units.position))
        rows.append(("R²", _num(reduced.get("r2"), 8), "-"))
        status = reduced.get("status") or ("converged" if reduced.get("converged") else "failed")
        reason = str(reduced.get("reason") or "")
        # Reasons of converged fits already begin with "converged:"; say the status once.
        reason = reason.split(": ", 1)[1] if reason.startswith(f"{status}: ") else reason
        why = f": {reason}" if reason else ""
        parts.append(f"<p>Reduced model fitted: <b>{_e(reduced.get('model', '?'))}</b> "
                     f"({_e(status)}{_e(why)})</p>")
        parts.append(_table(("parameter", "value", "unit"), rows, num_cols=(1,)))
    return "\n".join(parts) if parts else None


def _extra_sections_html(
    sections: Mapping[str, Any] | Iterable[tuple[str, Any]],
) -> list[str]:
    items = sections.items() if isinstance(sections, Mapping) else sections
    out = []
    for heading, body in items:
        if isinstance(body, str):
            # Plain text, often preformatted (tables from result.report()): keep the layout.
            html_body = f"<pre>{_e(body)}</pre>"
        else:
            html_body = _value_html(body)
        out.append(_section(str(heading), html_body))
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
    pred = _prediction_arrays(_prediction_source(result, prediction))
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

    body: list[str] = [f"<h1>{_e(page_title)}</h1>"]
    body.append(
        f"<p>{_e(result.model_name)} model, {_e(result.method)} fit: "
        f"{_e(status_text(result))}; RMSE = {_e(_num(result.rmse))} {_e(unit_text(pos))}, "
        f"R² = {_e(_num(result.r2, 8))}.</p>"
    )
    body.append(_section("Summary", _summary_html(result), sid="summary"))
    input_html = _input_html(result)
    if input_html:
        body.append(_section("Input data", input_html, sid="input"))
    all_notes = _all_notes(result, notes)
    if all_notes:
        body.append(_section("Notes on the input data", _list(all_notes), sid="notes"))
    body.append(_section("Convergence", _status_html(result), sid="convergence"))
    body.append(_section("Parameters", _params_html(result), sid="parameters"))
    body.append(_section("Fit quality", _quality_html(result), sid="quality"))
    if result.derived:
        body.append(_section("Derived quantities", _derived_html(result), sid="derived"))
    if result.warnings:
        body.append(_section("Warnings", _list(result.warnings), sid="warnings"))
    boundary_html = _boundary_html(result)
    if boundary_html:
        body.append(_section("Boundary solution", boundary_html, sid="boundary"))
    if result.model is not None or result.identifiability:
        body.append(_section("Identifiability", _identifiability_html(result),
                             sid="identifiability"))
    if "correlation" in result.extra:
        body.append(_section("Parameter correlation",
                             _correlation_html(result, result.extra["correlation"]),
                             sid="correlation"))
    pred_src = _prediction_source(result, prediction)
    pred_html = _prediction_html(result, pred_src) if pred_src is not None else None
    if pred_html:
        body.append(_section("Prediction", pred_html, sid="prediction"))
    if pngs:
        body.append(_section("Figures", _figures_html(pngs), sid="figures"))
    other = {k: v for k, v in result.extra.items()
             if k not in _KNOWN_EXTRA or (k == "prediction" and pred_html is None)}
    if other:
        body.append(_section("Other results", _value_html(other), sid="other"))
    if extra_sections:
        body += _extra_sections_html(extra_sections)
    body.append(_section("Iteration history", _history_html(result), sid="history"))
    body.append(f"<footer>Generated by pumpid {_e(_version())}.</footer>")

    return "\n".join([
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(page_title)}</title>",
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
    paths["json"] = atomic_write(out / "result.json", result.to_json(indent=2) + "\n")
    paths["report"] = write_report(result, out, title=title, figures=pngs, notes=notes,
                                   prediction=prediction, extra_sections=extra_sections)
    return paths
