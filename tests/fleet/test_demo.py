"""The demo field of make demo shows what the README says: one well that changed."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from pumpid.fleet import FitSpec, read_results, run_batch, write_fleet_report
from pumpid.fleet.demo import DEMO_FIELD, DEMO_PUMP_FIELD, PUMP_CHANGE_AT, main


@pytest.mark.slow
def test_demo_field_batch_and_report(tmp_path: Path, capsys) -> None:
    assert main([str(tmp_path / "field")]) == 0
    assert "432 cards of 6 wells" in capsys.readouterr().out
    truth = pd.read_csv(tmp_path / "truth.csv")
    assert len(truth) == 432 and truth["changed"].sum() == 72 - DEMO_FIELD["change"].at
    run_batch([tmp_path / "field"], tmp_path / "results",
              fit=FitSpec("kelvin", options={"observe": "u"}))
    table = read_results(tmp_path / "results")
    assert len(table) == 432 and set(table["well_id"].dropna()) == set(truth["well_id"])
    paths = write_fleet_report(table, tmp_path / "fleet")
    alerts = pd.read_csv(paths["alerts"])
    assert set(alerts["well_id"]) == {"W003"}
    stiffness = alerts[alerts["quantity"] == "static_stiffness"].iloc[0]
    assert 0.1 < stiffness["change_rel"] < 0.3  # k1 + 30 % moves the stiffness seen at u
    first = truth.set_index("card_id").loc[stiffness["first_card_id"], "card_index"]
    assert abs(first - DEMO_FIELD["change"].at) <= 3


def test_demo_usage(capsys, tmp_path: Path, monkeypatch) -> None:
    assert main([]) == 2
    assert "usage" in capsys.readouterr().err
    # --help is help, not a folder named "--help" (with a truth table written beside it)
    monkeypatch.chdir(tmp_path)
    assert main(["--help"]) == 0
    assert "usage" in capsys.readouterr().out
    assert main(["--pumps", "--bogus"]) == 2 and main(["-x"]) == 2
    assert list(tmp_path.iterdir()) == []


def test_demo_words_agree_with_its_truth_table(tmp_path: Path, capsys) -> None:
    assert main([str(tmp_path / "field")]) == 0
    out = capsys.readouterr().out
    truth = pd.read_csv(tmp_path / "truth.csv")
    first = truth[truth["changed"]].sort_values("card_index").iloc[0]
    assert first["card_index"] == DEMO_FIELD["change"].at
    assert (f"well {first['well_id']}'s k1 rises by 30% from card_index "
            f"{first['card_index']} of the truth table (card {first['card_id']}") in out


def test_pump_demo_words_agree_with_its_truth_table(tmp_path: Path, capsys) -> None:
    assert main(["--pumps", str(tmp_path / "pumps" / "field")]) == 0
    out = capsys.readouterr().out
    truth = pd.read_csv(tmp_path / "pumps" / "truth.csv")
    assert len(truth) == 4 * DEMO_PUMP_FIELD["cards"]
    assert (tmp_path / "pumps" / "wells.json").exists()
    changed = truth[truth["changed"]]
    assert set(changed["well_id"]) == {"P002", "P003"}
    assert changed["card_index"].min() == PUMP_CHANGE_AT
    assert f"{len(truth)} cards of 4 wells" in out
    assert "well P002: fillage 1.00 -> 0.75 (fraction) from card_index 12" in out
    drop = re.search(r"well P003: fluid load \d+ -> \d+ lbf \(([-+]\d+)%\) from card_index 12",
                     out)
    assert drop is not None and -22 <= int(drop.group(1)) <= -15  # -18 % and the scatter
