"""The well description and its JSON well file: units, materials, matching, named errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from pumpid.rods import MATERIALS, Taper, Well, WellError, read_well_file, wells_from_dict
from pumpid.rods.well import Pump

US = {"units": {"length": "ft", "diameter": "in"},
      "wells": {"W-1": {"rods": [{"length": 2500, "diameter": 1.0, "material": "steel"},
                                 {"length": 1875, "diameter": 0.875, "material": "steel"}],
                        "sinker_bars": [{"length": 250, "diameter": 1.5, "material": "steel"}],
                        "pump": {"depth": 4630, "plunger_diameter": 1.75},
                        "tubing": {"anchored": True},
                        "fluid": {"specific_gravity": 1.0}}}}

METRIC = {"units": {"length": "m", "diameter": "mm", "modulus": "Pa", "density": "kg/m3"},
          "wells": {"fj": {"rods": [{"length": 523.61, "diameter": 25, "modulus": 2.1e11,
                                     "density": 8456}],
                           "pump": {"depth": 523.61, "plunger_diameter": 44},
                           "fluid": {"density": 996.7}}}}


def write(tmp_path: Path, doc: object, name: str = "wells.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_us_file_is_read_in_si(tmp_path: Path) -> None:
    wf = read_well_file(write(tmp_path, US))
    well = wf.for_card(None)
    assert [t.kind for t in well.tapers] == ["rod", "rod", "sinker"]
    assert well.tapers[0].length == pytest.approx(2500 * 0.3048)
    assert well.tapers[1].diameter == pytest.approx(0.875 * 0.0254)
    assert well.pump.depth == pytest.approx(4630 * 0.3048)
    assert well.fluid is not None and well.fluid.density == pytest.approx(1000.0)
    assert well.system == "us"
    e, rho = MATERIALS["steel"]
    assert well.tapers[0].modulus == e and well.tapers[0].density == rho
    # Steel: about 5,000 m/s (16,000-17,000 ft/s) whatever the units.
    assert 5000 < well.tapers[0].wave_speed < 5200


def test_metric_file_with_explicit_material(tmp_path: Path) -> None:
    well = read_well_file(write(tmp_path, METRIC)).for_card("anything")
    t = well.tapers[0]
    assert t.modulus == 2.1e11 and t.density == 8456 and t.material is None
    assert t.diameter == pytest.approx(0.025)
    assert well.system == "metric"


def test_one_well_applies_to_every_card_several_are_matched(tmp_path: Path) -> None:
    doc = json.loads(json.dumps(US))
    doc["wells"]["W-2"] = doc["wells"]["W-1"]
    wf = read_well_file(write(tmp_path, doc))
    assert wf.for_card("W-2").well_id == "W-2"
    with pytest.raises(WellError, match="no well id"):
        wf.for_card(None, "c1")
    with pytest.raises(WellError, match="no well 'W-9'"):
        wf.for_card("W-9", "c1")


@pytest.mark.parametrize("mutate,field,words", [
    (lambda d: d["wells"]["W-1"]["rods"][1].update(diameter=-1), "rods[1].diameter",
     "positive"),
    (lambda d: d["wells"]["W-1"]["rods"][0].update(material="unobtainium"),
     "rods[0].material", "unknown material"),
    (lambda d: d["wells"]["W-1"]["rods"][0].pop("material"), "rods[0].modulus",
     "give a material"),
    (lambda d: d["wells"]["W-1"]["pump"].pop("depth"), "pump.depth", "missing"),
    (lambda d: d["wells"]["W-1"]["pump"].update(depth=9000), "rods", "above the pump"),
    (lambda d: d["wells"]["W-1"]["pump"].update(depth=3000), "pump.depth",
     "below the pump depth"),
    (lambda d: d["wells"]["W-1"].update(tubing={"anchored": "yes"}), "tubing.anchored",
     "true or false"),
    (lambda d: d["wells"]["W-1"].update(fluid={"specific_gravity": 1, "density": 60}),
     "fluid.density", "not both"),
    (lambda d: d["wells"]["W-1"]["rods"][0].update(lenght=3), "rods[0].lenght",
     "unknown key"),
    (lambda d: d["units"].update(length="furlong"), "units.length", "unknown unit"),
    (lambda d: d["units"].pop("diameter"), "units.diameter", "missing"),
    # Slips of unit or key gave confident pump quantities, exit 0.
    (lambda d: d["wells"]["W-1"].update(fluid={"specific_gravity": 988}),
     "fluid.specific_gravity", "a density belongs in fluid.density"),
    (lambda d: d["wells"]["W-1"].update(fluid={"density": 0.9}), "fluid.density",
     "outside the range of well fluids"),
    (lambda d: d["wells"]["W-1"]["pump"].update(plunger_diameter=17.5), "pump.plunger_diameter",
     "444.5 mm is outside the range of rod pumps' plungers"),
    (lambda d: d["wells"]["W-1"]["rods"][1].update(diameter=8.75), "rods[1].diameter",
     "outside the range of rods and sinker bars"),
    (lambda d: d["wells"]["W-1"]["rods"][0].update(density=0.528), "rods[0].density",
     "outside the range of rod materials"),
    (lambda d: d["wells"]["W-1"]["rods"][0].update(modulus=30e9), "rods[0].modulus",
     "outside the range of rod materials"),
])
def test_every_problem_is_named(tmp_path: Path, mutate, field: str, words: str) -> None:
    doc = json.loads(json.dumps(US))
    mutate(doc)
    path = write(tmp_path, doc)
    with pytest.raises(WellError) as info:
        read_well_file(path)
    message = str(info.value)
    assert words in message
    assert info.value.field == field, message
    assert str(path) in message
    if not field.startswith("units"):
        assert "'W-1'" in message


def test_bad_json_and_missing_file_are_named(tmp_path: Path) -> None:
    path = tmp_path / "broken.json"
    path.write_text("{", encoding="utf-8")
    with pytest.raises(WellError, match="not valid JSON"):
        read_well_file(path)
    with pytest.raises(WellError, match="no such file"):
        read_well_file(tmp_path / "absent.json")


def test_assumptions_are_said(tmp_path: Path) -> None:
    doc = json.loads(json.dumps(US))
    del doc["wells"]["W-1"]["tubing"], doc["wells"]["W-1"]["fluid"]
    well = wells_from_dict(doc)["W-1"]
    said = " ".join(well.notes)
    assert "taken as anchored" in said and "no buoyancy" in said
    assert well.fluid is None and well.fluid_density == 0.0


def test_damping_coefficient_is_gibbs_rule() -> None:
    e, rho = MATERIALS["steel"]
    well = Well("w", (Taper(1000.0, 0.025, e, rho), Taper(500.0, 0.019, e, rho)),
                Pump(1500.0, 0.044))
    a = math.sqrt(e / rho)
    assert well.damping_coefficient(0.2) == pytest.approx(math.pi * 0.2 / (2 * 1500.0 / a))
    assert well.damping_coefficient(0.0) == 0.0


def test_dataclasses_are_frozen_and_checked() -> None:
    e, rho = MATERIALS["steel"]
    taper = Taper(100.0, 0.02, e, rho)
    with pytest.raises(AttributeError):
        taper.length = 5.0  # type: ignore[misc]
    with pytest.raises(WellError):
        Taper(float("nan"), 0.02, e, rho)


def test_a_unit_the_file_does_not_name_is_said_when_used() -> None:
    doc = json.loads(json.dumps(US))
    plain = wells_from_dict(doc)["W-1"]
    assert not any("read in psi" in n for n in plain.notes)
    doc["wells"]["W-1"]["rods"][0].update(modulus=30.0e6)
    well = wells_from_dict(doc)["W-1"]
    assert any("modulus values are read in psi" in n for n in well.notes)
    assert well.tapers[0].modulus == pytest.approx(30.0e6 * 6894.757293168361)


@pytest.mark.parametrize("depth,where", [(4580, "below"), (4700, "above")])
def test_a_string_slightly_off_the_pump_depth_is_noted(depth: float, where: str) -> None:
    doc = json.loads(json.dumps(US))
    doc["wells"]["W-1"]["pump"]["depth"] = depth   # the string is 4,625 ft
    well = wells_from_dict(doc)["W-1"]
    # In the file's unit (it said "13.72 m" of a file in feet).
    assert any(f"ends {abs(depth - 4625):g} ft {where} the pump depth" in n
               for n in well.notes), well.notes
