"""CSV files pumpid writes for spreadsheets cannot carry a formula; Parquet keeps raw text."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from pumpid.fleet.batch import write_csv
from pumpid.fleet.changes import detect_changes
from pumpid.fleet.report import write_fleet_report
from pumpid.fleet.store import ResultsStore, results_schema
from pumpid.models import MassSpringDamper
from pumpid.report.spreadsheet import neutralise, neutralise_frame

from .test_changes import results_table

HOSTILE = ["=1+1", "+SUM(A1)", "@cmd", "-2+3", "\t=1", "\r=1", "-A1"]


def test_cells_that_would_be_formulas_are_quoted() -> None:
    for text in HOSTILE:
        assert neutralise(text) == "'" + text
    for text in ("W001", "-", "+", "-5", "+1.5e3", "-.5", "lbf/in", "", " =x"):
        assert neutralise(text) == text
    assert neutralise(-5.0) == -5.0 and neutralise(None) is None
    frame = pd.DataFrame({"id": ["=x", "ok"], "v": [-1.0, 2.0], "t": pd.NaT})
    out = neutralise_frame(frame)
    assert out["id"].tolist() == ["'=x", "ok"] and out["v"].tolist() == [-1.0, 2.0]
    assert frame["id"].tolist() == ["=x", "ok"]  # the caller's frame is left alone


def _hostile_table() -> pd.DataFrame:
    frame = results_table(len(HOSTILE), 40, cv=0.02, seed=3,
                          steps={0: ("stiffness", 1.4, 20)})
    names = dict(zip(sorted(frame["well_id"].unique()), HOSTILE, strict=True))
    frame["well_id"] = frame["well_id"].map(names)
    frame["card_id"] = "=" + frame["card_id"]
    return frame


def test_report_csvs_are_neutralised(tmp_path: Path) -> None:
    frame = _hostile_table()
    alerts = detect_changes(frame, ["stiffness"])
    assert len(alerts) == 1 and alerts["well_id"].iloc[0] == "=1+1"  # raw in the table
    files = write_fleet_report(frame, tmp_path, alerts=alerts, quantities=["stiffness"])
    for key in ("alerts", "wells"):
        cells = pd.read_csv(files[key], dtype=str, keep_default_na=False).to_numpy().ravel()
        bad = [c for c in cells if c.startswith(("=", "+", "@", "\t", "\r"))
               or (c.startswith("-") and neutralise(c) != c)]
        assert not bad, f"{key}.csv: {bad[:3]}"
    wells = pd.read_csv(files["wells"], dtype=str, keep_default_na=False)
    assert set(wells["well_id"]) == {"'" + h for h in HOSTILE}
    first = pd.read_csv(files["alerts"], dtype=str)["first_card_id"].iloc[0]
    assert first.startswith("'=W")


def test_batch_csv_is_neutralised_and_parquet_raw(tmp_path: Path) -> None:
    schema = results_schema(MassSpringDamper)
    rows = []
    for i, text in enumerate(HOSTILE):
        row = dict.fromkeys(schema.names)
        row.update(well_id=text, card_id=f"@card{i}", status="converged", r2=-0.5, item=i,
                   partition=0, reason="-", warnings="=bad")
        rows.append(row)
    store = ResultsStore.create(tmp_path / "res", {"inputs": [], "files": [], "options": {}})
    store.write_part(0, rows, schema)
    path = write_csv(store, 1, tmp_path / "results.csv")
    back = pd.read_csv(path, dtype=str, keep_default_na=False)
    assert back["well_id"].tolist() == ["'" + h for h in HOSTILE]
    assert back["card_id"].str.startswith("'@card").all()
    assert (back["reason"] == "-").all() and (back["warnings"] == "'=bad").all()
    assert (back["r2"] == "-0.5").all()
    raw = pd.read_parquet(store.part_path(0))
    assert raw["well_id"].tolist() == HOSTILE


def test_report_command_prints_ids_as_the_files_have_them(tmp_path: Path, capsys) -> None:
    from pumpid.cli import main

    frame = _hostile_table()
    results = tmp_path / "results"
    results.mkdir()
    frame.to_parquet(results / "part-00000.parquet")
    code = main(["report", str(results), "--out", str(tmp_path / "fleet"),
                 "--quantity", "stiffness"])
    out = capsys.readouterr().out
    assert code == 0
    assert "1 alert in 1 well" in out
    assert "well =1+1: stiffness" in out and "from card =W" in out
    assert "'=" not in out  # the CSV's neutralising quote is not the id


def test_report_draws_well_names_with_dollars_and_controls(tmp_path: Path) -> None:
    frame = results_table(2, 40, cv=0.02, seed=5)
    frame["well_id"] = frame["well_id"].map(dict(zip(sorted(frame["well_id"].unique()),
                                                     ["$x^{$", "a\tb\x1b[31m"], strict=True)))
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"])
    assert files["report"].exists()
