"""One BLAS thread while pumpid computes.

pumpid's matrices are small (3 x 3 to 17 x 17, and thin N x 6 panels of samples). A
multi-threaded BLAS only adds synchronisation to each of these calls: with OpenBLAS's
default of one thread per core, a single 2001-sample Kelvin fit took 4.2-4.5 ms instead of
3.6-3.7 ms on two cores, and fits run in parallel (``fit_many(..., workers=2)``, or a user's
own processes) oversubscribe the cores. The public entry points (:func:`pumpid.fit`,
:func:`pumpid.fit_many`, ...) therefore run with BLAS limited to one thread, through
threadpoolctl; the limits in force before are restored when the last of any concurrent
calls returns, so the rest of the program keeps its own setting.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any, TypeVar

import threadpoolctl
from threadpoolctl import ThreadpoolController

F = TypeVar("F", bound=Callable[..., Any])

_lock = threading.Lock()
_state: dict[str, Any] = {"depth": 0, "limiter": None, "controller": None}


def _release_control() -> None:
    """Let any thread set OpenBLAS's pool size again.

    OpenBLAS without OpenMP has one process-wide pool, and threadpoolctl (3.8 and later)
    then lets only one "controlling" thread change it, the first to do so, until it is
    released. pumpid sets the limit from whichever thread enters first and restores it from
    whichever leaves last, so it takes that control only for the moment of each change.
    """
    openblas = getattr(threadpoolctl, "OpenBLASController", None)
    clear = getattr(openblas, "clear_controlling_thread", None)
    if clear is not None:
        clear(force=True)


def _enter() -> None:
    with _lock:
        if _state["depth"] == 0:
            if _state["controller"] is None:
                # Created on first use, once numpy's and scipy's BLAS libraries are loaded
                # (pumpid imports both); inspecting the loaded libraries costs ~1 ms once.
                _state["controller"] = ThreadpoolController()
            _release_control()
            _state["limiter"] = _state["controller"].limit(limits=1, user_api="blas")
            _release_control()
        _state["depth"] += 1


def _leave() -> None:
    with _lock:
        _state["depth"] -= 1
        if _state["depth"] == 0 and _state["limiter"] is not None:
            _release_control()
            _state["limiter"].restore_original_limits()
            _release_control()
            _state["limiter"] = None


def single_threaded(fn: F) -> F:
    """Run ``fn`` with BLAS limited to one thread (nested and concurrent calls share it)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        _enter()
        try:
            return fn(*args, **kwargs)
        finally:
            _leave()

    return wrapper  # type: ignore[return-value]
