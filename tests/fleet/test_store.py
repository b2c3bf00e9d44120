"""The results store keeps every row: a value a column cannot hold costs neither its
partition nor the partitions after it."""

from __future__ import annotations

from pathlib import Path

import pumpid.fleet.batch as batch
from pumpid.fleet import FitSpec, read_results, run_batch
from pumpid.fleet.store import results_schema, storable_table
from pumpid.models import MassSpringDamper
from pumpid.pump.synthetic import FieldCards, synthetic_field


def test_a_row_that_cannot_be_stored_keeps_its_partition_and_the_later_ones(
        tmp_path: Path, monkeypatch) -> None:
    field = tmp_path / "field"
    synthetic_field(field, n_wells=1, days=3, cards_per_day=4, formats=("json",), seed=5,
                    cards=FieldCards(n_samples=40, hold="none"))
    real = batch.fit_partition

    def hostile(items, spec, threads, partition, first_item, *rest):
        rows = real(items, spec, threads, partition, first_item, *rest)
        if partition == 1:
            # a lone surrogate, as a JSON id "\ud800" gives: UTF-8 cannot encode it
            rows[0]["card_id"] = "bad\ud800id"
            rows[1]["r2"] = "not a number"
        return rows

    monkeypatch.setattr(batch, "fit_partition", hostile)
    out = tmp_path / "out"
    summary = run_batch([field], out, fit=FitSpec("msd"), partition_size=3)
    assert summary.partitions == 4 and summary.cards == 12
    table = read_results(out)
    assert len(table) == 12 and table["item"].tolist() == list(range(12))
    escaped = table[table["item"] == 3].iloc[0]
    assert escaped["card_id"] == "bad\\ud800id"
    assert escaped["status"] == "converged"
    assert "not valid Unicode stored escaped" in escaped["warnings"]
    lost = table[table["item"] == 4].iloc[0]
    assert lost["status"] == "failed" and "could not be stored" in lost["reason"]
    assert lost["card_id"].startswith("W000_")
    assert (table[~table["item"].isin([3, 4])]["status"] == "converged").all()


def test_storable_table_keeps_good_rows_as_they_are() -> None:
    schema = results_schema(MassSpringDamper)
    rows = [dict.fromkeys(schema.names) for _ in range(3)]
    for i, row in enumerate(rows):
        row.update(well_id="W", card_id=f"c{i}", status="converged", r2=0.9)
    rows[1]["well_id"] = "\udcff"
    table = storable_table(rows, schema).to_pylist()
    assert [r["card_id"] for r in table] == ["c0", "c1", "c2"]
    assert table[0] == rows[0] and table[2] == rows[2]
    assert table[1]["well_id"] == "\\udcff" and table[1]["r2"] == 0.9
