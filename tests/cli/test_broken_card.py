"""End to end: one broken card of a file is an invalid-input row; its neighbours are fitted."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

import pumpid
from pumpid.cli import main

from .conftest import cli_env, write_cards


def _break(path: Path, card_id: str, k: int) -> int:
    """Put an unparsable position in the k-th row of ``card_id``; its 1-based line."""
    lines = path.read_text().splitlines()
    rows = [i for i, ln in enumerate(lines) if ln.startswith(card_id + ",")]
    cells = lines[rows[k]].split(",")
    cells[2] = "1.2.3"
    lines[rows[k]] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return rows[k] + 1


def test_batch_and_fit_keep_the_neighbours_of_a_broken_card(tmp_path: Path, capsys) -> None:
    path = write_cards(tmp_path / "field.csv", ["W-1", "W-2", "W-3"], n_samples=40)
    line = _break(path, "W-2", 5)

    code = main(["batch", str(path), "--out", str(tmp_path / "run"), "--model", "msd",
                 "--quiet"])
    capsys.readouterr()
    table = pumpid.read_results(tmp_path / "run").set_index("card_id")
    assert code in (0, 3)
    assert table.loc["W-1", "status"] == table.loc["W-3", "status"] == "converged"
    assert table.loc["W-2", "status"] == "invalid-input"
    assert table.loc["W-2", "source"] == f"{path}, line {line}, field 'position_in'"
    assert "'1.2.3'" in table.loc["W-2", "reason"]

    code = main(["fit", str(path), "--model", "msd", "--brief"])
    out = capsys.readouterr().out
    assert code != 0  # one card could not be fitted
    rows = {ln.split()[0]: ln for ln in out.splitlines() if ln.startswith("W-")}
    assert set(rows) == {"W-1", "W-2", "W-3"}
    assert "converged" in rows["W-1"] and "converged" in rows["W-3"]
    assert "invalid-input" in rows["W-2"]

    out_dir = tmp_path / "fit"
    main(["fit", str(path), "--model", "msd", "--brief", "--out", str(out_dir)])
    capsys.readouterr()
    index = pd.read_csv(out_dir / "results.csv").set_index("card_id")
    assert index.loc["W-2", "status"] == "invalid-input"
    assert f"line {line}, field 'position_in'" in index.loc["W-2", "source"]


def test_fit_refuses_a_fifo_instead_of_waiting(tmp_path: Path) -> None:
    fifo = tmp_path / "cards.csv"
    os.mkfifo(fifo)
    run = subprocess.run([sys.executable, "-m", "pumpid.cli", "fit", str(fifo)], env=cli_env(),
                         capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 2
    assert "not a regular file but a named pipe" in run.stderr


def test_batch_refuses_a_fifo_and_dev_null_by_what_they_are(tmp_path: Path, capsys) -> None:
    fifo = tmp_path / "cards.csv"
    os.mkfifo(fifo)
    for given, words in ((fifo, "a named pipe"), ("/dev/null", "a character device")):
        code = main(["batch", str(given), "--out", str(tmp_path / "run")])
        err = capsys.readouterr().err
        assert code == 2 and f"not a regular file but {words}" in err
        assert "no such file" not in err


def test_json_is_given_when_the_only_file_cannot_be_read(tmp_path: Path, capsys) -> None:
    # A script that fits one file a call parses stdout: when that file could not be read,
    # --json printed nothing (the message only on stderr), though it promises its document.
    import json

    bad = tmp_path / "bad.csv"
    bad.write_text("position_m,load_kN\n0,1\n1,\n", encoding="utf-8")
    well = tmp_path / "w.json"
    well.write_text(json.dumps({"units": {"length": "m", "diameter": "mm"}, "wells": {"W": {
        "rods": [{"length": 1000, "diameter": 22, "material": "steel"}],
        "pump": {"depth": 1000, "plunger_diameter": 38}, "tubing": {"anchored": True},
        "fluid": {"specific_gravity": 1.0}}}}), encoding="utf-8")
    for command in (["fit"], ["downhole", "--well", str(well)]):
        code = main([*command, str(bad), "--spm", "4", "--json"])
        doc = json.loads(capsys.readouterr().out)
        assert code == 2
        (card,) = doc["cards"]
        assert card["status"] == "invalid-input" and "line 3, field 'load_kN'" in card["reason"]
        assert doc["summary"]["status"] == {"invalid-input": 1}
    # Without --json the message is the run's error, as before.
    assert main(["fit", str(bad), "--spm", "4"]) == 2
    assert "line 3, field 'load_kN': empty value" in capsys.readouterr().err
