"""The HTML report: well-formed, self-contained, escaped, and complete."""

from __future__ import annotations

import base64
import dataclasses
import json
import math
from html.parser import HTMLParser

import numpy as np
import pytest
from matplotlib.figure import Figure

import pumpid
from pumpid.inference.boundaries import BoundaryInfo, Limiting, ReducedFit
from pumpid.report import plots, render_html, write_outputs, write_report
from pumpid.result import CardInfo, FitResult, Status

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source",
        "track", "wbr"}


class Checker(HTMLParser):
    """Records the document structure and the first nesting error, if any.

    Strict on purpose: every non-void element must be closed explicitly and in order (HTML5
    allows omitting some end tags, this report never does).
    """

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.doctype: str | None = None
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.text: dict[str, list[str]] = {}
        self.tables: list[list[list[str]]] = []
        self._cell: list[str] | None = None

    def handle_decl(self, decl: str) -> None:
        self.doctype = decl

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))
        if tag in VOID:
            return
        self.stack.append(tag)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr" and self.tables:
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))
        if tag not in VOID:
            self.errors.append(f"self-closing non-void <{tag}/>")

    def handle_endtag(self, tag: str) -> None:
        if tag in VOID:
            self.errors.append(f"end tag for void element </{tag}>")
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'}")
            return
        self.stack.pop()
        if tag in ("td", "th") and self._cell is not None and self.tables:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self.stack:
            self.text.setdefault(self.stack[-1], []).append(data)
        if self._cell is not None:
            self._cell.append(data)


def parse(text: str) -> Checker:
    checker = Checker()
    checker.feed(text)
    checker.close()
    return checker


def assert_well_formed(checker: Checker) -> None:
    assert not checker.errors, checker.errors
    assert not checker.stack, f"unclosed: {checker.stack}"


@pytest.fixture(scope="module")
def result() -> FitResult:
    t = np.linspace(0.0, 8.0, 400)
    load = 9000 + 3000 * np.sin(2 * np.pi * t / 8) + 800 * np.sin(4 * np.pi * t / 8 + 0.4)
    true = pumpid.Kelvin(k0=120, m=2.0, c1=60, k1=90)
    disp = pumpid.simulate(true, t, load, initial_state="periodic")
    disp = disp + 0.2 * np.random.default_rng(0).standard_normal(t.size)
    return pumpid.fit(pumpid.Kelvin(k0=100, m=2.5, c1=50, k1=80), (t, load, disp),
                      options=pumpid.FitOptions(initial_state="periodic", offset=True),
                      units=pumpid.Units(load="lbf", position="in"))


@pytest.fixture(scope="module")
def tiny_figures() -> dict[str, bytes]:
    """One small PNG standing in for all figures where the figures are not under test."""
    f = Figure(figsize=(1, 1))
    f.add_subplot().plot([0, 1], [0, 1])
    return {"displacement": plots.figure_to_png(f, dpi=30)}


def param_table(checker: Checker) -> list[list[str]]:
    for table in checker.tables:
        if table and table[0][:3] == ["parameter", "value", "unit"]:
            return table
    raise AssertionError("no parameter table")


# --------------------------------------------------------------------------- the checker
def test_checker_catches_malformed_html() -> None:
    bad = parse("<!DOCTYPE html><html><body><p><b>x</p></b></body></html>")
    assert bad.errors
    unclosed = parse("<!DOCTYPE html><html><body><div><p>x</p></body></html>")
    assert unclosed.errors or unclosed.stack
    good = parse("<!DOCTYPE html><html><head><meta charset='utf-8'></head>"
                 "<body><img src='x'><br></body></html>")
    assert_well_formed(good)


# --------------------------------------------------------------------------- the report
def test_written_report_is_self_contained_and_complete(result: FitResult, tmp_path) -> None:
    path = write_report(result, tmp_path / "out", notes=["card 7 of well A", "stroke 2 only"])
    assert path == tmp_path / "out" / "report.html"
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    doc = parse(text)
    assert_well_formed(doc)
    assert doc.doctype is not None and doc.doctype.lower() == "doctype html"
    assert "".join(doc.text.get("title", [])).strip()

    # Figures: embedded PNGs only, nothing loaded from elsewhere, no scripts.
    imgs = [attrs for tag, attrs in doc.tags if tag == "img"]
    assert len(imgs) == 4
    for attrs in imgs:
        src = attrs.get("src") or ""
        assert src.startswith("data:image/png;base64,")
        payload = base64.b64decode(src.split(",", 1)[1], validate=True)
        assert payload.startswith(PNG_SIGNATURE)
        assert attrs.get("alt")
    tag_names = {tag for tag, _ in doc.tags}
    assert not tag_names & {"script", "link", "iframe", "object", "embed"}
    assert "http://" not in text and "https://" not in text

    # Parameter table: every parameter with its unit on the same row, then C and offset.
    table = param_table(doc)
    rows = {row[0]: row for row in table[1:]}
    units = result.param_units()
    assert units  # guards against a vacuous loop
    for name, value in result.params.items():
        assert name in rows
        assert rows[name][2] == units[name]
        assert float(rows[name][1]) == pytest.approx(value, rel=1e-7)
    assert rows["offset"][2] == "in" and rows["C"][2] == "-"
    assert rows["offset"][1] != "n/a"

    # Fit quality with units, status, notes, history.
    body = " ".join(" ".join(v) for v in doc.text.values())
    quality = next(t for t in doc.tables if t and t[0] == ["quantity", "value", "unit"])
    rmse_row = next(r for r in quality if r[0] == "RMSE")
    assert rmse_row[2] == "in" and float(rmse_row[1]) == pytest.approx(result.rmse, rel=1e-5)
    assert "converged" in body and result.reason in body
    assert "card 7 of well A" in body and "stroke 2 only" in body
    history = next(t for t in doc.tables if t and t[0][0] == "iteration")
    assert len(history) == 1 + len(result.history)
    assert "k0 [lbf/in]" in history[0] and "offset [in]" in history[0]


def test_text_is_escaped(result: FitResult, tiny_figures) -> None:
    evil = '<script>alert("x")</script> & <b>bold</b>'
    res = result.with_parts(warnings=(evil,), reason=evil)
    text = render_html(res, title=evil, figures=tiny_figures, notes=evil,
                       extra_sections={"More <i>": evil, "list": [evil, 1.5]})
    doc = parse(text)
    assert_well_formed(doc)
    tag_names = {tag for tag, _ in doc.tags}
    assert "script" not in tag_names and "b" not in tag_names and "i" not in tag_names
    assert "&lt;script&gt;" in text
    assert evil in "".join(doc.text.get("title", []))


def test_uncertainty_columns_and_extra(result: FitResult, tiny_figures) -> None:
    names = list(result.params)
    unc = dataclasses.replace(
        result.uncertainty, stderr={n: 0.01 * (i + 1) for i, n in enumerate(names)},
        ci95={n: (1.0, 2.0) for n in names}, correlation=np.eye(len(result.free)))
    res = result.with_parts(uncertainty=unc,
                            identifiability=("k0 and m are strongly correlated",),
                            application={"my_new_metric": {"aic": 12.5}})
    doc = parse(render_html(res, figures=tiny_figures))
    assert_well_formed(doc)
    table = param_table(doc)
    assert "std. error" in table[0] and "95 % CI" in table[0]
    se_col, ci_col = table[0].index("std. error"), table[0].index("95 % CI")
    rows = {row[0]: row for row in table[1:]}
    assert rows["m"][se_col] == "0.02" and rows["m"][ci_col] == "[1, 2]"
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "k0 and m are strongly correlated" in body
    assert "my_new_metric" in body and "12.5" in body
    corr = next(t for t in doc.tables if t and t[0][0] == "" and "k0" in t[0])
    assert corr[0][1:] == list(result.free)


def test_no_uncertainty_columns_without_stderr(result: FitResult, tiny_figures) -> None:
    bare = result.with_parts(uncertainty=None)
    table = param_table(parse(render_html(bare, figures=tiny_figures)))
    assert "std. error" not in table[0] and "95 % CI" not in table[0]


def test_robust_interval_column_only_when_residuals_are_not_white(
    result: FitResult, tiny_figures
) -> None:
    hac = "95 % CI, robust to serial correlation (HAC)"
    assert result.extra["uncertainty"]["whiteness"]["white"]
    assert hac not in param_table(parse(render_html(result, figures=tiny_figures)))[0]
    unc = dataclasses.replace(
        result.uncertainty, whiteness={**result.uncertainty.whiteness, "white": False},
        ci95_hac={n: (3.0, 4.0) for n in result.params})
    doc = parse(render_html(result.with_parts(uncertainty=unc), figures=tiny_figures))
    assert_well_formed(doc)
    table = param_table(doc)
    col = table[0].index(hac)
    rows = {row[0]: row for row in table[1:]}
    assert rows["c1"][col] == "[3, 4]" and rows["offset"][col] == "n/a"


def test_failed_fit_report(result: FitResult, tiny_figures) -> None:
    res = result.with_parts(
        model=None, params=dict.fromkeys(result.params, math.nan), scale=math.nan,
        offset=math.nan, status=Status.FAILED, reason="Newton step 2 made k0 non-positive",
        rmse=math.nan, r2=math.nan, fitted=np.full_like(result.data, np.nan),
        uncertainty=None,
    )
    doc = parse(render_html(res, figures=tiny_figures))
    assert_well_formed(doc)
    rows = {row[0]: row for row in param_table(doc)[1:]}
    # The units come from the model class even when no model was produced.
    assert rows["k0"][1] == "n/a" and rows["k0"][2] == "lbf/in"
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "NOT converged" in body and "Newton step 2" in body


def test_prediction_given_as_arrays(result: FitResult) -> None:
    pred = {"t": result.t, "load": result.load, "measured": result.data,
            "predicted": result.fitted, "label": "stroke 3"}
    doc = parse(render_html(result, figures={}, prediction=pred))
    assert_well_formed(doc)
    assert not [t for t, _ in doc.tags if t == "img"]  # figures={} embeds none
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "stroke 3" in body


def test_prediction_scores_only_and_card_info(result: FitResult, tiny_figures) -> None:
    """A card fit carries its card's provenance; a prediction may come as scores only."""
    res = result.with_parts(card=CardInfo(
        id="EX-1A", well=None, source="cards.csv, lines 2-101", spm=8.0, period=7.5,
        notes=("time rebuilt from SPM", "dup")))
    doc = parse(render_html(res, figures=tiny_figures, notes=["dup", "given by caller"],
                            prediction={"card": "EX-1B", "rmse": 0.631, "r2": 0.9996}))
    assert_well_formed(doc)
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "card EX-1B" in body and "Other results" not in body
    quality_tables = [t for t in doc.tables if t and t[0] == ["quantity", "value", "unit"]]
    pred_rows = {r[0]: r for r in quality_tables[-1]}
    assert pred_rows["RMSE"][1:] == ["0.631", "in"]
    info = next(t for t in doc.tables if t and t[0] == ["item", "value", "unit"])
    rows = {r[0]: r for r in info[1:]}
    assert rows["card"][1] == "EX-1A" and rows["stroke period"][1:] == ["7.5", "s"]
    assert "well" not in rows  # missing values are left out, not shown as "None"
    # Caller's notes first, card notes after, each once.
    li_text = [s.strip() for s in doc.text.get("li", [])]
    assert li_text[:3] == ["dup", "given by caller", "time rebuilt from SPM"]
    assert li_text.count("dup") == 1


def test_boundary_section(result: FitResult, tiny_figures) -> None:
    info = BoundaryInfo(
        (Limiting("k0", "infinity", 1e6, "k0 -> infinity: a mass-spring-dashpot"),),
        ReducedFit(model="MassSpringDamper", params={"m": 2.0, "c": 60.0},
                   units={"m": "lbf*s^2/in", "c": "lbf*s/in"}, scale=1.0, offset=0.1,
                   rmse=0.29, r2=0.9998, status="converged", reason="ok"))
    res = result.with_parts(boundary=info, status=Status.BOUNDARY)
    doc = parse(render_html(res, figures=tiny_figures))
    assert_well_formed(doc)
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "boundary (limiting model)" in body and "MassSpringDamper" in body
    bounds = next(t for t in doc.tables if t and t[0] == ["parameter", "runs to", "limit"])
    assert bounds[1][:2] == ["k0", "infinity"]
    reduced = next(t for t in doc.tables if t and t[0] == ["parameter", "value", "unit"]
                   and any(r[0] == "c" for r in t))
    rows = {r[0]: r for r in reduced[1:]}
    assert rows["c"][1:] == ["60", "lbf*s/in"] and rows["RMSE"][2] == "in"


def test_parameter_table_status_says_bound_and_undetermined(result: FitResult,
                                                            tiny_figures) -> None:
    # The table called k0 "fitted" where the text beside it said k0 ran to a bound, and an
    # undetermined value "fitted" like a determined one.
    info = BoundaryInfo((Limiting("k0", "infinity", 1e6, "k0 -> infinity"),), None)
    res = result.with_parts(boundary=info, status=Status.BOUNDARY,
                            determined={"parameters": ["c1", "k1", "offset"],
                                        "not_determined": ["m"]})
    table = param_table(parse(render_html(res, figures=tiny_figures)))
    status = {r[0]: r[table[0].index("status")] for r in table[1:]}
    assert status["k0"] == "runs to infinity: limiting model, not determined"
    assert status["m"] == "fitted, not determined"
    assert status["c1"] == status["k1"] == status["offset"] == "fitted"
    assert status["C"] == "fixed"


def test_write_outputs_with_prediction_arrays(result: FitResult, tmp_path) -> None:
    pred = {"card": "B", "t": result.t, "load": result.load, "measured": result.data,
            "predicted": result.fitted + 0.1}
    paths = write_outputs(result, tmp_path, prediction=pred, dpi=50)
    assert paths["prediction"].name == "prediction.png"
    doc = parse(paths["report"].read_text(encoding="utf-8"))
    assert_well_formed(doc)
    assert len([t for t, _ in doc.tags if t == "img"]) == 5
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "card B (400 samples)" in body


def test_bad_figure_input_rejected(result: FitResult) -> None:
    with pytest.raises(ValueError, match="not a PNG"):
        render_html(result, figures={"x": b"GIF89a"})


def test_write_outputs(result: FitResult, tmp_path) -> None:
    paths = write_outputs(result, tmp_path, notes="synthetic record")
    assert set(paths) == {"displacement", "card", "residuals", "history", "json", "report"}
    for key in ("displacement", "card", "residuals", "history"):
        assert paths[key].name == f"{key}.png"
        png = paths[key].read_bytes()
        assert png.startswith(PNG_SIGNATURE)
        # The report embeds exactly the bytes written to disk.
        assert base64.b64encode(png).decode() in paths["report"].read_text(encoding="utf-8")
    data = json.loads(paths["json"].read_text(encoding="utf-8"))
    assert data["model"] == "Kelvin" and set(data["params"]) == set(result.params)
    assert_well_formed(parse(paths["report"].read_text(encoding="utf-8")))


def test_reduced_model_status_is_said_once(result: FitResult, tiny_figures) -> None:
    info = BoundaryInfo(
        (Limiting("k0", "infinity", 1e6, "k0 -> inf"),),
        ReducedFit(model="MassSpringDamper", params={"m": 2.0, "c": 50.0, "k": 60.0},
                   units={"m": "lbf*s^2/in", "c": "lbf*s/in", "k": "lbf/in"}, scale=1.0,
                   offset=0.5, rmse=0.2, r2=0.999, status="converged",
                   reason="converged: the relative step fell below xtol = 1e-12"))
    doc = parse(render_html(result.with_parts(boundary=info), figures=tiny_figures))
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "(converged: the relative step fell below xtol = 1e-12)" in body
    assert "converged: converged" not in body


def test_identifiability_findings_are_never_cut(result: FitResult, tiny_figures) -> None:
    """Findings are sentences: shown whole, however long; none means all is determined."""
    long = ("The trade-off between k0, m, c1 and k1 (d ln k0 : d ln m : d ln c1 : d ln k1 = "
            "+1.00 : -0.15 : -0.67 : -0.33) is practically not identifiable: the data "
            "constrain this direction only to a standard error of 111 % (relative to the "
            "values; relative singular value 2.0e-04), so the intervals of the parameters "
            "involved are wide, and this sentence is longer than three hundred characters.")
    assert len(long) > 300
    doc = parse(render_html(result.with_parts(identifiability=(long,)), figures=tiny_figures))
    assert long in doc.text.get("li", [])
    clean = parse(render_html(result.with_parts(identifiability=()), figures=tiny_figures))
    body = " ".join(" ".join(v) for v in clean.text.values())
    assert "Every fitted value is determined by the data." in body
    assert "[]" not in body


def test_unstated_units_are_said_not_shown_as_placeholders(result: FitResult,
                                                           tiny_figures) -> None:
    bare = result.with_parts(units=pumpid.Units(load="load-unit", position="position-unit"))
    doc = parse(render_html(bare, figures=tiny_figures))
    rows = {r[0]: r[1] for t in doc.tables for r in t if len(r) == 2}
    assert rows["units"] == "load unit not stated, position unit not stated, time s"


def test_one_iteration_fit_has_no_convergence_figure(result: FitResult, tmp_path) -> None:
    one = result.with_parts(history=result.history[:2])
    paths = write_outputs(one, tmp_path, dpi=40)
    assert "history" not in paths and not (tmp_path / "history.png").exists()
    doc = parse(paths["report"].read_text(encoding="utf-8"))
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "The path recorded has 1 step: it starts at or next to the optimum" in body
    # The counts' difference is said without claiming a path the card did not take ("a
    # card that crawls along a flat valley" was printed on every card).
    assert "crawls" not in body and "joined from the solves that led to the answer" in body


@pytest.mark.realdata
def test_the_history_ends_at_the_answer_reported(shared_raw, tmp_path) -> None:
    # SX6I03A: the history ended at k0 = 1.276e8 beside the reported 3.469e8 (the boundary
    # test moves k0 to its limit after the solver's last iteration), and said "the solver
    # made 1 iteration" beside "iterations 2" in the Convergence table.
    from pumpid.cards import read_cards

    card = next(c for c in read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")
                if c.card_id == "SX6I03A")
    fit = pumpid.fit(pumpid.Kelvin, card)
    assert fit.boundary is not None and fit.history[-1]["k0"] != fit.params["k0"]
    doc = parse(write_outputs(fit, tmp_path, dpi=40)["report"].read_text(encoding="utf-8"))
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "The last row is the answer reported: after the solver's last iteration the " \
        "boundary test moved k0 toward its limit" in body
    steps = sum(1 for row in fit.history if row["iteration"] > 0)
    if fit.iterations != steps:
        said = ("the Convergence table counts the iterations of the last solve alone "
                f"({fit.iterations})")
        assert said in body and f"The table holds the path the fit recorded ({steps} step" in body
    history = next(t for t in doc.tables if t and t[0] and t[0][0] == "iteration")
    assert history[-1][0] == "answer"
    assert float(history[-1][1]) == pytest.approx(fit.params["k0"], rel=1e-7)


@pytest.mark.parametrize("status", [Status.UNDETERMINED, Status.POOR_FIT])
def test_an_optimum_the_gates_qualified_is_not_called_not_converged(
        result: FitResult, tiny_figures, status) -> None:
    # An undetermined or poor fit is an optimum the solver converged to: its report said
    # "NOT converged" beside a result (and JSON) saying undetermined.
    doc = parse(render_html(result.with_parts(status=status), figures=tiny_figures))
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "NOT converged" not in body and status.key in body


def test_fit_quality_sets_r2_beside_the_stroke_s_fundamental(tiny_figures) -> None:
    from ..conftest import spread_card

    card, _ = spread_card(6)
    periodic = pumpid.fit(pumpid.Kelvin, card)
    text = render_html(periodic, figures=tiny_figures)
    assert_well_formed(parse(text))
    assert "R² of the stroke&#x27;s fundamental alone" in text or \
        "R² of the stroke's fundamental alone" in text
    assert "share of what the fundamental leaves that the model explains" in text
    # A record from rest is not one period of a card: no such rows.
    t = np.linspace(0.0, 20.0, 401)
    load = 1000.0 + 300.0 * np.sin(2 * np.pi * t / 7.5)
    rest = pumpid.fit(pumpid.Kelvin, (t, load, pumpid.simulate(
        pumpid.Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0), t, load)))
    assert "fundamental" not in render_html(rest, figures=tiny_figures)


def test_a_model_choice_is_a_table(tmp_path) -> None:
    # --model auto's ranking was under "Other results" as a Python dict cut off after a few
    # hundred characters, its rss without a unit.
    from pumpid.cli import main

    example = pumpid.__path__[0] + "/data/example_cards.csv"
    assert main(["fit", example, "--card", "EX-1A", "--model", "auto", "--out",
                 str(tmp_path / "out")]) in (0, 6)
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    doc = parse(page)
    assert "Other results" not in page and "'rss'" not in page
    ranking = next(t for t in doc.tables if t and t[0][:3] == ["structure", "fitted values",
                                                              "R^2"])
    names = [row[0] for row in ranking[1:]]
    assert {"msd", "kelvin (u2)", "maxwell"} <= set(names)
    assert abs(sum(float(row[6]) for row in ranking[1:]) - 1.0) < 0.01
    assert "Chosen: " in page and "likelihood ratio" in page


def test_a_history_that_joins_solves_says_so(tmp_path) -> None:
    # The bundled example's EX-1A: its path joins three solves (22 steps) while the
    # Convergence table counts the last one's 9, and the page said "the fit made 9 in all".
    from pumpid.cards import read_cards

    card = next(c for c in read_cards(pumpid.__path__[0] + "/data/example_cards.csv")
                if c.card_id == "EX-1A")
    fit = pumpid.fit(pumpid.Kelvin, card)
    steps = sum(1 for row in fit.history if row["iteration"] > 0)
    doc = parse(write_outputs(fit, tmp_path, dpi=40)["report"].read_text(encoding="utf-8"))
    body = " ".join(" ".join(v) for v in doc.text.values())
    assert "in all, over its stages" not in body
    if steps != fit.iterations:
        assert f"recorded ({steps} steps" in body
    history = next(t for t in doc.tables if t and t[0] and t[0][0] == "iteration")
    assert len(history) - 1 == len(fit.history) + (history[-1][0] == "answer")
