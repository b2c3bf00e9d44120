"""pumpid report refuses, in words, a RESULTS that is not a results table: what is wrong
and what to give instead (never pyarrow's words alone, never "None")."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from pumpid.cli import main


def _report(capsys, results: Path, tmp_path: Path) -> tuple[int, str]:
    code = main(["report", str(results), "--out", str(tmp_path / "fleet")])
    return code, capsys.readouterr().err


def test_missing_folder_is_named(tmp_path: Path, capsys) -> None:
    code, err = _report(capsys, tmp_path / "nowhere", tmp_path)
    assert code == 2
    assert "None" not in err
    assert "nowhere: no such file or folder" in err and "pumpid batch --out" in err
    assert not (tmp_path / "fleet").exists()


def test_empty_folder_says_it_holds_no_results(tmp_path: Path, capsys) -> None:
    (tmp_path / "empty").mkdir()
    code, err = _report(capsys, tmp_path / "empty", tmp_path)
    assert code == 2
    assert "holds no Parquet results" in err and "pumpid batch --out" in err
    assert not err.rstrip().endswith("it has")


def test_csv_given_as_the_results(tmp_path: Path, capsys) -> None:
    csv = tmp_path / "results.csv"
    pd.DataFrame({"well_id": ["W1"], "card_id": ["c"], "status": ["converged"]}).to_csv(csv)
    code, err = _report(capsys, csv, tmp_path)
    assert code == 2
    assert "magic bytes" not in err.lower() and "footer" not in err
    assert "results.csv: a CSV file" in err and "Parquet folder" in err


def test_parquet_without_the_columns_names_what_it_has(tmp_path: Path, capsys) -> None:
    table = tmp_path / "other.parquet"
    pd.DataFrame({"a": [1.0], "b": [2.0]}).to_parquet(table)
    code, err = _report(capsys, table, tmp_path)
    assert code == 2
    assert "not a results table of pumpid batch (1 row; its columns are a, b" in err
    assert "well_id, card_id, status" in err


def test_empty_parquet_table_says_it_has_no_columns(tmp_path: Path, capsys) -> None:
    table = tmp_path / "nothing.parquet"
    pd.DataFrame().to_parquet(table)
    code, err = _report(capsys, table, tmp_path)
    assert code == 2
    assert "it has no columns" in err
