"""A batch's inputs: a broken card is its own item, hostile files never stop the listing."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pumpid.cards import CardError
from pumpid.fleet.dataset import iter_parquet_cards
from pumpid.fleet.inputs import BadItem, CardItem, ReadOptions, find_inputs, iter_items

TH = np.linspace(0.0, 2 * np.pi, 30, endpoint=False)
POS = 50 * (1 - np.cos(TH))
LOAD = 6000 + 2000 * np.sin(TH + 0.3)


def _csv(path: Path, ids: list[str], broken: str | None = None) -> Path:
    lines = ["card_id,well_id,spm,position_in,load_lbf"]
    for cid in ids:
        for i, (p, f) in enumerate(zip(POS, LOAD, strict=True)):
            value = "1.2.3" if cid == broken and i == 7 else f"{p:.4f}"
            lines.append(f"{cid},W-1,6,{value},{f:.3f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def _items(*paths: Path) -> list[CardItem | BadItem]:
    return list(iter_items(find_inputs(list(paths)), ReadOptions()))


def test_a_broken_card_of_a_text_file_is_its_own_item(tmp_path: Path) -> None:
    items = _items(_csv(tmp_path / "w.csv", ["a", "b", "c"], broken="b"))
    assert [type(i).__name__ for i in items] == ["CardItem", "BadItem", "CardItem"]
    bad = items[1]
    assert isinstance(bad, BadItem) and not bad.whole_file
    assert (bad.card_id, bad.well_id) == ("b", "W-1")
    assert bad.source == f"{tmp_path / 'w.csv'}, line 39, field 'position_in'"
    assert "1.2.3" in bad.reason


def test_deep_json_and_a_lone_surrogate_do_not_stop_the_listing(tmp_path: Path) -> None:
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    doc = [{"card_id": "x\ud800", "well_id": "W\ud800", "spm": 6,
            "position": POS.tolist(), "load": LOAD.tolist()}]
    (tmp_path / "s.json").write_text(json.dumps(doc))
    items = _items(tmp_path)
    deep, good = items
    assert isinstance(deep, BadItem) and deep.whole_file and "invalid JSON" in deep.reason
    assert isinstance(good, CardItem) and good.card_id == "x\\ud800"
    good.card_id.encode("utf-8")
    (good.card.well_id or "").encode("utf-8")


def test_pipes_and_devices_are_refused_by_name(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(CardError, match=r"pipe: not a regular file but a named pipe"):
        find_inputs([fifo])
    with pytest.raises(CardError, match="not a regular file but a character device"):
        find_inputs(["/dev/null"])
    with pytest.raises(FileNotFoundError):
        find_inputs([tmp_path / "missing.csv"])


def _long(ids: list[str], n: int = 30) -> pd.DataFrame:
    return pd.concat([pd.DataFrame({
        "well_id": "P-1", "card_id": cid, "sample": np.arange(n).astype(str),
        "position": POS[:n], "load": LOAD[:n], "spm": 6.0}) for cid in ids], ignore_index=True)


def test_parquet_non_numeric_sample_costs_its_card_only(tmp_path: Path) -> None:
    frame = _long(["a", "b", "c"])
    frame.loc[(frame["card_id"] == "b") & (frame["sample"] == "3"), "sample"] = "three"
    frame.to_parquet(tmp_path / "x.parquet")
    items = list(iter_parquet_cards(tmp_path / "x.parquet"))
    assert [getattr(i, "card_id", None) for i in items] == ["a", "b", "c"]
    assert isinstance(items[1], CardError) and items[1].field == "sample"
    assert "'three'" in items[1].reason
    assert not isinstance(items[0], CardError) and items[0].n == 30


def test_parquet_datetime_t_is_seconds_from_the_first_sample(tmp_path: Path) -> None:
    frame = _long(["a"]).drop(columns=["sample", "spm"])
    frame["t"] = pd.Timestamp("2024-05-01 06:00") + pd.to_timedelta(np.arange(30) * 0.25, "s")
    frame.to_parquet(tmp_path / "t.parquet")
    (card,) = iter_parquet_cards(tmp_path / "t.parquet")
    assert not isinstance(card, CardError)
    np.testing.assert_allclose(card.t, np.arange(30) * 0.25)  # not epoch nanoseconds
    assert any("dates and times: converted to seconds" in n for n in card.notes)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(n_cards=st.integers(2, 4), data=st.data())
def test_parquet_a_mutated_card_costs_only_itself(tmp_path: Path, n_cards: int, data) -> None:
    ids = [f"c{k}" for k in range(n_cards)]
    frame = _long(ids)
    frame.to_parquet(tmp_path / "intact.parquet")
    intact = {c.card_id: c for c in iter_parquet_cards(tmp_path / "intact.parquet")}
    k = data.draw(st.integers(0, n_cards - 1), label="card")
    i = data.draw(st.integers(0, 29), label="sample")
    column, value = data.draw(st.sampled_from([
        ("position", np.nan), ("load", np.inf), ("sample", "x"), ("sample", None),
        ("sample", "0"), ("well_id", None)]), label="mutation")
    row = k * 30 + i
    if column == "sample" and value == "0" and i == 0:
        value = "1"  # a repeated sample number either way
    frame.loc[row, column] = value
    frame.to_parquet(tmp_path / "broken.parquet")
    items = list(iter_items(find_inputs([tmp_path / "broken.parquet"]), ReadOptions()))
    assert [i.card_id for i in items] == ids
    for j, item in enumerate(items):
        if j == k:
            assert isinstance(item, BadItem) and not item.whole_file
            assert f"card {ids[k]}" in item.source and item.reason
            continue
        assert isinstance(item, CardItem)
        np.testing.assert_array_equal(item.card.position, intact[item.card_id].position)
        np.testing.assert_array_equal(item.card.load, intact[item.card_id].load)


def test_batch_writes_past_a_deep_json_file_and_a_lone_surrogate(tmp_path: Path) -> None:
    from pumpid.fleet import FitSpec, read_results, run_batch

    field = tmp_path / "field"
    field.mkdir()
    (field / "a_deep.json").write_text("[" * 100_000 + "]" * 100_000)
    doc = [{"card_id": "x\ud800", "well_id": "W\udc00", "spm": 6, "op\ud800": "v\ud800",
            "position": POS.tolist(), "load": LOAD.tolist()}]
    (field / "b_surrogate.json").write_text(json.dumps(doc))
    _csv(field / "c.csv", ["a", "b"], broken="a")
    run_batch([field], tmp_path / "out", fit=FitSpec("msd"), partition_size=1)
    table = read_results(tmp_path / "out").set_index("card_id")
    assert table.loc[str(field / "a_deep.json"), "status"] == "invalid-input"
    fitted = ("converged", "boundary", "undetermined")  # fitted, whatever it determines
    assert table.loc["x\\ud800", "status"] in fitted
    assert table.loc["x\\ud800", "well_id"] == "W\\udc00"
    assert table.loc["a", "status"] == "invalid-input" and table.loc["b", "status"] in fitted


def test_a_broken_card_keeps_the_well_and_time_its_file_states(tmp_path: Path) -> None:
    lines = ["card_id,well_id,timestamp,spm,position_in,load_lbf"]
    for i, (p, f) in enumerate(zip(POS, LOAD, strict=True)):
        lines.append(f"a,W-7,2024-05-01T06:00:00Z,6,{'nan' if i == 3 else f'{p:.4f}'},{f:.3f}")
    (tmp_path / "one.csv").write_text("\n".join(lines) + "\n")
    (bad,) = _items(tmp_path / "one.csv")
    assert isinstance(bad, BadItem) and not bad.whole_file
    assert (bad.card_id, bad.well_id, bad.time) == ("a", "W-7", "2024-05-01T06:00:00Z")
    assert bad.source.endswith("one.csv, line 5, field 'position_in'")
