"""A card exported twice is flagged in the batch results and counted once downstream."""

from __future__ import annotations

import json
from pathlib import Path

from pumpid.fleet import FitSpec, read_results, run_batch
from pumpid.fleet.changes import detect_changes, summarise_wells
from pumpid.fleet.report import write_fleet_report
from pumpid.pump.synthetic import FieldCards, synthetic_field


def test_exact_repeats_are_flagged_and_counted_once(tmp_path: Path) -> None:
    field = tmp_path / "field"
    synthetic_field(field, n_wells=2, days=2, cards_per_day=4, formats=("json",), seed=5,
                    cards=FieldCards(n_samples=40, hold="none"))
    path = field / "json" / "W000.json"
    data = json.loads(path.read_text(encoding="utf-8"))
    full = data["cards"][2]
    # the controller's "Current" card: the same data, another id, five seconds later
    current = {**full, "card_id": full["card_id"] + "_Current",
               "timestamp": full["timestamp"].replace(":00:00Z", ":00:05Z")}
    # and a card of the same shape whose data differ in one sample: not a repeat
    near = {**full, "card_id": full["card_id"] + "_near",
            "load": [*full["load"][:-1], full["load"][-1] + 0.001]}
    data["cards"][3:3] = [current, near]
    path.write_text(json.dumps(data), encoding="utf-8")
    out = tmp_path / "out"
    done = run_batch([field], out, fit=FitSpec("msd"), partition_size=3,
                     csv=tmp_path / "r.csv")
    assert done.duplicates == 1 and "duplicate cards: 1 repeat" in done.text()
    table = read_results(out)
    assert len(table) == 18
    flagged = table[table["duplicate_of"].notna()]
    assert flagged["card_id"].tolist() == [current["card_id"]]
    assert flagged["duplicate_of"].tolist() == [full["card_id"]]
    summary = summarise_wells(table).set_index("well_id")
    assert summary.loc["W000", "cards"] == 9 and summary.loc["W000", "duplicates"] == 1
    assert summary.loc["W001", "cards"] == 8 and summary.loc["W001", "duplicates"] == 0
    alerts = detect_changes(table)
    assert current["card_id"] not in set(alerts["first_card_id"])
    files = write_fleet_report(table, tmp_path / "fleet", steady_sample=2)
    page = files["report"].read_text(encoding="utf-8")
    assert ("duplicate cards set aside (exact repeats of an earlier card of the same well, "
            "counted once)</td><td>1 card") in page
    assert "2 wells, 17 cards" in page
    assert current["card_id"] in (tmp_path / "r.csv").read_text(encoding="utf-8")
