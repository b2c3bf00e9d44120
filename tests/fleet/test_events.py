"""Alerts grouped into the changes of a well: one change seen in several quantities."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pumpid.fleet.changes import detect_changes, summarise_wells
from pumpid.fleet.events import change_size, number_events, ordered_by_event
from pumpid.fleet.report import write_fleet_report

from .test_changes import results_table


def _alerts(rows: list[tuple[str, float, str, str]]) -> pd.DataFrame:
    """Alerts of (well, change_se, first time, alarm time)."""
    frame = pd.DataFrame(rows, columns=["well_id", "change_se", "first_time", "alarm_time"])
    frame["first_time"] = pd.to_datetime(frame["first_time"], utc=True)
    frame["alarm_time"] = pd.to_datetime(frame["alarm_time"], utc=True)
    frame["first_index"] = frame["alarm_index"] = 0
    frame["quantity"] = [f"q{i}" for i in range(len(frame))]
    frame["first_card_id"] = [f"card{i}" for i in range(len(frame))]
    return frame


def test_overlapping_alerts_of_a_well_are_one_change_numbered_by_size() -> None:
    alerts = _alerts([
        ("A", 5.0, "2024-01-05", "2024-01-07"),    # A's first change ...
        ("A", -9.0, "2024-01-06", "2024-01-08"),   # ... seen again, starting a card later
        ("A", 4.0, "2024-03-01", "2024-03-02"),    # A's second change, weeks later
        ("B", 7.0, "2024-01-05", "2024-01-07"),    # another well, the same cards
    ])
    assert number_events(alerts).tolist() == [1, 1, 3, 2]
    ordered = ordered_by_event(alerts)
    assert ordered["change_se"].tolist() == [-9.0, 5.0, 7.0, 4.0]
    assert number_events(alerts.iloc[:0]).empty


def test_a_well_without_times_is_grouped_by_card_positions() -> None:
    alerts = _alerts([("A", 5.0, None, None), ("A", 6.0, None, None), ("A", 3.0, None, None)])
    alerts["first_index"], alerts["alarm_index"] = [10, 12, 40], [14, 15, 45]
    assert number_events(alerts).tolist() == [1, 1, 2]


def test_alerts_from_one_card_are_one_change_whatever_their_positions() -> None:
    # Without times the positions count each quantity's own usable cards: a quantity
    # missing on a well's first 6 cards placed the same first card 6 positions earlier, and
    # one change read as two.
    alerts = _alerts([("A", 5.0, None, None), ("A", 6.0, None, None), ("B", 1.0, None, None)])
    alerts["first_index"], alerts["alarm_index"] = [6, 12, 0], [8, 14, 2]
    alerts["first_card_id"] = ["X", "X", "Y"]
    assert number_events(alerts).tolist() == [1, 1, 2]
    # A size not known ranks last, not first.
    alerts.loc[2, "change_se"] = np.nan
    alerts.loc[2, "first_index"] = 0
    assert number_events(alerts).tolist()[2] == 2


def test_one_change_in_two_quantities_is_ranked_by_quantity_not_by_rounding() -> None:
    # A leaking valve: the intake pressure follows the fluid load, their change_se equal to
    # 7e-13, and the derived one ranked first by that rounding.
    alerts = pd.DataFrame({"quantity": ["pump_fluid_load", "pump_intake_pressure"],
                           "change_se": [-27.959494717437952, 27.95949471743863]})
    size = change_size(alerts)
    assert size.iloc[0] == size.iloc[1]
    order = alerts.assign(_size=size).sort_values("_size", ascending=False, kind="stable")
    assert order["quantity"].tolist() == ["pump_fluid_load", "pump_intake_pressure"]


def test_one_change_seen_in_two_quantities_counts_once(tmp_path: Path, capsys) -> None:
    # A pump field's leak gave five alerts and read "9 alerts in 2 wells" with another
    # well's fluid pound; each change is now one, its quantities listed under one number.
    from pumpid.cli import main

    frame = results_table(3, 80, cv=0.02, seed=4)
    hit = (frame["well_id"] == "W0001") & (frame.groupby("well_id").cumcount() >= 50)
    frame.loc[hit, "d_stiffness"] *= 1.3
    frame.loc[hit, "d_damping_ratio"] *= 0.7
    alerts = detect_changes(frame, ["stiffness", "damping_ratio"])
    assert len(alerts) == 2 and alerts["event"].tolist() == [1, 1]
    wells = summarise_wells(frame, alerts)
    assert wells.set_index("well_id").loc["W0001", ["alerts", "changes"]].tolist() == [2, 1]
    page = write_fleet_report(frame, tmp_path / "fleet", alerts=alerts,
                              quantities=["stiffness", "damping_ratio"])["report"]
    text = page.read_text(encoding="utf-8")
    assert "2 alerts in 1 well: 1 change (the alerts of a well over the same cards" in text
    assert "3 wells, 240 cards, 2 alerts (1 change)." in text  # the page's headline
    assert "<td>2 (1 change)</td>" in text.replace('<td class="num">', "<td>")
    frame.to_parquet(tmp_path / "results.parquet")
    assert main(["report", str(tmp_path / "results.parquet"), "--out", str(tmp_path / "r"),
                 "--quantity", "stiffness", "--quantity", "damping_ratio"]) == 0
    out = capsys.readouterr().out
    assert "2 alerts in 1 well, 1 change (a change seen in several quantities" in out
    assert out.count("  change 1, well W0001: ") == 2
    assert np.isin(["event"], pd.read_csv(tmp_path / "r" / "alerts.csv").columns).all()
