"""A fresh install's first fit: the simulating entry point compiled in a second process."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

from pumpid import Kelvin, fit
from pumpid.engine import aside, compiled, drive
from pumpid.engine.problem import CardData

from ..conftest import stroke_problem


def _problem():
    return stroke_problem(seed=8)


def test_the_second_process_compiles_the_signature_this_one_calls(tmp_path) -> None:
    # The arrays travel through a file; read back, they must have the types the job's own
    # calls have (read-only where they were), or the second process would compile a
    # signature nobody calls and the first fit would compile items again after waiting.
    problem = _problem()
    t, load, d = problem.card(0)
    assert fit(Kelvin, CardData(t, load, d, "periodic", 6.0)).converged
    before = set(drive.items.signatures)
    path = tmp_path / "arrays.pickle"
    aside.dump(problem.arrays, path)
    aside.compile_items(aside.load(path))
    assert set(drive.items.signatures) == before
    # The helper's entry point: compiles from the file, removes it, and says how it is used.
    assert aside.main([str(path)]) == 0
    assert not path.exists()
    assert aside.main([]) == 2


def test_first_call_waits_for_the_second_process(tmp_path) -> None:
    # Every thread that needs the function while another process compiles it waits for
    # that process (none starts a compile of its own), and its files are removed after.
    lock = tmp_path / "items.compiling"
    lock.touch()
    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(1.0)"])
    compiled.compiling_aside("test.entry", process, (lock,))
    assert compiled.pending_aside("test.entry")
    ended: list[float] = []

    def call() -> None:
        compiled.wait_aside("test.entry")
        ended.append(time.perf_counter())

    threads = [threading.Thread(target=call) for _ in range(3)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(timeout=30)
    assert len(ended) == 3
    assert process.poll() is not None
    assert not lock.exists() and not compiled.pending_aside("test.entry")
    compiled.wait_aside("test.entry")  # nothing pending: returns at once


def test_no_second_process_on_a_warm_cache() -> None:
    # The suite has compiled the main job: nothing is started, nothing is pending.
    assert compiled.uncached((aside.ENTRY,)) == []
    assert aside.start(_problem().arrays) is False
    assert not compiled.pending_aside(aside.ENTRY)


def test_one_second_process_per_cache(tmp_path, monkeypatch) -> None:
    # A cold cache whose lock another process holds (a cold pumpid batch's other worker):
    # this one starts none and compiles as it would have.
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: list(names))
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    (tmp_path / "items.compiling").touch()
    assert aside.start(_problem().arrays) is False
    assert not compiled.pending_aside(aside.ENTRY)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["items.compiling"]


def test_the_second_process_runs_and_cleans_up(tmp_path, monkeypatch) -> None:
    # The real command line: a fresh interpreter that finds this pumpid, compiles (here it
    # loads: the suite's cache is warm), exits 0 and leaves no file behind.
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: list(names))
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    if not aside.start(_problem().arrays):  # one core: nothing to hand over
        assert not compiled.pending_aside(aside.ENTRY)
        return
    assert compiled.pending_aside(aside.ENTRY)
    assert compiled.wait_aside(aside.ENTRY) == 0
    assert list(tmp_path.iterdir()) == []
