"""``pumpid fit``: short output by default, one line or JSON on request, bad cards as rows."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pumpid.cli import main
from pumpid.cli.render import first_sentence

from .conftest import write_cards

U = ["--observe", "u"]


def test_default_output_is_one_short_block_per_card(two_cards: Path, capsys) -> None:
    assert main(["fit", str(two_cards), *U]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    # The assumptions are stated once, not per card.
    assert sum("assumptions:" in ln for ln in lines) == 1
    assert sum("standard error" in ln for ln in lines) == 1
    # File-wide notes once, before the cards.
    assert sum("position unit in taken from column name" in ln for ln in lines) == 1
    blocks = [ln for ln in lines if ln.startswith(("W-1 ", "W-2 "))]
    assert len(blocks) == 2
    for head in blocks:
        assert "R^2 = " in head and "RMSE = " in head and " in " in head
    assert "k0 = " in out and "lbf/in" in out and "lbf*s^2/in" in out and "±" in out
    assert "natural frequency = " in out and " Hz" in out
    # Each card's block is a few lines (a boundary fit adds its limiting model and why; a
    # card whose ± are the robust errors, one line that says so).
    starts = [i for i, ln in enumerate(lines) if ln.startswith(("W-1 ", "W-2 "))]
    assert starts[1] - starts[0] <= 10 and len(lines) - starts[1] <= 13
    assert "correlation:" not in out  # the full diagnostics (correlation matrix) are --verbose's
    assert lines[-1] == "2 cards: 2 converged" or lines[-1].startswith("2 cards:")


def test_verbose_gives_the_full_report(two_cards: Path, capsys) -> None:
    assert main(["fit", str(two_cards), *U, "--verbose", "--card", "W-1"]) == 0
    out = capsys.readouterr().out
    assert "correlation:" in out and "95 % interval" in out and "uncertainty:" in out


def test_brief_is_one_line_per_card(two_cards: Path, capsys) -> None:
    assert main(["fit", str(two_cards), *U, "--brief"]) == 0
    rows = [ln.split("\t") for ln in capsys.readouterr().out.splitlines()
            if not ln.startswith("#")]
    assert [r[0] for r in rows] == ["W-1", "W-2"]
    for r in rows:
        assert r[1] in ("converged", "boundary")
        assert r[2].startswith("R^2=") and r[3].startswith("RMSE=") and r[3].endswith(" in")
        assert any((f.startswith("k0") and f.endswith("lbf/in")) or "ran to a bound" in f
                   for f in r)


@pytest.mark.parametrize("ids", [["W-1"], ["W-1", "W-2", "W-3"]])
def test_json_shape_is_the_same_for_one_card_and_many(tmp_path: Path, ids: list[str],
                                                      capsys) -> None:
    path = write_cards(tmp_path / "cards.csv", ids)
    assert main(["fit", str(path), *U, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) == {"cards", "summary"}
    assert [c["card"]["id"] for c in doc["cards"]] == ids
    for card in doc["cards"]:
        assert {"status", "reason", "card", "params", "r2", "rmse", "units", "output"} <= set(card)
        assert card["units"]["position"] == "in"
    summary = doc["summary"]
    assert summary["cards"] == len(ids) and summary["interrupted"] is False
    assert sum(summary["status"].values()) == len(ids)


def test_a_bad_card_is_a_row_not_the_end_of_its_file(tmp_path: Path, capsys) -> None:
    """Cards the readers accept but the fit cannot use fail alone: B has no stroke rate (no
    time axis), C a stroke rate of 1e300 per minute (the engine raised on it when this was
    written), D a load of 1e308 lbf; A and E are fitted."""
    cards = []
    for i, card_id in enumerate("ABCDE"):
        src = write_cards(tmp_path / f"{card_id}.csv", [card_id], seed=i)
        rows = src.read_text().splitlines()[1:]
        pos = [float(r.split(",")[2]) for r in rows]
        load = [float(r.split(",")[3]) for r in rows]
        if card_id == "D":
            load[5] = 1e308
        card = {"card_id": card_id, "position": pos, "load": load}
        if card_id != "B":
            card["spm"] = 1e300 if card_id == "C" else 8.0
        cards.append(card)
    path = tmp_path / "cards.json"
    path.write_text(json.dumps({"units": {"position": "in", "load": "lbf"}, "cards": cards}))
    code = main(["fit", str(path), *U, "--json"])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    doc = json.loads(captured.out)
    rows = {c["card"]["id"]: c for c in doc["cards"]}
    assert list(rows) == list("ABCDE")
    assert rows["B"]["status"] == "invalid-input" and "spm" in rows["B"]["reason"]
    assert rows["C"]["status"] in ("failed", "invalid-input") and rows["C"]["reason"]
    assert any("1e+308" in w for w in rows["D"]["data_warnings"])
    for ok in "AE":
        assert rows[ok]["status"] in ("converged", "boundary"), rows[ok]["reason"]
    assert code == 3


def test_an_unreadable_file_is_a_row_and_the_other_files_are_fitted(two_cards: Path,
                                                                     tmp_path: Path,
                                                                     capsys) -> None:
    junk = tmp_path / "junk.csv"
    junk.write_bytes(b"\x00\x8f\xff" * 50)
    code = main(["fit", str(junk), str(two_cards), *U, "--brief"])
    out = capsys.readouterr().out
    rows = [ln.split("\t") for ln in out.splitlines() if not ln.startswith("#")]
    assert rows[0][0].endswith("junk.csv") and rows[0][1] == "invalid-input"
    assert [r[0] for r in rows[1:]] == ["W-1", "W-2"]
    assert code == 3


def test_single_unreadable_file_is_exit_2_with_its_json_element(tmp_path: Path,
                                                                capsys) -> None:
    # --json promises its document: a script reading one file a call got an empty stdout.
    junk = tmp_path / "junk.csv"
    junk.write_bytes(b"\x00\x8f\xff" * 50)
    assert main(["fit", str(junk), "--json"]) == 2
    (card,) = json.loads(capsys.readouterr().out)["cards"]
    assert card["status"] == "invalid-input" and "junk.csv" in card["reason"]
    assert main(["fit", str(junk)]) == 2  # without --json: the run's error, on stderr
    captured = capsys.readouterr()
    assert captured.out == "" and "junk.csv" in captured.err


def test_prediction_of_another_card(two_cards: Path, capsys) -> None:
    assert main(["fit", str(two_cards), *U, "--card", "W-1", "--predict", "W-2"]) == 0
    out = capsys.readouterr().out
    assert "prediction of card W-2: R^2 = " in out
    assert "(the card's fundamental alone: " in out


def test_warnings_are_shortened_to_their_first_sentence() -> None:
    text = ("the residuals are not white noise: their lag-1 autocorrelation is 0.32 (white "
            "noise stays below 0.26 for 100 samples, 99.5 %). The standard errors are too "
            "narrow here.")
    assert first_sentence(text).endswith("99.5 %).")
    assert first_sentence("short one") == "short one"


def test_a_poor_fit_is_said_and_has_its_own_exit_status(tmp_path: Path, capsys) -> None:
    """Position and load that do not belong together: status poor-fit, a warning, exit 5."""
    path = write_cards(tmp_path / "one.csv", ["W-1"])
    lines = path.read_text(encoding="utf-8").splitlines()
    rows = [ln.split(",") for ln in lines[1:]]
    loads = [r[3] for r in rows]
    np.random.default_rng(0).shuffle(loads)
    path.write_text("\n".join([lines[0], *(",".join([*r[:3], f]) for r, f in
                                          zip(rows, loads, strict=True))]) + "\n",
                    encoding="utf-8")
    assert main(["fit", str(path), *U]) == 5
    out = capsys.readouterr().out
    assert "poor-fit" in out and "poor fit: R^2 = " in out
    # With the gate opened the answer stands, but a shuffled load determines no parameter:
    # status undetermined, exit 6 (it was converged, exit 0).
    assert main(["fit", str(path), *U, "--min-r2=-1"]) == 6
    assert "undetermined" in capsys.readouterr().out


def test_history_prints_the_solvers_path(two_cards: Path, capsys) -> None:
    # --history fits the cards one at a time, but through a list of one card, whose result
    # kept no path: "(no iterations recorded)" under a report that counted 14 iterations.
    assert main(["fit", str(two_cards), *U, "--history", "--card", "W-1"]) == 0
    out = capsys.readouterr().out
    assert "no iterations recorded" not in out
    lines = out.splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.startswith("iteration "))
    assert "cost" in lines[at] and "k0" in lines[at]
    # Every column with its unit (the numbers stood bare).
    assert "[in^2]" in lines[at + 1] and "[lbf/in]" in lines[at + 1]


@pytest.mark.realdata
def test_a_stroke_is_chosen_by_the_id_split_strokes_gives_it(shared_raw, capsys) -> None:
    # "no card '3X6E03#2' in this file; its cards are: 3X6E03, 3X6I03": the ids the split
    # prints could be neither fitted alone nor predicted.
    record = str(shared_raw / "sandia_dds" / "downhole_timeseries.csv")
    assert main(["fit", record, "--split-strokes", "--card", "3X6E03#2", "--brief"]) in (0, 6)
    lines = [ln for ln in capsys.readouterr().out.splitlines() if not ln.startswith("#")]
    assert [ln.split("\t")[0] for ln in lines] == ["3X6E03#2"]
    main(["fit", record, "--split-strokes", "--card", "3X6E03", "--predict", "3X6E03#3"])
    out = capsys.readouterr().out
    assert out.count("prediction of card 3X6E03#3: R^2 = ") == 6
    assert main(["fit", record, "--split-strokes", "--card", "3X6E03#9"]) == 2
    err = capsys.readouterr().err
    assert "no stroke '3X6E03#9': record '3X6E03' splits into 3X6E03#0, 3X6E03#1" in err
    assert main(["fit", record, "--split-strokes", "--card", "3X6E04#1"]) == 2
    err = capsys.readouterr().err
    assert "no card '3X6E04' (of stroke '3X6E04#1') in this file; its cards are: 3X6E03" in err


def test_a_record_that_cannot_be_split_is_one_row(tmp_path, capsys) -> None:
    # --split-strokes --card A, A too short a stroke to split: its reason and a second row
    # "no card 'A' in this file; its cards are: A, B".
    t = np.arange(120) * 0.1
    rows = ["card_id,t,position_in,load_lbf"]
    for cid, period in (("A", 1.0), ("B", 6.0)):
        pos = 50 * (1 - np.cos(2 * np.pi * t / period))
        rows += [f"{cid},{ti:.3f},{p:.4f},{5000 + 30 * p:.3f}" for ti, p in zip(t, pos,
                                                                             strict=True)]
    path = tmp_path / "two.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    main(["fit", str(path), str(path), "--split-strokes", "--card", "A", "--brief"])
    out = capsys.readouterr()
    said = [ln for ln in (out.out + out.err).splitlines() if "no card" in ln]
    assert said == [], said
    assert (out.out + out.err).count("every stroke is shorter than") == 2


def test_the_short_output_marks_an_echo_and_a_fundamental_alone(tmp_path: Path,
                                                                   capsys) -> None:
    # A position that is one sinusoid within the noise: the mass-spring-dashpot's natural
    # frequency is "determined" on the stroke frequency, an echo the HTML marked and this
    # line printed as the well's; its R^2 "explained 0.0 % of the rest" of mere noise.
    period = 7.5
    t = np.arange(200) * period / 200
    w = 2 * np.pi / period
    load = 50.0 + 10.0 * np.sin(w * t) + 2.0 * np.sin(2 * w * t)
    pos = 1.5 * np.sin(w * t - 1.2) + 0.01 * np.random.default_rng(0).standard_normal(200)
    path = tmp_path / "sine.csv"
    path.write_text("t_s,position_in,load_lbf\n" + "".join(
        f"{a:.6f},{b:.8f},{c:.6f}\n" for a, b, c in zip(t, pos, load, strict=True)))
    assert main(["fit", str(path), "--model", "msd", "--period", str(period)]) == 0
    out = capsys.readouterr().out
    assert "natural frequency = " in out
    assert "(an echo of the stroke, not the well's)" in out
    # At the noise level, not "noise": a field card's correlated residual of that size had
    # read "the rest is noise" beside "the residuals are not white noise".
    assert "the rest at the noise level)" in out and "of the rest)" not in out
    # --verbose's table marks the offset as the short output does (it said "(fitted)").
    assert main(["fit", str(path), "--period", str(period), "--verbose"]) in (0, 6)
    table = capsys.readouterr().out
    offset = next(ln for ln in table.splitlines() if ln.startswith("  offset  "))
    assert offset.endswith("(not determined)") and "(fitted)" not in offset
    # The error table gives no relative error of an offset (its zero is a convention).
    rows = [ln.split() for ln in table.splitlines() if ln.startswith("  offset  ")]
    assert len(rows) >= 2 and rows[1][2] == "-", rows


def test_a_column_of_date_time_stamps_is_read_as_time(tmp_path: Path, capsys) -> None:
    # A controller's export with a stamp per sample: the error told a command-line user to
    # pass columns={'t': None} (Python), which no option took; a column named otherwise was
    # dropped, and the card said "no time in the file". ISO stamps are now the card's time.
    n, period = 100, 10.0
    phase = 2 * np.pi * np.arange(n) / n
    stamps = [f"2024-05-01 10:00:{s:09.6f}" for s in np.arange(n) * period / n]
    rows = "".join(f"{s},{50 * (1 - np.cos(p)):.6f},{8000 + 3000 * np.sin(p - 0.4):.3f}\n"
                   for s, p in zip(stamps, phase, strict=True))
    named_t = tmp_path / "stamped.csv"
    named_t.write_text("time,position_in,load_lbf\n" + rows)
    assert main(["fit", str(named_t), "--json"]) in (0, 6)
    card = json.loads(capsys.readouterr().out)["cards"][0]["card"]
    assert card["time_source"] == "file" and card["period"] == pytest.approx(period)
    assert card["time"] == "2024-05-01 10:00:00+00:00"
    other = tmp_path / "other.csv"
    other.write_text("timestamp,position_in,load_lbf\n" + rows)
    main(["fit", str(other)])
    out = " ".join(capsys.readouterr().out.split())
    assert ("column 'timestamp' has a date/time stamp per row ('2024-05-01 10:00:00.000000', "
            "...): not read as the card's time (its first stamp dates the card); to read it "
            "as the time, name it the time column (columns={'t': 'timestamp'}, command line "
            "--columns t=timestamp)") in out
    assert "no time read from the file" in out
    assert main(["fit", str(other), "--columns", "t=timestamp"]) in (0, 6)
    out = " ".join(capsys.readouterr().out.split())
    assert "column 'timestamp' holds ISO 8601 date/time stamps" in out
    # A form whose day and month cannot be told apart is refused, with the way round it.
    us = tmp_path / "us.csv"
    us.write_text("time,position_in,load_lbf\n" + rows.replace("2024-05-01", "05/01/2024"))
    assert main(["fit", str(us)]) == 2
    assert "is not a date and time in ISO 8601 form" in capsys.readouterr().err
    assert main(["fit", str(us), "--columns", "t=-", "--spm", "6"]) in (0, 6)
    assert "time rebuilt from" in capsys.readouterr().out
    assert main(["fit", str(us), "--columns", "position=-", "--spm", "6"]) == 2
    assert "position needs a column" in capsys.readouterr().err


def test_a_card_its_reader_refused_keeps_its_well_in_the_json(tmp_path: Path, capsys) -> None:
    # pumpid batch recorded a broken card's well; pumpid fit --json dropped it.
    phase = 2 * np.pi * np.arange(40) / 40
    card = {"position": list(50 * (1 - np.cos(phase))), "load": list(8000 + 3000 * np.sin(phase))}
    doc = [{"well": "W7", "spm": 6, "position_unit": "in", "load_unit": "lbf",
            "cards": [card, {"card_id": "broken", "position": [1.0, 2.0]}]}]
    path = tmp_path / "well.json"
    path.write_text(json.dumps(doc))
    main(["fit", str(path), "--json"])
    refused = json.loads(capsys.readouterr().out)["cards"][0]
    assert refused["status"] == "invalid-input"
    assert refused["card"]["id"] == "broken" and refused["card"]["well"] == "W7"
