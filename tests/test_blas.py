"""pumpid's entry points run with one BLAS thread and give the caller's setting back."""

from __future__ import annotations

import threading

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

import pumpid
from pumpid.batch import fit_many
from pumpid.blas import single_threaded
from pumpid.profile import profile


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_one_thread_inside_and_the_callers_setting_after() -> None:
    seen: list[list[int]] = []

    @single_threaded
    def inner() -> None:
        seen.append(_blas_threads())

    @single_threaded
    def outer() -> None:
        inner()  # nested: still one thread, and the outer call restores
        seen.append(_blas_threads())

    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        assert before and all(n == 2 for n in before)
        outer()
        assert seen == [[1] * len(before)] * 2
        assert _blas_threads() == before


def test_concurrent_calls_restore_once_the_last_returns() -> None:
    # Two threads inside at once share one limit; the first to leave must not lift it. (What
    # OpenBLAS reports to a thread other than the one that set a limit varies between its
    # versions, so the bookkeeping is checked here, and the caller's setting afterwards.)
    from pumpid import blas

    inside = threading.Barrier(2)
    seen: list[tuple[int, bool]] = []

    @single_threaded
    def work() -> None:
        inside.wait(timeout=10)
        seen.append((blas._state["depth"], blas._state["limiter"] is not None))
        inside.wait(timeout=10)

    before = _blas_threads()
    threads = [threading.Thread(target=work) for _ in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert seen == [(2, True), (2, True)]
    assert blas._state["depth"] == 0 and blas._state["limiter"] is None
    assert _blas_threads() == before


def test_the_fitting_entry_points_are_single_threaded() -> None:
    for fn in (pumpid.fit, fit_many, profile):
        assert hasattr(fn, "__wrapped__"), fn
    t = np.linspace(0.0, 7.5, 300)
    load = 5500.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5)
    truth = pumpid.Kelvin(k0=9000.0, m=45.0, c1=900.0, k1=5200.0)
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        res = pumpid.fit(truth, t, load, pumpid.simulate(truth, t, load))
        assert res.converged and _blas_threads() == before
