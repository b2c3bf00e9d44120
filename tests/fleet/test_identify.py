"""pumpid batch --well-file identifies each card's pump: the identified quantities with
their errors as columns, the diagnostic card at the identified damping, failures kept as
rows, resume exact; the change detector finds the demo's fluid pound and leaking valve."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from pumpid.fleet import FitSpec, detect_changes, read_results, run_batch, write_fleet_report
from pumpid.fleet.demo import make_pump_field
from pumpid.fleet.downhole import IDENTIFIED, PUMP_QUANTITIES, DownholeSpec
from pumpid.fleet.store import ResultsFolderError

CARDS = 10
AT = 6  # the first card of the two changes
PARTS = 10  # one well per partition, the stray card alone in the last


@pytest.fixture(scope="module")
def identified(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame,
                                                                   pd.DataFrame]:
    """The demo's pump field cut to 10 cards a well (changes at card 6), and a card of a
    well the well file does not describe, batched with identification."""
    root = tmp_path_factory.mktemp("identify")
    truth = pd.read_csv(make_pump_field(root / "field", cards=CARDS, at=AT))
    stray = json.loads((root / "field" / "P001.json").read_text(encoding="utf-8"))
    stray["well"] = "STRAY"
    stray["cards"] = [dict(stray["cards"][0], card_id="STRAY_1")]
    (root / "field" / "X_STRAY.json").write_text(json.dumps(stray), encoding="utf-8")
    # The lumped fits are not what is tested: few evaluations keep the run short.
    run_batch([root / "field"], root / "results", fit=FitSpec("msd", options={"max_nfev": 20}),
              partition_size=PARTS, downhole=DownholeSpec.load(root / "wells.json"))
    return root, truth, read_results(root / "results")


def test_identified_quantities_with_errors_and_units(identified) -> None:
    _, truth, table = identified
    got = truth.merge(table, on=["well_id", "card_id"], how="left")
    assert (got["identify_status"].isin(("converged", "boundary"))).all()
    for name in IDENTIFIED:
        assert got[f"pump_{name}"].notna().all()
        se = got[f"pump_{name}_se"]
        if name == "fillage":  # a full pump's is held (no error): the full wells' cards
            held = se.isna()
            assert held.any() and (got.loc[held, "fillage"] == 1.0).all()
            se = se[~held]
        assert se.notna().all() and (se > 0).all()
        # Each value says whether the card determines it; a full pump's held fillage counts.
        assert got[f"pump_{name}_determined"].notna().all()
    assert got["pump_fluid_load_determined"].all() and got["pump_fillage_determined"].all()
    assert set(got["pump_fillage_unit"]) == {"fraction"}
    assert set(got["pump_fluid_load_unit"]) == {"lbf"}
    # the load lines are the diagnostic's only, as pumpid downhole gives them
    assert (got["pump_upper_load_line"] == got["downhole_upper_load_line"]).all()
    # fillage measured on the identified pump card, fluid load as the pump made them
    assert (got["pump_fillage"] - got["fillage"]).abs().max() < 0.03
    assert ((got["pump_fluid_load"] / got["fluid_load"] - 1).abs() < 0.03).all()
    # the strings were made with nu = 0.1; the diagnostic card uses the identified damping
    assert got["pump_damping"].between(0.08, 0.12).all() and (got["pump_damping_se"] > 0).all()
    assert (got["downhole_damping"] == got["pump_damping"]).all()
    assert got["pump_damping_rule"].str.startswith("identified from the card").all()
    assert (got["downhole_status"] == "computed").all()
    assert (got["downhole_fillage"] - got["pump_fillage"]).abs().max() < 0.03
    assert (got["pump_r2"] > 0.99).all() and got["pump_residual_rho"].abs().max() < 0.5


def test_a_card_that_cannot_be_identified_keeps_its_row(identified) -> None:
    _, _, table = identified
    row = table[table["well_id"] == "STRAY"].iloc[0]
    assert row["identify_status"] == "invalid-input" and "STRAY" in row["identify_reason"]
    assert "pump not identified (invalid-input)" in row["warnings"]
    for name in PUMP_QUANTITIES:
        assert pd.isna(row[f"pump_{name}"]) and pd.isna(row[f"downhole_{name}"])
        if name in IDENTIFIED:
            assert pd.isna(row[f"pump_{name}_determined"])
    assert all(pd.isna(row[c]) for c in ("pump_damping", "pump_r2", "pump_fillage_se"))
    assert row["status"] in ("converged", "boundary", "undetermined", "poor-fit", "failed")


def test_resume_is_exact_and_keeps_the_identification(identified, tmp_path: Path) -> None:
    root, _, table = identified
    out = tmp_path / "partial"
    shutil.copytree(root / "results", out)
    manifest = json.loads((out / "_manifest.json").read_text())
    assert manifest["options"]["downhole"]["identify"] is True
    manifest["complete"] = False
    (out / "_manifest.json").write_text(json.dumps(manifest))
    (out / "part-000004.parquet").unlink()  # the stray card's partition
    with pytest.raises(ResultsFolderError, match="downhole"):
        run_batch([], out, resume=True,
                  downhole=DownholeSpec.load(root / "wells.json", identify=False))
    summary = run_batch([], out, resume=True)  # the run's own options: identification
    assert (summary.fitted, summary.skipped) == (1, 4 * CARDS)
    # the summary counts the identification's statuses, earlier partitions' included
    assert summary.pump_statuses["invalid-input"] == 1
    assert sum(summary.pump_statuses.values()) == 4 * CARDS + 1
    assert "pumps identified, cards per status: " in summary.text()
    pd.testing.assert_frame_equal(read_results(out), table)


def test_both_changes_alerted_and_the_steady_wells_not(identified, tmp_path: Path) -> None:
    _, _, table = identified
    # Ten cards a well: each history is tested as a whole (the two-segment test), as a
    # report run three cards after the change would test it.
    alerts = detect_changes(table)
    pump = alerts[alerts["kind"] == "pump"]
    assert set(pump["well_id"]) == {"P002", "P003"}  # P001 and P004 are steady
    fill = pump[(pump["well_id"] == "P002") & (pump["quantity"] == "pump_fillage")]
    load = pump[(pump["well_id"] == "P003") & (pump["quantity"] == "pump_fluid_load")]
    for found, drop in ((fill, 0.2), (load, 0.12)):
        assert len(found) == 1
        a = found.iloc[0]
        assert a["direction"] == "down" and a["change_rel"] < -drop
        assert int(a["first_index"]) == AT  # the change's first card, found
        assert int(a["alarm_index"]) - AT <= 3  # alerted within three cards of it
    # the fleet report trends the identified quantities
    paths = write_fleet_report(table, tmp_path / "report")
    shown = pd.read_csv(paths["alerts"])
    assert set(shown.loc[shown["quantity"].str.startswith("pump_"), "well_id"]) == {
        "P002", "P003"}
    assert "pump_fluid_load" in Path(paths["report"]).read_text(encoding="utf-8")


def test_identify_options_checked_and_old_manifests_read(tmp_path: Path) -> None:
    from pumpid.fleet.pumpfield import write_well_file

    wells = write_well_file(tmp_path / "wells.json", ["W"])
    with pytest.raises(ValueError, match="--no-identify"):
        DownholeSpec.load(wells, damping=0.0)  # undamped cannot be held in the fit
    assert DownholeSpec.load(wells, damping=0.0, identify=False).damping == 0.0
    spec = DownholeSpec.load(wells, damping=0.2)
    assert DownholeSpec.from_dict(spec.to_dict()) == spec
    # a manifest written before identification existed: its run was diagnostic only
    old = {k: v for k, v in spec.to_dict().items() if k != "identify"}
    assert DownholeSpec.from_dict(old).identify is False


def test_identifying_batches_default_to_small_partitions(tmp_path: Path) -> None:
    # A partition is the unit of progress and of what a Ctrl-C keeps: identified cards cost
    # tenths of a second each, so their default partition is small.
    from pumpid.fleet.defaults import IDENTIFY_PARTITION_SIZE, PARTITION_SIZE
    from pumpid.fleet.store import ResultsStore

    make_pump_field(tmp_path / "field", cards=1, at=1)
    wells = tmp_path / "wells.json"  # the demo writes the well file beside the field
    fit = FitSpec("msd", options={"max_nfev": 20})
    for identify, size in ((False, PARTITION_SIZE), (True, IDENTIFY_PARTITION_SIZE)):
        out = tmp_path / f"results-{identify}"
        run_batch([tmp_path / "field"], out, fit=fit,
                  downhole=DownholeSpec.load(wells, identify=identify))
        options = ResultsStore.options_of(out)
        assert options is not None and options["partition_size"] == size
    assert IDENTIFY_PARTITION_SIZE < PARTITION_SIZE


@pytest.fixture(scope="module")
def pump_only(identified, tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    """The same field batched with ``--pump-only``: no lumped model fitted (the summary's
    words in ``attrs["summary"]``)."""
    root, _, _ = identified
    out = tmp_path_factory.mktemp("pump-only") / "results"
    summary = run_batch([root / "field"], out, partition_size=PARTS,
                        downhole=DownholeSpec.load(root / "wells.json", lumped=False))
    table = read_results(out)
    table.attrs["summary"] = summary.text()
    return table


def test_pump_only_rows_are_the_identification(identified, pump_only) -> None:
    _, _, both = identified
    table = pump_only
    # no lumped model: no parameter or derived columns, the fit's columns the pump's
    assert not [c for c in table.columns if c.startswith(("p_", "d_"))]
    assert set(table["model"]) == {"rod string and pump"}
    assert set(table["observe"]) == {"polished-rod load"}
    assert table["status"].tolist() == table["identify_status"].tolist()
    assert table["reason"].tolist() == table["identify_reason"].tolist()
    ok = table["identify_status"] != "invalid-input"
    assert (table.loc[ok, "r2"] == table.loc[ok, "pump_r2"]).all()
    # the identification's evaluations (pumpid.pump.PumpFit.evaluations), nulls elsewhere
    assert (table.loc[ok, "nfev"] > 0).all() and table.loc[ok, "nfev"].sum() > 4 * 3 * CARDS
    assert table.loc[~ok, "r2"].isna().all()
    assert "STRAY" in table.loc[~ok, "reason"].iloc[0]
    # the summary says the statuses once: they are the identification's
    text = table.attrs["summary"]
    assert "cards per status (the pump identified): converged" in text
    assert "pumps identified, cards per status" not in text
    # the pump's columns are the ones the run with the lumped fits gives, to the bit
    pump = [c for c in both.columns if c.startswith(("pump_", "identify_", "downhole_"))]
    pd.testing.assert_frame_equal(table[["card_id", *pump]], both[["card_id", *pump]])
    # the change detector finds the same pump alerts (its threshold is higher with the
    # lumped quantities tested too: the false-alarm rate is split among more of them)
    found = ["well_id", "quantity", "direction", "first_index", "alarm_index"]
    got = detect_changes(table)
    want = detect_changes(both)
    assert set(got["kind"]) == {"pump"}
    pd.testing.assert_frame_equal(got[found].reset_index(drop=True),
                                  want.loc[want["kind"] == "pump", found].reset_index(drop=True))


def test_pump_only_is_kept_on_resume_and_checked(identified, tmp_path: Path) -> None:
    root, _, _ = identified
    wells = root / "wells.json"
    with pytest.raises(ValueError, match=r"--pump-only.*--no-identify"):
        DownholeSpec.load(wells, identify=False, lumped=False)
    spec = DownholeSpec.load(wells, lumped=False)
    assert DownholeSpec.from_dict(spec.to_dict()) == spec
    # a manifest from before --pump-only: the lumped model was fitted too
    old = {k: v for k, v in spec.to_dict().items() if k != "lumped"}
    assert DownholeSpec.from_dict(old).lumped is True
    card = root / "field" / "X_STRAY.json"
    broken = tmp_path / "broken.json"
    broken.write_text('{"cards": [', encoding="utf-8")
    out = tmp_path / "r"
    run_batch([card, broken], out, downhole=spec)
    with pytest.raises(ResultsFolderError, match="downhole"):
        run_batch([card, broken], out, resume=True, downhole=DownholeSpec.load(wells))
    run_batch([], out, resume=True)  # the run's own inputs and options
    table = read_results(out)
    # an unreadable file's row names the model of the run too
    assert table["model"].tolist() == ["rod string and pump"] * 2
    assert table["status"].tolist() == ["invalid-input"] * 2


@pytest.mark.parametrize(("extra", "words"), [
    (["--pump-only"], "need --well-file"),
    # A resumed run keeps its own well file: "need --well-file" was said to one that has it.
    (["--resume", "--damping", "0.1"], "--damping: a resumed run keeps its own downhole"),
    (["--well-file", "WELLS", "--pump-only", "--no-identify"], "--no-identify"),
    (["--well-file", "WELLS", "--pump-only", "--model", "msd"], "lumped fit's options"),
    # The default model asked for by name was run as if left out.
    (["--well-file", "WELLS", "--pump-only", "--model", "kelvin"], "lumped fit's options"),
    (["--well-file", "WELLS", "--pump-only", "--observe", "u"], "lumped fit's options"),
])
def test_pump_only_options_refused_with_the_reason(identified, tmp_path: Path, capsys,
                                                   extra: list[str], words: str) -> None:
    from pumpid.cli.main import main

    root, _, _ = identified
    args = [str(root / "wells.json") if a == "WELLS" else a for a in extra]
    code = main(["batch", str(root / "field" / "X_STRAY.json"), "--out",
                 str(tmp_path / "r"), *args])
    assert code == 2 and words in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_worker_processes_give_the_same_table(identified, pump_only, tmp_path: Path) -> None:
    # The partitions go to two worker processes (one thread each) instead of this
    # process's threads: every row the same, to the bit.
    root, _, _ = identified
    out = tmp_path / "processes"
    summary = run_batch([root / "field"], out, partition_size=PARTS, engine="processes",
                        workers=2, downhole=DownholeSpec.load(root / "wells.json",
                                                              lumped=False))
    assert summary.engine == "processes (2 worker processes)"
    pd.testing.assert_frame_equal(read_results(out), pump_only)


def test_the_command_identifying_pumps_runs_on_worker_processes(identified, tmp_path: Path,
                                                                capsys, monkeypatch) -> None:
    # pumpid batch's default engine: worker processes when --well-file identifies pumps
    # (about a third of an identification holds the interpreter's lock), threads otherwise;
    # a resume takes the run's own well file; --engine always wins.
    from pumpid.cli.main import main

    root, _, _ = identified
    stray, wells = str(root / "field" / "X_STRAY.json"), str(root / "wells.json")

    def engine(*argv: str) -> str:
        main(["batch", *argv])
        found = re.search(r"engine: (\w+)", capsys.readouterr().out)
        assert found is not None
        return found.group(1)

    out = str(tmp_path / "pumps")
    assert engine(stray, "--out", out, "--well-file", wells) == "processes"
    assert engine("--resume", "--out", out) == "processes"
    assert engine(stray, "--out", str(tmp_path / "b"), "--well-file", wells,
                  "--pump-only") == "processes"
    # a resume of a pump-only run compiles what the run does: the pump's march alone
    from pumpid.engine import compiled

    asked: list[tuple[str, ...]] = []
    monkeypatch.setattr(compiled, "uncached", lambda names=(): asked.append(names) or [])
    assert engine("--resume", "--out", str(tmp_path / "b")) == "processes"
    assert engine("--resume", "--out", out) == "processes"
    assert asked == [compiled.PUMP_JOB, compiled.MAIN_JOB + compiled.PUMP_JOB]
    assert engine(stray, "--out", str(tmp_path / "c")) == "local"
    assert engine(stray, "--out", str(tmp_path / "d"), "--well-file", wells,
                  "--no-identify") == "local"
    assert engine(stray, "--out", str(tmp_path / "e"), "--well-file", wells,
                  "--engine", "local") == "local"
    # where worker processes cannot run (no shared memory for their locks), threads
    import multiprocessing

    def refused():
        raise OSError(38, "Function not implemented")

    monkeypatch.setattr(multiprocessing, "Lock", refused)
    assert engine(stray, "--out", str(tmp_path / "f"), "--well-file", wells) == "local"


@pytest.mark.realdata
def test_a_pump_not_identified_has_the_values_pumpid_downhole_gives(shared_raw: Path,
                                                                     tmp_path: Path,
                                                                     capsys) -> None:
    # fj1's identification is undetermined: pumpid downhole gives the diagnostic card's
    # quantities (fluid load 32.5 kN), and the batch table's pump_fluid_load had been the
    # identification's unusable 12 kN under the same name. Not trended either way.
    from pumpid.cli import main

    from ..rods.test_realcards import FOLDER, well_file

    well, entry = well_file(shared_raw, "fj1", tmp_path)
    field = tmp_path / "field"
    field.mkdir()
    shutil.copy(shared_raw / FOLDER / entry["card_csv"], field / "fj1.csv")
    spm = f"{float(entry['spm']):g}"
    assert main(["downhole", str(field / "fj1.csv"), "--well", str(well), "--spm", spm,
                 "--json"]) == 6
    shown = json.loads(capsys.readouterr().out)["cards"][0]
    assert shown["identification"]["status"] == "undetermined"
    main(["batch", str(field), "--out", str(tmp_path / "results"), "--well-file", str(well),
          "--pump-only", "--spm", spm, "--quiet"])
    row = read_results(tmp_path / "results").iloc[0]
    assert row["identify_status"] == "undetermined"
    for name, q in shown["pump"].items():
        assert row[f"pump_{name}"] == pytest.approx(q["value"], rel=1e-9), name
        assert row[f"pump_{name}_unit"] == q["unit"]
        if name in IDENTIFIED:
            assert pd.isna(row[f"pump_{name}_se"]) and not row[f"pump_{name}_determined"]
    assert row["pump_damping"] == pytest.approx(shown["damping"]["value"])
    assert row["pump_damping_rule"] == shown["damping"]["rule"]
