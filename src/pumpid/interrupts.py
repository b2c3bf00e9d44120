"""A Ctrl-C that cannot be lost.

Python turns SIGINT into ``KeyboardInterrupt`` wherever the main thread happens to be. Raised
inside a finaliser or a callback (the garbage collection of a figure, a library's cleanup),
it is reported as "ignored" and the run goes on as if nothing had happened. The commands
therefore also record the signal, and their loops check the record between units of work (a
chunk of cards, a card, a partition), so an interrupted run always stops.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["check", "recorded"]

_SEEN = threading.Event()


def _on_sigint(signum: int, frame: Any) -> None:
    _SEEN.set()
    raise KeyboardInterrupt


@contextlib.contextmanager
def recorded() -> Iterator[None]:
    """Within the block, a Ctrl-C raises ``KeyboardInterrupt`` as usual and is recorded."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _SEEN.clear()
    previous = signal.signal(signal.SIGINT, _on_sigint)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        _SEEN.clear()


def check() -> None:
    """Raise ``KeyboardInterrupt`` if a recorded Ctrl-C has not surfaced (it was swallowed)."""
    if _SEEN.is_set():
        raise KeyboardInterrupt
