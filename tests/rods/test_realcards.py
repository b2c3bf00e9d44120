"""The two public CMCM 2012 surface cards through ``pumpid downhole`` (read at test time).

Their wells come from the data set's own ``wells.json`` (not in pumpid's schema): a well
file in pumpid's schema is written from it into a temporary folder. The figures measured
are printed in the test summary.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pumpid.cli.main import main

from ..conftest import REPORTED

pytestmark = pytest.mark.realdata

FOLDER = "cmcm2012_rod_pump"


def well_file(raw: Path, well_id: str, tmp_path: Path) -> tuple[Path, dict]:
    """Our well file for one of the data set's wells, and the data set's entry."""
    source = json.loads((raw / FOLDER / "wells.json").read_text(encoding="utf-8"))
    entry = source["wells"][well_id]
    common = source["common"]
    water = entry["water_cut"]
    # No mixture density is given: mix crude and water by the water cut, as the source's
    # notes say its teams did.
    density = (common["crude_oil_density_kg_m3"] * (1 - water)
               + common["water_density_kg_m3"] * water)
    doc = {"units": {"length": "m", "diameter": "mm", "modulus": "Pa", "density": "kg/m3"},
           "wells": {well_id: {
               "rods": [{"length": t["length_m"], "diameter": t["diameter_mm"],
                         "modulus": t["E_Pa"], "density": t["density_kg_m3"]}
                        for t in entry["rod_tapers"]],
               "pump": {"depth": entry["pump_depth_m"],
                        "plunger_diameter": entry["plunger_diameter_mm"]},
               "tubing": {"anchored": True},
               "fluid": {"density": density}}}}
    path = tmp_path / f"{well_id}.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path, entry


def _positions(card: Path) -> list[float]:
    lines = card.read_text(encoding="utf-8").splitlines()[1:]
    return [float(line.split(",")[0]) for line in lines if line.strip()]


def run(capsys, card: Path, well: Path, spm: float, *extra: str) -> dict:
    code = main(["downhole", str(card), "--well", str(well), "--spm", f"{spm:g}", "--json",
                 *extra])
    doc = json.loads(capsys.readouterr().out)
    assert code == 0, doc
    return doc["cards"][0]


@pytest.mark.parametrize("well_id", ["fj1", "fj2"])
def test_real_cards_through_pumpid_downhole(shared_raw: Path, tmp_path: Path, capsys,
                                            well_id: str) -> None:
    well, entry = well_file(shared_raw, well_id, tmp_path)
    card = shared_raw / FOLDER / entry["card_csv"]
    spm = float(entry["spm"])
    runs = {"default": run(capsys, card, well, spm),
            "nu0-h15": run(capsys, card, well, spm, "--damping", "0", "--harmonics", "15"),
            "fd": run(capsys, card, well, spm, "--method", "fd")}
    for name, res in runs.items():
        pump = res["pump"]
        assert res["status"] == "computed"
        assert res["downhole"]["units"] == {"position": "m", "load": "kN"}
        assert 0 <= pump["fillage"]["value"] <= 1
        # The plunger's travel is the polished rod's, give or take the rod stretch and
        # overtravel: within 15 % of it.
        surface_stroke = max(_positions(card)) - min(_positions(card))
        assert pump["gross_stroke"]["value"] == pytest.approx(surface_stroke, rel=0.15)
        assert len(res["downhole"]["load"]) == entry["n_points"]
        REPORTED.append(
            f"cmcm2012 {well_id} ({name}): gross stroke {pump['gross_stroke']['value']:.3f} m, "
            f"net stroke {pump['net_stroke']['value']:.3f} m, fluid load "
            f"{pump['fluid_load']['value']:.2f} kN, fillage {pump['fillage']['value']:.3f}, "
            f"displacement {pump['displacement']['value']:.1f} m3/d, intake pressure "
            f"{pump['intake_pressure']['value']:.0f} kPa")
    # The fluid load is the fluid column's on the plunger, within the card's uncertainty
    # (no tubing pressure, mixture density assumed): within 20 %.
    column = (json.loads(well.read_text())["wells"][well_id]["fluid"]["density"] * 9.80665
              * entry["pump_depth_m"] * 3.141592653589793 / 4
              * (entry["plunger_diameter_mm"] / 1000) ** 2 / 1000)
    assert runs["default"]["pump"]["fluid_load"]["value"] == pytest.approx(column, rel=0.2)
    # The two solvers agree on the real card.
    a, b = runs["default"]["downhole"]["load"], runs["fd"]["downhole"]["load"]
    span = max(a) - min(a)
    assert max(abs(x - y) for x, y in zip(a, b, strict=True)) < 0.01 * span
