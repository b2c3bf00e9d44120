"""The job's stages: a fresh install's first fit (compile_first)."""

from __future__ import annotations

import numpy as np

from pumpid import Kelvin, simulate
from pumpid.engine import aside, compiled
from pumpid.engine.problem import CardData, build_problem
from pumpid.job import stages

from ..conftest import well_load


def _problem():
    period, n = 6.0, 120
    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=2)
    data = simulate(Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0), t, load,
                    initial_state="periodic", period=period)
    return build_problem(Kelvin, [CardData(t, load, data, "periodic", period)], offset=True)


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
