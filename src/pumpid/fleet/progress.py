"""How a batch run shows its progress: a bar on a terminal, plain lines in a log, or nothing.

The number of cards is not known until every file is read (a file holds one card or
thousands), so the total is estimated from the bytes read so far (cards per byte times the
bytes of all inputs) and becomes exact once the last file is read; the rate counts the
cards fitted in this run, so the time left does not count partitions a resumed run skips.
"""

from __future__ import annotations

import sys
import time
from typing import IO, Any

__all__ = ["BarProgress", "LinesProgress", "Progress", "QuietProgress", "make_progress"]


class Progress:
    """Counts of a run, for the displays below (this base class shows nothing).

    Parameters
    ----------
    total_bytes : int
        Bytes of all the run's input files.
    """

    def __init__(self, total_bytes: int = 0) -> None:
        self.total_bytes = max(int(total_bytes), 0)
        self.bytes_read = 0
        self.cards_read = 0
        self.files_read = 0
        self.reading_done = False
        self.done = 0  # cards with a row (fitted now or found written)
        self.fitted = 0  # cards fitted in this run
        self.started = time.monotonic()

    def start(self, total_bytes: int, description: str) -> None:
        """A run begins (its inputs' size, and the engine in words)."""
        self.total_bytes = max(int(total_bytes), 0)
        self.started = time.monotonic()

    def file_read(self, size: int, cards: int) -> None:
        """One more input file read, holding ``cards`` cards (or unreadable items)."""
        self.bytes_read += size
        self.cards_read += cards
        self.files_read += 1

    def all_read(self) -> None:
        """Every input file has been read: the total is exact."""
        self.reading_done = True

    def advance(self, cards: int, *, skipped: bool = False) -> None:
        """``cards`` more cards have their rows (``skipped``: written by an earlier run)."""
        self.done += cards
        if not skipped:
            self.fitted += cards

    def tick(self) -> None:
        """Called often; displays that update on time do it here."""

    def note(self, text: str) -> None:
        """A message line between updates."""

    def close(self) -> None:
        """The run is over."""

    # ------------------------------------------------------------------ figures
    def total(self) -> int | None:
        """Cards in the run: exact once all is read, else estimated from the bytes read."""
        if self.reading_done or self.bytes_read >= self.total_bytes > 0:
            return self.cards_read
        if self.bytes_read == 0 or self.cards_read == 0:
            return None
        return max(self.cards_read, round(self.cards_read * self.total_bytes / self.bytes_read))

    def rate(self) -> float:
        """Cards fitted per second in this run (end to end)."""
        elapsed = time.monotonic() - self.started
        return self.fitted / elapsed if elapsed > 0 else 0.0

    def remaining(self) -> float | None:
        """Seconds left at the current rate, when it can be told."""
        total, rate = self.total(), self.rate()
        if total is None or rate <= 0:
            return None
        return max(total - self.done, 0) / rate


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "unknown"
    s = round(seconds)
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h} h {m:02d} min" if h else (f"{m} min {s:02d} s" if m else f"{s} s")


class QuietProgress(Progress):
    """No display (``--quiet``)."""


class LinesProgress(Progress):
    """A plain line every ``interval`` seconds (logs, pipes, CI), and at the end.

    Parameters
    ----------
    stream : file, optional
        Default: standard error.
    interval : float, default 10
        Seconds between lines.
    """

    def __init__(self, stream: IO[str] | None = None, interval: float = 10.0) -> None:
        super().__init__()
        self.stream = stream if stream is not None else sys.stderr
        self.interval = float(interval)
        self._last = 0.0

    def _line(self) -> str:
        total = self.total()
        exact = self.reading_done or total is None
        of = "" if total is None else f" of {'' if exact else 'about '}{total}"
        share = f" ({100.0 * self.done / total:.0f} %)" if total else ""
        if exact and total is not None and self.done >= total and not self.fitted:
            # A resume with nothing left: "0.0 cards/s, time left unknown" said nothing true.
            return (f"pumpid batch: {self.done}{of} cards{share}, every one from an earlier "
                    "run: nothing to fit")
        return (f"pumpid batch: {self.done}{of} cards{share}, {self.rate():.1f} cards/s, "
                f"time left {_clock(self.remaining())}")

    def start(self, total_bytes: int, description: str) -> None:
        super().start(total_bytes, description)
        self._last = time.monotonic()
        print(f"pumpid batch: fitting on {description}", file=self.stream, flush=True)

    def tick(self) -> None:
        now = time.monotonic()
        if now - self._last >= self.interval:
            self._last = now
            print(self._line(), file=self.stream, flush=True)

    def note(self, text: str) -> None:
        print(f"pumpid batch: {text}", file=self.stream, flush=True)

    def close(self) -> None:
        print(self._line(), file=self.stream, flush=True)


class BarProgress(Progress):
    """A tqdm bar with rate and time left, for a terminal."""

    def __init__(self, stream: IO[str] | None = None) -> None:
        super().__init__()
        from tqdm import tqdm

        class Bar(tqdm):  # type: ignore[misc]
            # No monitor thread: the run refreshes the bar at least every half second, and
            # a thread alive when the processes engine starts keeps it from forking the run
            # (its workers would wait for a server that imports pumpid again, 1.2-1.3 s).
            monitor_interval = 0

        self._bar: Any = Bar(total=None, unit="card", file=stream or sys.stderr,
                             dynamic_ncols=True, smoothing=0.05, desc="pumpid batch",
                             mininterval=0.5)

    def start(self, total_bytes: int, description: str) -> None:
        super().start(total_bytes, description)
        self._bar.write(f"pumpid batch: fitting on {description}")

    def _retotal(self) -> None:
        total = self.total()
        if total is not None and total != self._bar.total:
            self._bar.total = total
            self._bar.set_postfix_str("" if self.reading_done else "total estimated",
                                      refresh=False)

    def file_read(self, size: int, cards: int) -> None:
        super().file_read(size, cards)
        self._retotal()

    def all_read(self) -> None:
        super().all_read()
        self._retotal()
        self._bar.set_postfix_str("", refresh=False)

    def advance(self, cards: int, *, skipped: bool = False) -> None:
        super().advance(cards, skipped=skipped)
        if skipped:
            # Cards of an earlier run: counted, but not in tqdm's rate.
            self._bar.n += cards
            self._bar.last_print_n = self._bar.n
            self._bar.refresh()
        else:
            self._bar.update(cards)

    def tick(self) -> None:
        self._bar.refresh()

    def note(self, text: str) -> None:
        self._bar.write(f"pumpid batch: {text}")

    def close(self) -> None:
        self._bar.close()


def make_progress(mode: str = "auto", stream: IO[str] | None = None,
                  interval: float = 10.0) -> Progress:
    """A display: ``"bar"``, ``"lines"``, ``"quiet"``, or ``"auto"`` (a bar on a terminal,
    else lines).

    Parameters
    ----------
    mode : {"auto", "bar", "lines", "quiet"}
    stream : file, optional
        Where to write (default: standard error).
    interval : float, default 10
        Seconds between plain lines.

    Returns
    -------
    Progress
    """
    out = stream if stream is not None else sys.stderr
    if mode == "auto":
        mode = "bar" if getattr(out, "isatty", lambda: False)() else "lines"
    if mode == "bar":
        return BarProgress(out)
    if mode == "lines":
        return LinesProgress(out, interval)
    if mode == "quiet":
        return QuietProgress()
    raise ValueError(f"unknown progress mode {mode!r}; choose auto, bar, lines or quiet")
