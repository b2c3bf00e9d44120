"""pumpid batch and pumpid report on the command line: summary, CSV, refusals, and runs
stopped by a real SIGKILL or SIGINT, then resumed, equal to an uninterrupted run."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import pumpid
from pumpid.cli import main
from pumpid.pump.synthetic import StepChange
from tests.fleet.fields import make_field

PARTS = ["--partition-size", "20"]
#: The exit status of a run over the field: some of its cards are broken (invalid-input).
SOME_NOT_FITTED = 3
FIT = ["--model", "msd"]


@pytest.fixture(scope="module")
def field(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame]:
    """2,000 cards of 25 wells in four layouts, 5 % broken (see tests/fleet/fields.py)."""
    folder = tmp_path_factory.mktemp("field")
    return folder, make_field(folder)


@pytest.fixture(scope="module")
def reference(field, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """The uninterrupted run, in this process (MSD: the machinery does not depend on the
    model, and it keeps 2,000 cards to seconds)."""
    out = tmp_path_factory.mktemp("cli") / "reference"
    argv = ["batch", str(field[0]), "--out", str(out), *FIT, *PARTS, "--csv", "--quiet"]
    return out, argv


def _run(capsys, argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _batch_process(args: list[str]) -> subprocess.Popen[str]:
    env = dict(os.environ)
    src = str(Path(pumpid.__file__).resolve().parents[1])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    code = "import sys; from pumpid.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen([sys.executable, "-c", code, "batch", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _stop_part_way(out: Path, proc: subprocess.Popen[str], sig: int) -> tuple[str, str]:
    """Send ``sig`` once a few partitions are written; the run must not be over by then."""
    deadline = time.monotonic() + 120
    while len(list(out.glob("part-*.parquet"))) < 3:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no partition written in 2 minutes"
        time.sleep(0.01)
    proc.send_signal(sig)
    return proc.communicate(timeout=120)


def test_summary_csv_and_report(field, reference, capsys, tmp_path: Path) -> None:
    _, truth = field
    out, argv = reference
    code, text, err = _run(capsys, argv)
    assert code == SOME_NOT_FITTED and err == ""  # --quiet: no progress lines
    assert f"pumpid batch: complete; results in {out}" in text
    assert "cards: 2000 in 100 partitions" in text and "cards/s end to end" in text
    assert "invalid-input 100" in text
    garbage = truth.loc[truth["broken"] == "unreadable", "path"].iloc[0]
    assert "unreadable files:" in text and garbage in text
    assert "failed or invalid cards by reason:" in text and "constant load" in text
    table = pumpid.read_results(out)
    csv = pd.read_csv(out.with_name("reference.csv"))
    assert len(csv) == len(table) == 2000
    assert csv["card_id"].tolist() == table["card_id"].tolist()
    assert csv["n_samples"].dropna().eq(60).all()
    # the fleet report over the real results table
    code, text, _ = _run(capsys, ["report", str(out), "--out", str(tmp_path / "fleet")])
    assert code == 0 and "2000 cards of" in text
    assert (tmp_path / "fleet" / "report.html").is_file()
    wells = pd.read_csv(tmp_path / "fleet" / "wells.csv")
    assert set(truth["well_id"]) <= set(wells["well_id"])
    assert wells["cards"].sum() == 2000


def test_progress_lines_when_not_a_terminal(field, tmp_path: Path) -> None:
    small = tmp_path / "small"
    make_field(small, n_wells=2, days=3, broken_fraction=0.0)
    proc = _batch_process([str(small), "--out", str(tmp_path / "out"), *FIT,
                           "--partition-size", "4", "--progress-interval", "0"])
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    lines = err.strip().splitlines()
    assert lines[0].startswith("pumpid batch: fitting on local")
    assert len(lines) >= 3  # the start, at least one line on the way, the end
    assert "24 of 24 cards (100 %)" in lines[-1] and "cards/s" in lines[-1]
    assert "\r" not in err  # no bar drawn into a log


@pytest.mark.slow
def test_sigkill_then_resume_equals_uninterrupted(field, reference, capsys,
                                                  tmp_path: Path) -> None:
    out = tmp_path / "killed"
    proc = _batch_process([str(field[0]), "--out", str(out), *FIT, *PARTS, "--quiet"])
    _stop_part_way(out, proc, signal.SIGKILL)
    assert proc.returncode == -signal.SIGKILL
    manifest = json.loads((out / "_manifest.json").read_text())
    written = len(list(out.glob("part-*.parquet")))
    assert not manifest["complete"] and 3 <= written < 100
    code, text, _ = _run(capsys, ["batch", str(field[0]), "--out", str(out), "--resume",
                                  "--quiet"])
    assert code == SOME_NOT_FITTED
    assert f"{20 * written} from an earlier run" in text
    if not (reference[0] / "_manifest.json").exists():
        assert main(reference[1]) == SOME_NOT_FITTED
    pd.testing.assert_frame_equal(pumpid.read_results(out), pumpid.read_results(reference[0]))
    assert len(list(out.glob("part-*.parquet"))) == 100 and not list(out.glob(".*"))


@pytest.mark.slow
def test_sigint_finishes_in_flight_then_resume_equals_uninterrupted(field, reference, capsys,
                                                                    tmp_path: Path) -> None:
    out = tmp_path / "interrupted"
    proc = _batch_process([str(field[0]), "--out", str(out), *FIT, *PARTS])
    stdout, stderr = _stop_part_way(out, proc, signal.SIGINT)
    assert proc.returncode == 130, stderr
    assert "pumpid batch: interrupted" in stdout
    assert f"continue with: pumpid batch --resume --out {out}" in stdout
    assert "Traceback" not in stderr
    with pytest.warns(UserWarning, match="not complete"):
        partial = pumpid.read_results(out)
    assert partial["card_id"].is_unique and len(partial) % 20 == 0
    assert not list(out.glob(".*"))  # nothing half-written left behind
    # resumed without inputs or options: the run's own are used
    code, text, _ = _run(capsys, ["batch", "--resume", "--out", str(out), "--quiet"])
    assert code == SOME_NOT_FITTED and f"{len(partial)} from an earlier run" in text
    if not (reference[0] / "_manifest.json").exists():
        assert main(reference[1]) == SOME_NOT_FITTED
    pd.testing.assert_frame_equal(pumpid.read_results(out), pumpid.read_results(reference[0]))


def test_other_inputs_or_options_are_refused(field, reference, capsys, tmp_path: Path) -> None:
    out, argv = reference
    if not (out / "_manifest.json").exists():
        assert main(argv) == SOME_NOT_FITTED
        capsys.readouterr()
    code, _, err = _run(capsys, ["batch", "--resume", "--out", str(out), "--model", "kelvin"])
    assert code == 2 and "not mixed" in err and '"model": "msd"' in err
    code, _, err = _run(capsys, ["batch", str(field[0]), "--out", str(out), *FIT, *PARTS])
    assert code == 2 and "holds a complete batch run" in err and "--resume" in err
    code, _, err = _run(capsys, ["batch", str(field[0] / "csv"), "--out", str(out), "--resume"])
    assert code == 2 and "no longer given" in err
    code, _, err = _run(capsys, ["batch", "--out", str(tmp_path / "new")])
    assert code == 2 and "give at least one INPUT" in err
    code, _, err = _run(capsys, ["batch", str(field[0]), "--out", str(tmp_path / "x"),
                                 "--scheduler", "tcp://127.0.0.1:1"])
    assert code == 2 and "needs --engine dask" in err
    code, _, err = _run(capsys, ["batch", str(field[0]), "--out", str(tmp_path / "y"),
                                 "--observe", "u9"])
    assert code == 2 and "--observe 'u9': Kelvin can observe u, u2" in err
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_report_names_the_well_that_changed(tmp_path: Path, capsys) -> None:
    field = tmp_path / "field"
    make_field(field, n_wells=6, days=12, cards_per_day=4, broken_fraction=0.02, seed=21,
               change=StepChange(well=3, parameter="k", factor=1.35, at=26))
    assert main(["batch", str(field), "--out", str(tmp_path / "r"), *FIT,
                 "--quiet"]) == SOME_NOT_FITTED
    capsys.readouterr()
    code, text, _ = _run(capsys, ["report", str(tmp_path / "r"), "--out",
                                  str(tmp_path / "fleet")])
    assert code == 0
    alerts = pd.read_csv(tmp_path / "fleet" / "alerts.csv")
    assert set(alerts["well_id"]) == {"W003"}
    assert "static_stiffness" in set(alerts["quantity"])
    assert "well W003: static_stiffness" in text and "lbf/in" in text
    page = (tmp_path / "fleet" / "report.html").read_text()
    assert re.search(r"Well W003 \(\d+ alerts?\)", page)


def test_a_file_of_one_well_is_named_by_well_id(tmp_path: Path, capsys) -> None:
    # A file without a well column had no way to its well: its cards were filed under
    # "(unknown well)", which is not trended, and a well file of several wells refused them.
    example = Path(pumpid.__path__[0]) / "data" / "example_cards.csv"
    out = tmp_path / "named"
    code, _, _ = _run(capsys, ["batch", str(example), "--out", str(out), *FIT, "--quiet",
                               "--well-id", "W-7"])
    assert code == 0
    table = pd.read_parquet(out)
    assert list(table["well_id"]) == ["W-7", "W-7"]
    # A resumed run keeps the run's own well id.
    code, _, _ = _run(capsys, ["batch", str(example), "--out", str(out), "--resume", "--quiet"])
    assert code == 0 and list(pd.read_parquet(out)["well_id"]) == ["W-7", "W-7"]
    # A run written before --well-id existed has no well_id in its manifest: resuming it is
    # refused in words, not as two option lists that read alike.
    manifest = out / "_manifest.json"
    doc = json.loads(manifest.read_text())
    del doc["options"]["read"]["well_id"]
    manifest.write_text(json.dumps(doc))
    code, _, err = _run(capsys, ["batch", str(example), "--out", str(out), "--resume",
                                 "--quiet"])
    assert code == 2 and "written by an earlier pumpid (its manifest has no well_id)" in err
    code, out_text, _ = _run(capsys, ["fit", str(example), "--well-id", "W-7", "--json"])
    assert code == 0
    assert {c["card"]["well"] for c in json.loads(out_text)["cards"]} == {"W-7"}


def test_a_run_whose_table_has_other_columns_is_not_resumed(tmp_path: Path, capsys) -> None:
    # A run written by a pumpid whose results table had other columns (before r2_fundamental
    # and r2_beyond): resuming it mixed the two versions' parts, and the new columns were
    # dropped on reading.
    example = Path(pumpid.__path__[0]) / "data" / "example_cards.csv"
    out = tmp_path / "run"
    code, _, _ = _run(capsys, ["batch", str(example), "--out", str(out), *FIT, "--quiet"])
    assert code == 0
    assert {"r2_fundamental", "r2_beyond"} <= set(pd.read_parquet(out).columns)
    manifest = out / "_manifest.json"
    doc = json.loads(manifest.read_text())
    del doc["table"]
    manifest.write_text(json.dumps(doc))
    code, _, err = _run(capsys, ["batch", str(example), "--out", str(out), "--resume",
                                 "--quiet"])
    assert code == 2 and "its results table has other columns" in err


def test_pumps_asked_for_and_not_identified_are_not_a_complete_run(tmp_path: Path,
                                                                   capsys) -> None:
    # Cards without a well id against a well file of several wells: every pump was
    # invalid-input, and the run exited 0 with no pump in its table.
    from pumpid.fleet.demo import make_pump_field

    wells = make_pump_field(tmp_path / "field", cards=1).parent / "wells.json"
    example = Path(pumpid.__path__[0]) / "data" / "example_cards.csv"
    code, text, _ = _run(capsys, ["batch", str(example), "--out", str(tmp_path / "r"), *FIT,
                                  "--well-file", str(wells), "--quiet"])
    assert code == SOME_NOT_FITTED, text
    assert "pumps identified, cards per status: invalid-input 2" in text
    assert "2 cards: pump invalid-input:" in text and "--well-id" in text
    # Named, they are identified (the demo's wells are alike but for their pumps).
    code, text, _ = _run(capsys, ["batch", str(example), "--out", str(tmp_path / "named"),
                                  *FIT, "--well-file", str(wells), "--quiet",
                                  "--well-id", "P001"])
    assert "pump invalid-input" not in text and code != SOME_NOT_FITTED, text


def test_an_out_that_is_a_file_exits_4_as_for_pumpid_fit(tmp_path: Path, capsys) -> None:
    # pumpid fit --out FILE exits 4 (an output that cannot be written); pumpid batch exited 2.
    example = Path(pumpid.__path__[0]) / "data" / "example_cards.csv"
    target = tmp_path / "afile"
    target.write_text("")
    code, _, err = _run(capsys, ["batch", str(example), "--out", str(target), *FIT, "--quiet"])
    assert code == 4 and "is not an empty folder" in err
    folder = tmp_path / "other"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    code, _, _ = _run(capsys, ["batch", str(example), "--out", str(folder), *FIT, "--quiet"])
    assert code == 2
