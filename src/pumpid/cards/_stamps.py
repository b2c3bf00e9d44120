"""A time column of date/time stamps, one a sample, read as seconds.

Controllers and SCADA historians export a stamp per sample (``2024-05-01 10:00:00.250``)
rather than seconds. ISO 8601 is the one form read: a date with a time (``T`` or a space
between them, a zone or none) or a time of day alone. Day-first and month-first forms
(``05/01/2024``) are ambiguous and are refused by the caller with a hint. Each stamp
becomes a whole number of microseconds after the column's first stamp, computed from the
stamps' difference (not from seconds since 1970, whose float keeps a quarter of a
microsecond), and a card's times are its microseconds after its own first stamp, in seconds.
"""

from __future__ import annotations

import re
from datetime import date, datetime, time, timedelta

import numpy as np

from ._common import Opts, Raw

__all__ = ["StampColumn", "StampError", "is_dated_stamp", "is_stamp", "join_stamps",
           "looks_like_stamp", "parse_date", "stamped_time"]

_MICROSECOND = timedelta(microseconds=1)
_HOUR_US = 3_600_000_000
# A time of day that falls more than half a day below the one before is the next day's.
_HALF_DAY_US = 12 * _HOUR_US
# A date and a time of day as two fields of a whitespace table.
_DATE = re.compile(r"\d{4}-\d{2}-\d{2}\Z")
_CLOCK = re.compile(r"\d{1,2}:\d{2}")


class StampError(ValueError):
    """A stamp that cannot be read (``form``: not ISO 8601; else the column's forms mix)."""

    def __init__(self, reason: str, *, form: bool) -> None:
        super().__init__(reason)
        self.form = form


def looks_like_stamp(tok: str) -> bool:
    """Whether a cell that is not a number reads as a date or a time (any form)."""
    return any(ch in tok for ch in ":/T") or tok.count("-") > 1


def _parse(tok: str) -> tuple[datetime, bool]:
    """A stamp as a datetime, and whether it is a time of day alone (dated 2000-01-01)."""
    try:
        return datetime.fromisoformat(tok), False
    except ValueError:
        pass
    try:
        return datetime.combine(date(2000, 1, 1), time.fromisoformat(tok)), True
    except ValueError:
        what = "an empty time cell" if not tok else f"{tok!r}"
        raise StampError(f"{what} is not a date and time in ISO 8601 form", form=True) from None


def is_stamp(tok: str) -> bool:
    """Whether ``tok`` is a date and time, a date or a time of day that :class:`StampColumn`
    reads."""
    if not looks_like_stamp(tok):
        return False
    try:
        _parse(tok)
    except StampError:
        return False
    return True


def is_dated_stamp(tok: str) -> bool:
    """Whether ``tok`` is a date with a time of day (a moment, not a date or a time alone)."""
    if not is_stamp(tok) or parse_date(tok) is not None:
        return False
    return not _parse(tok)[1]


def parse_date(tok: str) -> date | None:
    """A date alone (``2024-05-01``), None for anything else."""
    if not _DATE.match(tok.strip()):
        return None
    try:
        return date.fromisoformat(tok.strip())
    except ValueError:
        return None


def join_stamps(tokens: list[str]) -> list[str]:
    """A whitespace table's fields with each date and the time of day after it made one
    field again (``2024-05-01 10:00:00`` is one stamp, split by the spaces)."""
    out: list[str] = []
    for tok in tokens:
        if out and _CLOCK.match(tok) and _DATE.match(out[-1]):
            out[-1] = f"{out[-1]} {tok}"
        else:
            out.append(tok)
    return out


class StampColumn:
    """The stamps of one time column, read in file order.

    All the column's stamps must have one form: dates with times, all with a zone or all
    without, or times of day (a day is added where one falls more than half a day below
    the one before: a record that runs past midnight).
    """

    __slots__ = ("count", "day", "last", "origin", "time_of_day", "zoned")

    def __init__(self) -> None:
        self.origin: datetime | None = None
        self.zoned: bool | None = None
        self.time_of_day: bool | None = None
        self.day = 0
        self.last = 0
        self.count = 0

    def micros(self, tok: str) -> float:
        """Microseconds of stamp ``tok`` after the column's first stamp: a whole number, so
        that a card's times, its first stamp's subtracted, are steps of exactly equal size
        where the stamps are (seconds after a first stamp days before kept their steps only
        to 3e-9 of them).

        Raises
        ------
        StampError
            With the reason, when ``tok`` is not an ISO 8601 stamp or its form differs from
            the column's first one.
        """
        stamp, of_day = _parse(tok)
        zoned = stamp.tzinfo is not None
        if self.origin is None:
            self.origin, self.zoned, self.time_of_day = stamp, zoned, of_day
        elif of_day != self.time_of_day:
            raise StampError(f"{tok!r}: a column's stamps are all dates with times or all "
                             "times of day, not both", form=False)
        elif zoned != self.zoned:
            raise StampError(f"{tok!r}: a column's stamps all state a time zone or none "
                             "does", form=False)
        value = (stamp - self.origin + timedelta(days=self.day)) // _MICROSECOND
        if of_day and value < self.last - _HALF_DAY_US:
            self.day += 1
            value = (stamp - self.origin + timedelta(days=self.day)) // _MICROSECOND
        self.last = value
        self.count += 1
        return float(value)

    def at(self, micros: float, on: date | None = None) -> datetime | None:
        """The date and time ``micros`` microseconds after the first stamp, in the stamps'
        own zone (or none). Times of day have no date: None, unless one is given (``on``,
        the date of that sample)."""
        if self.origin is None:
            return None
        when = self.origin + timedelta(microseconds=micros)
        if not self.time_of_day:
            return when
        return None if on is None else datetime.combine(on, when.timetz())


def stamped_time(o: Opts, raw: Raw, stamps: StampColumn, name: str, on: date | None) -> None:
    """Give a card whose time column held stamps its time: seconds from its first stamp,
    whose date and time become the card's recording time (unless the file names one; a time
    of day takes its date from ``on``). A column whose stamps do not change within the card
    stamps the card, not its samples.

    Raises
    ------
    CardError
        Where stamps without a zone jump by an hour (a clock change), or repeat.
    """
    assert raw.t is not None
    micros = np.asarray(raw.t, dtype=float)
    first = float(micros[0])
    when = stamps.at(first, on)
    if when is not None:
        raw.metadata["first_sample_time"] = when.isoformat()
    raw.t_factor = 1.0  # seconds already, whatever unit the column's name states
    lines = raw.lines

    def line(k: int) -> int | None:
        return int(lines[k]) if lines is not None and k < len(lines) else None

    if micros.size > 1 and np.all(micros == first):
        raw.t = None
        raw.notes.append(f"column {name!r} holds one date/time stamp for the whole card: read "
                         "as the card's recording time, not as a time per sample")
        return
    steps = np.diff(micros)
    if not stamps.zoned:
        hour = np.flatnonzero(np.abs(np.abs(steps) - _HOUR_US) <= 0.01 * _HOUR_US)
        if hour.size:
            k = int(hour[0])
            raise o.error(
                f"the stamps {'jump ahead' if steps[k] > 0 else 'fall back'} by an hour between "
                f"lines {line(k)} and {line(k + 1)}: a change between summer and winter "
                "time? Stamps without a time zone cannot say; write them with their offset "
                "(2024-03-31T03:00:00+02:00) or in UTC, or read no time column and give the "
                "stroke rate (command line: --columns t=- --spm N; Python: columns={'t': None})",
                line=line(k + 1), field=name)
    if np.any(steps == 0):
        k = int(np.flatnonzero(steps == 0)[0])
        raise o.error(
            f"the stamps of lines {line(k)} and {line(k + 1)} are the same: stamps coarser "
            "than the sampling cannot time the samples (the first stamp still dates the "
            "card); read no time column and give the stroke rate (command line: --columns "
            "t=- --spm N; Python: columns={'t': None})",
            line=line(k + 1), field=name)
    raw.t = (micros - first) / 1e6
    what = "times of day" if stamps.time_of_day else "date/time stamps"
    raw.notes.append(f"column {name!r} holds ISO 8601 {what}: read as seconds from the card's "
                     "first stamp")
