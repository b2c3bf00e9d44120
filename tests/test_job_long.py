"""Long records: the automatic start works on a shorter copy of a long card, and the fit of
the whole record reaches the same optimum as a start over every sample."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import pumpid
from pumpid import Kelvin, job
from pumpid.engine import drive
from pumpid.engine.problem import CardData, build_problem
from pumpid.engine.start import search_wider as plain_search_wider
from pumpid.job import state as job_state

from .conftest import well_load

#: The module that runs the stages (``pumpid.job.run`` the attribute is its function ``run``):
#: the wider search is looked up there.
JOB_RUN = importlib.import_module("pumpid.job.stages")

TRUE = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)


def _record(n: int, periodic: bool, model_error: float = 0.0
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float | None]:
    period = 5.0
    t = np.arange(n) * (period / n if periodic else 0.01)
    load = well_load(t, period)
    state = "periodic" if periodic else "rest"
    disp = pumpid.simulate(TRUE, t, load, observe="u", initial_state=state,
                           period=period if periodic else None)
    rng = np.random.default_rng(3)
    # A smooth distortion the model cannot explain, as on a real card: the job's guards
    # (the wider search) then run.
    disp = disp + model_error * 4.0 * ((disp - disp.mean()) / np.ptp(disp)) ** 3 * np.ptp(disp)
    disp = disp + 0.002 * np.ptp(disp) * rng.standard_normal(n) + (7.0 if periodic else 0.0)
    return t, load, disp, period if periodic else None


def _fit(n: int, periodic: bool, model_error: float = 0.0) -> pumpid.FitResult:
    t, load, disp, period = _record(n, periodic, model_error)
    options = pumpid.FitOptions(observe="u")
    if periodic:
        options = options.replace(initial_state="periodic", period=period, offset=True)
    return pumpid.fit(Kelvin, (t, load, disp), options=options)


@pytest.mark.parametrize(("periodic", "model_error"), [(False, 0.0), (True, 0.0), (True, 0.1)])
def test_a_long_card_starts_from_a_shorter_copy_and_reaches_the_same_optimum(
        periodic, model_error, monkeypatch) -> None:
    n = 1500
    searched: list[int] = []

    def search_wider(problem, cards, *args, **kwargs):
        searched.extend(problem.n_samples(int(k)) for k in cards)
        return plain_search_wider(problem, cards, *args, **kwargs)

    monkeypatch.setattr(JOB_RUN, "search_wider", search_wider)
    whole = _fit(n, periodic, model_error)
    assert searched == ([n] if model_error else [])
    monkeypatch.setattr(job_state, "START_SAMPLES", 400)
    searched.clear()
    short = _fit(n, periodic, model_error)
    used = 400 if not periodic else len(range(0, n, -(-n // 400)))
    # A card the model misses (as a real card) gets the wider search, on the shorter copy.
    assert searched == ([used] if model_error else [])
    assert f"on {used} of the card's {n} samples" in short.start.note
    assert f"of the card's {n} samples" not in whole.start.note
    assert short.status == whole.status
    # The same optimum of the whole record: its cost, and each parameter within a tiny
    # fraction of its standard error.
    assert short.cost == pytest.approx(whole.cost, rel=1e-7)
    for name, value in whole.params.items():
        se = whole.stderr[name]
        assert abs(short.params[name] - value) <= 0.01 * se, name


def test_the_start_problem_keeps_the_coordinates(monkeypatch) -> None:
    # A point costs on the shortened card what it costs on the same samples of the whole
    # card: scale, offset and load shift mean the same in both problems.
    monkeypatch.setattr(job_state, "START_SAMPLES", 300)
    cards = []
    for periodic in (False, True):
        t, load, disp, period = _record(900, periodic)
        cards.append(CardData(t, load, disp, initial_state="periodic" if periodic else "rest",
                              period=period))
    t, load, disp, _ = _record(200, False)
    cards.append(CardData(t, load, disp))
    problem = build_problem(Kelvin, cards, observe="u", offset=True)
    order = np.array([2, 1, 0], dtype=np.int64)
    sub = job.start_problem(problem, order)
    assert sub is not None
    assert [sub.n_samples(i) for i in range(3)] == [200, 300, 300]
    z = np.log(np.r_[TRUE.values, 1.0])[None].repeat(3, axis=0)
    z[:, -1] = [0.0, 7.0, 0.0]
    # The short card is the same card; the cut rest record is its own first samples.
    full = drive.cost_items(order, z, *problem.arrays)
    part = drive.cost_items(np.arange(3, dtype=np.int64), z, *sub.arrays)
    assert part[0] == full[0]
    head = build_problem(Kelvin, [CardData(*(a[:300] for a in problem.card(0)))],
                         observe="u", offset=True)
    assert part[2] == pytest.approx(
        drive.cost_items(np.zeros(1, dtype=np.int64), z[2:], *head.arrays)[0], rel=1e-12)
    assert job.start_problem(problem, np.array([2], dtype=np.int64)) is None
