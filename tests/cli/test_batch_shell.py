"""pumpid batch's shell: exit statuses as pumpid fit's, its options checked as pumpid fit
checks them, --csv checked before fitting, the summary escaped and in words."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from pumpid.cli import main
from tests.cli.conftest import write_cards

FIT = ["--model", "msd", "--quiet"]
ESC = "W\x1b[2J\u202e-1"


def _run(capsys, argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _flat_card(path: Path, card_id: str) -> Path:
    """A card whose load is constant: refused as invalid-input."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["card_id", "spm", "position_in", "load_lbf"])
        for i in range(60):
            writer.writerow([card_id, "8", f"{(i * 7) % 60}.0", "100.0"])
    return path


@pytest.fixture
def good(tmp_path: Path) -> Path:
    folder = tmp_path / "good"
    folder.mkdir()
    write_cards(folder / "a.csv", ["W-1", "W-2"])
    return folder


def test_all_fitted_exits_0_and_words_agree(good: Path, tmp_path: Path, capsys) -> None:
    code, out, _ = _run(capsys, ["batch", str(good), "--out", str(tmp_path / "r"), *FIT])
    assert code == 0, out
    assert "cards: 2 in 1 partition (" in out and "1 partitions" not in out


def test_a_broken_card_makes_exit_3(good: Path, tmp_path: Path, capsys) -> None:
    _flat_card(good / "flat.csv", "F-1")
    code, out, _ = _run(capsys, ["batch", str(good), "--out", str(tmp_path / "r"), *FIT])
    assert code == 3, out
    assert "invalid-input 1" in out and "    1 card: " in out


def test_nothing_fittable_exits_2(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "bad"
    folder.mkdir()
    _flat_card(folder / "flat.csv", "F-1")
    code, out, _ = _run(capsys, ["batch", str(folder), "--out", str(tmp_path / "r"), *FIT])
    assert code == 2, out


@pytest.mark.parametrize(("option", "words"), [
    (["--scale", "nan"], "output scale must be a positive number"),
    (["--scale", "inf"], "output scale must be a positive number"),
    (["--scale", "x"], "neither a number nor 'free'"),
    (["--max-nfev", "0"], "--max-nfev 0"),
    # One evaluation is only a solve's start: it ran two and said "(2) was reached".
    (["--max-nfev", "1"], "at least 2 (a solve's start and one step)"),
    (["--min-r2", "nan"], "R^2 is a number at most 1"),
    (["--min-r2", "2"], "R^2 is a number at most 1"),
    (["--x0", "m=1,c=nan,k=1"], "not a finite number"),
    (["--x0", "m=1"], "give all of"),
    (["--initial-state", "1,inf"], "not finite"),
    (["--spm", "0"], "not a pumping speed"),
])
def test_options_refused_as_pumpid_fit_refuses_them(good: Path, tmp_path: Path, capsys,
                                                    option: list[str], words: str) -> None:
    code, _, err = _run(capsys, ["batch", str(good), "--out", str(tmp_path / "r"), *FIT,
                                 *option])
    assert code == 2 and words in err, err
    assert not (tmp_path / "r").exists()
    # pumpid fit says the same of the same option (one validation for both)
    if option[0] not in ("--max-nfev",):
        fit_code, _, fit_err = _run(capsys, ["fit", str(good / "a.csv"), "--model", "msd",
                                             *option])
        assert fit_code == 2 and words in fit_err


def test_csv_onto_a_folder_is_refused_before_fitting(good: Path, tmp_path: Path,
                                                     capsys) -> None:
    folder = tmp_path / "taken"
    folder.mkdir()
    code, out, err = _run(capsys, ["batch", str(good), "--out", str(tmp_path / "r"), *FIT,
                                   "--csv", str(folder)])
    assert code == 4, err
    assert "is a folder" in err and out == ""
    assert not (tmp_path / "r").exists()  # nothing fitted


def test_summary_escapes_ids_and_file_names(good: Path, tmp_path: Path, capsys) -> None:
    _flat_card(good / "flat.csv", ESC)
    (good / "x\u202egpj.csv").write_text("not,a\ncard\n", encoding="utf-8")
    code, out, _ = _run(capsys, ["batch", str(good), "--out", str(tmp_path / "r"), *FIT])
    assert code == 3
    assert "\x1b" not in out and "\u202e" not in out
    assert "W\\x1b[2J\\u202e-1" in out  # the id, escaped
    assert "x\\u202egpj.csv" in out  # the unreadable file, escaped
