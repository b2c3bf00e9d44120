"""The two public CMCM 2012 surface cards through ``pumpid downhole`` (read at test time):
the diagnostic pump card and the pump identified from the surface card.

Their wells come from the data set's own ``wells.json`` (not in pumpid's schema): a well
file in pumpid's schema is written from it into a temporary folder. The figures measured
are printed in the test summary.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from pumpid.cli.main import main

from ..conftest import REPORTED
from .strings import cmcm_well_document

pytestmark = pytest.mark.realdata

FOLDER = "cmcm2012_rod_pump"


def well_file(raw: Path, well_id: str, tmp_path: Path) -> tuple[Path, dict]:
    """Our well file for one of the data set's wells, and the data set's entry."""
    source = json.loads((raw / FOLDER / "wells.json").read_text(encoding="utf-8"))
    entry = source["wells"][well_id]
    doc = cmcm_well_document(entry, source["common"], well_id)
    path = tmp_path / f"{well_id}.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path, entry


def _positions(card: Path) -> list[float]:
    lines = card.read_text(encoding="utf-8").splitlines()[1:]
    return [float(line.split(",")[0]) for line in lines if line.strip()]


def run(capsys, card: Path, well: Path, spm: float, *extra: str,
        codes: tuple[int, ...] = (0,)) -> dict:
    code = main(["downhole", str(card), "--well", str(well), "--spm", f"{spm:g}", "--json",
                 *extra])
    doc = json.loads(capsys.readouterr().out)
    assert code in codes, doc
    return doc["cards"][0]


def _pm(entry: dict, digits: str = ".3g") -> str:
    se = entry.get("stderr")
    return f"{entry['value']:{digits}}" + ("" if se is None else f" +- {se:.2g}")


@pytest.mark.parametrize("well_id", ["fj1", "fj2"])
def test_real_cards_through_pumpid_downhole(shared_raw: Path, tmp_path: Path, capsys,
                                            well_id: str) -> None:
    well, entry = well_file(shared_raw, well_id, tmp_path)
    card = shared_raw / FOLDER / entry["card_csv"]
    spm = float(entry["spm"])
    # identified by default: exit 0, or 5 / 6 when the identification is poor / undetermined
    # (the card is computed either way and says so)
    runs = {"identified": run(capsys, card, well, spm, codes=(0, 5, 6)),
            "nu0-h15": run(capsys, card, well, spm, "--damping", "0", "--harmonics", "15"),
            "fd": run(capsys, card, well, spm, "--method", "fd", "--no-identify")}
    for name, res in runs.items():
        pump = res["downhole"]["pump"]  # the diagnostic card's own quantities
        assert res["status"] == "computed"
        assert res["downhole"]["units"] == {"position": "m", "load": "kN"}
        assert 0 <= pump["fillage"]["value"] <= 1
        # The plunger's travel is the polished rod's, give or take the rod stretch and
        # overtravel: within 15 % of it.
        surface_stroke = max(_positions(card)) - min(_positions(card))
        assert pump["gross_stroke"]["value"] == pytest.approx(surface_stroke, rel=0.15)
        assert len(res["downhole"]["load"]) == entry["n_points"]
        REPORTED.append(
            f"cmcm2012 {well_id} ({name}, diagnostic at nu {res['damping']['value']:.3g}): "
            f"gross stroke {pump['gross_stroke']['value']:.3f} m, "
            f"net stroke {pump['net_stroke']['value']:.3f} m, fluid load "
            f"{pump['fluid_load']['value']:.2f} kN, fillage {pump['fillage']['value']:.3f}, "
            f"displacement {pump['displacement']['value']:.1f} m3/d, intake pressure "
            f"{pump['intake_pressure']['value']:.0f} kPa")
    got = runs["identified"]
    ident = got["identification"]
    assert ident is not None and runs["nu0-h15"]["identification"] is None
    assert ident["status"] in ("converged", "boundary", "poor-fit", "undetermined", "failed")
    if "parameters" in ident:
        # The fit's figures are reported whatever its status; its quantities carry errors.
        assert 0 < got["r2"] <= 1 and -1 <= got["residual_autocorrelation"] <= 1
        q = ident["pump"]
        assert q["fluid_load"]["unit"] == "kN" and q["fillage"]["unit"] == "fraction"
        nu = ident["parameters"]["damping"]
        energy = ident["energy"]
        # The fitted pump card against the diagnostic of the fitted surface load: the two
        # solvers agree within 1 % of the load range on a real well too (the measured
        # card's agreement adds the surface residual carried down).
        assert ident["consistency"] < 0.01
        REPORTED.append(
            f"cmcm2012 {well_id} identification: {ident['status']} "
            f"({'used' if ident['used'] else 'not used'}), surface-load R^2 {got['r2']:.4f}, "
            f"residual lag-1 autocorrelation {got['residual_autocorrelation']:.2f}, fluid load "
            f"{_pm(q['fluid_load'], '.4g')} kN, fillage {_pm(q['fillage'])}, damping nu "
            f"{_pm(nu)}, fitted vs diagnostic pump card RMS {100 * ident['agreement']:.1f} % "
            f"of the load range (vs the diagnostic of the fitted surface load "
            f"{100 * ident['consistency']:.2f} %), string loss "
            f"{100 * energy['string_loss']:.0f} % of the surface work")
    else:
        REPORTED.append(f"cmcm2012 {well_id} identification: {ident['status']}: "
                        f"{ident['reason']}")
    # The outputs say which damping the diagnostic card used, and why.
    assert got["damping"]["rule"] and got["downhole"]["damping"]["value"] == \
        got["damping"]["value"]
    if not ident["used"]:
        assert all(e["stderr"] is None for e in got["pump"].values())
    # The fluid load is the fluid column's on the plunger, within the card's uncertainty
    # (no tubing pressure, mixture density assumed): within 20 % (the diagnostic card at
    # the default damping).
    column = (json.loads(well.read_text())["wells"][well_id]["fluid"]["density"] * 9.80665
              * entry["pump_depth_m"] * 3.141592653589793 / 4
              * (entry["plunger_diameter_mm"] / 1000) ** 2 / 1000)
    default = run(capsys, card, well, spm, "--no-identify")
    assert default["pump"]["fluid_load"]["value"] == pytest.approx(column, rel=0.2)
    # The two solvers agree on the real card.
    a, b = default["downhole"]["load"], runs["fd"]["downhole"]["load"]
    span = max(a) - min(a)
    assert max(abs(x - y) for x, y in zip(a, b, strict=True)) < 0.01 * span


def test_the_text_says_what_the_intake_pressure_assumes(shared_raw: Path, tmp_path: Path,
                                                       capsys) -> None:
    # fj2's text block had no note, while the JSON said the rods end 13.28 m above the pump
    # and the intake pressure takes the tubing-head pressure as 0 (not in the well file).
    well, entry = well_file(shared_raw, "fj2", tmp_path)
    card = shared_raw / FOLDER / entry["card_csv"]
    main(["downhole", str(card), "--well", str(well), "--spm", f"{float(entry['spm']):g}",
          "--no-identify"])
    out = " ".join(capsys.readouterr().out.split())
    assert "note: the rod string ends 13.28 m above the pump depth" in out
    assert "note: pump intake pressure with the tubing-head pressure taken as 0" in out


def test_the_load_lines_are_on_the_card_shown(shared_raw: Path, tmp_path: Path,
                                             capsys) -> None:
    # --convention true on fj2: the card ran from -12.07 to 16.62 kN and its load lines
    # were printed at 20.20 and -5.74 kN, the effective card's, 4.96 kN off.
    well, entry = well_file(shared_raw, "fj2", tmp_path)
    card = shared_raw / FOLDER / entry["card_csv"]
    got = {c: run(capsys, card, well, float(entry["spm"]), "--damping", "0", "--method", "fd",
                  "--convention", c) for c in ("effective", "true")}
    shift = got["effective"]["pump"]["upper_load_line"]["value"] - \
        got["true"]["pump"]["upper_load_line"]["value"]
    assert shift > 1.0  # kN: the fluid pressure on the rod's section at the pump
    for c, doc in got.items():
        loads = doc["downhole"]["load"]
        q = doc["pump"]
        assert min(loads) - 1.0 < q["lower_load_line"]["value"] < q["upper_load_line"][
            "value"] < max(loads) + 1.0, c
    assert got["effective"]["pump"]["lower_load_line"]["value"] - got["true"]["pump"][
        "lower_load_line"]["value"] == pytest.approx(shift)
    assert got["true"]["pump"]["fluid_load"] == got["effective"]["pump"]["fluid_load"]


def test_a_pump_quantity_whose_error_exceeds_it_is_not_determined(shared_raw: Path,
                                                                   tmp_path: Path,
                                                                   capsys) -> None:
    # fj2's identified intake pressure, 4014 +- 1e4 kPa, was shown as a used value in the
    # text, the HTML and the JSON, with no word that the card does not determine it.
    well, entry = well_file(shared_raw, "fj2", tmp_path)
    card = shared_raw / FOLDER / entry["card_csv"]
    spm = float(entry["spm"])
    doc = run(capsys, card, well, spm, codes=(0, 5, 6))
    pump = doc["pump"]
    loose = [n for n, q in pump.items() if q.get("determined") is False]
    for name, q in pump.items():
        if q.get("determined"):
            assert q["stderr"] is not None and q["stderr"] <= abs(q["value"]), name
    assert loose == ["intake_pressure"], pump
    assert pump["intake_pressure"]["stderr"] > abs(pump["intake_pressure"]["value"])
    main(["downhole", str(card), "--well", str(well), "--spm", f"{spm:g}"])
    text = " ".join(capsys.readouterr().out.split())
    for name in loose:
        assert re.search(name.replace("_", " ") + r" [^,]* \(not determined\)", text), name


def test_an_unusable_identification_gives_its_residual_autocorrelation(
        shared_raw: Path, tmp_path: Path, capsys) -> None:
    # fj1's identification is undetermined: its line gave R^2 without the residuals' lag-1
    # autocorrelation, which the usable ones give.
    well, entry = well_file(shared_raw, "fj1", tmp_path)
    main(["downhole", str(shared_raw / FOLDER / entry["card_csv"]), "--well", str(well),
          "--spm", f"{float(entry['spm']):g}"])
    text = " ".join(capsys.readouterr().out.split())
    assert re.search(r"pump not identified \(undetermined, R\^2 0\.\d+, residual lag-1 "
                     r"autocorrelation 0\.\d\d\); diagnostic pump card why not identified: "
                     r"no parameter", text), text[:400]
    # A full pump's fillage follows from the held liquid fraction: not "determined".
    assert "determined derived quantities: gross_stroke" in text
    assert "fillage, gross_stroke" not in text


def test_a_batch_row_gives_the_damping_of_the_values_it_gives(shared_raw: Path,
                                                               tmp_path: Path) -> None:
    # fj1's identification is undetermined, so the diagnostic card used the default rule's
    # 0.05: the row's quantities are that card's (as pumpid downhole gives them), and
    # pump_damping the 0.05 that made them, without an error (the identified quantities
    # had once sat beside 0.05, then beside the fit's own 0.64 while the diagnostic card's
    # values were shown by pumpid downhole).
    import pandas as pd

    well, entry = well_file(shared_raw, "fj1", tmp_path)
    field = tmp_path / "field"
    field.mkdir()
    card = field / "fj1.csv"
    card.write_bytes((shared_raw / FOLDER / entry["card_csv"]).read_bytes())
    main(["batch", str(field), "--out", str(tmp_path / "res"), "--well-file", str(well),
          "--spm", f"{float(entry['spm']):g}", "--pump-only", "--engine", "local"])
    row = pd.read_parquet(tmp_path / "res").iloc[0]
    assert row["identify_status"] == "undetermined"
    assert row["downhole_damping"] == pytest.approx(0.05)
    assert row["pump_damping"] == pytest.approx(0.05) and pd.isna(row["pump_damping_se"])
    assert row["pump_fluid_load"] == pytest.approx(row["downhole_fluid_load"])


def test_the_energy_balance_leads_with_the_card_used(shared_raw: Path, tmp_path: Path,
                                                      capsys) -> None:
    # fj1's identification is not used: its 68.7 % loss led the sentence, while the
    # diagnostic card the outputs use loses 5.5 %; the share was of a surface work not
    # printed.
    well, entry = well_file(shared_raw, "fj1", tmp_path)
    out = tmp_path / "out"
    main(["downhole", str(shared_raw / FOLDER / entry["card_csv"]), "--well", str(well),
          "--spm", f"{float(entry['spm']):g}", "--out", str(out)])
    capsys.readouterr()
    page = re.sub(r"<[^>]+>", "", (out / "report.html").read_text(encoding="utf-8"))
    said = page[page.index("work per stroke: "):].split(".\n")[0]
    assert said.startswith("work per stroke: the measured surface card ")
    assert "the fitted surface card " in said and said.endswith("(the identification, not used)")


def test_an_unused_identification_says_whose_quantities_are_shown(shared_raw: Path,
                                                                  tmp_path: Path,
                                                                  capsys) -> None:
    # fj1's fit reason ends "determined derived quantities: gross_stroke, net_stroke,
    # displacement", and the values printed below it were the diagnostic card's.
    well, entry = well_file(shared_raw, "fj1", tmp_path)
    main(["downhole", str(shared_raw / FOLDER / entry["card_csv"]), "--well", str(well),
          "--spm", f"{float(entry['spm']):g}"])
    text = capsys.readouterr().out
    why = next(line for line in text.splitlines() if "why not identified" in line)
    assert why.endswith("; the quantities below are the diagnostic pump card's")
