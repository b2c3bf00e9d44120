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
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numba

__all__ = ["COMPILED_MODULES", "cache_dir", "jit"]

F = TypeVar("F", bound=Callable[..., Any])

#: The source files (relative to the package) that define compiled functions.
COMPILED_MODULES = (
    "engine/compiled.py",
    "engine/kernel.py",
    "engine/lm.py",
    "engine/drive.py",
    "engine/start.py",
    "inference/hac.py",
    "inference/uncertainty.py",
)


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


def jit(fn: F) -> F:
    """Compile ``fn`` (no Python objects, GIL released, numpy's error rules) with the cache."""
    with _cache_location():
        return numba.njit(cache=True, nogil=True, error_model="numpy")(fn)  # type: ignore[no-any-return]
