"""Short histories (6 to 30 cards of a well) are tested, by the two-segment and drift
tests, at their simulated false-alarm rate; shorter ones are named as not tested."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.stats

from pumpid.fleet.changes import detect_changes, history_coverage
from pumpid.fleet.thresholds import (
    drift_statistic,
    drift_threshold,
    stored,
    two_segment_statistic,
    two_segment_threshold,
)

from .test_changes import results_table


def _issue_field(step: bool) -> tuple:
    # 30 wells x 10 cards; W0004's stiffness about 710 lbf/in (card-to-card scatter 1 %,
    # fits' standard errors about 1 lbf/in), stepping to about 820 from its sixth card.
    table = results_table(30, 10, cv=0.01, seed=12)
    rng = np.random.default_rng(5)
    mine = (table["well_id"] == "W0004").to_numpy()
    level = np.where(np.arange(10) >= 5, 820.0, 710.0) if step else np.full(10, 710.0)
    table.loc[mine, "d_stiffness"] = level * np.exp(0.01 * rng.standard_normal(10))
    table.loc[mine, "d_stiffness_se"] = 1.0
    return table, mine


def test_a_step_in_a_week_of_cards_alerts() -> None:
    table, _ = _issue_field(step=True)
    alerts = detect_changes(table, ["stiffness"])
    mine = alerts[alerts["well_id"] == "W0004"]
    assert len(mine) == 1, alerts
    row = mine.iloc[0]
    assert row["method"] == "two-segment" and row["direction"] == "up"
    assert row["first_index"] == 5 and row["first_card_id"] == "W0004-0005"
    assert row["alarm_index"] == 9 and row["n_before"] == 5 and row["n_after"] == 5
    assert row["before"] == pytest.approx(710, rel=0.02)
    assert row["after"] == pytest.approx(820, rel=0.02)
    assert row["unit"] == "lbf/in" and row["change_se"] > 10
    steady, _ = _issue_field(step=False)
    assert "W0004" not in set(detect_changes(steady, ["stiffness"])["well_id"])


@pytest.mark.parametrize(("n_cards", "n_wells"), [(6, 1500), (10, 1500), (30, 400)])
def test_steady_short_wells_alert_at_the_simulated_rate(n_cards: int, n_wells: int) -> None:
    # Steady wells x 3 quantities, Student-t tails and 1 % outlier cards: the noise the
    # threshold is simulated for; a steady well alerts with probability at most 1 %.
    table = results_table(n_wells, n_cards, cv=0.04, seed=n_cards, outliers=0.01)
    alerts = detect_changes(table, false_alarm=0.01)
    assert set(alerts["method"]) <= {"two-segment", "drift"}
    # at most the binomial's 99.9th percentile at 1 % (27 of 1500, 11 of 400)
    assert alerts["well_id"].nunique() <= scipy.stats.binom.ppf(0.999, n_wells, 0.01)


def test_an_outlier_is_not_a_change_and_lengths_are_covered() -> None:
    y = np.log(np.full(8, 500.0) * np.exp(0.01 * np.random.default_rng(3).standard_normal(8)))
    y[-1] += 0.5  # the last card alone 65 % off
    stat, _, _ = two_segment_statistic(y)
    assert stat[0] < two_segment_threshold(8, alpha=0.01)
    table = results_table(4, 8, cv=0.02, seed=1)
    short = table["well_id"] == "W0003"
    table = table[~short | (table["card_id"].str[-4:].astype(int) < 5)]
    cover = history_coverage(table, ["stiffness"]).set_index("well_id")
    assert cover.loc["W0003", "method"] == "too short" and cover.loc["W0003", "cards"] == 5
    assert set(cover.loc[["W0000", "W0001", "W0002"], "method"]) == {"two-segment"}
    long = results_table(1, 31, seed=2)
    assert history_coverage(long, ["stiffness"])["method"].tolist() == ["cusum"]
    with pytest.raises(ValueError, match="min_short_cards"):
        detect_changes(table, min_short_cards=5)


def test_the_report_says_which_wells_were_tested(tmp_path) -> None:
    from pumpid.fleet.report import write_fleet_report

    table, _ = _issue_field(step=True)
    few = table["well_id"].isin(["W0010", "W0011"]) & (table["card_id"].str[-4:] >= "0004")
    table = table[~few]
    files = write_fleet_report(table, tmp_path, quantities=["stiffness"], steady_sample=0)
    page = files["report"].read_text(encoding="utf-8")
    assert "1 alert in 1 well" in page
    # Its alarm card is the history's newest, tested whole: no detector's delay is claimed.
    assert "(its newest usable card: the history is tested whole)" in page and "later)" not in page
    assert "0 wells by the CUSUM" in page and "28 wells by the two-segment and drift tests" in page
    assert ("wells too short to test (fewer than 6 usable cards of every quantity)</td>"
            "<td>2 wells: W0010, W0011") in page
    wells = files["wells"].read_text(encoding="utf-8")
    # The wells table names both short-history tests, and what a "too short" well lacks.
    assert "too few usable cards" in wells and "two-segment and drift" in wells


def _declining_fillage(cv: float = 0.003) -> pd.DataFrame:
    # 3 wells x 14 daily cards; W0001's fillage-like quantity falls steadily from 0.99 to
    # 0.61 (card-to-card scatter 0.3 %, fits' errors 0.1 %): a pump starting to pound.
    table = results_table(3, 14, cv=cv, seed=21)
    mine = (table["well_id"] == "W0001").to_numpy()
    rng = np.random.default_rng(8)
    table.loc[mine, "d_stiffness"] = np.linspace(0.99, 0.61, 14) * np.exp(
        cv * rng.standard_normal(14))
    table.loc[mine, "d_stiffness_se"] = 0.001
    return table


def test_a_steady_decline_alerts_as_a_drift() -> None:
    alerts = detect_changes(_declining_fillage(), ["stiffness"])
    mine = alerts[alerts["well_id"] == "W0001"]
    assert len(mine) == 1, alerts
    row = mine.iloc[0]
    assert row["method"] == "drift" and row["direction"] == "down"
    # under way from the first card, its size the fitted line's over the whole history
    # (the medians of two halves gave half of it, "from" the middle card)
    assert row["first_index"] == 0 and row["alarm_index"] == 13
    assert row["first_card_id"] == "W0001-0000" and row["delay_cards"] == 13
    # a line on the log scale: a geometric fall, within 3 % of the linear one's ends
    assert row["before"] == pytest.approx(0.99, rel=0.03)
    assert row["after"] == pytest.approx(0.61, rel=0.03)
    assert row["change_rel"] == pytest.approx(0.61 / 0.99 - 1, abs=0.03)
    assert row["change_se"] < -10 and (row["n_before"], row["n_after"]) == (0, 14)
    assert set(alerts["well_id"]) == {"W0001"}


def test_the_two_segment_statistic_cannot_see_a_straight_line() -> None:
    # Why the drift test exists: on an exact line the two-segment statistic does not grow
    # with the slope (the scatter within the segments grows with it); the drift test's does.
    x = np.arange(14, dtype=float)
    gentle, steep = 0.001 * x, 0.1 * x
    step_stats = [two_segment_statistic(y, 1e-4)[0][0] for y in (gentle, steep)]
    assert step_stats[0] == pytest.approx(step_stats[1], rel=1e-9)
    # below the threshold of the pump field's nine quantities, however steep
    assert step_stats[1] < two_segment_threshold(14, alpha=0.01 / 9)
    drift = [drift_statistic(y, 1e-4) for y in (gentle, steep)]
    assert drift[1][0][0] == pytest.approx(100 * drift[0][0][0], rel=1e-9)
    assert drift[1][1][0] == pytest.approx(0.1) and drift[0][0][0] > drift_threshold(14)


def test_wild_first_and_last_cards_are_not_a_drift() -> None:
    rng = np.random.default_rng(4)
    y = 0.01 * rng.standard_normal(10)
    y[-1] += 0.12  # the last card 12 noise scales up and the first down: a slope's worst case
    y[0] -= 0.12
    stat, slope, _, _ = drift_statistic(y)
    assert abs(slope[0]) < 0.005 and stat[0] < drift_threshold(10, alpha=0.01)


def test_the_report_says_a_drift(tmp_path: Path, capsys) -> None:
    from pumpid.cli import main

    _declining_fillage().to_parquet(tmp_path / "results.parquet")
    assert main(["report", str(tmp_path / "results.parquet"), "--out",
                 str(tmp_path / "fleet")]) == 0
    out = capsys.readouterr().out
    assert "1 alert in 1 well" in out
    assert "W0001: stiffness 1.001 -> 0.6278 lbf/in (-37.3%" in out
    assert "from card W0001-0000 (a steady drift over the history" in out
    page = (tmp_path / "fleet" / "report.html").read_text(encoding="utf-8")
    assert "(-37.3%, a steady drift)" in page and "(fitted line, first card → last)" in page


def test_an_exact_line_is_a_drift() -> None:
    # No scatter about the line and no errors: the drift test was skipped and the history
    # called a step at its middle card.
    from pumpid.fleet.detectors import scan_two_segments

    got = scan_two_segments(np.linspace(0.0, 1.0, 14), np.zeros(14), alpha=0.01,
                            tail_dof=5.0, outlier_fraction=0.01)
    assert len(got) == 1 and got[0].drift and got[0].first == 0 and got[0].size == np.inf


def test_the_wells_table_says_a_drift() -> None:
    from pumpid.fleet.changes import summarise_wells

    table = _declining_fillage()
    alerts = detect_changes(table, ["stiffness"])
    wells = summarise_wells(table, alerts, ["stiffness"]).set_index("well_id")
    said = wells.loc["W0001", "largest_change"]
    assert said.startswith("stiffness 1.001 -> 0.6278") and said.endswith(", a steady drift")


def test_the_figure_draws_a_drift_through_its_cards(tmp_path) -> None:
    from pumpid.fleet.report import write_fleet_report

    table = _declining_fillage()
    files = write_fleet_report(table, tmp_path, quantities=["stiffness"], steady_sample=0)
    assert (tmp_path / "well_W0001.png").exists()
    assert "steady drift" in files["report"].read_text(encoding="utf-8")


def test_thresholds_are_stored_on_disk_and_a_bad_store_ignored(tmp_path) -> None:
    # A report in a new process took the same simulations again at every run (3.6 of its
    # 9 s on the demo's pump field). A second process reads the stored value (here made
    # recognisable by hand), and a store that cannot be read is simulated around.
    code = ("from pumpid.fleet.thresholds import two_segment_threshold as f; "
            "print(repr(f(12, alpha=0.02, replicates=4000)))")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}

    def run() -> float:
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, check=True)
        return float(out.stdout.strip())

    first = run()
    files = list((tmp_path / "pumpid").glob("thresholds-*.json"))
    assert len(files) == 1
    table = json.loads(files[0].read_text(encoding="utf-8"))
    assert len(table) == 2 and first in table.values()  # heavy-tailed and Gaussian noise
    files[0].write_text(json.dumps({k: 123.0 for k in table}), encoding="utf-8")
    assert run() == 123.0
    for bad in ("{not json", "[]", '{"a": null}'):  # unreadable, or not a table of numbers
        files[0].write_text(bad, encoding="utf-8")
        assert run() == first
    assert two_segment_threshold(12, alpha=0.02, replicates=4000) == first


def test_a_stored_threshold_keeps_what_another_process_stored_meanwhile(tmp_path,
                                                                        monkeypatch) -> None:
    # Two reports run at once: each process wrote its own table whole, so the one that
    # finished last dropped the other's values and the next run simulated them again.
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))

    @stored
    def square(x: int) -> float:
        return float(x * x)

    assert square(2) == 4.0
    (path,) = (tmp_path / "pumpid").glob("thresholds-*.json")
    other = json.loads(path.read_text(encoding="utf-8"))
    other["cube(3,)"] = 27.0  # what another process stored after this one read the file
    path.write_text(json.dumps(other), encoding="utf-8")
    assert square(5) == 25.0
    table = json.loads(path.read_text(encoding="utf-8"))
    assert table == {"square(2,)": 4.0, "cube(3,)": 27.0, "square(5,)": 25.0}
