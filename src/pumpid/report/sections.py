"""The sections of a fit's report, each drawn from the result alone (HTML).

Facts the sections share (the model class, the unit of a fitted value, a prediction's
arrays) are worked out here too, also for a failed fit whose model is None.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..models import Model, OwnModel, ParamInfo, model_class
from ..result import FitResult, Prediction, n_eff_words
from .markup import bullet_list, escape, interval, number, table, value_html
from .plots import (
    has_history_figure,
    history_columns,
    model_param_units,
    prediction_stats,
    status_text,
    unit_text,
)

__all__ = [
    "boundary_html",
    "correlation_html",
    "derived_html",
    "history_html",
    "identifiability_html",
    "input_html",
    "model_choice_html",
    "params_html",
    "prediction_arrays",
    "prediction_html",
    "prediction_source",
    "quality_html",
    "status_html",
    "summary_html",
]

_PREDICTION_KEYS = ("t", "load", "measured", "predicted")


def _model_cls(result: FitResult) -> type[Model] | None:
    """The lumped model's class, also for a failed fit whose ``model`` is None (None for a
    model that brings its own simulator)."""
    if isinstance(result.model, OwnModel):
        return None
    if result.model is not None:
        return type(result.model)
    if result.problem is not None:
        return result.problem.model
    try:
        return model_class(result.model_name)
    except ValueError:
        return None


def _param_infos(result: FitResult) -> dict[str, ParamInfo]:
    if isinstance(result.model, OwnModel):
        # An own model's Parameter has the same name, unit, doc and bounds a ParamInfo has.
        return {p.name: p for p in result.model.param_info()}  # type: ignore[misc]
    cls = _model_cls(result)
    return {p.name: p for p in cls.param_info()} if cls is not None else {}


def _param_status(result: FitResult, name: str) -> str:
    """A value's status in the parameter table, in the words the text uses: a value that ran
    to a bound is not an ordinary fitted one, nor one the data leave undetermined."""
    if name not in result.free:
        return "fixed"
    limits = result.boundary.limits if result.boundary is not None else ()
    for b in limits:
        if b.name == name:
            return f"runs {b.where}: limiting model, not determined"
    if name in (result.determined.get("not_determined") or ()):
        return "fitted, not determined"
    return "fitted"


def _param_unit(result: FitResult, infos: Mapping[str, ParamInfo], name: str) -> str:
    """Unit of any fitted value by name, in the data's units."""
    if name in infos:
        return infos[name].unit_for(result.units.load, result.units.position)
    if name == "offset":
        return result.units.position
    if name in ("C", "D", "epsilon"):
        return "-"
    if name == "cost":
        return result.cost_unit("²")
    return ""


def _prediction_label(pred: Mapping[str, Any]) -> str:
    if pred.get("label"):
        return str(pred["label"])
    if pred.get("card") is not None:
        return f"card {pred['card']}"
    return "another stroke"


def prediction_arrays(pred: Any) -> dict[str, Any] | None:
    """A prediction with equal-length arrays t, load, measured, predicted, or None.

    Parameters
    ----------
    pred : Prediction, mapping or Any
        A prediction of another record.

    Returns
    -------
    dict or None
        The four arrays and a ``label``; None when ``pred`` has no such arrays (only
        scores, or nothing usable).
    """
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


def prediction_source(result: FitResult, prediction: Any) -> Any:
    """The prediction to report: the one given, as a mapping when it is a :class:`Prediction`.

    Parameters
    ----------
    result : FitResult
        The fit.
    prediction : Prediction, mapping or None
        The caller's prediction.

    Returns
    -------
    Any
        A mapping with the prediction's arrays and scores, or ``prediction`` as given.
    """
    if isinstance(prediction, Prediction):
        return {**prediction.to_dict(), "t": prediction.t, "load": prediction.load,
                "measured": prediction.measured, "predicted": prediction.predicted}
    return prediction


# --------------------------------------------------------------------------- sections
def summary_html(result: FitResult) -> str:
    """The summary table: model, method, options, data and units.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
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
        ("data", f"{t.size} samples over {number(duration)} {result.units.time}"),
        ("units", f"input {unit_text(result.units.load)}, output "
                  f"{unit_text(result.units.position)}, time {result.units.time}"
         if isinstance(result.model, OwnModel) else
         f"load {unit_text(result.units.load)}, position "
         f"{unit_text(result.units.position)}, time {result.units.time}"),
    ]
    if result.extra.get("gauge"):
        rows.append(("gauge fixed", str(result.extra["gauge"])))
    if result.extra.get("start"):
        rows.append(("starting values", str(result.extra["start"])))
    return table(("item", "value"), rows)


def status_html(result: FitResult) -> str:
    """The fit's status with its reason, iterations and simulations.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
    word = status_text(result)
    cls = {"converged": "ok", "boundary": "warn", "undetermined": "warn"}.get(
        str(getattr(result, "status", "")), "bad")
    rows = [
        ("iterations", str(result.iterations)),
        ("model simulations", str(result.nfev)),
    ]
    return (f'<p>Status: <span class="{cls}">{word}</span> &mdash; {escape(result.reason)}</p>\n'
            + table(("item", "value"), rows, num_cols=(1,)))


def _residuals_white(result: FitResult) -> bool:
    """False only when the fit's whiteness check ran and failed."""
    unc = result.extra.get("uncertainty")
    check = unc.get("whiteness") if isinstance(unc, Mapping) else None
    return not (isinstance(check, Mapping) and check.get("white") is False)


def params_html(result: FitResult) -> str:
    """The parameters with units, errors and intervals, C and the offset.

    The columns shown depend on what the fit stored: standard errors, 95 % intervals, and
    where the residuals are serially correlated also the other kind of interval.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
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
        cells = [name, number(value, 8), unit]
        if stderr is not None:
            cells.append(number(stderr.get(name)))
        if ci95 is not None:
            cells.append(interval(ci95[name]) if name in ci95 else "n/a")
        if ci95_hac is not None:
            cells.append(interval(ci95_hac[name]) if name in ci95_hac else "n/a")
        return [*cells, status, doc]

    rows = []
    for name, value in result.params.items():
        info = infos.get(name)
        rows.append(row(name, value, _param_unit(result, infos, name),
                        _param_status(result, name), info.doc if info else ""))
    if not isinstance(result.model, OwnModel):  # an own model has no lumped scale or offset
        scale_status = "fitted" if ({"C", "D"} & free) else "fixed"
        rows.append(row("C", result.scale, result.scale_unit(), scale_status,
                        "output scale factor"))
        if result.residual == "log":
            d = math.log(result.scale) if result.scale > 0 else math.nan
            rows.append(row("D", d, "-", scale_status, "D = ln C (log residual)"))
        rows.append(row("offset", result.offset, result.units.position,
                        _param_status(result, "offset"), "additive position offset"))
    value_cols = range(1, len(headers) - 2)
    out = table(headers, rows, cls="params", num_cols=[i for i in value_cols if i != 2])
    test = result.serial_test
    if robust and test.get("found") is False:
        # Nothing else on the page says why: no whiteness warning is raised.
        out += (f"<p>The robust errors are shown: the card's {result.t.size} samples are too "
                "few for a test of the residuals' independence to tell independent noise "
                "from noise correlated "
                f"{test.get('alternative_rho', math.nan):g} from one sample to the next.</p>\n")
    return out


def derived_html(result: FitResult) -> str:
    """The derived quantities (poles and static gain) with their errors.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
    rows = [[d.name, number(d.value, 6), d.unit, number(d.stderr), number(d.stderr_white),
             ("yes" if d.determined else "no")
             + ("" if d.well_property else "; not a property of the well"),
             d.meaning if d.well_property else f"{d.meaning}. {d.note}"]
            for d in result.derived.values()]
    # The well's words only where a quantity is marked (a flow fit spoke of a well).
    echo = any(not d.well_property for d in result.derived.values())
    return (
        "<p>Physical combinations of the parameters, from the model's poles and static gain: "
        "they stay determined where single parameters trade off, so they are the numbers "
        "to trend"
        + (", except those marked as not a property of the well (a resonance on the "
           "stroke frequency echoes the pumping speed)" if echo else "")
        + ".</p>\n"
        + table(("quantity", "value", "unit", "std. error (shown: robust where the "
                 "residuals are serially correlated or too few to test)",
                 "std. error assuming independent "
                 "noise", "determined", "meaning"), rows, num_cols=(1, 3, 4)))


def quality_html(result: FitResult) -> str:
    """RMSE, R², the largest residual, the cost and the sample count.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
    pos = result.units.position
    res = result.residuals
    finite = res[np.isfinite(res)]
    max_abs = float(np.max(np.abs(finite))) if finite.size else math.nan
    rows = [
        ("RMSE", number(result.rmse), pos),
        ("R²", number(result.r2, 8), "-"),
        *((("R² of the stroke's fundamental alone (what any load gives)",
            number(result.r2_fundamental, 8), "-"),
           ("share of what the fundamental leaves that the model explains",
            number(result.r2_beyond, 4), "-"))
          if math.isfinite(result.r2_beyond) else ()),
        ("max |residual|", number(max_abs), pos),
        ("cost ½Σr²", number(result.cost), _param_unit(result, {}, "cost")),
        ("samples", str(result.t.size), "-"),
    ]
    return table(("quantity", "value", "unit"), rows, num_cols=(1,))


def _corr(value: Any) -> str:
    """A correlation with three decimals: 0.9996 must not read as a perfect 1."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return "n/a"
    return f"{x:.3f}" if math.isfinite(x) else "n/a"


def correlation_html(result: FitResult, value: Any) -> str:
    """A correlation matrix as a table, when its labels can be known; else generic.

    Parameters
    ----------
    result : FitResult
        The fit.
    value : Any
        The correlation: ``{"names", "matrix"}``, a mapping of mappings, or a square
        matrix over the fitted values.

    Returns
    -------
    str
        HTML.
    """
    if isinstance(value, Mapping) and "names" in value and "matrix" in value:
        names = [str(n) for n in value["names"]]
        rows = [[a, *(_corr(x) for x in row)]
                for a, row in zip(names, value["matrix"], strict=True)]
        return table(["", *names], rows, num_cols=range(1, len(names) + 1))
    if isinstance(value, Mapping) and all(isinstance(v, Mapping) for v in value.values()):
        names = list(value)
        rows = [[str(a), *(_corr(value[a].get(b)) for b in names)] for a in names]
        return table(["", *map(str, names)], rows, num_cols=range(1, len(names) + 1))
    arr = np.asarray(value, dtype=object)
    if arr.ndim == 2 and arr.shape[0] == arr.shape[1] == len(result.free):
        names = list(result.free)
        rows = [[a, *(_corr(x) for x in arr[i])] for i, a in enumerate(names)]
        return table(["", *names], rows, num_cols=range(1, len(names) + 1))
    return value_html(value)


def identifiability_html(result: FitResult) -> str:
    """Every finding in full (they are sentences), or that everything is determined.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
    if not result.identifiability:
        return "<p>Every fitted value is determined by the data.</p>"
    return bullet_list(result.identifiability)


def history_html(result: FitResult) -> str:
    """The solver's iterations: cost and values per iteration.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str
        HTML.
    """
    if not result.history:
        return ("<p>No iterations recorded (a fit of many cards in one batch keeps no "
                "per-iteration history; fit the card alone to see it: "
                "<code>pumpid.fit(model, card)</code>, or <code>pumpid fit FILE --card ID "
                "--out DIR</code>).</p>")
    intro = ""
    steps = sum(1 for row in result.history if (row.get("iteration") or 0) > 0)
    if not has_history_figure(result):
        intro = (f"<p>The path recorded has {steps} step{'s' if steps != 1 else ''}: it "
                 "starts at or next to the optimum, so there is no convergence figure.</p>\n")
    if result.iterations != steps:
        # The Convergence table counts the last solve's iterations (a boundary fit's refit
        # at its limit, say); the history is the path recorded, which joins a crawling
        # card's solves ("iterations 2" beside "made 1 iteration"; 9 beside 22 steps).
        # Said of every fit whose counts differ, not only of a card that crawled along a
        # flat valley (the words claimed that path on every card).
        intro += (f"<p>The table holds the path the fit recorded ({steps} step"
                  f"{'s' if steps != 1 else ''}, joined from the solves that led to the "
                  "answer); the Convergence table counts the iterations of the last solve "
                  f"alone ({result.iterations}).</p>\n")
    infos = _param_infos(result)
    history = list(result.history)
    last = history[-1]
    moved = [n for n, v in result.params.items() if n in last and not _same(last[n], v)]
    if "C" in last and not _same(last["C"], result.scale):
        moved.append("C")
    if "offset" in last and not _same(last["offset"], result.offset):
        moved.append("offset")
    if moved:
        # A boundary fit is moved to its limit after the solver's last iteration: the
        # history ended at k0 = 1.3e8 beside the reported 3.5e8, with no word of why.
        history.append({"iteration": math.nan, **result.params,
                        **({"C": result.scale} if "C" in last else {}),
                        **({"D": math.log(result.scale)} if "D" in last
                           and result.scale > 0 else {}),
                        **({"offset": result.offset} if "offset" in last else {}),
                        "cost": result.cost})
        limits = ([b.name for b in result.boundary.limits if b.name in moved]
                  if result.boundary else [])
        why = (f"after the solver's last iteration the boundary test moved "
               f"{', '.join(limits)} toward {'its' if len(limits) == 1 else 'their'} limit, "
               "where the fit is as good, and refitted the other values there"
               if limits else
               f"after the solver's last iteration a later stage moved {', '.join(moved)}")
        intro += f"<p>The last row is the answer reported: {why}.</p>\n"
    cols = history_columns(history)
    headers = [c if c == "iteration" else f"{c} [{_param_unit(result, infos, c) or '-'}]"
               for c in cols]
    rows = []
    for entry in history:
        cells = []
        for c in cols:
            v = entry.get(c)
            if c == "iteration" and v is not None and math.isfinite(v):
                cells.append(str(int(v)))
            elif c == "iteration":
                cells.append("answer")
            else:
                cells.append(number(v, 8))
        rows.append(cells)
    return intro + table(headers, rows, cls="history")


def _same(a: float | None, b: float) -> bool:
    """Two values alike in the digits the table shows."""
    return a is None or number(a, 8) == number(b, 8)


def prediction_html(result: FitResult, pred: Any) -> str | None:
    """Scores of a prediction: computed from its arrays, or as stored (scores only).

    Parameters
    ----------
    result : FitResult
        The fit.
    pred : Any
        The prediction (see :func:`prediction_source`).

    Returns
    -------
    str or None
        HTML; None when ``pred`` has neither arrays nor scores.
    """
    arrays = prediction_arrays(pred)
    if arrays is not None:
        rmse, r2 = prediction_stats(arrays["measured"], arrays["predicted"])
        record = f"{arrays['label']} ({arrays['t'].size} samples)"
    elif isinstance(pred, Mapping) and ("rmse" in pred or "r2" in pred):
        rmse, r2 = pred.get("rmse"), pred.get("r2")
        record = _prediction_label(pred)
    else:
        return None
    rows = [("RMSE", number(rmse), result.units.position), ("R²", number(r2, 8), "-")]
    alone = pred.get("r2_fundamental") if isinstance(pred, Mapping) else None
    if isinstance(alone, float) and math.isfinite(alone):
        # Any linear model reproduces the card's fundamental from any load: the R^2 means
        # something only beside it.
        rows.append(("R² of the card's fundamental alone", number(alone, 8), "-"))
    return (f"<p>The fitted parameters (with the same C and offset) applied to the load of a "
            f"record the model was not fitted on: {escape(record)}.</p>\n"
            + table(("quantity", "value", "unit"), rows, num_cols=(1,)))


def input_html(result: FitResult) -> str | None:
    """Where the data came from: ``extra["card"]`` as stored by the card fitter.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str or None
        HTML; None when the fit stored no card.
    """
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
        text = number(value) if isinstance(value, int | float) else str(value)
        rows.append((label, text, unit))
    return table(("item", "value", "unit"), rows) if rows else None


def boundary_html(result: FitResult) -> str | None:
    """Parameters that ran to 0 or infinity and the reduced (limiting) model fitted instead.

    Parameters
    ----------
    result : FitResult
        The fit.

    Returns
    -------
    str or None
        HTML; None when no parameter ran to a bound.
    """
    bounds = result.extra.get("boundaries")
    reduced = result.extra.get("reduced")
    parts = []
    if isinstance(bounds, list) and bounds:
        rows = [(str(b.get("name", "")), str(b.get("direction", "")), str(b.get("limit", "")))
                for b in bounds if isinstance(b, Mapping)]
        parts.append("<p>These parameters ran to a bound: their fitted values are arbitrary "
                     "and the solution is a limiting model.</p>")
        parts.append(table(("parameter", "runs to", "limit"), rows))
    if isinstance(reduced, Mapping) and isinstance(reduced.get("params"), Mapping):
        units = model_param_units(str(reduced.get("model", "")), result.units) or (
            reduced.get("units") if isinstance(reduced.get("units"), Mapping) else {})
        rows = [(str(n), number(v, 8), str(units.get(n, ""))) for n, v in reduced["params"].items()]
        rows.append(("C", number(reduced.get("scale"), 8),
                     str((reduced.get("units") or {}).get("C", "-"))))
        if reduced.get("offset") is not None:
            rows.append(("offset", number(reduced.get("offset"), 8), result.units.position))
        rows.append(("RMSE", number(reduced.get("rmse")), result.units.position))
        rows.append(("R²", number(reduced.get("r2"), 8), "-"))
        status = reduced.get("status") or ("converged" if reduced.get("converged") else "failed")
        reason = str(reduced.get("reason") or "")
        # Reasons of converged fits already begin with "converged:"; say the status once.
        reason = reason.split(": ", 1)[1] if reason.startswith(f"{status}: ") else reason
        why = f": {reason}" if reason else ""
        parts.append(f"<p>Reduced model fitted: <b>{escape(reduced.get('model', '?'))}</b> "
                     f"({escape(status)}{escape(why)})</p>")
        parts.append(table(("parameter", "value", "unit"), rows, num_cols=(1,)))
    return "\n".join(parts) if parts else None


def model_choice_html(choice: Mapping[str, Any]) -> str:
    """A model choice's ranking (``application["model_choice"]``), as the text output has
    it: the criterion and effective sample size, a row per structure, the nested tests.

    Parameters
    ----------
    choice : mapping
        The ranking.

    Returns
    -------
    str
        HTML.
    """
    used = n_eff_words(choice)
    intro = (f"<p>Chosen: <b>{escape(str(choice['chosen']))}</b>, by "
             f"{escape(str(choice['criterion']).upper())} on the effective sample size (n = "
             f"{choice['n']} samples, residual lag-1 autocorrelation {choice['rho']:.3f}, "
             f"{escape(used)}). Delta is each structure's criterion above the best; the "
             "weights are the criterion's evidence weights (they sum to 1).</p>\n")
    rows = [[str(c["name"]), str(c["k"]), number(c["r2"], 6), number(c["bic"], 6),
             number(c["aicc"], 6), number(c["delta"], 4), number(c["weight"], 3),
             str(c["status"])] for c in choice["candidates"]]
    out = intro + table(["structure", "fitted values", "R^2", "BIC", "AICc", "delta",
                         "weight", "status"], rows, cls="choice")
    tests = [f"likelihood ratio {t['big']} against {t['small']} ({t['limit']}): statistic "
             f"{t['statistic']:.3g} on {t['dof']} degrees of freedom, p = {t['p_value']:.3g}"
             for t in choice.get("nested_tests", ())]
    return out + (bullet_list(tests) if tests else "")
