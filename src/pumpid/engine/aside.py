"""A fresh install's first fit compiles on both cores: the simulation in a second process.

On an empty cache the first fit compiles everything it calls, one function after another
(numba compiles under one lock per process). The largest part by far is the one entry point
that simulates, :func:`pumpid.engine.drive.items` (the simulation and the solver: about 30
of the 46 s of work in one process); the start, the summary and the uncertainty's analysis
need no simulation. So :func:`start` hands ``items`` to a second Python process, which compiles it
into the same cache while this process compiles the rest; the first call of ``items`` here
waits for that process (:func:`pumpid.engine.compiled.wait_aside`) and loads what it left.

The second process is a fresh interpreter running :func:`main`, not a
``multiprocessing`` child: it re-runs nothing of the caller's script and works from a
daemon process (a Dask worker). It gets the problem's arrays, so that it compiles exactly
the signature this process will call. If it fails or is killed, this process compiles
``items`` itself after the wait, as it would have without it. One at a time per cache: a
lock file keeps the threads and processes of a cold ``pumpid batch`` from starting one each.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from . import compiled, drive

__all__ = ["ENTRY", "compile_items", "dump", "load", "main", "start"]

#: The function compiled aside (module.function, as :func:`compiled.uncached` names it).
ENTRY = "drive.items"
#: A lock older than this (s) is a crashed helper's: it no longer keeps another from starting.
_STALE = 1800.0

_LOCK = "items.compiling"


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _lock(folder: Path) -> Path | None:
    """Take the cache's lock file (None when another helper holds a fresh one)."""
    lock = folder / _LOCK
    for _ in range(2):
        try:
            os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            return lock
        except FileExistsError:
            try:
                if time.time() - lock.stat().st_mtime < _STALE:
                    return None
                lock.unlink()
            except OSError:
                return None
        except OSError:
            return None
    return None


def _flags(obj: Any) -> Any:
    """Which arrays of a nested tuple are read-only (pickling makes every array writable,
    and a read-only array is another compiled signature)."""
    if isinstance(obj, tuple):
        return tuple(_flags(x) for x in obj)
    return (not obj.flags.writeable) if isinstance(obj, np.ndarray) else None


def _restore(obj: Any, flags: Any) -> Any:
    if isinstance(obj, tuple):
        return tuple(_restore(x, f) for x, f in zip(obj, flags, strict=True))
    if isinstance(obj, np.ndarray) and flags:
        obj.flags.writeable = False
    return obj


def start(arrays: tuple[Any, Any, Any]) -> bool:
    """Start compiling :func:`~pumpid.engine.drive.items` in a second process for a
    problem's ``arrays`` (:attr:`Problem.arrays`), when this build's cache lacks it, no
    other process is compiling it and the machine has a second core. True if started."""
    if compiled.pending_aside(ENTRY) or _cores() < 2 or not compiled.uncached((ENTRY,)):
        return False
    folder = compiled.cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    lock = _lock(folder)
    if lock is None:
        return False
    payload = folder / f"items-{os.getpid()}.pickle"
    try:
        dump(arrays, payload)
        # This process's pumpid when the interpreter would find no other (a script that put
        # the sources on its own path); appended, so nothing else on the path is shadowed.
        code = ("import sys; sys.path.append(sys.argv[1]); "
                "from pumpid.engine.aside import main; sys.exit(main(sys.argv[2:]))")
        process = subprocess.Popen(
            [sys.executable, "-c", code, str(Path(__file__).resolve().parents[2]),
             str(payload)],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except (OSError, pickle.PicklingError, ValueError):
        for file in (payload, lock):
            with contextlib.suppress(OSError):
                file.unlink()
        return False
    compiled.compiling_aside(ENTRY, process, (payload, lock))
    return True


def dump(arrays: tuple[Any, ...], path: Path) -> None:
    """Write a problem's arrays for the second process (:func:`load` reads them back)."""
    with Path(path).open("wb") as fh:
        pickle.dump((arrays, _flags(arrays)), fh)


def load(path: Path) -> tuple[Any, ...]:
    """The arrays :func:`dump` wrote, read-only where they were (the same signature)."""
    with Path(path).open("rb") as fh:
        arrays, flags = pickle.load(fh)
    return _restore(arrays, flags)


def compile_items(arrays: tuple[Any, Any, Any]) -> None:
    """Compile :func:`~pumpid.engine.drive.items` for a problem's arrays (no items run)."""
    data, model, settings = arrays
    drive.outputs(np.zeros(0, np.int64), np.zeros((0, 1)), data, model, settings, 0)


def main(argv: list[str] | None = None) -> int:
    """The second process: compile for the arrays in the file named, then remove it."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m pumpid.engine.aside FILE (a file written by dump)",
              file=sys.stderr)
        return 2
    payload = Path(args[0])
    try:
        arrays = load(payload)
    finally:
        with contextlib.suppress(OSError):
            payload.unlink()
    try:
        compile_items(arrays)
    finally:
        with contextlib.suppress(OSError):
            (payload.parent / _LOCK).unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
