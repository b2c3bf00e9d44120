"""The one decorator for pumpid's compiled code, and where its compiled form is kept.

Every compiled function is compiled once per machine and cached on disk, so that a command
line run loads it (a fraction of a second) instead of compiling it again (tens of seconds).

numba keys each cached function by its own source file only, not by the functions it calls:
change a callee in another file and a caller's cache silently keeps the old callee. So the
cache lives in a folder named after a hash of *all* of pumpid's compiled sources: any change
to any of them starts a fresh cache, and an installed release never sees another's. The
folder is under ``$NUMBA_CACHE_DIR`` when that is set, else under the user's cache directory
(``$XDG_CACHE_HOME`` or ``~/.cache``), never beside the sources (which may be read-only).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numba
import numpy as np
from numba.core.compiler_lock import global_compiler_lock

__all__ = ["COLD_SECONDS", "COMPILED_MODULES", "MAIN_JOB", "OPT_LEVELS", "PUMP_COLD_SECONDS",
           "PUMP_JOB", "cache_base", "cache_dir",
           "compiling_aside", "copy_into", "jit", "pending_aside", "registered", "uncached",
           "wait_aside"]

F = TypeVar("F", bound=Callable[..., Any])

#: The source files (relative to the package) that define compiled functions.
COMPILED_MODULES = (
    "engine/compiled.py",
    "engine/kernel.py",
    "engine/lm.py",
    "engine/spectrum.py",
    "engine/drive.py",
    "engine/start/equation_error.py",
    "engine/start/harmonics.py",
    "inference/hac.py",
    "inference/serial.py",
    "inference/uncertainty.py",
    "rods/march.py",
    "rods/quantities.py",
)


#: Compiled functions every fit of the main job calls (module.function), whatever its card
#: and options: while one of them has no compiled form in this build's cache, the first fit
#: compiles. (Functions only some fits reach, such as the wider search's, would announce a
#: compile on every run of the others.)
MAIN_JOB = ("drive.items",)
#: What compiling the main job costs on an empty cache (seconds, low and high): the bundled
#: example's first card comes after 40-45 s on 2 cores (load average about 1.2) and after
#: about 52-54 s with one of the two cores busy with another process, the entry point that
#: simulates compiled in a second process at LLVM level 2; the rest of the job compiles
#: what its later cards reach. (It said "1-2 minutes", twice what a user waits.)
COLD_SECONDS = (40, 60)
#: Compiled functions every identification of a pump calls (``pumpid downhole``, ``pumpid
#: batch --well-file``): the rod string's march. The lumped fit's entry point is not among
#: them, so a command that identifies pumps alone compiles less, and would otherwise be told
#: of a compile on every run while the lumped fit's code stays uncompiled.
PUMP_JOB = ("march.march",)
#: What compiling the pump's identification costs on an empty cache (seconds, low and
#: high): ``pumpid downhole`` of a public field card took 25 s instead of 1.9 s warm, and
#: ``pumpid batch --well-file --pump-only --engine processes`` of 4,096 cards 18 s more
#: than warm, on 2 cores otherwise idle.
PUMP_COLD_SECONDS = (20, 40)

#: LLVM's optimisation level for the compiled functions (module.function) that do not take
#: numba's (3), with what they call. The one entry point that simulates is most of a fresh
#: install's compile and all of its first fit's wait: at level 2 the bundled example's first
#: card on an empty cache came after 42-44 s instead of 55-57 s (2 cores, load about 1.3),
#: with the same answers; the public field cards took 3-4 % less time in all with the solver's
#: own small factorisations (at level 3 they would take 8 % less), the synthetic periodic
#: cards about 5 % more. The functions a fit calls once per card before or after its solve
#: (the periodic equation-error start, the summary, the uncertainty's analysis) take level
#: 1: the first card's compile work 4 % less (45.4 against 47.1 s of CPU in one process),
#: the same costs on the public real cards, no change in the benchmarks' times beyond their
#: noise. With another process on one of two cores, the first card waits for all of that
#: work, not for the entry point alone. The rest keep level 3 (the wider search's scan at
#: level 1 saved nothing). A ``NUMBA_OPT`` set by the user applies to everything instead.
OPT_LEVELS: dict[str, int] = {"drive.items": 2, "drive.summary_rows": 1,
                              "uncertainty.analyse_rows": 1,
                              "equation_error._harmonic_items": 1}

#: Every compiled function by module.function, filled as the modules are imported.
_DISPATCHERS: dict[str, Any] = {}


def cache_base() -> Path:
    """The folder of pumpid's caches: ``pumpid`` under ``NUMBA_CACHE_DIR``, else under
    ``XDG_CACHE_HOME``, else under ``~/.cache`` (read at each call; not created here).

    Returns
    -------
    pathlib.Path
    """
    base = os.environ.get("NUMBA_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME") or str(
        Path.home() / ".cache")
    return Path(base) / "pumpid"


@functools.cache
def cache_dir() -> Path:
    """The folder of this build's compiled cache (created on first use)."""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for name in COMPILED_MODULES:
        digest.update(name.encode())
        digest.update((package / name).read_bytes())
    digest.update(numba.__version__.encode())
    digest.update(repr(sorted(OPT_LEVELS.items())).encode())
    return cache_base() / digest.hexdigest()[:16]


@contextlib.contextmanager
def _cache_location() -> Iterator[None]:
    # numba fixes a function's cache folder when the function is decorated; point it at
    # this build's folder for that moment only, so other numba code keeps its own setting.
    previous = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(cache_dir())
    try:
        yield
    finally:
        numba.config.CACHE_DIR = previous


def jit(fn: F | None = None, *, inline: bool = False) -> Any:
    """Compile ``fn`` (no Python objects, GIL released, numpy's error rules) with the cache.

    ``inline=True`` (as ``@jit(inline=True)``) for a thin wrapper between the simulation and
    its compiled callers, or a small step called in a hot loop: numba then copies its body
    into each caller instead of compiling it as a function of its own. Every function of
    its own re-optimises all the compiled code it calls when it is compiled (about 15 s for
    the simulation on one core), so each wrapper level in the call chain cost a fresh
    install that much again; and a call per step keeps the loop from being optimised
    across it (the pump's step in the rod string's march).
    """
    if fn is None:
        return functools.partial(jit, inline=inline)
    with _cache_location():
        dispatcher = numba.njit(cache=True, nogil=True, error_model="numpy",
                                inline="always" if inline else "never")(fn)
    name = f"{fn.__module__.rsplit('.', 1)[-1]}.{fn.__name__}"
    if name in OPT_LEVELS:
        _compile_at(dispatcher, OPT_LEVELS[name])
    _DISPATCHERS[name] = dispatcher
    return dispatcher


def _compile_at(dispatcher: Any, level: int) -> None:
    """Make ``dispatcher`` compile (itself and what it calls) at LLVM level ``level``.

    numba reads its optimisation level from ``NUMBA_OPT`` when a compile starts and has no
    per-function setting, so the variable is set for this compile only, under numba's own
    compile lock (no other thread compiles meanwhile); a value the user set is left alone.
    """
    compile_ = dispatcher.compile

    @functools.wraps(compile_)
    def compile_at_level(sig: Any) -> Any:
        with global_compiler_lock:
            if "NUMBA_OPT" in os.environ:
                return compile_(sig)
            os.environ["NUMBA_OPT"] = str(level)
            try:
                return compile_(sig)
            finally:
                del os.environ["NUMBA_OPT"]

    dispatcher.compile = compile_at_level


@jit
def copy_into(dst, src):
    """``dst[...] = src`` for two arrays of one shape, in compiled code.

    Why not ``dst[:] = src``: for every function with an array assigned to a slice, numba
    compiles and links in a routine that writes the two shapes into an error message (its
    text formatting included): about 4 s of the 60 s of work a fresh install's first fit
    did, for a mismatch pumpid's shapes never have.
    """
    for index in np.ndindex(dst.shape):
        dst[index] = src[index]


def _in_cache(dispatcher: Any) -> bool:
    """Does this build's cache hold a compiled form of the function (any signature)?"""
    try:
        # numba's own index reader: empty when the index is missing, of another numba
        # version or older than the source file (exactly when numba would compile again).
        return bool(dispatcher._cache._cache_file._load_index())
    except (AttributeError, OSError, EOFError, ValueError):
        # numba's internals moved: say nothing rather than announce a compile wrongly.
        return True


def registered() -> tuple[str, ...]:
    """The compiled functions of the imported modules (module.function)."""
    return tuple(_DISPATCHERS)


def uncached(names: tuple[str, ...] = MAIN_JOB) -> list[str]:
    """The functions among ``names`` (module.function, of imported modules) that this
    build's cache lacks: a call to them compiles first. Empty on a warm cache."""
    return [name for name in names
            if name in _DISPATCHERS and not _in_cache(_DISPATCHERS[name])]


#: Functions another process is compiling into this build's cache, by name: (its process,
#: files to remove once it has ended). See :func:`compiling_aside`.
_ASIDE: dict[str, tuple[Any, tuple[Path, ...]]] = {}
_ASIDE_LOCK = threading.Lock()


def compiling_aside(name: str, process: Any, files: tuple[Path, ...] = ()) -> None:
    """Note that ``process`` (a :class:`subprocess.Popen`) is compiling the function
    ``name`` into this build's cache: the first call of it here waits for that process
    (:func:`wait_aside`) and then loads its compiled form instead of compiling it again.
    ``files`` (its input, its lock) are removed when it has ended."""
    with _ASIDE_LOCK:
        _ASIDE[name] = (process, tuple(files))


def pending_aside(name: str) -> bool:
    """Is another process compiling ``name`` for this one (not yet waited for)?"""
    return name in _ASIDE


def wait_aside(name: str) -> int | None:
    """Before the first call of ``name``: wait for the process compiling it, if any, and
    return its exit status (None when there was none to wait for).

    Whatever that process's outcome, the call then proceeds: numba looks in the cache and
    compiles only if the other process left nothing there. Threads that arrive together
    wait together, so none starts a compile of its own meanwhile."""
    if name not in _ASIDE:
        return None
    with _ASIDE_LOCK:
        entry = _ASIDE.get(name)
        if entry is None:
            return None
        process, files = entry
        try:
            return int(process.wait())
        finally:
            del _ASIDE[name]
            for file in files:
                with contextlib.suppress(OSError):
                    file.unlink()
