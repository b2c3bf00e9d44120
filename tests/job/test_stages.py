"""The job's stages: a fresh install's first fit (compile_first)."""

from __future__ import annotations

from pumpid.engine import aside, compiled
from pumpid.job import stages

from ..conftest import stroke_problem


def _problem():
    return stroke_problem(seed=2)


def test_compile_first_does_nothing_on_a_warm_cache() -> None:
    assert stages.compile_first(_problem()) is False
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
    started = stages.compile_first(_problem())
    assert started == compiled.pending_aside(aside.ENTRY)
    if started:
        assert compiled.wait_aside(aside.ENTRY) == 0
    assert list(tmp_path.iterdir()) == []
