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

__all__ = ["COLD_MINUTES", "COMPILED_MODULES", "MAIN_JOB", "cache_dir", "compiling_aside",
           "jit", "pending_aside", "registered", "uncached", "wait_aside"]

F = TypeVar("F", bound=Callable[..., Any])

#: The source files (relative to the package) that define compiled functions.
COMPILED_MODULES = (
    "engine/compiled.py",
    "engine/kernel.py",
    "engine/lm.py",
    "engine/drive.py",
    "engine/start/equation_error.py",
    "engine/start/harmonics.py",
    "inference/hac.py",
    "inference/uncertainty.py",
    "rods/march.py",
)


#: Compiled functions every fit of the main job calls (module.function), whatever its card
#: and options: while one of them has no compiled form in this build's cache, the first fit
#: compiles. (Functions only some fits reach, such as the wider search's, would announce a
#: compile on every run of the others.)
MAIN_JOB = ("drive.items",)
#: What compiling the main job costs on an empty cache (minutes, low and high): the bundled
#: example's first card took 105 s on 2 cores (load average 1.0) once the entry point that
#: simulates was compiled in a second process (179 s before), a real card's 121 s; about
#: twice as long on a busy machine (load average 3.3 on 2 cores).
COLD_MINUTES = (2, 4)

#: Every compiled function by module.function, filled as the modules are imported.
_DISPATCHERS: dict[str, Any] = {}


@functools.cache
def cache_dir() -> Path:
    """The folder of this build's compiled cache (created on first use)."""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for name in COMPILED_MODULES:
        digest.update(name.encode())
        digest.update((package / name).read_bytes())
    digest.update(numba.__version__.encode())
    base = os.environ.get("NUMBA_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME") or str(
        Path.home() / ".cache")
    folder = Path(base) / "pumpid" / digest.hexdigest()[:16]
    return folder


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
    its compiled callers: numba then copies its body into each caller instead of compiling
    it as a function of its own. Every function of its own re-optimises all the compiled
    code it calls when it is compiled (about 15 s for the simulation on one core), so each
    wrapper level in the call chain cost a fresh install that much again.
    """
    if fn is None:
        return functools.partial(jit, inline=inline)
    with _cache_location():
        dispatcher = numba.njit(cache=True, nogil=True, error_model="numpy",
                                inline="always" if inline else "never")(fn)
    _DISPATCHERS[f"{fn.__module__.rsplit('.', 1)[-1]}.{fn.__name__}"] = dispatcher
    return dispatcher


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
