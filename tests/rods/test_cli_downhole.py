"""``pumpid downhole``: JSON shape, units, well matching, outputs, errors, and the pump
identified from each card (quantities with errors, damping, R^2; --no-identify, --damping)."""

from __future__ import annotations

import csv
import json
import re
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
    assert {k: full["card"][k] for k in ("id", "well")} == {"id": "card0", "well": "W-1"}
    assert full["card"]["warnings"] == [] and full["card"]["notes"]
    down = full["downhole"]
    assert down["units"] == {"position": "in", "load": "lbf"}
    assert len(down["position"]) == len(down["load"]) == 120
    assert down["convention"] == "effective"
    # the identified quantities, each with its error; the diagnostic card's own beside them
    for name in ("gross_stroke", "net_stroke", "fluid_load", "fillage", "displacement",
                 "intake_pressure"):
        entry = full["pump"][name]
        assert set(entry) == {"value", "stderr", "unit", "determined", "held"}
        if name == "fillage":  # a full pump's: its liquid fraction held at 1
            assert entry["held"] and entry["stderr"] is None and not entry["determined"]
            continue
        assert 0 < entry["stderr"] < 0.05 * abs(entry["value"]) and entry["determined"]
        assert set(down["pump"][name]) == {"value", "unit"}
    for name in ("upper_load_line", "lower_load_line"):  # measured on the diagnostic only
        assert full["pump"][name]["stderr"] is None
    assert full["pump"]["fillage"]["unit"] == "fraction"
    assert full["pump"]["fluid_load"]["value"] == pytest.approx(18000 / LBF, rel=0.02)
    assert pound["pump"]["fillage"]["value"] < full["pump"]["fillage"]["value"] - 0.2
    assert pound["pump"]["fillage"]["value"] == pytest.approx(0.7, abs=0.02)
    # the damping the card chose (made at 0.05), its error and rule; the diagnostic used it
    damping = full["damping"]
    assert set(damping) == {"value", "stderr", "unit", "rule"}
    assert damping["value"] == pytest.approx(0.05, rel=0.15) and damping["stderr"] > 0
    assert "identified from the card" in damping["rule"]
    assert down["damping"]["value"] == damping["value"]
    assert full["r2"] > 0.99 and -1 <= full["residual_autocorrelation"] <= 1
    ident = full["identification"]
    assert ident["status"] == "converged" and ident["used"] is True
    assert {"reason", "parameters", "agreement", "energy", "identifiability",
            "warnings"} <= set(ident)
    assert ident["parameters"]["fluid_load"]["unit"] == "lbf"
    assert ident["parameters"]["fluid_load"]["stderr"] > 0
    assert ident["agreement"] < 0.02 and ident["consistency"] < 0.01
    assert isinstance(ident["evaluations"], int) and ident["evaluations"] >= 3
    assert ident["energy"]["unit"] == "lbf*in" and ident["energy"]["pump_work"] > 0
    assert len(ident["pump_card"]["load"]) == len(ident["surface_fit"]["load"]) == 120
    summary = doc["summary"]
    assert summary["cards"] == 2 and summary["status"] == {"computed": 2}
    assert summary["identified"] == {"converged": 2}
    assert summary["damping"] == "identified per card" and "0.05" in summary["damping_rule"]


def test_a_single_well_applies_to_every_card_and_says_so(tmp_path: Path, surface,
                                                         capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface, ids=("W-1", "OTHER"))
    code, doc = run_json(capsys, str(cards), "--well", str(write_well(tmp_path / "w.json")),
                         "--spm", str(SPM), "--no-identify")
    assert code == 0
    first, second = doc["cards"]
    assert not any("differs" in n for n in first["notes"])
    assert any("'OTHER' differs from the well file's only well 'W-1'" in n
               for n in second["notes"])


def test_metric_card_with_us_well_file_is_converted(tmp_path: Path, surface, capsys) -> None:
    well = write_well(tmp_path / "well.json")
    _c, us = run_json(capsys, str(write_cards(tmp_path / "us.csv", surface)), "--well",
                      str(well), "--spm", str(SPM), "--card", "card1")
    _c, si = run_json(capsys, str(write_cards(tmp_path / "si.csv", surface, metric=True)),
                      "--well", str(well), "--spm", str(SPM), "--card", "card1")
    a, b = us["cards"][0], si["cards"][0]
    assert b["downhole"]["units"] == {"position": "m", "load": "kN"}
    assert b["downhole"]["pump"]["gross_stroke"]["value"] == pytest.approx(
        a["downhole"]["pump"]["gross_stroke"]["value"] * INCH, rel=1e-5)
    # the identification in either unit system: the same pump, its errors converted too
    assert b["pump"]["fluid_load"]["unit"] == "kN" and b["pump"]["fluid_load"]["stderr"] > 0
    for name, factor in (("fluid_load", LBF / 1000), ("gross_stroke", INCH),
                         ("fillage", 1.0)):
        assert b["pump"][name]["value"] == pytest.approx(
            a["pump"][name]["value"] * factor, rel=1e-3)
        assert b["pump"][name]["stderr"] == pytest.approx(
            a["pump"][name]["stderr"] * factor, rel=0.05)
    assert any("converted" in n for n in b["notes"])
    # The text says it too, without --verbose (it printed kN beside the well file's units
    # with the note in the JSON only).
    main(["downhole", str(tmp_path / "si.csv"), "--well", str(well), "--spm", str(SPM),
          "--card", "card1", "--no-identify"])
    text = " ".join(capsys.readouterr().out.split())
    assert ("note: the card is in m/kN and the well file in US units: converted, results in "
            "the card's units") in text


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


def test_reversed_card_is_said_and_identified(tmp_path: Path, surface, capsys) -> None:
    cards = write_cards(tmp_path / "rev.csv", surface, reverse=True)
    well = str(write_well(tmp_path / "w.json"))
    code = main(["downhole", str(cards), "--well", well, "--spm", str(SPM), "--card", "card1"])
    text = capsys.readouterr().out
    assert code == 0 and "reversed" in text and "reverse time order" in text
    # Said once, in one wording: the reader had said "fitted as given" and two notes
    # "fitted reversed" and "used reversed"; then its warning repeated the note and spoke of
    # a lumped fit this command does not run.
    assert text.count("it is taken as stored in reverse time order and used reversed; a "
                      "position measured downwards must be negated instead") == 1, text
    assert "fitted as given" not in text
    assert text.count("turns the wrong way") == 1 and "lumped fit" not in text, text
    code, doc = run_json(capsys, str(cards), "--well", well, "--spm", str(SPM), "--card",
                         "card1")
    got = doc["cards"][0]
    assert got["identification"]["status"] == "converged"
    # The damping's unit said one way (the identification's had read "1" beside it).
    assert got["identification"]["fitted_damping"]["unit"] == got["damping"]["unit"] == \
        got["downhole"]["damping"]["unit"] == "dimensionless (Gibbs' nu)"
    assert got["pump"]["fillage"]["value"] == pytest.approx(0.7, abs=0.02)
    # the fitted surface load comes back in the file's sample order, as the pump cards do
    measured = surface[1][1][::-1] / LBF
    fitted = np.array(got["identification"]["surface_fit"]["load"])
    assert np.sqrt(np.mean((fitted - measured) ** 2)) < 0.02 * np.ptp(measured)


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
    assert rows[0]["identification_status"] == "converged"
    assert float(rows[1]["pump_fillage_stderr"]) > 0 and float(rows[1]["r2"]) > 0.99
    assert (many / rows[1]["folder"] / "cards.png").is_file()
    with (one / "pump_card.csv").open(encoding="utf-8") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 120
    assert {"fitted_surface_load_lbf", "identified_pump_position_in",
            "identified_pump_load_lbf"} <= set(table[0])


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
    code, split = run_json(capsys, str(path), "--well", well, "--split-strokes",
                           "--no-identify")
    assert code == 0 and len(split["cards"]) >= 2
    assert all(c["pump"]["fillage"]["value"] < 0.85 for c in split["cards"])
    # A stroke by the id --split-strokes gives it, as pumpid fit takes it (it chose none).
    stroke = split["cards"][1]["card"]["id"]
    code, one = run_json(capsys, str(path), "--well", well, "--split-strokes",
                         "--no-identify", "--card", stroke)
    assert code == 0 and [c["card"]["id"] for c in one["cards"]] == [stroke]


def test_text_gives_each_quantity_with_its_error_the_damping_and_r2(tmp_path: Path, surface,
                                                                   capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--card", "card1"])
    text = capsys.readouterr().out
    assert code == 0
    assert "pump identified: converged, R^2 0.99" in text
    assert re.search(r"fluid load 40\d\d \+- [\d.]+ lbf", text)
    assert re.search(r"fillage 0\.(69|70)\d* \+- [\d.e-]+,", text)
    assert re.search(r"damping: identified from the card: nu = 0\.0[45]\d* \+- [\d.e-]+", text)
    assert "1 converged" in text


def test_no_identify_gives_the_diagnostic_only(tmp_path: Path, surface, capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    code, doc = run_json(capsys, str(cards), "--well", str(write_well(tmp_path / "w.json")),
                         "--spm", str(SPM), "--no-identify")
    assert code == 0
    for got in doc["cards"]:
        assert got["identification"] is None and got["r2"] is None
        assert got["residual_autocorrelation"] is None
        assert all(q["stderr"] is None for q in got["pump"].values())
        assert got["pump"]["fillage"]["value"] == got["downhole"]["pump"]["fillage"]["value"]
        assert got["damping"] == {"value": 0.05, "stderr": None,
                                  "unit": "dimensionless (Gibbs' nu)",
                                  "rule": "default rule: nu = 0.05 for every well"}
    assert doc["summary"]["identified"] is None and doc["summary"]["damping"] == 0.05


def test_a_negative_intake_pressure_is_said_without_verbose(tmp_path: Path, surface,
                                                            capsys) -> None:
    # A light fluid in the well file: the fluid load exceeds its column's, and the intake
    # pressure comes out below zero. The note that says so was printed only with --verbose,
    # while the number stood on its own in the default output.
    light = json.loads(json.dumps(WELL))
    light["wells"]["W-1"]["fluid"]["specific_gravity"] = 0.4
    cards = write_cards(tmp_path / "cards.csv", surface)
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json", light)),
                 "--spm", str(SPM), "--no-identify", "--card", "card1"])
    text = capsys.readouterr().out
    assert code == 0
    pressure = float(re.search(r"intake pressure (-?[0-9.]+) psi", text).group(1))
    assert pressure < 0
    assert "note: the pump intake pressure is negative" in text


def test_damping_given_is_held_in_the_identification(tmp_path: Path, surface,
                                                     capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    code, doc = run_json(capsys, str(cards), "--well", str(write_well(tmp_path / "w.json")),
                         "--spm", str(SPM), "--card", "card1", "--damping", "0.08")
    assert code == 0
    got = doc["cards"][0]
    assert got["damping"]["value"] == 0.08 and got["damping"]["stderr"] is None
    assert got["damping"]["rule"].startswith("given")
    assert got["downhole"]["damping"]["value"] == 0.08
    ident = got["identification"]
    assert ident["parameters"]["damping"]["value"] == 0.08
    assert ident["parameters"]["damping"]["stderr"] is None  # held, not fitted
    assert got["pump"]["fluid_load"]["stderr"] > 0


def test_damping_zero_is_the_undamped_diagnostic_and_says_why(tmp_path: Path, surface,
                                                             capsys) -> None:
    cards = write_cards(tmp_path / "cards.csv", surface)
    code, doc = run_json(capsys, str(cards), "--well", str(write_well(tmp_path / "w.json")),
                         "--spm", str(SPM), "--damping", "0")
    assert code == 0
    for got in doc["cards"]:
        assert got["status"] == "computed" and got["identification"] is None
        assert got["downhole"]["damping"]["value"] == 0.0
        assert any("needs some damping" in n for n in got["notes"])
    assert "needs some damping" in doc["summary"]["identification"]


def test_card_that_cannot_be_identified_keeps_its_diagnostic(tmp_path: Path, surface,
                                                             capsys) -> None:
    # the full pump's loads against the motion half a stroke away, in reverse: a loop no rod
    # string and pump make from this motion; diagnosed, not identified
    s, loads = surface
    odd = np.roll(loads[0][::-1], -s.size // 2)
    cards = write_cards(tmp_path / "odd.csv", (s, odd[None]), ids=("W-1",))
    out = tmp_path / "out"
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 5  # every card computed, its identification poor (as pumpid fit's 5)
    assert "pump not identified (poor-fit, R^2" in text and "diagnostic pump card" in text
    got = json.loads((out / "downhole.json").read_text(encoding="utf-8"))
    assert got["status"] == "computed"
    ident = got["identification"]
    assert ident["status"] == "poor-fit" and ident["used"] is False and ident["reason"]
    assert got["r2"] < 0.95
    # the outputs are the diagnostic card's, at the default rule's damping, said so
    assert all(q["stderr"] is None for q in got["pump"].values())
    assert got["pump"]["fillage"]["value"] == got["downhole"]["pump"]["fillage"]["value"]
    assert got["damping"]["value"] == 0.05 and got["damping"]["stderr"] is None
    assert "default rule" in got["damping"]["rule"] and "poor-fit" in got["damping"]["rule"]
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "not used" in page and 'diagnostic pump card <span class="muted">(used)' in page


def test_an_identification_that_breaks_does_not_stop_the_run(tmp_path: Path, surface, capsys,
                                                            monkeypatch) -> None:
    import pumpid.cli.downhole as downhole

    def broken(*args, **kwargs):
        raise RuntimeError("simulated defect")

    monkeypatch.setattr(downhole, "identify_cards", broken)
    cards = write_cards(tmp_path / "cards.csv", surface)
    code, doc = run_json(capsys, str(cards), "--well", str(write_well(tmp_path / "w.json")),
                         "--spm", str(SPM))
    assert code == 3  # some identifications failed
    for got in doc["cards"]:
        assert got["status"] == "computed" and got["downhole"]["pump"]["fillage"]["value"]
        assert got["identification"]["status"] == "failed"
        assert "simulated defect" in got["identification"]["reason"]
        assert "default rule" in got["damping"]["rule"] and got["damping"]["value"] == 0.05


def test_true_loads_say_why_the_pump_cards_are_not_compared(tmp_path: Path, surface,
                                                            capsys) -> None:
    # Every other mode prints the fitted-against-diagnostic comparison; with true loads it
    # was missing without a word.
    cards = write_cards(tmp_path / "cards.csv", surface)
    well = str(write_well(tmp_path / "w.json"))
    code = main(["downhole", str(cards), "--well", well, "--spm", str(SPM), "--card", "card1",
                 "--convention", "true"])
    text = capsys.readouterr().out
    assert code == 0 and "pump cards not compared: the diagnostic card is in true loads" in text
    # The identified card is in effective loads: it was written as if in true ones.
    out = tmp_path / "out"
    main(["downhole", str(cards), "--well", well, "--spm", str(SPM), "--card", "card1",
          "--convention", "true", "--out", str(out), "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert doc["cards"][0]["identification"]["pump_card"]["convention"] == "effective"
    head = (out / "pump_card.csv").read_text(encoding="utf-8").splitlines()[0]
    assert "identified_effective_pump_load_lbf" in head and "pump_load_lbf" in head
    # The caption promised the diagnostic card beneath the identified one.
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "in effective loads and alone: the diagnostic card is in true loads" in page
    code = main(["downhole", str(cards), "--well", well, "--spm", str(SPM), "--card", "card1"])
    text = capsys.readouterr().out
    assert code == 0 and "fitted and diagnostic pump cards differ by RMS" in text


def test_the_readers_warnings_are_given(tmp_path: Path, surface, capsys) -> None:
    # Position and load columns swapped by their headers: the reader warned, downhole said
    # nothing and gave a plunger stroke of tens of metres, exit 0.
    s, loads = surface
    path = tmp_path / "swapped.csv"
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["card_id", "well_id", "load_lbf", "position_in"])
        for a, b in zip(s / INCH, loads[0] / LBF, strict=True):
            w.writerow(["card0", "W-1", f"{a:.6f}", f"{b:.4f}"])
    well = write_well(tmp_path / "well.json")
    main(["downhole", str(path), "--well", str(well), "--spm", str(SPM), "--no-identify"])
    out = capsys.readouterr().out
    assert re.search(r"\n  warning: .*swapped", out)
    _, doc = run_json(capsys, str(path), "--well", str(well), "--spm", str(SPM),
                      "--no-identify")
    assert any("swapped" in w for w in doc["cards"][0]["card"]["warnings"])


def test_a_rate_given_over_the_cards_own_is_a_warning(tmp_path: Path, surface,
                                                      capsys) -> None:
    # --spm 4 over a card file's own 8 SPM halved the displacement, said only in a note
    # under --verbose.
    s, loads = surface
    path = tmp_path / "card.json"
    path.write_text(json.dumps({"card_id": "c", "well_id": "W-1", "spm": SPM,
                                "position": (s / INCH).tolist(),
                                "load": (loads[0] / LBF).tolist(),
                                "position_unit": "in", "load_unit": "lbf"}),
                    encoding="utf-8")
    well = write_well(tmp_path / "well.json")
    main(["downhole", str(path), "--well", str(well), "--spm", "4", "--no-identify"])
    out = capsys.readouterr().out
    assert "warning: the card's time is rebuilt from the stroke rate given (4 SPM), not " \
           "from the file's own (8 SPM" in out
    main(["downhole", str(path), "--well", str(well), "--spm", str(SPM), "--no-identify"])
    assert "warning" not in capsys.readouterr().out


def test_a_card_without_fluid_load_gives_no_fillage(tmp_path: Path, surface, capsys) -> None:
    # A damping far too high leaves the pump card no fluid load: "fillage 1" and an intake
    # pressure above the discharge pressure were printed, the note only under --verbose.
    cards = write_cards(tmp_path / "cards.csv", surface)
    well = str(write_well(tmp_path / "w.json"))
    main(["downhole", str(cards), "--well", well, "--spm", str(SPM), "--no-identify",
          "--card", "card0", "--damping", "5"])
    text = capsys.readouterr().out
    assert "fluid load -" in text and "fillage" not in text.split("note:")[0]
    assert "note: the pump card has no fluid load" in text
    _, doc = run_json(capsys, str(cards), "--well", well, "--spm", str(SPM), "--no-identify",
                      "--card", "card0", "--damping", "5")
    pump = doc["cards"][0]["pump"]
    assert all(pump[q]["value"] is None
               for q in ("fillage", "net_stroke", "displacement", "intake_pressure"))
    # Its figure too (the transfer point was drawn at fillage x stroke: a crash, exit 2).
    assert main(["downhole", str(cards), "--well", well, "--spm", str(SPM), "--no-identify",
                 "--card", "card0", "--damping", "5", "--out", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    assert (tmp_path / "out" / "cards.png").is_file()


def test_loads_below_the_rods_weight_are_said(tmp_path: Path, surface, capsys) -> None:
    # Loads in lbf read as N: the pump card's load lines sat far below zero, its fillage
    # and displacement plausible, without a word.
    cards = write_cards(tmp_path / "cards.csv", surface)
    wrong = tmp_path / "wrong.csv"
    wrong.write_text(cards.read_text().replace("load_lbf", "load_N"), encoding="utf-8")
    main(["downhole", str(wrong), "--well", str(write_well(tmp_path / "w.json")), "--spm",
          str(SPM), "--no-identify", "--card", "card0"])
    assert "note: the card's largest load is below the rods' weight in the fluid" in \
        capsys.readouterr().out


def test_the_text_says_the_stroke_every_rate_rests_on(tmp_path: Path, surface,
                                                      capsys) -> None:
    # A time column in milliseconds read as seconds gave a displacement a thousand times
    # too small, with the stroke's period only in the JSON.
    cards = write_cards(tmp_path / "cards.csv", surface)
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--no-identify"])
    out = capsys.readouterr().out
    assert code == 0
    assert out.count("stroke 7.5 s = 8 strokes/min from the stroke rate") == 2, out


def test_the_free_tubings_stretch_is_said_without_verbose(tmp_path: Path, surface,
                                                          capsys) -> None:
    # Free tubing of known size took 0.15 m off the net stroke, said only under --verbose.
    doc = json.loads(json.dumps(WELL))
    doc["wells"]["W-1"]["tubing"] = {"anchored": False, "outer_diameter": 2.875,
                                     "inner_diameter": 2.441}
    cards = write_cards(tmp_path / "cards.csv", surface)
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json", doc)),
                 "--spm", str(SPM), "--no-identify", "--card", "card0"])
    out = capsys.readouterr().out
    assert code == 0 and "note: net stroke less the free tubing's stretch under the fluid " \
                         "load" in out, out


def test_the_padding_dropped_is_said_without_verbose(tmp_path: Path, surface, capsys) -> None:
    # A card that lost a fifth of its samples as padding said so only under --verbose.
    cards = write_cards(tmp_path / "cards.csv", surface, ids=("W-1",))
    lines = cards.read_text(encoding="utf-8").splitlines()
    lines += ["card0,W-1,0.000000,0.0000"] * 30
    cards.write_text("\n".join(lines) + "\n", encoding="utf-8")
    code = main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--no-identify"])
    out = capsys.readouterr().out
    assert code == 0 and "note: padding dropped: the last 30 of 150 samples" in out, out
    assert "note: load unit" not in out  # the other reading notes: --verbose


def test_the_well_files_assumptions_are_said_in_the_text(tmp_path: Path, surface,
                                                         capsys) -> None:
    # A well file without tubing, a material whose density is replaced, and rods listed
    # from the bottom: the JSON said the first two, the terminal none, and nothing said the
    # third (it changes the identification).
    doc = json.loads(json.dumps(WELL))
    well = doc["wells"]["W-1"]
    del well["tubing"]
    well["rods"] = well["rods"][::-1]
    well["rods"][0]["density"] = 7850
    doc["units"]["density"] = "kg/m3"
    cards = write_cards(tmp_path / "c.csv", surface)
    main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json", doc)),
          "--spm", str(SPM), "--card", "card0", "--no-identify"])
    text = capsys.readouterr().out
    assert "no tubing entry: the tubing is taken as anchored" in text
    assert "the given density replaces that of steel" in text
    assert "rods[1] is thicker than rods[0] above it" in text and "from the bottom" in text


def test_a_parquet_card_file_gives_the_csv_files_answer(tmp_path: Path, surface,
                                                        capsys) -> None:
    # The same card from the Parquet long layout pumpid batch reads: the same pump card;
    # a bad card in it stops the file with its reason, as from a text file.
    import pandas as pd

    cards = write_cards(tmp_path / "cards.csv", surface)
    table = pd.read_csv(cards)
    table["sample"] = table.groupby("card_id").cumcount()
    long = table.rename(columns={"position_in": "position", "load_lbf": "load"}).assign(
        position_unit="in", load_unit="lbf", spm=SPM)
    long.to_parquet(tmp_path / "cards.parquet", index=False)
    well = str(write_well(tmp_path / "well.json"))
    _, from_csv = run_json(capsys, str(cards), "--well", well, "--spm", str(SPM), "--card",
                           "card1", "--no-identify")
    _, from_parquet = run_json(capsys, str(tmp_path / "cards.parquet"), "--well", well,
                               "--card", "card1", "--no-identify")
    a, b = from_csv["cards"][0], from_parquet["cards"][0]
    assert b["status"] == a["status"] == "computed"
    for name, q in a["pump"].items():
        assert b["pump"][name]["value"] == pytest.approx(q["value"], rel=1e-9), name
    long.loc[long.index[3], "load"] = float("nan")
    long.to_parquet(tmp_path / "bad.parquet", index=False)
    code, doc = run_json(capsys, str(tmp_path / "bad.parquet"), "--well", well, "--card",
                         "card1", "--no-identify")
    assert code == 2 and "NaN value in load" in json.dumps(doc)
