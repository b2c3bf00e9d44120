"""The pumpid command: a thin shell over the API."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pumpid
from pumpid.cli import main

from ..conftest import well_load
from .conftest import cli_env


def _write_record(path: Path, **cols: np.ndarray) -> Path:
    names = list(cols)
    rows = np.column_stack([cols[n] for n in names])
    path.write_text(",".join(names) + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                                       for r in rows) + "\n")
    return path


def test_a_command_fits_a_card_without_the_heavy_scipy_modules() -> None:
    # scipy.signal's import was half a second of every command's start (0.55 of import
    # pumpid's 1.13 s), scipy.stats' about a third of one: a card's fit whose robust errors
    # are shown (the AR(1) floor filtered with scipy.signal) needs neither.
    code = ("import sys, pumpid, pumpid.cli.main; from pumpid.cards import read_cards; "
            "from importlib import resources; "
            "card = str(resources.files('pumpid') / 'data' / 'example_cards.csv'); "
            "r = pumpid.fit(pumpid.Kelvin, read_cards(card)[0]); "
            "assert r.errors_shown == 'robust', r.errors_shown; "
            "sys.exit(sorted({'scipy.signal', 'scipy.stats'} & set(sys.modules)) or 0)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0, done.stderr


def test_reproduce_json(capsys) -> None:
    assert main(["reproduce", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["table1"]["paper_mode"]["tau"] == pytest.approx(5.005001666667, rel=1e-11)
    assert out["table1"]["exact"]["tau"] == pytest.approx(5.0, rel=1e-9)
    assert out["table2"]["paper_mode"]["D"] == pytest.approx(0.0, abs=1e-9)
    assert set(out["table3"]["paper_mode"]) >= {"m", "c", "k", "C", "iterations"}
    assert out["table3"]["exact"]["m"] == pytest.approx(9.88, rel=1e-3)


def test_reproduce_text(capsys) -> None:
    assert main(["reproduce"]) == 0
    text = capsys.readouterr().out
    assert "Table 1" in text and "5.005001666667" in text and "tau [s]" in text


def test_simulate_then_fit_round_trip(tmp_path, capsys) -> None:
    t = np.linspace(0, 20, 801)
    load = 10 + 3 * np.sin(0.9 * t) + np.sin(2.3 * t)
    _write_record(tmp_path / "load.csv", t=t, load=load)
    out = tmp_path / "sim.csv"
    assert main(["simulate", str(tmp_path / "load.csv"), "--model", "kelvin",
                 "-p", "k0=4,m=1,c1=2", "-p", "k1=4", "-o", str(out)]) == 0
    sim = np.genfromtxt(out, delimiter=",", names=True)
    expected = pumpid.simulate(pumpid.Kelvin(k0=4, m=1, c1=2, k1=4), t, load)
    np.testing.assert_allclose(sim["displacement"], expected, rtol=1e-12)
    assert main(["fit", str(out), "--model", "kelvin", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) == {"cards", "summary"} and len(doc["cards"]) == 1
    res = doc["cards"][0]
    for key in ("model", "method", "params", "scale", "converged", "iterations", "rmse", "r2",
                "warnings"):
        assert key in res
    assert res["converged"] and res["model"] == "Kelvin" and res["method"] == "lm"
    assert res["params"]["m"] == pytest.approx(1.0, rel=1e-6)
    assert main(["fit", str(out), "--method", "newton-fd", "--x0", "k0=4.1,m=1.02,c1=1.95,k1=4",
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["cards"][0]
    assert res["method"] == "newton-fd" and res["converged"]


def test_fit_text_output_has_units(tmp_path, capsys) -> None:
    t = np.linspace(0, 20, 801)
    load = 10 + 3 * np.sin(0.9 * t)
    disp = pumpid.simulate(pumpid.MassSpringDamper(m=1, c=0.8, k=3), t, load)
    path = _write_record(tmp_path / "rec.csv", t=t, load_lbf=load, displacement_in=disp)
    assert main(["fit", str(path), "--model", "msd"]) == 0
    text = capsys.readouterr().out
    assert "lbf*s^2/in" in text and "R^2" in text


def test_fit_writes_report(tmp_path, capsys) -> None:
    assert main(["demo", "--out", str(tmp_path / "demo")]) == 0
    assert (tmp_path / "demo" / "report.html").stat().st_size > 10_000
    data = json.loads((tmp_path / "demo" / "result.json").read_text())
    assert data["converged"]


def test_errors_exit_2_with_a_message(tmp_path, capsys) -> None:
    assert main(["fit", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("t,load,displacement\n0,1,2\n")
    assert main(["fit", str(bad)]) == 2
    assert "error" in capsys.readouterr().err
    assert main(["simulate", str(bad), "-p", "k0=1"]) == 2
    assert "missing" in capsys.readouterr().err


def test_split_strokes_fits_each_stroke(tmp_path, capsys) -> None:
    period, n_strokes = 6.0, 3
    t1 = np.arange(0, period, 0.05)
    load1 = 8000 + 2500 * np.sin(2 * np.pi * t1 / period) + 400 * np.sin(6 * np.pi * t1 / period)
    model = pumpid.Kelvin(k0=200, m=3, c1=40, k1=120)
    pos1 = pumpid.simulate(model, t1, load1, observe="u", initial_state="periodic") + 40
    t = np.arange(n_strokes * t1.size) * 0.05
    load, pos = np.tile(load1, n_strokes), np.tile(pos1, n_strokes)
    path = _write_record(tmp_path / "multi.csv", t=t, load_lbf=load, position_in=pos)
    assert main(["fit", str(path), "--split-strokes", "--observe", "u", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["cards"]) >= 2
    for res in out["cards"]:
        assert res["initial_state"] == "periodic" and res["r2"] > 0.999


def _noisy_record(path: Path, rho: float) -> Path:
    t = np.linspace(0, 20, 401)
    load = 10 + 3 * np.sin(0.9 * t) + np.sin(2.3 * t)
    disp = pumpid.simulate(pumpid.MassSpringDamper(m=1, c=0.8, k=3), t, load)
    rng = np.random.default_rng(3)
    noise = np.empty(t.size)
    noise[0] = rng.standard_normal()
    for i in range(1, t.size):
        noise[i] = rho * noise[i - 1] + np.sqrt(1 - rho**2) * rng.standard_normal()
    return _write_record(path, t=t, load_lbf=load, displacement_in=disp + 0.01 * noise)


def test_the_text_says_which_errors_the_plus_minus_are(tmp_path, capsys) -> None:
    # The ± shown on a card with serially correlated residuals are the robust errors: the
    # card says so (the first sentence of the whiteness warning alone did not), and the
    # run's header no longer says that every ± assumes independent residuals.
    assert main(["fit", str(_noisy_record(tmp_path / "ar.csv", 0.9)), "--model", "msd"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "± robust: residuals serially correlated (lag-1 0." in text
    assert "assuming independence," in text and "x smaller" in text
    assert "± is one standard error assuming independent residuals" not in text
    assert main(["fit", str(_noisy_record(tmp_path / "white.csv", 0.0)), "--model", "msd"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "± robust" not in text and "± is one standard error" in text


@pytest.mark.realdata
def test_no_robust_line_where_no_value_has_an_error_shown(shared_raw, capsys) -> None:
    # Sandia's first downhole stroke: every value undetermined (the fit reproduces only the
    # fundamental), so no ± is printed; "± robust: ... (lag-1 1)" said what none of them
    # were, with a lag-1 of 0.995 rounded to 1.
    record = shared_raw / "sandia_dds" / "downhole_timeseries.csv"
    main(["fit", str(record), "--split-strokes"])
    blocks = capsys.readouterr().out.split("\n3X6E03#")
    first = next(b for b in blocks if b.startswith("0 "))
    assert "undetermined" in first and " ± " not in first.split("derived:")[0]
    assert "± robust" not in first
    robust = [ln for ln in "\n".join(blocks).splitlines() if "± robust" in ln]
    assert robust and all(re.search(r"\(lag-1 -?\d\.\d\d\)", ln) for ln in robust)


@pytest.mark.realdata
def test_an_offset_the_card_does_not_fix_is_flagged_in_the_short_output(shared_raw,
                                                                       capsys) -> None:
    # A field card whose static stiffness runs to zero: the offset (-1e8 ± 2e13 m) trades
    # off with it. The JSON listed it as not determined; the short and brief outputs
    # printed it unmarked beside a flagged m.
    # Its error, too, was the level's (the position at the mean load), which the card does
    # fix: "offset = 2.49 ± 1.3 m (not determined)". The offset's own error is unbounded.
    card = str(shared_raw / "cmcm2012_rod_pump" / "fj1_surface_card.csv")
    main(["fit", card, "--spm", "5", "--json"])
    doc = json.loads(capsys.readouterr().out)["cards"][0]
    assert "offset" in doc["determined"]["not_determined"]
    assert doc["stderr"]["offset"] is None and doc["ci95"]["offset"] is None
    assert doc["stderr_white"]["offset"] is None
    main(["fit", card, "--spm", "5"])
    text = " ".join(capsys.readouterr().out.split())
    assert re.search(r"offset = \S+ m \(not determined\)", text), text
    main(["fit", card, "--spm", "5", "--brief"])
    line = capsys.readouterr().out.splitlines()[-2]
    assert any(f.startswith("offset=") and f.endswith("(not determined)")
               for f in line.split("\t")), line


@pytest.mark.realdata
def test_the_warning_and_the_robust_line_give_one_widening(shared_raw, capsys) -> None:
    # A Sandia card said "72-80x smaller" on one line and "about 6.5 times wider" in its
    # warning: the warning now gives the errors shown against the independent-noise ones.
    main(["fit", str(shared_raw / "sandia_dds" / "surface_cards.csv"), "--card", "SX6E03A",
          "--verbose"])
    verbose = " ".join(capsys.readouterr().out.split())
    main(["fit", str(shared_raw / "sandia_dds" / "surface_cards.csv"), "--card", "SX6E03A"])
    short = " ".join(capsys.readouterr().out.split())
    line = re.search(r"assuming independence, ([0-9.-]+)x smaller", short)
    said = re.search(r"ci95_hac\), ([0-9.-]+)x the independent-noise ones", verbose)
    assert line and said and line.group(1) == said.group(1), (short, verbose)


def test_a_card_too_short_to_test_says_why_its_errors_are_robust(tmp_path, capsys) -> None:
    # 30 samples of white noise: the serial test cannot tell, so the robust errors are
    # shown; the short output said "residuals serially correlated" of every robust card.
    period = 7.5
    truth = pumpid.Kelvin(k0=400.0, m=5.0, c1=40.0, k1=80.0)
    t = np.arange(30) * period / 30
    load = well_load(t, period=period, seed=3)
    clean = pumpid.simulate(truth, t, load, initial_state="periodic", period=period)
    noisy = clean + 0.01 * np.ptp(clean) * np.random.default_rng(2).standard_normal(t.size)
    path = tmp_path / "short.csv"
    np.savetxt(path, np.column_stack([t, load, noisy]), delimiter=",",
               header="t,load,position", comments="")
    main(["fit", str(path), "--period", "7.5", "--out", str(tmp_path / "out")])
    out = " ".join(capsys.readouterr().out.split())
    assert "± robust: 30 samples, too few to test the residuals' independence" in out
    assert "residuals serially correlated (lag-1" not in out
    assert "serially correlated or too few to test (the card says so)" in out
    # The HTML report raises no whiteness warning here: its table says why instead.
    page = (tmp_path / "out" / "report.html").read_text()
    assert "the card's 30 samples are too few for a test of the residuals' independence" in page


def test_python_m_pumpid_is_the_command() -> None:
    # "No module named pumpid.__main__": README named python -m pumpid.cli, and users tried
    # the package's own name first.
    run = subprocess.run([sys.executable, "-m", "pumpid", "--version"], env=cli_env(),
                         capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0 and run.stdout.startswith("pumpid "), run.stderr


def test_simulate_reads_the_columns_fit_reads(tmp_path, capsys) -> None:
    # pumpid fit read t_s and load_lbf from their names; simulate refused them ("no column
    # 't'") and wrote t,load without their units.
    t = np.linspace(0, 20, 401)
    load = 10 + 3 * np.sin(0.9 * t)
    (tmp_path / "named.csv").write_text("time_ms,load_lbf\n" + "".join(
        f"{1000 * float(a)!r},{float(b)!r}\n" for a, b in zip(t, load, strict=True)))
    out = tmp_path / "sim.csv"
    assert main(["simulate", str(tmp_path / "named.csv"), "-p", "k0=4,m=1,c1=2,k1=4",
                 "-o", str(out)]) == 0
    assert out.read_text().startswith("t_s,load_lbf,displacement\n")
    sim = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_allclose(sim["t_s"], t, rtol=1e-12)
    expected = pumpid.simulate(pumpid.Kelvin(k0=4, m=1, c1=2, k1=4), t, load)
    np.testing.assert_allclose(sim["displacement"], expected, rtol=1e-12)
    (tmp_path / "other.csv").write_text("a,b\n0,1\n1,2\n")
    assert main(["simulate", str(tmp_path / "other.csv"), "-p", "k0=4,m=1,c1=2,k1=4"]) == 2
    assert "no column 't'" in capsys.readouterr().err
    (tmp_path / "two.csv").write_text("t_s,load_kN,load_lbf\n0,1,2\n1,2,3\n2,3,4\n")
    assert main(["simulate", str(tmp_path / "two.csv"), "-p", "k0=4,m=1,c1=2,k1=4"]) == 2
    assert "'load_kN', 'load_lbf' all read as load; name one with --load-col" in \
        capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "two.csv"), "-p", "k0=4,m=1,c1=2,k1=4",
                 "--load-col", "t_s"]) == 2
    assert "name the same column 't_s'" in capsys.readouterr().err
