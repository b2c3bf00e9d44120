"""Where a batch run's partitions are fitted: on this machine's cores, or on Dask.

A run hands every partition to an :class:`Engine` as one task, ``task(*args)``, and takes
the answers back in the order they finish; the run itself reads the inputs and writes the
results, so an engine only computes. :func:`make_engine` is the one place that picks an
engine, from its name:

``"local"`` (:class:`LocalEngine`, the default)
    Threads of this process. Partitions are fitted one after another, each by
    :func:`pumpid.fit` on every core (its compiled passes release the GIL), while
    the run reads the next partition and writes the last one.
``"processes"`` (:class:`ProcessEngine`)
    Worker processes of this machine (one per core, or as many as asked), each fitting
    one partition at a time on one thread. About a third of an identified pump's work, and
    more of a lumped fit's, is Python that holds the interpreter's lock, so two threads of
    one process do not make two cores' work; two processes do (``pumpid batch`` uses them
    by default when it identifies pumps). The cards travel to the workers with the task and
    the rows come back, as on Dask, without Dask's scheduler.
``"dask"`` (:class:`DaskEngine`)
    A ``dask.distributed`` cluster: an existing one by its scheduler's address, else a
    ``LocalCluster`` of single-threaded worker processes (one per core, or as many as
    asked) listening on the loopback address only. Each partition is one task, fitted on
    one thread of a worker; the cards travel to the workers with the task and the rows come
    back, so workers need pumpid installed but no access to the input files.

Results do not depend on the engine: every partition is the same list of cards fitted
with the same options, and a card's fit does not depend on its neighbours or on threads.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import math
import multiprocessing
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any, Protocol

from pumpid.engine.threads import default_workers

__all__ = ["ENGINES", "DaskEngine", "Engine", "EngineError", "LocalEngine", "ProcessEngine",
           "make_engine", "processes_available"]

#: Engine names :func:`make_engine` knows.
ENGINES = ("local", "processes", "dask")


class EngineError(RuntimeError):
    """An engine cannot be started, or lost a task (a worker died)."""


class Engine(Protocol):
    """What a batch run needs from an engine."""

    #: A name for messages (``"local (2 cores)"``).
    description: str
    #: Partitions worth keeping in flight (submitted, not yet collected).
    capacity: int
    #: Threads each task may use (``workers=`` of :func:`pumpid.fit`).
    threads: int

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Start ``fn(*args)``; return a handle to wait on."""
        ...

    def wait(self, handles: Iterable[Any], timeout: float) -> list[Any]:
        """The handles that have finished, waiting up to ``timeout`` s for the first."""
        ...

    def result(self, handle: Any) -> Any:
        """The task's return value (its exception is raised here)."""
        ...

    def cancel(self, handles: Iterable[Any]) -> None:
        """Drop tasks not wanted any more (a running local task is left to finish)."""
        ...

    def close(self) -> None:
        """Release threads, workers, clusters."""
        ...


class _PoolEngine:
    """An engine over a :mod:`concurrent.futures` executor (``self._pool``)."""

    _pool: cf.Executor

    def submit(self, fn: Callable[..., Any], *args: Any) -> cf.Future[Any]:
        return self._pool.submit(fn, *args)

    def wait(self, handles: Iterable[cf.Future[Any]], timeout: float) -> list[cf.Future[Any]]:
        done, _ = cf.wait(list(handles), timeout=timeout, return_when=cf.FIRST_COMPLETED)
        return list(done)

    def result(self, handle: cf.Future[Any]) -> Any:
        return handle.result()

    def cancel(self, handles: Iterable[cf.Future[Any]]) -> None:
        for h in handles:
            h.cancel()

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


class LocalEngine(_PoolEngine):
    """Partitions fitted in this process, one at a time on every core.

    Parameters
    ----------
    workers : int, optional
        Cores (threads) for each partition's fit; default: every core this process may use.
    """

    def __init__(self, workers: int | None = None) -> None:
        self.threads = default_workers() if workers is None else max(1, int(workers))
        # One partition fits at a time on all threads; one more waits, already read, so the
        # cores never idle while the run reads and writes.
        self._pool = cf.ThreadPoolExecutor(max_workers=1, thread_name_prefix="pumpid-fit")
        self.capacity = 2
        self.description = f"local ({self.threads} thread{'s' if self.threads > 1 else ''})"


def _ignore_interrupts() -> None:
    """A worker process leaves Ctrl-C to the run: it finishes the partition it holds (the
    run then writes it, or drops it at a second Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class ProcessEngine(_PoolEngine):
    """Partitions fitted by worker processes of this machine, one partition each at a time.

    Parameters
    ----------
    workers : int, optional
        Worker processes; default: one per core this process may use.

    How the workers start (:attr:`start_method`): on Linux, from a process that runs one
    thread only (a command line run, when its engine is made), they are forked from it at
    once (``fork``): they have pumpid imported already, where a server process would import
    it again first (1.2-1.4 s of a run's start). Forking a process with other threads can
    leave a lock held for ever in the copy, so otherwise they are forked from a server
    process that has imported pumpid (``forkserver``), and where the system has no fork,
    each starts a Python of its own (``spawn``). Each worker loads the compiled code from
    its cache on its first partition.
    """

    def __init__(self, workers: int | None = None) -> None:
        n = default_workers() if workers is None else max(1, int(workers))
        methods = multiprocessing.get_all_start_methods()
        if ("fork" in methods and sys.platform.startswith("linux")
                and threading.active_count() == 1):
            context = multiprocessing.get_context("fork")
        elif "forkserver" in methods:
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(["pumpid.fleet.batch"])
        else:  # no fork on this system: each worker starts a Python of its own
            context = multiprocessing.get_context("spawn")
        try:
            self._pool = cf.ProcessPoolExecutor(max_workers=n, mp_context=context,
                                                initializer=_ignore_interrupts)
        except (OSError, ImportError) as exc:
            raise EngineError(f"worker processes cannot start on this system ({exc}): use "
                              "--engine local") from exc
        #: How the workers start: ``fork``, ``forkserver`` or ``spawn`` (see above).
        self.start_method = context.get_start_method()
        if self.start_method == "fork":
            # A first task forks every worker now, while this is the only thread: the pool's
            # own thread starts after them.
            self._pool.submit(int)
        self.threads = 1
        self.capacity = 2 * n
        self.description = f"processes ({n} worker process{'es' if n > 1 else ''})"

    def result(self, handle: cf.Future[Any]) -> Any:
        try:
            return handle.result()
        except cf.process.BrokenProcessPool as exc:
            raise EngineError(f"a worker process died with a partition: {exc}") from exc


class DaskEngine:
    """Partitions fitted as ``dask.distributed`` tasks.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``); default: start a
        ``LocalCluster`` on this machine for the run.
    workers : int, optional
        Worker processes of the ``LocalCluster`` (default: one per core). Not used with a
        scheduler address.

    Raises
    ------
    EngineError
        If dask.distributed is not installed (``pip install "pumpid[fleet]"``) or the
        cluster cannot be reached or started.
    """

    def __init__(self, scheduler: str | None = None, workers: int | None = None) -> None:
        try:
            import distributed
        except ImportError as exc:  # pragma: no cover - the test environment has it
            raise EngineError(
                "--engine dask needs dask.distributed: pip install \"pumpid[fleet]\"") from exc
        self._distributed = distributed
        self._cluster = None
        try:
            if scheduler is None:
                n = default_workers() if workers is None else max(1, int(workers))
                # Loopback only: a run's own cluster is nobody else's business.
                self._cluster = distributed.LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address=None, silence_logs=logging.CRITICAL)
                self._client = distributed.Client(self._cluster)
                where = f"dask LocalCluster ({n} worker process{'es' if n > 1 else ''})"
            else:
                self._client = distributed.Client(scheduler, timeout="20s")
                where = f"dask scheduler {scheduler}"
        except (OSError, TimeoutError, ValueError) as exc:
            self.close()
            raise EngineError(f"cannot start or reach the dask cluster: {exc}") from exc
        info = self._client.scheduler_info()
        slots = sum(int(w.get("nthreads", 1)) for w in info.get("workers", {}).values())
        self.threads = 1
        self.capacity = max(2, 2 * max(slots, 1))
        self.description = f"{where}, {slots} thread{'s' if slots != 1 else ''} in all"
        self._count = 0

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        self._count += 1
        return self._client.submit(fn, *args, pure=False,
                                   key=f"pumpid-partition-{self._count}-{time.time_ns()}")

    def wait(self, handles: Iterable[Any], timeout: float) -> list[Any]:
        pending = list(handles)
        if not pending:
            return []
        try:
            done, _ = self._distributed.wait(pending, timeout=timeout,
                                             return_when="FIRST_COMPLETED")
        except TimeoutError:
            return [h for h in pending if h.done()]
        return list(done)

    def result(self, handle: Any) -> Any:
        try:
            return handle.result()
        except Exception as exc:
            if type(exc).__name__ in ("KilledWorker", "CancelledError", "FutureCancelledError"):
                raise EngineError(f"a dask worker lost a partition: {exc}") from exc
            raise

    def cancel(self, handles: Iterable[Any]) -> None:
        handles = list(handles)
        if handles:
            self._client.cancel(handles)

    def close(self) -> None:
        client = getattr(self, "_client", None)
        if client is not None:
            client.close()
        if self._cluster is not None:
            self._cluster.close()


def processes_available() -> bool:
    """Whether this system can run worker processes (:class:`ProcessEngine`): some
    containers have no shared memory for the locks that processes talk through."""
    try:
        multiprocessing.Lock()
    except (OSError, ImportError):
        return False
    return True


def make_engine(name: str = "local", *, scheduler: str | None = None,
                workers: int | None = None) -> LocalEngine | ProcessEngine | DaskEngine:
    """The engine called ``name`` (one of :data:`ENGINES`).

    Parameters
    ----------
    name : {"local", "processes", "dask"}
    scheduler : str, optional
        Dask only: a running scheduler's address.
    workers : int, optional
        Local: threads per partition. Processes: worker processes. Dask: processes of the
        LocalCluster.

    Returns
    -------
    Engine

    Raises
    ------
    ValueError
        For an unknown name, a scheduler address with the local engine, or workers < 1.
    EngineError
        If the Dask engine cannot start.
    """
    if workers is not None and (isinstance(workers, bool) or not workers >= 1
                                or not math.isfinite(workers)):
        raise ValueError(f"workers must be a whole number >= 1, got {workers!r}")
    if name in ("local", "processes") and scheduler is not None:
        raise ValueError("a scheduler address needs --engine dask")
    if name == "local":
        return LocalEngine(workers)
    if name == "processes":
        return ProcessEngine(workers)
    if name == "dask":
        return DaskEngine(scheduler, workers)
    raise ValueError(f"unknown engine {name!r}; choose one of {', '.join(ENGINES)}")
