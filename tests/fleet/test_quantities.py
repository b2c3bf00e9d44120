"""Which rows count for a quantity: one rule for the change detection and the figures."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pumpid.fleet.changes import detect_changes, history_coverage, summarise_wells
from pumpid.fleet.figures import quantity_values, unit_mix
from pumpid.fleet.quantities import (
    available_quantities,
    columns_of,
    counted,
    echo_count,
    flag,
    larger_error,
    with_asked,
)
from pumpid.fleet.report import write_fleet_report


def _table() -> pd.DataFrame:
    """Twelve cards of one well, each a different reason to count or not."""
    n = 12
    frame = pd.DataFrame({
        "well_id": "W1", "card_id": [f"c{i:02d}" for i in range(n)],
        "time": pd.Timestamp("2024-01-01", tz="UTC") + pd.to_timedelta(np.arange(n), unit="D"),
        "model": "kelvin", "status": "converged", "position_unit": "in", "load_unit": "lbf",
        "d_static_stiffness": 100.0 + np.resize([0.5, -0.3, 0.1, -0.4], n),
        "d_static_stiffness_se": 2.0, "d_static_stiffness_determined": True,
        "d_static_stiffness_unit": "lbf/in",
        "d_natural_frequency": 0.1, "d_natural_frequency_se": 0.001,
        "d_natural_frequency_determined": True, "d_natural_frequency_unit": "Hz",
        "d_natural_frequency_well_property": True,
        "p_k0": 400.0, "p_k0_se": 10.0, "p_k0_se_hac": 30.0,
    })  # fmt: skip
    frame.loc[1, "status"] = "failed"
    frame.loc[2, "d_static_stiffness"] = np.inf
    frame.loc[3, "d_static_stiffness_determined"] = False
    frame.loc[4, "d_natural_frequency_well_property"] = False
    frame.loc[5, "p_k0_se"] = np.inf
    frame.loc[6, "d_static_stiffness_se"] = -1.0
    # A poor fit's reason says to check the record before using its numbers.
    frame.loc[8, "status"] = "poor-fit"
    return frame


def test_columns_of_each_kind() -> None:
    derived = columns_of("static_stiffness")
    assert (derived.value, derived.errors, derived.unit, derived.kind) == (
        "d_static_stiffness", ("d_static_stiffness_se",), "d_static_stiffness_unit", "derived")
    param = columns_of("p_k0")
    assert (param.value, param.errors, param.unit, param.kind) == (
        "p_k0", ("p_k0_se", "p_k0_se_hac"), "p_k0_unit", "parameter")
    pump = columns_of("pump_fluid_load")
    assert (pump.value, pump.determined, pump.unit, pump.kind) == (
        "pump_fluid_load", "pump_fluid_load_determined", "pump_fluid_load_unit", "pump")
    # A well's unit for a parameter is the model's; its unit column only converts rows.
    assert [c.unit_from_model for c in (derived, param, pump)] == [False, True, False]


def test_counted_rows() -> None:
    frame = _table()
    values = frame["d_static_stiffness"].to_numpy(dtype=float)
    keep = counted(frame, "static_stiffness", values)
    # Not the failed fit, the infinite value, the undetermined one nor the poor fit.
    assert np.flatnonzero(~keep).tolist() == [1, 2, 3, 8]
    freq = frame["d_natural_frequency"].to_numpy(dtype=float)
    # An echo of the stroke counts only when asked for.
    assert np.flatnonzero(~counted(frame, "natural_frequency", freq)).tolist() == [1, 4, 8]
    asked = with_asked(frame, ["natural_frequency"])
    assert np.flatnonzero(~counted(asked, "natural_frequency", freq)).tolist() == [1, 8]
    assert with_asked(frame, ["static_stiffness"]) is frame  # no verdict to drop


def test_parameters_of_an_older_table_count_where_their_error_is_finite() -> None:
    frame = _table()
    values = frame["p_k0"].to_numpy(dtype=float)
    assert np.flatnonzero(~counted(frame, "p_k0", values)).tolist() == [1, 5, 8]
    frame["p_k0_determined"] = True
    frame.loc[7, "p_k0_determined"] = False
    # The table's own verdict where it has one.
    assert np.flatnonzero(~counted(frame, "p_k0", values)).tolist() == [1, 7, 8]


def test_larger_error() -> None:
    frame = _table()
    assert larger_error(frame, "p_k0")[0] == 30.0
    se = larger_error(frame, "static_stiffness")
    assert np.isnan(se[6]) and se[0] == 2.0


def test_the_figures_and_the_change_detection_count_the_same_cards() -> None:
    frame = _table()
    for q in available_quantities(frame, parameters=True):
        _, _, ok = quantity_values(frame, q)
        cover = history_coverage(frame, [q])
        assert int(cover["cards"].iloc[0]) == int(ok.sum()), q
    # The same rows are trended: a step made on the uncounted rows alone is not seen.
    stepped = frame.copy()
    stepped.loc[[1, 3], "d_static_stiffness"] = 1e4
    assert detect_changes(stepped, quantities=["static_stiffness"]).empty
    # ... while the same step on counted rows is.
    seen = frame.copy()
    seen.loc[6:, "d_static_stiffness"] *= 1.5
    assert not detect_changes(seen, quantities=["static_stiffness"]).empty


def test_a_poor_fit_is_never_a_well_s_latest_value() -> None:
    # A field well's latest natural frequency had come from its last card, a poor fit (R^2
    # 0.24, a stroke that did not close) whose reason said to check it before using it.
    frame = _table()
    frame.loc[11, "status"] = "poor-fit"
    frame.loc[11, "d_static_stiffness"] = 555.0
    latest = summarise_wells(frame, quantities=["static_stiffness"])
    assert float(latest["latest_static_stiffness"].iloc[0]) == frame.loc[10, "d_static_stiffness"]


def test_a_parameter_stated_in_another_unit_is_converted_for_the_views() -> None:
    # Two wells' k0 in lbf/in and N/m: the views across wells had drawn 17513 N/m beside
    # 100 lbf/in on one axis once a parameter's unit column was no longer read.
    frame = _table().iloc[:4].copy()
    frame["p_k0"] = [100.0, 101.0, 17513.0, 17600.0]
    frame["p_k0_unit"] = ["lbf/in", "lbf/in", "N/m", "N/m"]
    frame["status"] = "converged"
    value, _se, ok = quantity_values(frame, "p_k0", "lbf/in")
    assert value.to_numpy() == pytest.approx([100.0, 101.0, 100.0, 100.5], rel=1e-3)
    assert ok.all()
    assert unit_mix(frame, "p_k0", "lbf/in") == (["N/m"], 0)


def test_flags_read_from_text_or_with_gaps() -> None:
    text = pd.Series(["True", "False", None, "0", "1", "maybe"], dtype=object)
    assert flag(text, default=False).tolist() == [True, False, False, False, True, False]
    assert flag(text, default=True).tolist() == [True, False, True, False, True, True]
    gaps = pd.Series([np.nan, 1.0, 0.0])
    assert flag(gaps, default=True).tolist() == [True, True, False]
    assert flag(pd.Series([True, False]), default=False).tolist() == [True, False]


def _echo_table() -> pd.DataFrame:
    """Thirty cards whose resonance is the well's, then thirty whose fits echo the stroke
    at 0.1 Hz."""
    rng = np.random.default_rng(0)
    n = 60
    fn = np.r_[1.0 + 0.01 * rng.standard_normal(30), 0.1 + 0.001 * rng.standard_normal(30)]
    return pd.DataFrame({
        "well_id": "W", "card_id": [f"c{i}" for i in range(n)],
        "time": pd.Timestamp("2024-01-01", tz="UTC") + pd.to_timedelta(np.arange(n), unit="D"),
        "status": "converged", "d_natural_frequency": fn, "d_natural_frequency_se": 0.01,
        "d_natural_frequency_determined": True, "d_natural_frequency_unit": "Hz",
        "d_natural_frequency_well_property": np.arange(n) < 30,
    })  # fmt: skip


def test_the_report_s_own_detection_leaves_echoes_out(tmp_path) -> None:
    # Thirty cards whose resonance is the well's, then thirty whose fits echo the stroke at
    # 0.1 Hz: the report found its alerts with every quantity named, as if asked for, and
    # alerted at card c33 on points none of its plots showed.
    frame = _echo_table()
    files = write_fleet_report(frame, tmp_path)
    assert pd.read_csv(files["alerts"]).empty
    # Named, the echoes are trended: the user asked for them.
    assert not detect_changes(frame, ["natural_frequency"]).empty


def test_a_named_quantity_s_echoes_are_drawn_and_listed_as_they_are_trended(tmp_path) -> None:
    # Named, a quantity's echoes of the stroke were trended (an alert at the step to 0.1 Hz)
    # while the wells table gave the well's latest value from before the step and the plots
    # did not draw the points the alert stood on.
    frame = _echo_table()
    n, fn = len(frame), frame["d_natural_frequency"].to_numpy()
    files = write_fleet_report(frame, tmp_path / "named", quantities=["natural_frequency"])
    assert not pd.read_csv(files["alerts"]).empty
    wells = pd.read_csv(files["wells"])
    assert wells.loc[0, "latest_natural_frequency"] == pytest.approx(fn[-1])
    assert quantity_values(with_asked(frame, ["natural_frequency"]),
                           "natural_frequency")[2].sum() == n
    # Shown but not named (the command line's --parameters): echoes stay out everywhere.
    files = write_fleet_report(frame, tmp_path / "shown", quantities=["natural_frequency"],
                               asked=())
    assert pd.read_csv(files["alerts"]).empty
    assert pd.read_csv(files["wells"]).loc[0, "latest_natural_frequency"] == pytest.approx(
        fn[29])


def test_a_quantity_whose_values_are_all_echoes_says_so(tmp_path) -> None:
    # The default report said "quantities asked for natural_frequency [Hz] (no usable value
    # in any well: not trended)": nothing was asked, and 66 determined values were echoes.
    frame = _echo_table().assign(d_natural_frequency_well_property=False)
    page = write_fleet_report(frame, tmp_path)["report"].read_text(encoding="utf-8")
    assert "<td>quantities asked for</td>" not in page and "<td>quantities</td>" in page
    with pytest.raises(ValueError, match="asked for 'bogus', not in the table"):
        write_fleet_report(frame, tmp_path / "bogus", asked=["bogus"])
    assert ("natural_frequency [Hz] (60 values, all echoes of the stroke, not the well&#x27;s "
            "(name it to trend them: --quantity natural_frequency, Python asked=): not "
            "trended)") in page


def test_the_command_line_says_when_a_named_quantity_s_echoes_are_trended(tmp_path,
                                                                         capsys) -> None:
    # Named, a quantity's echoes of the stroke are trended, and the alert at the step to
    # 0.1 Hz was printed as a change of the well with no word that its values were echoes.
    from pumpid.cli import main

    frame = _echo_table()
    assert echo_count(frame, "natural_frequency") == 30
    assert echo_count(frame, "static_stiffness") == 0  # no such column: nothing named
    frame.to_parquet(tmp_path / "results.parquet")
    main(["report", str(tmp_path / "results.parquet"), "--out", str(tmp_path / "named"),
          "--quantity", "natural_frequency"])
    out = capsys.readouterr().out
    assert ("natural_frequency: named, so its 30 values that echo the stroke are trended "
            "too; a change in them may follow the pumping speed, not the well") in out
    main(["report", str(tmp_path / "results.parquet"), "--out", str(tmp_path / "default")])
    assert "echo the stroke" not in capsys.readouterr().out
