"""``pumpid downhole``: JSON shape, units, well matching, outputs, errors."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from pumpid.cli.main import main
from pumpid.rods import PumpModel, predict_surface

from .strings import INCH, LBF, surface_motion, three_tapers

SPM = 8.0
WELL = {"units": {"length": "ft", "diameter": "in"},
        "wells": {"W-1": {"rods": [{"length": 1500, "diameter": 1.0, "material": "steel"},
                                   {"length": 1600, "diameter": 0.875, "material": "steel"},
                                   {"length": 1800, "diameter": 0.75, "material": "steel"}],
                          "pump": {"depth": 4900, "plunger_diameter": 1.75},
                          "tubing": {"anchored": True},
                          "fluid": {"specific_gravity": 1.0}}}}


@pytest.fixture(scope="module")
def surface() -> tuple[np.ndarray, np.ndarray]:
    """Two surface cards (m, N): a full pump and a fluid pound at 70 %."""
    well = three_tapers()
    s = surface_motion(n=120, period=60 / SPM)
    pump = PumpModel(fluid_load=18000.0, fillage=np.array([1.0, 0.7]), transfer=0.05)
    pred = predict_surface(well, np.repeat(s[None], 2, 0), 60 / SPM, pump, nu=0.05,
                           tol=1e-5)
    return s, pred.surface_load + well.buoyant_weight()


def write_cards(path: Path, surface, ids=("W-1", "W-1"), metric: bool = False,
                reverse: bool = False) -> Path:
    s, loads = surface
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["card_id", "well_id", "position_m" if metric else "position_in",
                    "load_kN" if metric else "load_lbf"])
        for k, well_id in enumerate(ids):
            x = s if metric else s / INCH
            f = loads[k] / 1000 if metric else loads[k] / LBF
            rows = list(zip(x, f, strict=True))
            for a, b in (rows[::-1] if reverse else rows):
                w.writerow([f"card{k}", well_id, f"{a:.6f}", f"{b:.4f}"])
    return path


def write_well(path: Path, doc: dict = WELL) -> Path:
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def run_json(capsys, *args: str) -> tuple[int, dict]:
    code = main(["downhole", *args, "--json"])
    return code, json.loads(capsys.readouterr().out)


def test_json_shape_and_units(tmp_path: Path, surface, capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    well = write_well(tmp_path / "well.json")
    code, doc = run_json(capsys, str(cards), "--well", str(well), "--spm", str(SPM))
    assert code == 0
    assert set(doc) == {"cards", "summary"} and len(doc["cards"]) == 2
    full, pound = doc["cards"]
    assert full["status"] == "computed" and full["reason"] == ""
    assert full["card"] == {"id": "card0", "well": "W-1", "source": full["card"]["source"]}
    down = full["downhole"]
    assert down["units"] == {"position": "in", "load": "lbf"}
    assert len(down["position"]) == len(down["load"]) == 120
    assert down["convention"] == "effective"
    for name in ("gross_stroke", "net_stroke", "fluid_load", "fillage"):
        assert set(full["pump"][name]) == {"value", "unit"}
    assert full["pump"]["fillage"]["unit"] == "fraction"
    assert full["pump"]["fluid_load"]["value"] == pytest.approx(18000 / LBF, rel=0.02)
    assert pound["pump"]["fillage"]["value"] < full["pump"]["fillage"]["value"] - 0.2
    assert doc["summary"]["cards"] == 2 and doc["summary"]["status"] == {"computed": 2}
    assert doc["summary"]["damping"] == 0.05 and "default" in doc["summary"]["damping_rule"]


def test_a_single_well_applies_to_every_card_and_says_so(tmp_path: Path, surface,
                                                         capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface, ids=("W-1", "OTHER"))
    code, doc = run_json(capsys, str(cards), "--well", str(write_well(tmp_path / "w.json")),
                         "--spm", str(SPM))
    assert code == 0
    first, second = doc["cards"]
    assert not any("differs" in n for n in first["notes"])
    assert any("'OTHER' differs from the well file's only well 'W-1'" in n
               for n in second["notes"])


def test_metric_card_with_us_well_file_is_converted(tmp_path: Path, surface, capsys) -> None:
    well = write_well(tmp_path / "well.json")
    _c, us = run_json(capsys, str(write_cards(tmp_path / "us.csv", surface)), "--well",
                      str(well), "--spm", str(SPM))
    _c, si = run_json(capsys, str(write_cards(tmp_path / "si.csv", surface, metric=True)),
                      "--well", str(well), "--spm", str(SPM))
    a, b = us["cards"][0], si["cards"][0]
    assert b["downhole"]["units"] == {"position": "m", "load": "kN"}
    assert b["pump"]["gross_stroke"]["value"] == pytest.approx(
        a["pump"]["gross_stroke"]["value"] * INCH, rel=1e-5)
    assert b["pump"]["fluid_load"]["value"] == pytest.approx(
        a["pump"]["fluid_load"]["value"] * LBF / 1000, rel=1e-4)
    assert any("converted" in n for n in b["notes"])


def test_wells_matched_by_id_and_unknown_well_refused(tmp_path: Path, surface,
                                                      capsys) -> None:
    doc = json.loads(json.dumps(WELL))
    doc["wells"]["W-2"] = doc["wells"]["W-1"]
    well = write_well(tmp_path / "wells.json", doc)
    cards = write_cards(tmp_path / "cards.csv", surface, ids=("W-2", "W-9"))
    code, out = run_json(capsys, str(cards), "--well", str(well), "--spm", str(SPM))
    assert code == 3
    assert out["cards"][0]["status"] == "computed"
    bad = out["cards"][1]
    assert bad["status"] == "invalid-input" and "no well 'W-9'" in bad["reason"]
    assert bad["downhole"] is None and bad["pump"] is None


def test_reversed_card_is_said(tmp_path: Path, surface, capsys) -> None:
    cards = write_cards(tmp_path / "rev.csv", surface, reverse=True)
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM)])
    text = capsys.readouterr().out
    assert code == 0 and "reversed" in text and "reverse time order" in text


def test_outputs_one_card_and_several(tmp_path: Path, surface, capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    well = str(write_well(tmp_path / "w.json"))
    one = tmp_path / "one"
    assert main(["downhole", str(cards), "--well", well, "--spm", "8", "--card", "card1",
                 "--out", str(one)]) == 0
    assert {"downhole.json", "pump_card.csv", "cards.png"} <= {p.name for p in one.iterdir()}
    many = tmp_path / "many"
    assert main(["downhole", str(cards), "--well", well, "--spm", "8", "--out",
                 str(many)]) == 0
    capsys.readouterr()
    with (many / "downhole.csv").open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["card_id"] for r in rows] == ["card0", "card1"]
    assert rows[0]["pump_fillage_unit"] == "fraction"
    assert (many / rows[1]["folder"] / "cards.png").is_file()


@pytest.mark.parametrize("extra,words", [
    (["--damping", "-1"], "--damping"),
    (["--harmonics", "0"], "--harmonics"),
    (["--method", "fd", "--harmonics", "5"], "fourier only"),
])
def test_bad_options_exit_2(tmp_path: Path, surface, capsys, extra, words) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", "8", *extra])
    assert code == 2 and words in capsys.readouterr().err


def test_bad_well_file_names_the_field(tmp_path: Path, surface, capsys) -> None:
    doc = json.loads(json.dumps(WELL))
    doc["wells"]["W-1"]["pump"]["plunger_diameter"] = "big"
    code = main(["downhole", str(write_cards(tmp_path / "c.csv", surface)), "--well",
                 str(write_well(tmp_path / "w.json", doc)), "--spm", "8"])
    message = capsys.readouterr().err
    assert code == 2 and "pump.plunger_diameter" in message and "'W-1'" in message


def test_card_without_time_is_refused_with_the_fix(tmp_path: Path, surface, capsys) -> None:
    code, out = run_json(capsys, str(write_cards(tmp_path / "c.csv", surface)), "--well",
                         str(write_well(tmp_path / "w.json")))
    assert code == 2
    assert all("--spm" in c["reason"] for c in out["cards"])


def test_split_strokes_of_a_time_record(tmp_path: Path, surface, capsys) -> None:
    s, loads = surface
    path = tmp_path / "record.csv"
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["t_s", "position_in", "load_lbf"])
        for k in range(3 * s.size):
            w.writerow([f"{k * 60 / SPM / s.size:.6f}", f"{s[k % s.size] / INCH:.6f}",
                        f"{loads[1][k % s.size] / LBF:.4f}"])
    well = str(write_well(tmp_path / "w.json"))
    code, whole = run_json(capsys, str(path), "--well", well)
    assert code == 2 and "several strokes" in whole["cards"][0]["reason"]
    code, split = run_json(capsys, str(path), "--well", well, "--split-strokes")
    assert code == 0 and len(split["cards"]) >= 2
    assert all(c["pump"]["fillage"]["value"] < 0.85 for c in split["cards"])
