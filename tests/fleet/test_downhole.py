"""pumpid batch --well-file: pump quantities as columns, per card matched to its well; the
change detector and the fleet report trend them (a fillage drop is alerted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from pumpid.fleet import FitSpec, detect_changes, read_results, run_batch
from pumpid.fleet.downhole import PUMP_QUANTITIES, DownholeSpec, add_pump_columns
from pumpid.fleet.inputs import CardItem
from pumpid.fleet.report import write_fleet_report
from pumpid.rods import WellError

from .pumpfield import write_pump_field, write_well_file

CARDS = 50
DROP = 30  # the first card of the pounding well's lower fillage
MIN_CARDS = 15


@pytest.fixture(scope="module")
def pump_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame,
                                                                 pd.DataFrame]:
    """Two steady wells (a full pump, a steady 80 % pound), one whose fillage falls from
    full to 65 % at card 30, and a card of a well the well file does not describe."""
    root = tmp_path_factory.mktemp("pumpfield")
    truth = write_pump_field(root / "field", {
        "FULL": lambda k: 1.0, "STEADY80": lambda k: 0.8,
        "POUND": lambda k: 1.0 if k < DROP else 0.65}, cards=CARDS)
    stray = json.loads((root / "field" / "FULL.json").read_text(encoding="utf-8"))
    stray["well"] = "ELSEWHERE"
    stray["cards"] = [dict(stray["cards"][0], card_id="ELSEWHERE_1")]
    (root / "field" / "ELSEWHERE.json").write_text(json.dumps(stray), encoding="utf-8")
    wells = write_well_file(root / "wells.json", ["FULL", "STEADY80", "POUND"])
    out = root / "results"
    # The fits are not what is tested here: few evaluations keep the run short.
    run_batch([root / "field"], out, fit=FitSpec("msd", options={"max_nfev": 20}),
              partition_size=40,
              downhole=DownholeSpec.load(wells, identify=False), csv=root / "results.csv")
    return root, truth, read_results(out)


def test_every_card_has_its_pump_quantities_with_units(pump_run) -> None:
    root, truth, table = pump_run
    assert len(table) == 3 * CARDS + 1
    for name in PUMP_QUANTITIES:
        assert f"pump_{name}" in table.columns and f"pump_{name}_unit" in table.columns
    got = truth.merge(table, on=["well_id", "card_id"], how="left")
    assert (got["downhole_status"] == "computed").all()
    assert (got["downhole_well"] == got["well_id"]).all()
    assert set(got["pump_fillage_unit"]) == {"fraction"}
    assert set(got["pump_gross_stroke_unit"]) == {"in"}
    assert set(got["pump_fluid_load_unit"]) == {"lbf"}
    assert set(got["pump_displacement_unit"]) == {"bbl/d"}
    assert set(got["pump_intake_pressure_unit"]) == {"psi"}
    assert (got["downhole_damping"] == 0.05).all()  # the default rule
    # the fillage measured on each pump card follows the pump's liquid fraction
    assert (got["pump_fillage"] - got["fillage"]).abs().max() < 0.05
    assert got["pump_fluid_load"].notna().all() and (got["pump_fluid_load"] > 0).all()
    csv = pd.read_csv(root / "results.csv")
    assert csv["pump_fillage"].notna().sum() == 3 * CARDS
    assert (csv["pump_fillage_unit"].dropna() == "fraction").all()


def test_a_card_of_an_unknown_well_keeps_its_row_with_null_pump_columns(pump_run) -> None:
    _, _, table = pump_run
    row = table[table["well_id"] == "ELSEWHERE"].iloc[0]
    assert row["downhole_status"] == "invalid-input"
    assert "no well 'ELSEWHERE'" in row["downhole_reason"]
    assert "no pump card" in row["warnings"] and "ELSEWHERE" in row["warnings"]
    assert all(pd.isna(row[f"pump_{name}"]) for name in PUMP_QUANTITIES)
    assert row["status"] in ("converged", "boundary", "poor-fit", "failed")  # the fit's own


def test_a_one_well_file_applies_to_every_card(pump_run, tmp_path: Path) -> None:
    root, _, _ = pump_run
    from pumpid.cards import read_cards

    one = write_well_file(tmp_path / "one.json", ["ANY"])
    cards = read_cards(root / "field" / "ELSEWHERE.json") + read_cards(
        root / "field" / "POUND.json")[:2]
    items = [CardItem(c, c.card_id, "s", "f") for c in cards]
    rows: list = [{"warnings": ""} for _ in items]
    add_pump_columns(items, rows, DownholeSpec.load(one, identify=False))
    assert [r["downhole_status"] for r in rows] == ["computed"] * 3
    assert {r["downhole_well"] for r in rows} == {"ANY"}
    assert "differs from the well file's only well" in rows[0]["downhole_notes"]


def test_fillage_drop_is_alerted_and_steady_wells_are_not(pump_run) -> None:
    _, _, table = pump_run
    alerts = detect_changes(table, min_cards=MIN_CARDS)
    pump = alerts[alerts["kind"] == "pump"]
    fill = pump[pump["quantity"] == "pump_fillage"]
    assert list(fill["well_id"]) == ["POUND"]
    a = fill.iloc[0]
    assert a["direction"] == "down" and a["unit"] == "fraction"
    assert abs(int(a["first_index"]) - DROP) <= 1
    assert a["before"] > 0.95 and a["after"] < 0.7
    # no pump quantity of a steady well raises an alert
    assert set(pump["well_id"]) == {"POUND"}


def test_fleet_report_trends_the_pump_quantities(pump_run, tmp_path: Path) -> None:
    _, _, table = pump_run
    paths = write_fleet_report(table, tmp_path / "report", min_cards=MIN_CARDS)
    alerts = pd.read_csv(paths["alerts"])
    assert "pump_fillage" in set(alerts.loc[alerts["well_id"] == "POUND", "quantity"])
    wells = pd.read_csv(paths["wells"])
    assert "latest_pump_fillage" in wells.columns
    assert wells.loc[wells["well_id"] == "POUND", "latest_pump_fillage_unit"].iloc[0] == \
        "fraction"
    page = Path(paths["report"]).read_text(encoding="utf-8")
    assert "pump_fillage" in page


def test_batch_cli_well_file_options(tmp_path: Path, pump_run) -> None:
    root, _, _ = pump_run
    bad = tmp_path / "bad.json"
    bad.write_text('{"wells": {"W": {"rods": [{"length": -5, "diameter": 1}]}}}',
                   encoding="utf-8")
    with pytest.raises(WellError, match=r"bad\.json"):
        DownholeSpec.load(bad)
    proc = subprocess.run([sys.executable, "-m", "pumpid.cli", "batch", str(root / "field"),
                           "--out", str(tmp_path / "r"), "--damping", "0.1"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "--well-file" in proc.stderr


def test_resume_keeps_the_runs_well_file_and_refuses_another(pump_run, tmp_path: Path) -> None:
    from pumpid.fleet.store import ResultsFolderError

    root, _, _ = pump_run
    card = root / "field" / "ELSEWHERE.json"
    first = write_well_file(tmp_path / "first.json", ["ELSEWHERE"])
    out = tmp_path / "r"
    fit = FitSpec("msd", options={"max_nfev": 5})
    run_batch([card], out, fit=fit, downhole=DownholeSpec.load(first, identify=False))
    # resumed without the option: the run's own well file, nothing refused
    run_batch([card], out, resume=True)
    assert read_results(out)["downhole_status"].tolist() == ["computed"]
    # the same path with other wells in it: refused (its checksum is in the manifest)
    write_well_file(first, ["ELSEWHERE", "OTHER"])
    with pytest.raises(ResultsFolderError):
        run_batch([card], out, resume=True,
                  downhole=DownholeSpec.load(first, identify=False))
