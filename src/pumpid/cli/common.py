"""What every command shares: exit codes, user-facing errors, option parsing, safe text.

Exit codes (documented in the README and ``pumpid --help``):

==== ==========================================================================
0    every card was fitted (status ``converged`` or ``boundary``), outputs written
1    an internal error (a bug in pumpid): one line on stderr, no traceback
2    bad options or input: nothing could be fitted (the message names the file,
     line or field)
3    some cards were fitted and some were not (failed, invalid, unreadable)
4    an output file or folder could not be written (results still printed)
130  interrupted (Ctrl-C); the results finished so far are printed and written
141  standard output was closed early (e.g. piped into ``head``)
==== ==========================================================================
"""

from __future__ import annotations

import collections
import contextlib
import math
import sys
import warnings
from collections.abc import Iterator, Sequence
from typing import Any, TextIO

from ..cards import printable
from ..engine import compiled

__all__ = [
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_NOT_FITTED",
    "EXIT_OK",
    "EXIT_OUTPUT",
    "EXIT_PIPE",
    "EXIT_POOR_FIT",
    "EXIT_USAGE",
    "CliError",
    "WarningCounter",
    "columns_option",
    "compile_notice",
    "err",
    "fmt",
    "initial_state_option",
    "parse_assignments",
    "rate_option",
]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_NOT_FITTED = 3
EXIT_OUTPUT = 4
EXIT_POOR_FIT = 5
EXIT_INTERRUPTED = 130
EXIT_PIPE = 141

# Pumping speeds (strokes per minute) a --spm or --period may state: generous bounds, far
# outside any pumping unit, that keep the rebuilt time axis inside floating point.
SPM_RANGE = (1e-6, 1e6)


class CliError(ValueError):
    """A user-facing error of the options: printed without a traceback, exit status 2."""


def err(message: str, stream: TextIO | None = None) -> None:
    """One line on standard error, prefixed ``pumpid:``, control characters escaped."""
    print(f"pumpid: {printable(message)}", file=stream or sys.stderr, flush=True)


def compile_notice(stream: TextIO | None = None) -> bool:
    """Say on standard error, before a fit, that this build's compiled code is not cached yet:
    the first fit compiles it once (a silent wait of a minute looks like a hang). True if
    said."""
    if not compiled.uncached():
        return False
    low, high = compiled.COLD_MINUTES
    err(f"compiling the numerical core for this machine, once per installed version: about "
        f"{low}-{high} minutes on 2 cores (longer on a busy machine); later runs load it in a "
        "fraction of a second", stream)
    return True


def fmt(value: Any, digits: int = 4) -> str:
    """A number for the terminal: ``n/a`` for None, NaN and infinities."""
    if value is None or isinstance(value, bool):
        return "n/a" if value is None else str(value)
    try:
        x = float(value)
    except (TypeError, ValueError):
        return printable(value)
    if not math.isfinite(x):
        return "n/a"
    return f"{x:.{digits}g}"


def parse_assignments(items: Sequence[str] | None, what: str) -> dict[str, float]:
    """``NAME=VALUE[,NAME=VALUE...]`` options (repeatable) as a dictionary of finite numbers."""
    out: dict[str, float] = {}
    for item in items or []:
        for part in item.split(","):
            if not part.strip():
                continue
            if "=" not in part:
                raise CliError(f"{what}: expected name=value, got {printable(part)!r}")
            name, value = part.split("=", 1)
            try:
                number = float(value)
            except ValueError:
                raise CliError(f"{what}: {printable(name.strip())} = {printable(value)!r} is "
                               "not a number") from None
            if not math.isfinite(number):
                raise CliError(f"{what}: {printable(name.strip())} = {printable(value)} is not "
                               "a finite number")
            out[name.strip()] = number
    return out


def initial_state_option(text: str | None) -> Any:
    """``--initial-state``: a named state, or the state vector as comma-separated numbers."""
    if text is None:
        return None
    if text in ("rest", "equilibrium", "periodic"):
        return text
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise CliError(
            f"--initial-state: {printable(text)!r} is neither rest, equilibrium, periodic nor "
            "a list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise CliError(f"--initial-state: {printable(text)} has a value that is not finite")
    return values


def columns_option(spec: str | None, **single: str | None) -> dict[str, Any] | None:
    """Column roles from ``--columns ROLE=COL,...`` and the single ``--t-col``-style options.

    A column is a header name or a 0-based index (digits).
    """
    cols: dict[str, Any] = {}
    for part in (spec or "").split(","):
        if not part.strip():
            continue
        role, sep, col = part.partition("=")
        if not sep or not role.strip() or not col.strip():
            raise CliError(f"--columns: expected role=column (e.g. position=1,load=0), got "
                           f"{printable(part)!r}")
        cols[role.strip()] = col.strip()
    for role, col in single.items():
        if col is not None:
            cols[role] = col
    out = {k: int(v) if v.isdigit() else v for k, v in cols.items()}
    return out or None


def rate_option(spm: float | None, period: float | None) -> None:
    """Refuse a stated pumping speed or period that no record can have (CliError)."""
    lo, hi = SPM_RANGE
    if spm is not None and not (math.isfinite(spm) and lo <= spm <= hi):
        raise CliError(f"--spm {spm:g} strokes/min is not a pumping speed (give a number "
                       f"between {lo:g} and {hi:g})")
    if period is not None and not (math.isfinite(period) and 60.0 / hi <= period <= 60.0 / lo):
        raise CliError(f"--period {period:g} s is not a stroke period (give a number between "
                       f"{60.0 / hi:g} and {60.0 / lo:g} s)")


class WarningCounter:
    """Python warnings raised while a command runs, counted instead of printed.

    numpy's floating-point ``RuntimeWarning`` s (and matplotlib's) mean nothing to a user
    and are not errors: each card's status and warnings say whether its fit is usable. They
    are kept off the terminal and counted; ``--verbose`` prints the count.
    """

    _LIMIT = 50

    def __init__(self) -> None:
        self.counts: collections.Counter[str] = collections.Counter()

    @contextlib.contextmanager
    def active(self) -> Iterator[WarningCounter]:
        """Count every warning raised inside the block."""
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.showwarning = self._show  # type: ignore[assignment]
            yield self

    def _show(self, message: Warning | str, category: type[Warning], *args: Any,
              **kwargs: Any) -> None:
        key = f"{category.__name__}: {str(message).splitlines()[0][:120] if message else ''}"
        if key in self.counts or len(self.counts) < self._LIMIT:
            self.counts[key] += 1

    def summary(self) -> str | None:
        """One line saying what was counted, or None when nothing was."""
        if not self.counts:
            return None
        total = sum(self.counts.values())
        top = ", ".join(f"{k} ({n}x)" for k, n in self.counts.most_common(3))
        return (f"note: {total} numerical warning(s) were raised and not shown ({top}); each "
                "card's status and warnings say whether its fit is usable")
