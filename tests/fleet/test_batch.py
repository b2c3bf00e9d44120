"""run_batch: every input card once in the results, with its status; engines agree; resume
and refusals; ids, times and columns."""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import pumpid
from pumpid.fleet import FitSpec, ReadOptions, detect_changes, read_results, run_batch
from pumpid.fleet.batch import reason_kind
from pumpid.fleet.progress import make_progress
from pumpid.fleet.store import BATCH_COLUMNS, MANIFEST, ResultsFolderError, results_schema
from pumpid.pump.synthetic import (
    CardLabel,
    FieldCards,
    StepChange,
    synthetic_card,
    synthetic_field,
)

from .conftest import PARTS
from .fields import make_field

BROKEN_REASON = {
    "nan": r"NaN value",
    "truncated": r"values but|expected \d+ fields|only 5 samples",
    "constant-load": r"constant load",
    "unreadable": r"binary content|cannot read",
}


def test_every_card_once_with_its_status(field, local_run) -> None:
    folder, truth = field
    out, summary, table = local_run
    assert len(truth) == 2000 and truth["well_id"].nunique() == 25
    assert truth["broken"].notna().sum() == 100  # 5 %, each kind present
    assert set(truth["broken"].dropna()) == set(BROKEN_REASON)
    # one row per input card, ids unique, rows in input order
    assert len(table) == 2000
    assert table["card_id"].is_unique
    assert table["item"].tolist() == list(range(2000))
    assert not table["file"].str.endswith(("README.md", ".partial.csv")).any()

    good = truth[truth["broken"].isna()].merge(table, on="card_id", how="left",
                                               suffixes=("_truth", ""))
    assert good["status"].notna().all(), "a readable card has no row"
    assert set(good["status"]) <= {"converged", "boundary", "failed"}
    assert (good["status"].isin(["converged", "boundary"])).mean() > 0.98
    assert (good["well_id"] == good["well_id_truth"]).all()
    assert (good["time"] == good["time_truth"]).all()  # every layout states the card time
    assert (good["file"] == good["path"]).all()
    assert (good["n_samples"] == 60).all() and set(good["position_unit"]) == {"in"}
    assert set(good["model"]) == {"MassSpringDamper"}
    assert good["r2"].min() > 0.99
    for col in ("p_k", "p_k_se", "d_natural_frequency", "d_natural_frequency_se"):
        assert good[col].notna().all()
    assert good["source"].str.match(r".+, (lines? \d|cards\[\d+\]|card W)").all()

    broken = truth[truth["broken"].notna()]
    rows = table.set_index("file")
    for _, card in broken.iterrows():
        row = rows.loc[card["path"]]
        assert isinstance(row, pd.Series), f"{card['path']}: one row"
        assert row["status"] == "invalid-input"
        assert re.search(BROKEN_REASON[card["broken"]], row["reason"]), row["reason"]
        if card["format"] == "parquet" and card["broken"] != "unreadable":
            # a bad card in the long layout keeps its ids
            assert (row["card_id"], row["well_id"]) == (card["card_id"], card["well_id"])
        elif card["broken"] != "unreadable":
            # a file refused for its one bad card still says whose card and when
            assert row["well_id"] == card["well_id"], (card["path"], row["well_id"])
            assert row["time"] == pd.Timestamp(card["time"]), (card["path"], row["time"])
        else:
            assert pd.isna(row["well_id"])  # nothing to read it from
    # the multi-well export's cards all came from one file
    export = table[table["file"] == str(folder / "scada" / "export.txt")]
    assert export["well_id"].nunique() >= 6 and (export["status"] != "invalid-input").all()

    assert sum(summary.statuses.values()) == 2000
    assert summary.statuses["invalid-input"] == 100
    assert (summary.cards, summary.partitions, summary.fitted) == (2000, 2000 // PARTS, 2000)
    unreadable = dict(summary.unreadable)
    garbage = truth.loc[truth["broken"] == "unreadable", "path"].iloc[0]
    assert garbage in unreadable
    text = summary.text()
    assert "cards per status:" in text and garbage in text and "costliest cards" in text
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["complete"] and manifest["rows"] == 2000
    assert len(manifest["files"]) == len({*truth["path"]})
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == []
    # plain pandas reads the folder too
    assert len(pd.read_parquet(out)) == 2000


@pytest.mark.slow
def test_dask_engine_gives_the_same_table(field, local_run, tmp_path: Path) -> None:
    # The same 2,000 cards and partitions on a two-process LocalCluster: dask's start-up
    # and the workers' imports cost a few seconds, the fits the same as locally.
    folder, _ = field
    out = tmp_path / "dask"
    summary = run_batch([str(folder)], out, fit=FitSpec("msd"), partition_size=PARTS,
                        engine="dask", workers=2)
    assert "LocalCluster (2 worker processes)" in summary.engine
    pd.testing.assert_frame_equal(read_results(out), local_run[2])


def test_resume_skips_what_is_written_and_refuses_other_runs(field, local_run,
                                                             tmp_path: Path) -> None:
    folder, _ = field
    out = tmp_path / "partial"
    shutil.copytree(local_run[0], out)
    # As if stopped: the manifest not complete, some parts missing, one half-written.
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["complete"] = False
    (out / MANIFEST).write_text(json.dumps(manifest))
    for k in (3, 40, 99):
        (out / f"part-{k:06d}.parquet").unlink()
    (out / ".part-000040.parquet.tmp-1").write_bytes(b"PAR1 half")
    with pytest.warns(UserWarning, match="not complete"):
        assert len(read_results(out)) == 2000 - 3 * PARTS
    with pytest.raises(ResultsFolderError, match="holds an unfinished batch run"):
        run_batch([str(folder)], out, fit=FitSpec("msd"), partition_size=PARTS)
    with pytest.raises(ResultsFolderError, match="option fit"):
        run_batch([str(folder)], out, fit=FitSpec("kelvin"), resume=True)
    # A run written with other columns (an earlier pumpid of the same version number) is
    # not resumed into one table with this one's: its parts' new columns were dropped on
    # reading, and a column kept its name with another meaning.
    older = dict(manifest, table=[c for c in manifest["table"] if not c.endswith(
        "_determined")])
    (out / MANIFEST).write_text(json.dumps(older))
    with pytest.raises(ResultsFolderError, match="written by an earlier pumpid"):
        run_batch([], out, resume=True)
    (out / MANIFEST).write_text(json.dumps(manifest))
    summary = run_batch([], out, resume=True)  # inputs and options: the run's own
    assert (summary.fitted, summary.skipped) == (3 * PARTS, 2000 - 3 * PARTS)
    pd.testing.assert_frame_equal(read_results(out), local_run[2])
    assert not list(out.glob(".part-*"))
    # A complete run resumed again has nothing to do.
    again = run_batch([str(folder)], out, resume=True)
    assert again.fitted == 0 and again.cards == 2000


def test_changed_inputs_are_refused(tmp_path: Path) -> None:
    field = tmp_path / "field"
    synthetic_field(field, n_wells=2, days=2, formats=("csv",), seed=1,
                    cards=FieldCards(n_samples=40, hold="none"))
    out = tmp_path / "out"
    run_batch([field], out, fit=FitSpec("msd"))
    with pytest.raises(ResultsFolderError, match="holds a complete batch run"):
        run_batch([field], out, fit=FitSpec("msd"))
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "x.txt").write_text("x")
    with pytest.raises(ResultsFolderError, match="not an empty folder"):
        run_batch([field], tmp_path / "elsewhere", fit=FitSpec("msd"))
    victim = next((field / "csv").glob("*.csv"))
    os.utime(victim, ns=(victim.stat().st_atime_ns, victim.stat().st_mtime_ns + 10**9))
    with pytest.raises(ResultsFolderError, match=r"1 input file.* changed"):
        run_batch([field], out, resume=True)
    shutil.copy(victim, field / "csv" / "more.csv")
    with pytest.raises(ResultsFolderError, match=r"not in the run: .*more\.csv"):
        run_batch([field], out, resume=True)
    with pytest.raises(FileNotFoundError):
        run_batch([tmp_path / "nothing"], tmp_path / "out2")
    with pytest.raises(ValueError, match="unknown fit option"):
        run_batch([field], tmp_path / "out3", fit=FitSpec("msd", options={"obsreve": "u"}))
    with pytest.raises(ValueError, match="x0: give exactly"):
        run_batch([field], tmp_path / "out3", fit=FitSpec("msd", x0={"m": 1.0}))
    assert not (tmp_path / "out3").exists()


def test_a_resume_without_inputs_names_files_added_to_their_folders(tmp_path: Path) -> None:
    # A file added to an input folder was resumed without a word. It is said (not refused:
    # the run's own --csv may sit in an input folder, and it is no input).
    field = tmp_path / "field"
    synthetic_field(field, n_wells=1, days=2, formats=("csv",), seed=3,
                    cards=FieldCards(n_samples=40, hold="none"))
    out = tmp_path / "out"
    first = run_batch([field], out, fit=FitSpec("msd"), csv=field / "results.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert run_batch([], out, resume=True, csv=field / "results.csv").fitted == 0
    shutil.copy(next((field / "csv").glob("*.csv")), field / "csv" / "more.csv")
    with pytest.warns(UserWarning, match=r"1 file\(s\) in the run's input folders are not "
                                         r"in the run \(\S*more\.csv\)"):
        again = run_batch([], out, resume=True, csv=field / "results.csv")
    assert again.fitted == 0 and again.cards == first.cards


def test_ids_unique_and_the_same_on_every_run(tmp_path: Path) -> None:
    field = tmp_path / "field"
    truth = synthetic_field(field, n_wells=1, days=3, formats=("csv",), seed=2,
                            cards=FieldCards(n_samples=40, hold="none"))
    shutil.copy(field / "csv" / "W000.csv", field / "csv" / "W000_copy.csv")
    # a long-layout file with one bad card among good ones: the others are read
    card = synthetic_card(pumpid.MassSpringDamper(m=8.8, c=25, k=80), n_samples=30,
                          noise=0.003, seed=2)
    frame = pd.DataFrame({"well_id": "P1", "card_id": np.repeat(["a", "b", "c"], 30),
                          "sample": np.tile(np.arange(30), 3),
                          "position": np.tile(card.position, 3), "load": np.tile(card.load, 3),
                          "spm": 8.0})
    frame.loc[frame["card_id"] == "b", "load"] = 5.0
    frame.to_parquet(field / "cards.pq")
    ids = []
    for k in range(2):
        out = tmp_path / f"run{k}"
        run_batch([field], out, fit=FitSpec("msd"))
        table = read_results(out)
        assert table["card_id"].is_unique and len(table) == 2 * len(truth) + 3
        ids.append(table["card_id"].tolist())
    assert ids[0] == ids[1]
    copies = table[table["file"].str.endswith("W000_copy.csv")]
    assert all(cid.endswith(")") and "W000_copy.csv, lines" in cid for cid in copies["card_id"])
    long = table[table["file"].str.endswith("cards.pq")].set_index("card_id")
    assert long.loc["b", "status"] == "invalid-input" and long.loc["b", "well_id"] == "P1"
    assert "constant load" in long.loc["b", "reason"]
    assert set(long.loc[["a", "c"], "status"]) <= {"converged", "boundary"}
    assert long["time"].isna().all()  # the layout's time column is optional


def test_whitespace_cards_need_their_rate_and_columns(tmp_path: Path) -> None:
    # The whitespace layout has no ids, rate or time: the rate and the columns are given.
    field = tmp_path / "field"
    truth = synthetic_field(field, n_wells=1, days=4, formats=("whitespace",), seed=3,
                            cards=FieldCards(n_samples=50, hold="none"))
    spm = float(truth["spm"].iloc[0])
    out = tmp_path / "given"
    run_batch([field], out, fit=FitSpec("msd"),
              read=ReadOptions(spm=spm, columns={"position": 0, "load": 1}))
    table = read_results(out)
    assert set(table["status"]) <= {"converged", "boundary"} and len(table) == 4
    assert table["card_id"].tolist() == truth["card_id"].tolist()  # the file names
    bare = tmp_path / "bare"
    run_batch([field], bare, fit=FitSpec("msd"), read=ReadOptions(spm=spm))
    assert set(read_results(bare)["status"]) == {"invalid-input"}
    assert read_results(bare)["reason"].str.contains("columns=").all()


def test_schema_is_to_row_and_kelvin_rows(tmp_path: Path) -> None:
    for name, model in (("kelvin", pumpid.Kelvin(k0=200, m=8.8, c1=40, k1=130)),
                        ("msd", pumpid.MassSpringDamper(m=8.8, c=25, k=80))):
        card = synthetic_card(model, observe="u", label=CardLabel(well_id="W", card_id="c"),
                              n_samples=60, noise=0.003, seed=1)
        row = pumpid.fit(name, card, options=pumpid.FitOptions.for_cards(observe="u")).to_row()
        cols = [c for c in results_schema(type(model)).names if c not in BATCH_COLUMNS]
        assert cols == list(row), f"{name}: the results layout is FitResult.to_row's"
    field = tmp_path / "field"
    synthetic_field(field, n_wells=3, days=3, formats=("json", "parquet", "scada"), seed=4,
                    cards=FieldCards(observe="u", n_samples=60, hold="none"),
                    broken_fraction=0.1)
    out = tmp_path / "kelvin"
    run_batch([field], out, fit=FitSpec("kelvin", options={"observe": "u"}))
    table = read_results(out)
    assert str(table["time"].dtype) == "datetime64[ns, UTC]"
    assert str(table["nfev"].dtype) == "Int64"
    fitted = table[table["status"] != "invalid-input"]
    assert set(fitted["observe"]) == {"u"} and set(fitted["model"]) == {"Kelvin"}
    for q in ("natural_frequency", "damping_ratio", "time_constant", "static_stiffness"):
        assert fitted[f"d_{q}"].notna().all() and fitted[f"d_{q}_unit"].notna().all()
    assert set(fitted["d_static_stiffness_unit"]) == {"lbf/in"}
    bad = table[table["status"] == "invalid-input"]
    assert len(bad) == 1 and bad["p_k0"].isna().all() and bad["reason"].iloc[0]


def test_a_card_the_engine_cannot_fit_does_not_cost_the_others(tmp_path: Path,
                                                               monkeypatch) -> None:
    field = tmp_path / "field"
    synthetic_field(field, n_wells=1, days=4, formats=("json",), seed=5,
                    cards=FieldCards(n_samples=40, hold="none"))
    import pumpid.pump.runner

    real = pumpid.pump.runner.fit

    def flaky(model, cards, *args, **kwargs):
        some = cards if isinstance(cards, list) else [cards]
        if any(c.card_id.endswith("20240102T0000Z") for c in some):
            raise FloatingPointError("a kernel fault")
        return real(model, cards, *args, **kwargs)

    # The card runner both commands use: a batch that raises is redone card by card.
    monkeypatch.setattr(pumpid.pump.runner, "fit", flaky)
    out = tmp_path / "out"
    run_batch([field], out, fit=FitSpec("msd"))
    table = read_results(out).set_index("card_id")
    assert table.loc["W000_20240102T0000Z", "status"] == "failed"
    assert "FloatingPointError: a kernel fault" in table.loc["W000_20240102T0000Z", "reason"]
    assert (table.drop(index="W000_20240102T0000Z")["status"] == "converged").all()


def test_steps_found_and_steady_wells_left_alone(tmp_path: Path) -> None:
    # Twelve wells of 64 cards fitted by the batch; three get a step of 20-40 % in one
    # parameter at a known card. The derived quantities of the results table show them.
    steps = [StepChange(well=1, parameter="k", factor=1.3, at=32),
             StepChange(well=5, parameter="c", factor=1.4, at=40),
             StepChange(well=9, parameter="m", factor=0.8, at=35)]
    field = tmp_path / "field"
    make_field(field, n_wells=12, days=16, cards_per_day=4, broken_fraction=0.02, seed=8,
               change=steps)
    out = tmp_path / "out"
    run_batch([field], out, fit=FitSpec("msd"))
    alerts = detect_changes(read_results(out))
    assert sorted(set(alerts["well_id"])) == ["W001", "W005", "W009"]  # no steady well
    expected = {"W001": ("static_stiffness", 1.3, 32), "W005": ("damping_ratio", 1.4, 40),
                "W009": ("natural_frequency", 0.8**-0.5, 35)}
    for well, (quantity, factor, at) in expected.items():
        mine = alerts[(alerts["well_id"] == well) & (alerts["quantity"] == quantity)]
        assert len(mine) == 1, f"{well}: {quantity} flagged once"
        card = mine.iloc[0]
        when = pd.Timestamp("2024-01-01", tz="UTC") + pd.Timedelta(hours=6) * at
        assert abs((card["first_time"] - when) / pd.Timedelta(hours=6)) <= 3
        assert card["delay_cards"] <= 6
        assert card["change_rel"] == pytest.approx(factor - 1, abs=0.06)


def test_progress_displays() -> None:
    lines = io.StringIO()
    progress = make_progress("lines", stream=lines, interval=0.0)
    progress.start(1000, "local (2 threads)")
    progress.file_read(500, 40)
    progress.advance(20)
    progress.tick()
    progress.all_read()
    progress.advance(20, skipped=True)
    progress.close()
    text = lines.getvalue()
    assert "fitting on local (2 threads)" in text
    assert "20 of about 80 cards (25 %)" in text and "cards/s" in text and "time left" in text
    assert text.rstrip().splitlines()[-1].startswith("pumpid batch: 40 of 40 cards (100 %)")
    # A resume with nothing left says so ("0.0 cards/s, time left unknown" did not).
    lines = io.StringIO()
    progress = make_progress("lines", stream=lines, interval=0.0)
    progress.start(100, "local")
    progress.file_read(100, 10)
    progress.all_read()
    progress.advance(10, skipped=True)
    progress.close()
    last = lines.getvalue().rstrip().splitlines()[-1]
    assert last == ("pumpid batch: 10 of 10 cards (100 %), every one from an earlier run: "
                    "nothing to fit")
    bar = io.StringIO()
    threads = set(threading.enumerate())
    progress = make_progress("bar", stream=bar)
    # no thread of its own: the processes engine forks the run only while it has one
    assert not set(threading.enumerate()) - threads
    progress.start(100, "local")
    progress.file_read(100, 10)
    progress.all_read()
    progress.advance(10)
    progress.close()
    assert "10/10" in bar.getvalue() and "card/s" in bar.getvalue()
    assert make_progress("auto", stream=io.StringIO()).__class__.__name__ == "LinesProgress"


def test_reasons_are_grouped_by_kind() -> None:
    a = reason_kind("card 'W1_2024': NaN value in load_lbf (sample 33)")
    b = reason_kind("card 'W7_2023': NaN value in load_lbf (sample 4)")
    assert a == b == "card '…': NaN value in load_lbf (sample N)"
    # The summary groups them, but says a card's own reason: blanked, "has 200 values but
    # ... has 199" read "has N values but ... has N", the opposite of the trouble.
    import pyarrow as pa

    from pumpid.fleet.summary import BatchSummary

    summary = BatchSummary(results=Path("out"))
    summary.add(pa.table({
        "card_id": ["c1", "c2", "c3"], "status": ["invalid-input"] * 3,
        "reason": ["card 'c1': positions has 200 values but loads has 199",
                   "card 'c2': positions has 90 values but loads has 91",
                   "card 'c3': constant load (5 in every sample)"],
        "nfev": [None, None, None], "n_samples": [None, None, None]}))
    summary.close()
    text = summary.text()
    assert ("2 cards: invalid-input: card 'c1': positions has 200 values but loads has 199 "
            "(card c1; 1 more alike but for names and numbers)") in text
    assert "1 card: invalid-input: card 'c3': constant load (5 in every sample) (card c3)" in text
    assert "has N" not in text


def test_process_engine_reports_a_dead_worker_and_checks_its_options() -> None:
    from pumpid.fleet.engines import EngineError, make_engine

    with pytest.raises(ValueError, match="--engine dask"):
        make_engine("processes", scheduler="tcp://127.0.0.1:1")
    engine = make_engine("processes", workers=1)
    try:
        assert (engine.threads, engine.capacity) == (1, 2)
        assert engine.start_method in ("fork", "forkserver")
        assert engine.result(engine.submit(divmod, 7, 2)) == (3, 1)
        with pytest.raises(EngineError, match="worker process died"):
            engine.result(engine.submit(os._exit, 1))
    finally:
        engine.close()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork: Linux only")
def test_process_engine_forks_a_single_threaded_run_else_uses_a_server(tmp_path) -> None:
    from pumpid.fleet.engines import make_engine

    # A command line run has one thread when it makes its engine: the workers are forked
    # from it (no second import of pumpid).
    script = ("from pumpid.fleet.engines import make_engine\n"
              "e = make_engine('processes', workers=2)\n"
              "print(e.start_method, e.result(e.submit(divmod, 7, 2)))\n"
              "e.close()\n")
    got = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=True, timeout=120, cwd=tmp_path)
    assert got.stdout.split() == ["fork", "(3,", "1)"]
    # Another thread alive: a fork could copy a lock it holds; a server forks instead.
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        engine = make_engine("processes", workers=1)
        try:
            assert engine.start_method == "forkserver"
            assert engine.result(engine.submit(divmod, 9, 4)) == (2, 1)
        finally:
            engine.close()
    finally:
        stop.set()
        other.join()


def test_process_engine_says_where_processes_cannot_run(monkeypatch) -> None:
    # A container without shared memory cannot make the locks the workers talk through.
    import concurrent.futures as cf
    import multiprocessing

    from pumpid.fleet.engines import EngineError, make_engine, processes_available

    assert processes_available()

    def refused(*args, **kwargs):
        raise OSError(38, "Function not implemented")

    monkeypatch.setattr(cf, "ProcessPoolExecutor", refused)
    with pytest.raises(EngineError, match=r"cannot start on this system.*--engine local"):
        make_engine("processes", workers=1)
    monkeypatch.setattr(multiprocessing, "Lock", refused)
    assert not processes_available()


def test_process_engine_starts_without_fork_where_there_is_none(monkeypatch) -> None:
    import multiprocessing

    from pumpid.fleet.engines import make_engine

    monkeypatch.setattr(multiprocessing, "get_all_start_methods", lambda: ["spawn"])
    engine = make_engine("processes", workers=1)
    try:
        assert engine.result(engine.submit(divmod, 9, 4)) == (2, 1)
        assert engine.start_method == "spawn"
    finally:
        engine.close()
