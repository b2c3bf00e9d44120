"""The Parquet long layout reader: cards back, and every problem named by file and card."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pumpid.cards import Card, CardError
from pumpid.fleet.dataset import iter_parquet_cards, read_parquet_cards


def _long(card_ids: list[str], n: int = 30, **extra: object) -> pd.DataFrame:
    frames = []
    for k, cid in enumerate(card_ids):
        phase = np.arange(n) / n
        frames.append(pd.DataFrame({
            "well_id": "P-1", "card_id": cid,
            "time": pd.Timestamp("2024-05-01", tz="UTC") + pd.Timedelta(hours=k),
            "sample": np.arange(n), "position": 50 * (1 - np.cos(2 * np.pi * phase)),
            "load": 6000 + 2000 * np.sin(2 * np.pi * phase + 0.3), "spm": 6.0, **extra,
        }))
    return pd.concat(frames, ignore_index=True)


def test_reads_cards_with_time_and_units(tmp_path: Path) -> None:
    frame = _long(["a", "b"], position_unit="in", load_unit="lbf")
    frame = frame.sample(frac=1.0, random_state=0)  # row order must not matter
    frame.to_parquet(tmp_path / "x.parquet")
    cards = read_parquet_cards(tmp_path / "x.parquet")
    assert sorted(c.card_id for c in cards) == ["a", "b"]
    card = {c.card_id: c for c in cards}["b"]
    assert card.well_id == "P-1" and card.n == 30 and card.periodic
    assert (card.position_unit, card.load_unit) == ("in", "lbf")
    assert card.metadata["time"] == pd.Timestamp("2024-05-01 01:00", tz="UTC")
    np.testing.assert_allclose(card.t, np.arange(30) * 10.0 / 30)
    np.testing.assert_allclose(card.position, 50 * (1 - np.cos(2 * np.pi * np.arange(30) / 30)))


def test_padding_is_dropped_as_from_every_file(tmp_path: Path) -> None:
    # A fixed-length record filled with its last point, as the card files' readers drop it.
    stroke = _long(["a"])
    pad = pd.concat([stroke.iloc[[-1]]] * 6, ignore_index=True).assign(sample=np.arange(30, 36))
    pd.concat([stroke, pad], ignore_index=True).to_parquet(tmp_path / "padded.parquet")
    (card,) = read_parquet_cards(tmp_path / "padded.parquet")
    assert card.n == 30
    assert any("padding dropped: the last 6 of 36 samples" in n for n in card.notes)
    np.testing.assert_allclose(card.t, np.arange(30) * 10.0 / 30)
    # With a t column the times are dropped with their samples (the card was refused:
    # "t has 36 samples but position has 30").
    timed = pd.concat([stroke, pad], ignore_index=True).drop(columns=["sample"])
    timed.assign(t=np.arange(36) * 10.0 / 30).to_parquet(tmp_path / "timed.parquet")
    (card,) = read_parquet_cards(tmp_path / "timed.parquet")
    assert card.n == 30 and card.periodic
    np.testing.assert_allclose(card.t, np.arange(30) * 10.0 / 30)


def test_a_record_of_strokes_is_timed_per_stroke_as_from_every_file(tmp_path: Path) -> None:
    # Three strokes in one card without t were read as one stroke of 10 s.
    frame = _long(["a"], n=90)
    frame["position"] = np.tile(frame["position"].to_numpy()[::3], 3)
    frame["load"] = np.tile(frame["load"].to_numpy()[::3], 3)
    frame.to_parquet(tmp_path / "three.parquet")
    (card,) = read_parquet_cards(tmp_path / "three.parquet")
    assert not card.periodic
    np.testing.assert_allclose(np.diff(card.t), 10.0 / 30)
    assert any("holds several strokes" in w for w in card.warnings)


def test_a_duplicated_closing_point_is_dropped_as_from_every_file(tmp_path: Path) -> None:
    # The same card gave 200 samples from Parquet and 199 from its .ts file (whose reader
    # drops a last sample that repeats the first), and another fit status.
    stroke = _long(["a"])
    closed = pd.concat([stroke, stroke.iloc[[0]].assign(sample=30)], ignore_index=True)
    closed.to_parquet(tmp_path / "closed.parquet")
    (card,) = read_parquet_cards(tmp_path / "closed.parquet")
    assert card.n == 30 and any("duplicated closing point dropped" in n for n in card.notes)
    np.testing.assert_allclose(card.t, np.arange(30) * 10.0 / 30)
    from pumpid.cards import read_cards

    text = tmp_path / "closed.csv"
    text.write_text("position,load\n" + "".join(
        f"{p!r},{f!r}\n" for p, f in zip(closed["position"], closed["load"], strict=True)))
    (same,) = read_cards(text, spm=6.0)
    np.testing.assert_array_equal(same.position, card.position)
    # With a t column the samples are the file's, every one kept.
    timed = closed.drop(columns=["sample"]).assign(t=np.arange(31) * 0.3)
    timed.to_parquet(tmp_path / "timed.parquet")
    assert read_parquet_cards(tmp_path / "timed.parquet")[0].n == 31


def test_folder_and_t_column(tmp_path: Path) -> None:
    _long(["a"]).to_parquet(tmp_path / "1.parquet")
    frame = _long(["b"]).drop(columns=["sample", "spm"])
    frame["t"] = np.arange(30) * 0.25
    frame["time"] = frame["time"].dt.tz_localize(None)
    frame.to_parquet(tmp_path / "2.parquet")
    cards = read_parquet_cards(tmp_path, position_unit="m", load_unit="kN")
    assert [c.card_id for c in cards] == ["a", "b"]
    # One stroke in its own time: one period, as every reader takes it.
    assert cards[1].time_source == "file" and cards[1].periodic
    assert any("UTC" in n for n in cards[1].notes)
    assert cards[1].position_unit == "m"


@pytest.mark.parametrize(
    ("change", "message", "field"),
    [
        (lambda f: f.assign(load=np.where(f.index == 40, np.nan, f["load"])), "NaN", "load"),
        (lambda f: f.assign(sample=np.where(f.index == 40, 11, f["sample"])), "twice", "sample"),
        (lambda f: f.assign(well_id=np.where(f.index == 40, "P-2", f["well_id"])),
         "changes within", "well_id"),
        (lambda f: f.assign(load=np.where(f["card_id"] == "b", 1.0, f["load"])),
         "constant load", "load"),
        (lambda f: f[(f["card_id"] == "a") | (f["sample"] < 5)], "only 5 samples", "position"),
        (lambda f: f.assign(spm=np.where(f["card_id"] == "b", -3.0, f["spm"])), "spm", "spm"),
    ],
)
def test_bad_card_named(tmp_path: Path, change, message: str, field: str) -> None:
    path = tmp_path / "bad.parquet"
    change(_long(["a", "b"])).to_parquet(path)
    with pytest.raises(CardError, match=message) as info:
        read_parquet_cards(path)
    err = info.value
    assert err.path == str(path) and err.field == field and "card 'b'" in str(err)
    items = list(iter_parquet_cards(path))  # the batch reader keeps the good card
    assert isinstance(items[0], Card) and isinstance(items[1], CardError)


def test_bad_files(tmp_path: Path) -> None:
    (tmp_path / "junk.parquet").write_bytes(b"\x00not parquet at all")
    with pytest.raises(CardError, match="cannot read") as info:
        read_parquet_cards(tmp_path / "junk.parquet")
    assert info.value.path == str(tmp_path / "junk.parquet")
    _long(["a"]).drop(columns=["sample"]).to_parquet(tmp_path / "nosample.parquet")
    with pytest.raises(CardError, match=r"sample \(or t\)"):
        read_parquet_cards(tmp_path / "nosample.parquet")
    with pytest.raises(CardError, match="no such"):
        read_parquet_cards(tmp_path / "absent.parquet")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(CardError, match=r"no \.parquet"):
        read_parquet_cards(empty)


def test_one_stroke_with_its_time_is_one_period_as_from_every_file(tmp_path: Path) -> None:
    # A stroke with a t column was fitted from rest from Parquet, as one period from CSV.
    frame = _long(["a"]).drop(columns=["sample", "spm"]).assign(t=np.arange(30) * 10.0 / 30)
    frame.to_parquet(tmp_path / "timed.parquet")
    (card,) = read_parquet_cards(tmp_path / "timed.parquet")
    assert card.periodic and card.period == pytest.approx(10.0)


def test_the_callers_stroke_rate_wins_as_for_every_file(tmp_path: Path) -> None:
    # A run's --spm re-timed its CSV and JSON cards and left its Parquet ones at their own
    # spm column, without a word.
    _long(["a"]).to_parquet(tmp_path / "x.parquet")
    (card,) = read_parquet_cards(tmp_path / "x.parquet", spm=12.0)
    assert card.period == pytest.approx(5.0) and card.spm == pytest.approx(12.0)
    np.testing.assert_allclose(card.t, np.arange(30) * 5.0 / 30)
    assert any("not from the file's own (6 SPM" in w for w in card.warnings)
    (same,) = read_parquet_cards(tmp_path / "x.parquet", period=10.0)
    assert same.period == pytest.approx(10.0) and not same.warnings
    with pytest.raises(ValueError, match="not both"):
        read_parquet_cards(tmp_path / "x.parquet", spm=6.0, period=10.0)


def test_a_parquet_file_is_read_by_pumpid_fit_and_named_by_the_text_readers(
        tmp_path: Path, capsys) -> None:
    # pumpid fit and pumpid downhole called a Parquet card file's bytes an encoding
    # problem: a card a batch run found odd could not be looked at on its own.
    from pumpid.cards import read_cards
    from pumpid.cli import main

    _long(["a", "b"], position_unit="in", load_unit="lbf").to_parquet(tmp_path / "x.parquet")
    with pytest.raises(CardError, match="a Parquet file, not a text card file") as info:
        read_cards(tmp_path / "x.parquet")
    assert "encoding" not in str(info.value)
    assert main(["fit", str(tmp_path / "x.parquet"), "--card", "b", "--brief"]) in (0, 5, 6)
    out = capsys.readouterr().out
    assert "source=x.parquet, card b" in out and "# 1 card:" in out
