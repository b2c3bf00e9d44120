"""The job's stages: a fresh install's first fit (compile_first)."""

from __future__ import annotations

import numba
import numpy as np

from pumpid.engine import aside, compiled
from pumpid.engine.start import WidePlan, compile_ranking, search_wider, wider
from pumpid.job import stages

from ..conftest import stroke_problem


def _problem():
    return stroke_problem(seed=2)


def test_compile_first_does_nothing_on_a_warm_cache() -> None:
    assert stages.compile_first(_problem(), 0) is False
    assert not compiled.pending_aside(aside.ENTRY)


def test_compile_first_on_a_cold_cache_survives_a_failing_warm_up(tmp_path,
                                                                 monkeypatch) -> None:
    # A cold cache: the second process is started, and a warm-up that fails here (stand-in
    # numbers a model does not take) does not end the fit it precedes.
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: list(names))
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)

    def broken(*_args: object) -> None:
        raise ValueError("stand-in numbers refused")

    monkeypatch.setattr(stages, "analyse_rows", broken)
    started = stages.compile_first(_problem(), 0)
    assert started == compiled.pending_aside(aside.ENTRY)
    if started:
        assert compiled.wait_aside(aside.ENTRY) == 0
    assert list(tmp_path.iterdir()) == []


def test_compile_first_on_a_cold_cache_warms_the_ranking_too(tmp_path, monkeypatch) -> None:
    # The wider search's harmonic ranking is compiled while the simulation is, not after
    # it when the first card reaches the wider search; every warm-up runs though one fails.
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: list(names))
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(stages, "analyse_rows", lambda *_args: 1 / 0)
    warmed = []
    monkeypatch.setattr(stages, "compile_ranking", lambda problem, k: warmed.append(k))
    started = stages.compile_first(_problem(), 0)
    if started:
        assert compiled.wait_aside(aside.ENTRY) == 0
    assert warmed == ([0] if started else [])


def test_the_ranking_warm_up_compiles_the_signature_the_search_calls(monkeypatch) -> None:
    problem = _problem()
    seen = []
    plain = wider.harmonic_scan

    def recording(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        return plain(*args)

    monkeypatch.setattr(wider, "harmonic_scan", recording)
    compile_ranking(problem, 0)
    z = np.array([[np.log(120.0), np.log(2.0), np.log(60.0), np.log(90.0), 0.0]])
    search_wider(problem, np.zeros(1, np.int64), z, np.array([1.0]),
                 plan=WidePlan(rounds=1, per_round=1, random=0))
    assert len(seen) == 2 and seen[0] == seen[1]
