"""Every refusal and failure says in words what is wrong: a card not fitted because its
start is not finite has a reason; a bad x0 names x0; --joint --json has the shape of every
--json; an empty output path is refused; a refused resume lists its differences as lines."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import pumpid
import pumpid.pump
from pumpid.cards import read_cards
from pumpid.cli import main
from tests.cli.conftest import write_cards


def _brief_rows(text: str) -> list[dict[str, str]]:
    rows = []
    for line in text.splitlines():
        if line.startswith("#"):
            continue
        cells = line.split("\t")
        rows.append({"id": cells[0], "status": cells[1],
                     **dict(c.split("=", 1) for c in cells[2:] if "=" in c)})
    return rows


@pytest.mark.parametrize("option", [["--scale", "1e-320"],
                                    ["--initial-state", "1e308,1e308,1e308"]])
def test_a_start_that_is_not_finite_fails_with_a_reason(two_cards: Path, capsys,
                                                       option: list[str]) -> None:
    code = main(["fit", str(two_cards), "--brief", *option])
    rows = _brief_rows(capsys.readouterr().out)
    assert code == 3
    assert [r["status"] for r in rows] == ["failed", "failed"]
    for r in rows:
        assert "starting point is not a finite number" in r["reason"]


@pytest.mark.parametrize("x0", ["abc", {"k0": "abc", "m": 1.0, "c1": 1.0, "k1": 1.0},
                                ["1", "x", "1", "1"]])
def test_x0_that_is_not_numbers_is_named(two_cards: Path, x0: object) -> None:
    card = read_cards(two_cards)[0]
    with pytest.raises(ValueError, match=r"^x0: .* is not a number"):
        pumpid.fit(pumpid.Kelvin, card, x0=x0)
    with pytest.raises(ValueError, match=r"^x0: .* is not a number"):
        pumpid.fit(pumpid.Kelvin, [card], x0=x0)


def test_x0_option_that_is_not_a_number_is_named(two_cards: Path, capsys) -> None:
    code = main(["fit", str(two_cards), "--x0", "k0=abc,m=1,c1=1,k1=1"])
    assert code == 2
    assert "--x0: k0 = 'abc' is not a number" in capsys.readouterr().err


def test_joint_json_has_the_shape_of_every_json(two_cards: Path, capsys) -> None:
    code = main(["fit", str(two_cards), "--joint", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 0
    assert set(doc) == {"cards", "summary"}
    assert [c["card"]["id"] for c in doc["cards"]] == ["W-1", "W-2"]
    assert all(c["status"] == doc["summary"]["joint"]["status"] for c in doc["cards"])
    assert doc["summary"]["cards"] == 2 and "(joint, 2 cards)" in doc["summary"]["joint"]["model"]
    assert set(doc["summary"]["joint"]["params"]) == {"k0", "m", "c1", "k1", "level_1", "level_2"}
    assert all({"level", "offset", "r2", "rmse", "single"} <= set(c) for c in doc["cards"])


def test_card_given_again_chooses_more_cards(tmp_path: Path, capsys) -> None:
    # "--card A --card B" kept only B: a joint fit of two named cards of a file of four
    # was told it had fewer than two.
    path = write_cards(tmp_path / "four.csv", ["W-1", "W-2", "W-3", "W-4"])
    code = main(["fit", str(path), "--card", "W-3", "--card", "W-1", "--joint", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 0 and [c["card"]["id"] for c in doc["cards"]] == ["W-1", "W-3"]
    code = main(["fit", str(path), "--card", "W-2", "--card", "W-9", "--brief"])
    lines = [ln for ln in capsys.readouterr().out.splitlines() if not ln.startswith("#")]
    assert code == 3  # some cards fitted, some not
    assert {ln.split("\t")[0] for ln in lines} == {"W-2", "W-9"}
    assert any(ln.startswith("W-9\tinvalid-input") and "no card 'W-9'" in ln for ln in lines)


@pytest.mark.parametrize("argv", [["fit", "{cards}", "--out", ""],
                                  ["fit", "{cards}", "--out", " "],
                                  ["batch", "{cards}", "--out", ""],
                                  ["batch", "{cards}", "--out", "{tmp}/r", "--csv", ""],
                                  ["simulate", "{cards}", "-p", "k0=1,m=1,c1=1,k1=1",
                                   "-o", ""]])
def test_empty_output_path_is_refused(two_cards: Path, tmp_path: Path, capsys, monkeypatch,
                                      argv: list[str]) -> None:
    monkeypatch.chdir(tmp_path)  # a blank path taken as a name writes here, not in the repo
    argv = [a.format(cards=two_cards, tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert "an empty path" in captured.err and captured.out == ""
    assert not (tmp_path / "r").exists()


def test_refused_resume_lists_its_differences_as_lines(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    write_cards(folder / "a.csv", ["W-1"])
    out = tmp_path / "r"
    assert main(["batch", str(folder), "--out", str(out), "--model", "msd", "--quiet"]) == 0
    capsys.readouterr()
    code = main(["batch", "--resume", "--out", str(out), "--model", "kelvin", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert "\\n" not in err
    lines = err.splitlines()
    assert lines[0].startswith("pumpid: error: ") and "not mixed with this one:" in lines[0]
    assert any(line.startswith("  - ") and '"model": "msd"' in line for line in lines[1:])


@pytest.mark.parametrize(("counts", "code"), [
    ({"converged": 2}, 0), ({"converged": 1, "poor-fit": 1}, 5),
    ({"undetermined": 1, "converged": 1}, 6), ({"invalid-input": 2}, 2), ({}, 2),
    ({"failed": 1}, 3), ({"converged": 1, "invalid-input": 1}, 3),
    # Fitted, if poorly or undetermined, beside invalid cards: some fitted, some not (it
    # said 2, "nothing fitted").
    ({"undetermined": 3, "invalid-input": 1}, 3), ({"poor-fit": 1, "invalid-input": 1}, 3),
])
def test_exit_status_by_statuses(counts: dict[str, int], code: int) -> None:
    from pumpid.cli.common import exit_status

    assert exit_status(counts) == code


def test_cards_named_across_files_are_each_found_once(tmp_path: Path, capsys) -> None:
    # W-1 in one file and W-2 in another: both were fitted, and each file added a row for
    # the card it lacked (exit 3); a joint fit of the two was refused.
    a = write_cards(tmp_path / "a.csv", ["W-1"])
    b = write_cards(tmp_path / "b.csv", ["W-2", "W-3"], seed=1)
    code = main(["fit", str(a), str(b), "--card", "W-1", "--card", "W-2", "--card", "W-9",
                 "--brief"])
    lines = [ln for ln in capsys.readouterr().out.splitlines() if not ln.startswith("#")]
    assert sorted(ln.split("\t")[0] for ln in lines) == ["W-1", "W-2", "W-9"]
    assert any(ln.startswith("W-9\tinvalid-input") and "in any of the 2 files" in ln
               for ln in lines)
    assert code == 3
    code = main(["fit", str(a), str(b), "--card", "W-1", "--card", "W-2", "--joint",
                 "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 0 and [c["card"]["id"] for c in doc["cards"]] == ["W-1", "W-2"]


def test_a_stroke_of_a_refused_record_gives_the_readers_reason(tmp_path: Path,
                                                              capsys) -> None:
    # The record R refused by the reader (a NaN load) read "no card 'R' (of stroke 'R#1')".
    path = write_cards(tmp_path / "two.csv", ["R", "S"])
    text = path.read_text().splitlines()
    first = next(i for i, ln in enumerate(text) if ln.startswith("R,"))
    cells = text[first].split(",")
    text[first] = ",".join([*cells[:-1], "nan"])
    path.write_text("\n".join(text) + "\n")
    code = main(["fit", str(path), "--split-strokes", "--card", "R#1", "--card", "S",
                 "--brief"])
    out = capsys.readouterr().out
    row = next(ln for ln in out.splitlines() if ln.startswith("R\t"))
    assert "NaN" in row and "no card 'R'" not in out
    assert code == 3
