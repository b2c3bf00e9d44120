"""Output paths: inside ``--out`` only, distinct per card, whole files, reruns said."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np
import pytest

from pumpid.cli import main
from pumpid.report import output as output_module
from pumpid.report.output import MANIFEST, OutputError

from .conftest import write_cards

U = ["--observe", "u"]
HOSTILE_IDS = ["..", ".", "a/b", "a?b", "A/B", "../../escape", "/abs", "CON", "results.csv",
               "\x1b[31mred\x1b[0m", "a b", "x" * 300]


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def test_card_ids_cannot_escape_out_or_collide(tmp_path: Path, capsys) -> None:
    src = tmp_path / "in"
    src.mkdir()
    path = write_cards(src / "ids.csv", HOSTILE_IDS, n_samples=40)
    before = _tree(tmp_path)
    out = tmp_path / "work" / "out"
    code = main(["fit", str(path), *U, "--out", str(out), "--brief"])
    captured = capsys.readouterr()
    assert code in (0, 3), captured.err
    assert "\x1b" not in captured.out + captured.err
    # Nothing was written anywhere but in the output folder (and its parents, made for it).
    assert _tree(tmp_path) - before - {"work", "work/out"} == {
        f"work/out/{p}" for p in _tree(out)}
    folders = sorted(p for p in out.iterdir() if p.is_dir())
    assert len(folders) == len(HOSTILE_IDS)
    assert len({f.name.casefold() for f in folders}) == len(HOSTILE_IDS)
    for folder in folders:
        assert folder.parent == out and not folder.name.startswith(".")
        assert (folder / "result.json").is_file() and (folder / "report.html").is_file()
    with (out / "results.csv").open(encoding="utf-8") as fh:
        index = list(csv.DictReader(fh))
    assert [r["card_id"] for r in index] == HOSTILE_IDS
    assert sorted(r["folder"] for r in index) == [f.name for f in folders]
    # Each folder holds the result of the card the index says.
    for r in index:
        data = json.loads((out / r["folder"] / "result.json").read_text(encoding="utf-8"))
        assert data["card"]["id"] == r["card_id"]
    assert not (tmp_path / "escape").exists() and not (tmp_path / "work" / "escape").exists()


def test_one_card_writes_into_the_folder_and_a_rerun_says_what_it_replaces(
        tmp_path: Path, capsys) -> None:
    path = write_cards(tmp_path / "two.csv", ["W-1", "W-2"], n_samples=40)
    out = tmp_path / "out"
    (out).mkdir()
    (out / "notes.txt").write_text("the user's own file")
    assert main(["fit", str(path), *U, "--card", "W-1", "--predict", "W-2", "--out",
                 str(out)]) == 0
    capsys.readouterr()
    names = {p.name for p in out.iterdir()}
    assert {"report.html", "result.json", "card.png", "prediction.png", "notes.txt",
            MANIFEST} <= names
    # result.json is the report in machine form: the prediction the report shows is in it.
    said = json.loads((out / "result.json").read_text())["prediction"]
    assert said["card"] == "W-2" and 0 < said["rmse"] and said["r2"] <= 1
    # ... with the predicted card's fundamental alone beside its R^2, in both.
    assert 0 < said["r2_fundamental"] <= 1
    assert "R² of the card&#x27;s fundamental alone" in (out / "report.html").read_text() or \
        "R² of the card's fundamental alone" in (out / "report.html").read_text()
    # Rerun without a prediction: the old prediction.png must not sit beside the new report.
    assert main(["fit", str(path), *U, "--card", "W-1", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "replaced" in err and "report.html" in err
    assert "removed prediction.png" in err
    assert not (out / "prediction.png").exists()
    assert (out / "notes.txt").read_text() == "the user's own file"
    assert not [p for p in out.iterdir() if p.name.startswith(".pumpid-") and p.name != MANIFEST]


def test_rerun_of_many_cards_replaces_each_folder_whole(tmp_path: Path, capsys) -> None:
    path = write_cards(tmp_path / "two.csv", ["W-1", "W-2"], n_samples=40)
    out = tmp_path / "out"
    assert main(["fit", str(path), *U, "--out", str(out)]) == 0
    (out / "W-1" / "stale.png").write_bytes(b"from another time")
    capsys.readouterr()
    assert main(["fit", str(path), *U, "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"replaced 2 card folders of an earlier run in {out}: W-1, W-2" in err
    assert err.count("\n") == 1
    assert not (out / "W-1" / "stale.png").exists()


@pytest.mark.parametrize("how", ["file", "below-a-file"])
def test_out_that_cannot_be_a_folder_is_exit_4_before_any_fit(two_cards: Path,
                                                              tmp_path: Path, how: str,
                                                              capsys) -> None:
    afile = tmp_path / "afile"
    afile.write_text("keep me")
    out = afile if how == "file" else afile / "sub"
    assert main(["fit", str(two_cards), *U, "--out", str(out)]) == 4
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "afile" in captured.err and captured.err.count("\n") == 1
    assert afile.read_text() == "keep me"


def test_read_only_folder_is_exit_4_before_any_fit(two_cards: Path, tmp_path: Path,
                                                   capsys) -> None:
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders (see the read-only file system test)")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["fit", str(two_cards), *U, "--out", str(ro / "out")]) == 4
    finally:
        ro.chmod(0o755)
    assert "cannot create the output folder" in capsys.readouterr().err


def test_read_only_file_system_is_exit_4_before_any_fit(two_cards: Path, capsys) -> None:
    """sysfs refuses new folders even to root: a real operating-system refusal."""
    if not Path("/sys/kernel").is_dir():
        pytest.skip("needs Linux sysfs")
    assert main(["fit", str(two_cards), *U, "--out", "/sys/pumpid-test-out"]) == 4
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "/sys/pumpid-test-out: cannot create the output folder" in captured.err


def test_a_write_failure_after_the_fit_keeps_the_result(two_cards: Path, tmp_path: Path,
                                                        monkeypatch, capsys) -> None:
    """The folder became unwritable after the check (a full disk, a permission changed):
    every result is still printed, the run says where it could not write, exit 4."""

    def refuse(self, stage: Path, name: str) -> list[str]:
        raise OutputError(f"{self.path / name}: cannot write (No space left on device)")

    monkeypatch.setattr(output_module.OutputFolder, "commit_folder", refuse)
    out = tmp_path / "out"
    assert main(["fit", str(two_cards), *U, "--out", str(out), "--json"]) == 4
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert [c["card"]["id"] for c in doc["cards"]] == ["W-1", "W-2"]
    for card in doc["cards"]:
        assert card["status"] in ("converged", "boundary") and card["params"]["k0"] > 0
        assert card["output"] is None
        assert any("No space left on device" in w for w in card["warnings"])
    assert "could not be written" in captured.err
    assert [p.name for p in out.iterdir()] == ["results.csv"]


def test_simulate_output_problems(tmp_path: Path, capsys) -> None:
    t = np.linspace(0, 10, 101)
    rec = tmp_path / "load.csv"
    rec.write_text("t,load\n" + "\n".join(f"{float(a)!r},{10 + float(np.sin(a))!r}" for a in t)
                   + "\n")
    folder = tmp_path / "adir"
    folder.mkdir()
    params = ["-p", "k0=4,m=1,c1=2,k1=4"]
    assert main(["simulate", str(rec), *params, "-o", str(folder)]) == 4
    assert "is a folder" in capsys.readouterr().err
    assert main(["simulate", str(rec), *params, "-o", str(tmp_path / "missing" / "x.csv")]) == 4
    assert "cannot write" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir", "load.csv"]
    assert main(["simulate", str(rec), *params, "-o", str(tmp_path / "sim.csv")]) == 0
    assert (tmp_path / "sim.csv").read_text().startswith("t_s,load,displacement\n")


def test_flow_out_naming_a_file_is_exit_4(tmp_path: Path, capsys) -> None:
    rows = ["t,dp,q"] + [f"{0.1 * i:.1f},{0 if i == 0 else 2e5},{(1 - 0.5 ** i) * 1e-5:.12g}"
                         for i in range(30)]
    rec = tmp_path / "rec.csv"
    rec.write_text("\n".join(rows) + "\n")
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert main(["flow", "fit", str(rec), "--out", str(afile)]) == 4
    assert "exists and is not a folder" in capsys.readouterr().err
    out = tmp_path / "flowout"
    assert main(["flow", "fit", str(rec), "--out", str(out)]) == 0
    assert (out / "report.html").is_file() and (out / MANIFEST).is_file()


def test_fit_results_csv_cannot_carry_a_formula(tmp_path: Path, capsys) -> None:
    import pandas as pd

    path = write_cards(tmp_path / "field.csv", ["=HYPERLINK(1)", "@cmd"], n_samples=40)
    code = main(["fit", str(path), "--model", "msd", "--brief", "--out", str(tmp_path / "o")])
    capsys.readouterr()
    assert code in (0, 3, 5, 6)
    raw = (tmp_path / "o" / "results.csv").read_bytes()
    assert b"\r\n" in raw  # rows end as spreadsheets expect
    index = pd.read_csv(tmp_path / "o" / "results.csv", dtype=str, keep_default_na=False)
    assert sorted(index["card_id"]) == ["'=HYPERLINK(1)", "'@cmd"]
    assert not [c for c in index.to_numpy().ravel() if c.startswith(("=", "@"))]
