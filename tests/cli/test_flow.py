"""The ``pumpid flow`` commands on a parser of their own (as the main parser registers them)."""

from __future__ import annotations

import argparse
import json

import pytest

from pumpid.cli.flow import add_flow_parser
from pumpid.flow.pipeflow import Pipe, PowerLawFluid, newtonian_slowest_time_constant

FLUID = ["--K", "10", "--rho", "1000", "--radius", "5e-3", "--length", "1"]


def run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="pumpid")
    sub = parser.add_subparsers(dest="command", required=True)
    add_flow_parser(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


def test_simulate_then_fit_json_round_trip(tmp_path, capsys):
    out = tmp_path / "newtonian.csv"
    assert run(["flow", "simulate", *FLUID, "--n", "1", "--dp", "1e5", "--samples", "201",
                "-o", str(out)]) == 0
    assert out.read_text().splitlines()[0] == "t [s],dp [Pa],q [m^3/s]"
    capsys.readouterr()
    assert run(["flow", "fit", str(out), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    for key in ("model", "method", "params", "scale", "converged", "iterations", "rmse", "r2",
                "warnings"):
        assert key in obj
    assert obj["model"] == "FirstOrderLag" and obj["converged"] is True
    assert obj["units"]["params"] == {"tau": "s", "gain": "(m^3/s)/(Pa)"}
    # A derived unit brackets the compound one too (it read "Pa/m^3/s"), and its meaning is
    # a pipe's, not a rod-pumped well's ("load per unit displacement").
    assert obj["derived"]["static_stiffness"]["unit"] == "Pa/(m^3/s)"
    assert "hydraulic resistance" in obj["derived"]["static_stiffness"]["meaning"]
    assert run(["flow", "fit", str(out), "--out", str(tmp_path / "report")]) == 0
    html = (tmp_path / "report" / "report.html").read_text(encoding="utf-8")
    assert "static_stiffness" in html and "property of the well" not in html
    tau1 = newtonian_slowest_time_constant(10.0, 1000.0, Pipe(5e-3, 1.0))
    assert 0.9 * tau1 < obj["params"]["tau"] < tau1
    assert obj["r2"] > 0.999
    assert obj["flow"]["direction"] == "dp->q"


def test_fit_text_table_and_report_folder(tmp_path, capsys):
    out = tmp_path / "shear.csv"
    assert run(["flow", "simulate", *FLUID, "--n", "0.4", "--dp", "2e5", "--samples", "151",
                "--n-radial", "80", "-o", str(out)]) == 0
    capsys.readouterr()
    report = tmp_path / "report"
    assert run(["flow", "fit", str(out), "--model", "shear-thinning", "--fix", "n=0.4",
                "--out", str(report)]) == 0
    text = capsys.readouterr().out
    assert "tau" in text and " s" in text and "(m^3/s)/(Pa)" in text and "R^2 =" in text
    assert "(fixed)" in text
    for name in ("report.html", "result.json", "flow.png", "characteristic.png"):
        assert (report / name).is_file()
    html = (report / "report.html").read_text(encoding="utf-8")
    assert "pressure drop in, flow rate out" in html


def test_fit_reverse_direction_and_units(tmp_path, capsys):
    path = tmp_path / "lpm.csv"
    rows = ["t,dp,q"] + [f"{0.1 * i:.1f},{0 if i == 0 else 2.0},{(1 - 0.5 ** i) * 30:.12g}"
                         for i in range(30)]
    path.write_text("\n".join(rows) + "\n")
    assert run(["flow", "fit", str(path), "--dp-unit", "bar", "--q-unit", "L/min",
                "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["params"]["gain"] == pytest.approx(30 / 6e4 / 2e5, rel=0.05)
    assert any("bar to Pa" in n for n in obj["flow"]["notes"])


def test_study_command_writes_plot_and_table(tmp_path, capsys):
    out = tmp_path / "study"
    assert run(["flow", "study", *FLUID, "--n", "0.4", "--steps", "0.5,1,2", "--samples", "151",
                "--n-radial", "60", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "log-log slope of tau_linear vs dp" in text
    for name in ("tau_vs_step.png", "study.csv", "study.json", "report.html"):
        assert (out / name).is_file()


def test_errors_are_value_errors(tmp_path):
    with pytest.raises(ValueError, match="either --dp"):
        run(["flow", "simulate", *FLUID])
    with pytest.raises(ValueError, match="no such file"):
        run(["flow", "fit", str(tmp_path / "nope.csv")])
    with pytest.raises(ValueError, match="--steps"):
        run(["flow", "study", *FLUID, "--steps", "1"])
    with pytest.raises(SystemExit):
        run(["flow", "fit", "x.csv", "--model", "kelvin"])
    assert PowerLawFluid(K=1, n=1, rho=1)  # constructor used by the commands


def test_no_better_solution_is_claimed_at_the_same_cost(tmp_path, capsys):
    # "the fit from the given guess looked wrong ...; the automatic multistart found a better
    # solution (cost 1.98183e-09 -> 1.98183e-09)": no guess was given, and no cost changed.
    out = tmp_path / "rec.csv"
    assert run(["flow", "simulate", *FLUID, "--n", "0.4", "--dp", "1e5", "-o", str(out)]) == 0
    capsys.readouterr()
    assert run(["flow", "fit", str(out), "--json"]) == 0
    warnings = json.loads(capsys.readouterr().out)["warnings"]
    assert not any("better solution" in w for w in warnings), warnings


def _start_up(path, noise: float, seed: int = 0, delay: float = 0.0) -> None:
    """A step of 1e5 Pa from t = 0, the flow rising from rest (tau 2 s), with noise."""
    import numpy as np

    t = np.linspace(0.0, 15.0, 301)
    q = 3e-4 * (1.0 - np.exp(-np.clip(t - delay, 0.0, None) / 2.0))
    q = q + noise * 3e-4 * np.random.default_rng(seed).standard_normal(t.size)
    rows = "".join(f"{a:.17g},100000.0,{b:.17g}\n" for a, b in zip(t, q, strict=True))
    path.write_text("t,dp,q\n" + rows, encoding="utf-8")


def test_a_noisy_start_up_from_rest_is_fitted_from_rest(tmp_path, capsys):
    # With 0.1-1 % noise its first flow is not 1e-6 of the largest: it was refused ("carries
    # no information on the dynamics") or fitted from an equilibrium (R^2 0.0003).
    path = tmp_path / "start.csv"
    _start_up(path, noise=0.01)
    assert run(["flow", "fit", str(path), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["params"]["tau"] == pytest.approx(2.0, rel=0.05) and obj["r2"] > 0.99


def test_a_poor_flow_fit_exits_as_every_command_does(tmp_path, capsys):
    # A dead time the first-order model cannot follow: poor-fit, which exited 3 ("failed").
    path = tmp_path / "delay.csv"
    _start_up(path, noise=0.0, delay=3.0)
    assert run(["flow", "fit", str(path), "--out", str(tmp_path / "out")]) == 5
    capsys.readouterr()
    # The cost of a flow fit is in (m^3/s)^2 (it read "m^3/s^2").
    obj = json.loads((tmp_path / "out" / "result.json").read_text(encoding="utf-8"))
    assert obj["uncertainty"]["sigma2_unit"] == "(m^3/s)^2"


def test_simulate_reads_the_time_unit_and_refuses_what_it_cannot_use(tmp_path, capsys):
    # A history in ms was read as seconds; --t-end 0 took the default; --steps 1,1 fitted a
    # slope through one abscissa.
    hist = tmp_path / "hist.csv"
    hist.write_text("t [ms],dp [kPa]\n" + "".join(f"{k * 10},{100 if k else 0}\n"
                                                   for k in range(31)), encoding="utf-8")
    out = tmp_path / "rec.csv"
    assert run(["flow", "simulate", *FLUID, "--n", "1", "--dp-file", str(hist), "-o",
                str(out)]) == 0
    last = out.read_text(encoding="utf-8").splitlines()[-1]
    assert float(last.split(",")[0]) == pytest.approx(0.3)
    with pytest.raises(ValueError, match="--t-end must be positive"):
        run(["flow", "simulate", *FLUID, "--dp", "1e5", "--t-end", "0"])
    with pytest.raises(ValueError, match="two different positive factors"):
        run(["flow", "study", *FLUID, "--steps", "1,1"])


def test_a_magnitude_refusal_has_no_template_in_it(tmp_path):
    # "natural size (({position})/({pressure drop dp [Pa]}))" reached the user.
    import numpy as np

    t = np.linspace(0.0, 15.0, 301)
    q = 3e-304 * (1.0 - np.exp(-t / 2.0))
    rows = "".join(f"{a:.17g},100000.0,{b:.17g}\n" for a, b in zip(t, q, strict=True))
    path = tmp_path / "tiny.csv"
    path.write_text("t,dp,q\n" + rows, encoding="utf-8")
    with pytest.raises(ValueError) as info:
        run(["flow", "fit", str(path)])
    assert "rescale" in str(info.value) and "{" not in str(info.value)


def test_a_bad_fluid_or_pipe_is_named_by_its_option():
    # "PowerLawFluid.K (consistency) must be positive" named the class, not the option.
    with pytest.raises(ValueError, match=r"^--K \(consistency\) must be positive"):
        run(["flow", "simulate", "--K=-1", "--rho", "1000", "--radius", "5e-3",
             "--length", "1", "--dp", "1e5"])
    with pytest.raises(ValueError, match=r"^--radius must be positive"):
        run(["flow", "simulate", "--K", "10", "--rho", "1000", "--radius=-5e-3",
             "--length", "1", "--dp", "1e5"])


def test_a_negative_value_in_exponent_notation_follows_its_option(tmp_path, capsys):
    # "--dp -1e5" was refused ("expected one argument": argparse reads -1e5 as an option);
    # the pumpid command reads it as --dp=-1e5.
    from pumpid.cli import main

    spaced, joined = tmp_path / "spaced.csv", tmp_path / "joined.csv"
    assert main(["flow", "simulate", *FLUID, "--n", "1", "--dp", "-1e5", "--samples", "51",
                 "-o", str(spaced)]) == 0
    assert main(["flow", "simulate", *FLUID, "--n", "1", "--dp=-1e5", "--samples", "51",
                 "-o", str(joined)]) == 0
    assert spaced.read_text() == joined.read_text()
    assert float(spaced.read_text().splitlines()[1].split(",")[1]) == -1e5
    # An option's value that is not a number is left to argparse as before.
    assert main(["flow", "simulate", *FLUID, "--dp", "--samples", "51"]) == 2
