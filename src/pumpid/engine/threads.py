"""Spreading compiled work over threads.

The compiled drivers release the GIL, so plain Python threads run them on all cores with no
copies of the data. Work is cut into chunks of items handed out one at a time, so a thread
that finishes early takes the next chunk (a slow card holds up only its own chunk).

BLAS: the compiled code calls no multi-threaded BLAS (its matrices are a few rows wide and
are multiplied by hand; the one LAPACK call, a tiny SVD, never threads), so pumpid has
nothing to limit per call and leaves the caller's BLAS settings alone.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

__all__ = ["default_workers", "run_chunks"]


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def run_chunks(
    work: Callable[[int, int], None], n_items: int, *, workers: int | None = None,
    chunk: int = 32,
) -> None:
    """Call ``work(start, stop)`` over ``range(n_items)`` in chunks, on ``workers`` threads.

    ``work`` writes its results itself (each chunk to its own slice). With one worker, or
    one chunk, everything runs in the calling thread.
    """
    if n_items <= 0:
        return
    workers = default_workers() if workers is None else max(1, int(workers))
    chunk = max(1, int(chunk))
    spans = [(a, min(a + chunk, n_items)) for a in range(0, n_items, chunk)]
    if workers == 1 or len(spans) == 1:
        for a, b in spans:
            work(a, b)
        return
    with ThreadPoolExecutor(max_workers=min(workers, len(spans))) as pool:
        for future in [pool.submit(work, a, b) for a, b in spans]:
            future.result()
