"""Change detection on fleet results tables: steps found fast, steady wells left alone.

Stated performance (tested here on seeded tables, measured at scale by
``benchmarks/bench_changes.py``): with card-to-card noise of 2-5 % (coefficient of
variation; Student-t tails) a step of 20 %, 30 % or 40 % in one quantity is found every
time and its first card estimated within +-3 cards; the alarm comes within 5 cards of the
change at 2 % noise, within 6 cards for at least 90 % of wells (8 for all) at 5 % noise;
steady wells raise an alert with probability about 1 % over 300 cards.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pumpid.fleet.changes import (
    ALERT_COLUMNS,
    available_quantities,
    card_counts,
    cusum_threshold,
    detect_changes,
    summarise_wells,
)

QUANTITIES = {"stiffness": (80.0, "lbf/in"), "natural_frequency": (0.55, "Hz"),
              "damping_ratio": (0.18, "-")}  # fmt: skip
T5_ROBUST = 1.0773  # robust (MAD) scale of Student's t with 5 degrees of freedom


def results_table(n_wells: int, n_cards: int, *, cv: float = 0.04, seed: int = 0,
                  tails: str = "t5", outliers: float = 0.0,
                  steps: dict[int, tuple[str, float, int]] | None = None) -> pd.DataFrame:
    """A results table; ``steps[well] = (quantity, factor, first changed card)``."""
    rng = np.random.default_rng(seed)
    well = np.repeat(np.arange(n_wells), n_cards)
    card = np.tile(np.arange(n_cards), n_wells)
    wid = np.char.add("W", np.char.zfill(well.astype(str), 4))
    frame = pd.DataFrame({
        "well_id": wid,
        "card_id": np.char.add(np.char.add(wid, "-"), np.char.zfill(card.astype(str), 4)),
        "time": pd.Timestamp("2024-01-01", tz="UTC") + pd.to_timedelta(card * 6, unit="h"),
        "source": "synthetic", "model": "kelvin", "observe": "u", "status": "converged",
        "reason": "", "warnings": "", "r2": 0.99, "rmse": 0.1, "n_samples": 200,
        "position_unit": "in", "load_unit": "lbf",
    })
    for q, (centre, unit) in QUANTITIES.items():
        level = centre * np.exp(rng.uniform(-0.4, 0.4, n_wells))[well]
        if tails == "t5":
            e = rng.standard_t(5, well.size) / T5_ROBUST
        else:
            e = rng.standard_normal(well.size)
        if outliers:
            hit = rng.random(well.size) < outliers
            e = np.where(hit, rng.choice([-1.0, 1.0], well.size) * rng.uniform(6, 12, well.size),
                         e)
        value = level * np.exp(cv * e)
        for w, (sq, factor, at) in (steps or {}).items():
            if sq == q:
                value = np.where((well == w) & (card >= at), value * factor, value)
        frame[f"d_{q}"] = value
        frame[f"d_{q}_se"] = 0.3 * cv * value
        frame[f"d_{q}_determined"] = True
        frame[f"d_{q}_unit"] = unit
    return frame


@pytest.mark.parametrize("cv", [0.02, 0.05])
def test_steps_found_fast_and_placed(cv: float) -> None:
    # 18 wells step (20, 30, 40 %, up and down, 3 wells each) at card 150 of 300; 12 do not.
    factors = [1.2, 1.3, 1.4, 1 / 1.2, 1 / 1.3, 1 / 1.4]
    steps = {w: ("stiffness", factors[w % 6], 150) for w in range(18)}
    table = results_table(30, 300, cv=cv, seed=int(cv * 1000), steps=steps)
    alerts = detect_changes(table)
    assert list(alerts.columns) == list(ALERT_COLUMNS)
    assert set(alerts["well_id"]) <= {f"W{w:04d}" for w in range(30)}
    found = alerts[alerts["quantity"] == "stiffness"].set_index("well_id")
    for w, (_, factor, at) in steps.items():
        row = found.loc[f"W{w:04d}"]
        assert isinstance(row, pd.Series), "one alert per stepped well"
        assert abs(row["first_index"] - at) <= 3
        assert row["first_card_id"] == f"W{w:04d}-{row['first_index']:04d}"
        assert row["direction"] == ("up" if factor > 1 else "down")
        assert row["change_rel"] == pytest.approx(factor - 1, abs=0.03)
        assert abs(row["change_se"]) > 10
        assert row["unit"] == "lbf/in" and row["order"] == "time"
        assert row["first_time"] == pd.Timestamp("2024-01-01", tz="UTC") + pd.Timedelta(
            hours=6 * row["first_index"])
    delays = (found.loc[[f"W{w:04d}" for w in steps], "alarm_index"] - 150).to_numpy()
    assert np.all(delays >= 0) and np.all(delays <= 8)
    if cv <= 0.035:
        assert np.all(delays <= 5)
    else:
        assert np.mean(delays <= 6) >= 0.9
    # the steady wells and the other quantities of the stepped ones: no alert here
    assert len(alerts) == len(steps)


def test_steady_wells_rarely_alert() -> None:
    # 500 steady wells x 300 cards x 3 quantities, Student-t tails and a few outlier cards:
    # the noise the threshold is calibrated for, so about 1 % of wells alert by design.
    table = results_table(500, 300, cv=0.04, seed=7, outliers=0.01)
    alerts = detect_changes(table, false_alarm=0.01)
    assert alerts["well_id"].nunique() <= 5  # at most 1 % of the wells


def test_gaussian_steady_wells_and_threshold() -> None:
    table = results_table(300, 300, cv=0.03, seed=3, tails="gaussian")
    assert detect_changes(table)["well_id"].nunique() <= 3
    h = cusum_threshold(270, min_cards=30, alpha=0.01 / 3)
    assert 7.0 < h < 11.0
    assert cusum_threshold(270, alpha=0.01 / 3) == h  # cached and reproducible
    assert cusum_threshold(270, alpha=0.1) < h


def test_two_changes_in_one_well() -> None:
    table = results_table(2, 300, cv=0.03, seed=5, steps={0: ("natural_frequency", 1.3, 100)})
    late = (table["well_id"] == "W0000") & (table["card_id"].str[-4:].astype(int) >= 200)
    table.loc[late, "d_natural_frequency"] /= 1.3**2
    alerts = detect_changes(table)
    assert alerts["quantity"].tolist() == ["natural_frequency"] * 2
    assert [abs(i - j) <= 3 for i, j in zip(alerts["first_index"], (100, 200), strict=True)] \
        == [True, True]
    assert alerts["direction"].tolist() == ["up", "down"]
    assert alerts["n_before"].iloc[1] == alerts["n_after"].iloc[0]
    assert alerts["before"].iloc[1] == alerts["after"].iloc[0]


def test_messy_tables_are_handled(tmp_path: Path) -> None:
    table = results_table(4, 120, cv=0.03, seed=9, steps={1: ("damping_ratio", 1.4, 70)})
    rng = np.random.default_rng(0)
    bad = rng.choice(len(table), 40, replace=False)
    table.loc[table.index[bad[:15]], "status"] = "failed"
    table.loc[table.index[bad[:15]], "d_damping_ratio"] = np.nan
    table.loc[table.index[bad[15:25]], "status"] = "invalid-input"
    table.loc[table.index[bad[25:32]], "d_damping_ratio"] = np.nan  # NaN in usable rows
    table.loc[table.index[bad[32:]], "d_damping_ratio_determined"] = False
    table["d_damping_ratio_se"] = np.nan  # no standard errors at all
    w2 = table["well_id"] == "W0002"
    table.loc[w2, "time"] = pd.NaT  # no times: card order
    table.loc[table.index[w2][5], "d_stiffness"] = 1e6  # a wild value
    single = table.iloc[[0]].assign(well_id="LONE", card_id="LONE-1")
    table = pd.concat([table, single], ignore_index=True)
    path = tmp_path / "results.parquet"
    table.to_parquet(path)
    alerts = detect_changes(path)
    assert alerts[["well_id", "quantity"]].values.tolist() == [["W0001", "damping_ratio"]]
    assert abs(alerts["first_index"].iloc[0] - 70) <= 6  # indices count usable cards only
    summary = summarise_wells(table, alerts)
    assert summary["well_id"].iloc[0] == "W0001" and summary["alerts"].iloc[0] == 1
    assert set(summary["well_id"]) == {"W0000", "W0001", "W0002", "W0003", "LONE"}
    assert summary["cards"].sum() == len(table)
    assert (summary["n_failed"].sum(), summary["n_invalid_input"].sum()) == (15, 10)
    lone = summary.set_index("well_id").loc["LONE"]
    assert lone["cards"] == 1 and lone["alerts"] == 0
    assert lone["latest_stiffness"] == pytest.approx(table["d_stiffness"].iloc[0])
    assert lone["latest_stiffness_unit"] == "lbf/in"
    assert "damping_ratio" in summary["largest_change"].iloc[0]
    # Signed, as the change is (a fall read "[934 standard errors]").
    said = summary["largest_change"].iloc[0]
    assert f"{float(alerts['change_se'].iloc[0]):+.3g} standard errors" in said
    # a well whose times are partly missing keeps its time order: the cards without one
    # are set aside (counted, not trended)
    table.loc[table.index[table["well_id"] == "W0001"][3], "time"] = pd.NaT
    assert set(detect_changes(table)["order"]) == {"time"}
    assert card_counts(table)["undated"] == 1


def test_undated_cards_of_a_dated_well_are_set_aside_not_latest() -> None:
    # 30 dated cards with a step at card 15, then 4 cards of the same well with no time
    # (another file of the well, exported without dates) at the old level. In the table's
    # order they came last: one of them was the well's "latest" value and the alarm card,
    # and the alert's size read a fraction of a standard error.
    table = results_table(1, 30, cv=0.02, seed=3, steps={0: ("stiffness", 0.7, 15)})
    old = table.iloc[:4].assign(time=pd.NaT, card_id=[f"X{i}" for i in range(4)])
    mixed = pd.concat([table, old], ignore_index=True)
    alerts = detect_changes(mixed)
    (stiff,) = alerts[alerts["quantity"] == "stiffness"].itertuples()
    assert stiff.alarm_card_id.startswith("W0000-") and abs(float(stiff.change_se)) > 3
    summary = summarise_wells(mixed, alerts).set_index("well_id")
    assert summary.loc["W0000", "latest_stiffness"] == pytest.approx(
        table["d_stiffness"].iloc[-1])
    assert card_counts(mixed) == {"cards": 34, "repeats": 0, "wells": 1, "unnamed": 0,
                                  "undated": 4}
    # A well whose cards all lack a time keeps the table's order.
    assert card_counts(table.assign(time=pd.NaT))["undated"] == 0


def test_parameters_and_options() -> None:
    table = results_table(1, 100, seed=1)
    table["p_k0"] = 200 * np.exp(0.03 * np.random.default_rng(1).standard_normal(100))
    table.loc[60:, "p_k0"] *= 1.5
    table["p_k0_se"] = 1.0
    table["p_k0_se_hac"] = np.where(np.arange(100) % 2, 3.0, np.nan)
    assert available_quantities(table) == list(QUANTITIES)
    assert available_quantities(table, parameters=True) == [*QUANTITIES, "p_k0"]
    alerts = detect_changes(table, ["p_k0"])
    assert alerts[["quantity", "kind", "unit"]].values.tolist() == [
        ["p_k0", "parameter", "lbf/in"]]
    assert abs(alerts["first_index"].iloc[0] - 60) <= 3
    with pytest.raises(ValueError, match="no column 'd_speed'"):
        detect_changes(table, ["speed"])
    # The name a results table shows: a derived quantity's column, d_ and all.
    with pytest.raises(ValueError, match=r"named without its column's d_: stiffness\)$"):
        detect_changes(table, ["d_stiffness"])
    with pytest.raises(ValueError, match="false_alarm"):
        detect_changes(table, false_alarm=0.0)
    with pytest.raises(ValueError, match="status"):
        detect_changes(table.drop(columns="status"))
    empty = detect_changes(table.iloc[:0])
    assert empty.empty and list(empty.columns) == list(ALERT_COLUMNS)
    no_quantities = detect_changes(table[["well_id", "card_id", "status"]])
    assert no_quantities.empty


def test_a_parameter_is_trended_only_where_its_fit_determines_it() -> None:
    # Every card's fit left c1 undetermined (error inf): an alert on it had been sized at
    # "-68.8 standard errors". Its own verdict (p_NAME_determined) decides; a table
    # written before that column reads an infinite error as not determined.
    table = results_table(1, 100, seed=1)
    table["p_c1"] = 50 * np.exp(0.01 * np.random.default_rng(2).standard_normal(100))
    table.loc[60:, "p_c1"] *= 0.85
    table["p_c1_se"] = np.inf
    table["p_c1_determined"] = False
    assert "p_c1_determined" not in available_quantities(table, parameters=True)
    assert detect_changes(table, ["p_c1"]).empty
    assert detect_changes(table.drop(columns="p_c1_determined"), ["p_c1"]).empty
    # Where the fits determine it, the step is found.
    table["p_c1_se"] = 0.5
    table["p_c1_determined"] = True
    found = detect_changes(table, ["p_c1"])
    assert len(found) == 1 and found.iloc[0]["direction"] == "down"


def test_a_resonance_that_echoes_the_stroke_is_not_trended_unless_asked() -> None:
    # Well W0000's natural frequency steps 40 % with the pumping speed; its fits mark it
    # as an echo of the stroke (not a property of the well): no alert by default, the
    # step is found when the quantity is asked for by name.
    table = results_table(2, 120, cv=0.02, seed=4, steps={0: ("natural_frequency", 1.4, 60)})
    table["d_natural_frequency_well_property"] = table["well_id"] != "W0000"
    assert "natural_frequency_well_property" not in available_quantities(table)
    quiet = detect_changes(table)
    assert not ((quiet["well_id"] == "W0000") & (quiet["quantity"] == "natural_frequency")).any()
    asked = detect_changes(table, ["natural_frequency"])
    assert ((asked["well_id"] == "W0000") & (asked["quantity"] == "natural_frequency")).any()


@pytest.mark.parametrize("after", [2, 3, 4])
def test_a_change_near_the_history_end_is_sized_by_the_wells_scatter(after: int) -> None:
    # A step on the last few cards of a short history: a few cards after it have next to
    # no scatter of their own (one has none), and its size read -295 standard errors here
    # (-692 and -934 on the demo's pump field) from that alone. The cards' own errors (10 %)
    # set a floor, but only up to the well's card-to-card scatter over its whole history
    # (0.1 %): errors wider than that (a model error's, common to every card of the well)
    # say nothing of how well a change between cards is measured, and had sized a fluid
    # load's fall by 14 times its scatter at -0.17 standard errors.
    frame = results_table(1, 14, cv=0.001, seed=3, steps={0: ("stiffness", 0.76, 14 - after)})
    frame["d_stiffness_se"] = 0.1 * frame["d_stiffness"]
    row = detect_changes(frame, ["stiffness"], false_alarm=0.5).iloc[0]
    scatter = 0.001 * 1.2533
    floor = math.hypot(scatter * row["before"] / math.sqrt(row["n_before"]),
                       scatter * row["after"] / math.sqrt(row["n_after"]))
    assert math.isfinite(row["change_se"]) and row["change_se"] < 0
    # Never beyond what the well's scatter allows (a few cards cannot make it infinite) ...
    assert abs(row["change_se"]) <= 1.5 * abs(row["change"]) / floor, (row["change_se"], floor)
    # ... and far beyond what the cards' errors would say (-4.0 before). With two cards
    # after the step the split lands a card early: its second segment holds a card of the
    # first level, whose own scatter sizes the change (-2.6).
    if after >= 3:
        assert row["n_after"] == after and abs(row["change_se"]) > 50, row["change_se"]


@pytest.mark.parametrize("n_cards", [20, 60])
def test_errors_far_wider_than_the_scatter_do_not_hide_a_step(n_cards: int) -> None:
    # A pump's fluid load stepped by 5 % (14 times its card-to-card scatter of 0.08 kN)
    # with identification errors of +-14 kN: as the detector's noise, the errors hid the
    # step (0 alerts). They now only weigh the cards against each other.
    at = n_cards // 2
    frame = results_table(1, n_cards, cv=0.004, seed=5, steps={0: ("stiffness", 0.95, at)})
    frame["d_stiffness_se"] = 0.7 * frame["d_stiffness"]
    found = detect_changes(frame, ["stiffness"])
    assert len(found) == 1 and found.iloc[0]["direction"] == "down"
    assert abs(int(found.iloc[0]["first_index"]) - at) <= 1
    # The same errors on a steady well raise nothing.
    steady = results_table(20, n_cards, cv=0.004, seed=6)
    steady["d_stiffness_se"] = 0.7 * steady["d_stiffness"]
    assert detect_changes(steady, ["stiffness"]).empty


def test_a_pump_quantity_is_trended_where_the_identification_determines_it() -> None:
    # A steady pump (fluid load 32 kN, 1 % scatter) whose identification is undetermined
    # on every third card of the history's second half and on its last card, with the
    # 12 +- 55 kN such a fit gives: those values are not the pump's. The well's latest
    # fluid load had been that 12 kN; it is the last card that determines it.
    rng = np.random.default_rng(9)
    n = 60
    frame = results_table(1, n, cv=0.01, seed=9)
    value = 32.0 * np.exp(0.01 * rng.standard_normal(n))
    wrong = ((np.arange(n) >= n // 2) & (np.arange(n) % 3 == 0)) | (np.arange(n) == n - 1)
    value[wrong] = 12.0 + rng.standard_normal(wrong.sum())
    frame["identify_status"] = np.where(wrong, "undetermined", "converged")
    frame["pump_fluid_load"] = value
    frame["pump_fluid_load_se"] = np.where(wrong, 55.0, 0.5)
    frame["pump_fluid_load_unit"] = "kN"
    frame["pump_fluid_load_determined"] = ~wrong
    assert "pump_fluid_load_determined" not in available_quantities(frame)
    assert detect_changes(frame, ["pump_fluid_load"]).empty
    latest = summarise_wells(frame, quantities=["pump_fluid_load"]).iloc[0]
    assert latest["latest_pump_fluid_load"] == pytest.approx(value[n - 2])
    assert latest["latest_pump_fluid_load_unit"] == "kN"
    # Without the column (a run with no identification's verdict) every value counts.
    blind = summarise_wells(frame.drop(columns="pump_fluid_load_determined"),
                            quantities=["pump_fluid_load"]).iloc[0]
    assert blind["latest_pump_fluid_load"] == pytest.approx(value[n - 1])
