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


_THREADS_SCRIPT = """
import json, threading
from concurrent.futures import ThreadPoolExecutor
import numpy as np
import threadpoolctl
from threadpoolctl import threadpool_info, threadpool_limits
import pumpid
from pumpid.blas import single_threaded

def threads():
    return sorted({lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"})

def in_thread(fn):
    out = {}
    th = threading.Thread(target=lambda: out.setdefault("v", fn()))
    th.start()
    th.join()
    return out["v"]

@single_threaded
def probe():
    return threads()

def users_own_limit():
    with threadpool_limits(limits=1, user_api="blas"):
        return threads()

report = {"start": threads()}
# Two long-lived worker threads overlap; the one that set the limit leaves first.
a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()

@single_threaded
def call_a():
    a_in.set()
    b_in.wait(10)

@single_threaded
def call_b():
    b_in.set()
    a_out.wait(10)

with ThreadPoolExecutor(2) as pool:
    fa = pool.submit(call_a)
    a_in.wait(10)
    fb = pool.submit(call_b)
    fa.result()
    a_out.set()
    fb.result()
    report["after_overlap"] = threads()
# An ordinary fit in the main thread must not keep control of the pool.
t = np.linspace(0.0, 7.5, 300)
load = 5500.0 + 2000.0 * np.sin(2 * np.pi * t / 7.5)
truth = pumpid.Kelvin(k0=9000.0, m=45.0, c1=900.0, k1=5200.0)
pumpid.fit(truth, t, load, pumpid.simulate(truth, t, load))
report["after_fit"] = threads()
report["probe_in_thread"] = in_thread(probe)
report["user_limit_in_thread"] = in_thread(users_own_limit)
report["end"] = threads()
ctl = getattr(getattr(threadpoolctl, "OpenBLASController", None), "_SHARED_STATE", None)
report["controlling"] = None if ctl is None else str(ctl.controlling_thread)
print(json.dumps(report))
"""


def test_threads_of_a_two_thread_blas_are_limited_and_given_back() -> None:
    # In a fresh process whose BLAS starts with two threads (the suite itself pins one).
    import json
    import os
    import subprocess
    import sys

    env = {**os.environ, "OMP_NUM_THREADS": "2", "OPENBLAS_NUM_THREADS": "2"}
    out = subprocess.run([sys.executable, "-c", _THREADS_SCRIPT], env=env, check=True,
                         capture_output=True, text=True, timeout=120)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["start"] == [2]
    assert report["after_overlap"] == [2] and report["after_fit"] == [2]
    assert report["probe_in_thread"] == [1] and report["user_limit_in_thread"] == [1]
    assert report["end"] == [2] and report["controlling"] in (None, "None")
