"""A time column of date/time stamps, one a sample, read as seconds.

Controllers and SCADA historians export a stamp per sample (``2024-05-01 10:00:00.250``)
rather than seconds. ISO 8601 is the one form read: a date with a time (``T`` or a space
between them, a zone or none) or a time of day alone. Day-first and month-first forms
(``05/01/2024``) are ambiguous and are refused by the caller with a hint. Each stamp
becomes seconds after the column's first stamp, computed from the stamps' difference (not
from seconds since 1970, whose float would keep only a fraction of a microsecond less).
"""

from __future__ import annotations

from datetime import datetime, time, timedelta

__all__ = ["StampColumn", "looks_like_stamp"]

# A time of day that falls this far below the one before is taken as the next day.
_DAY_S = 86_400.0


def looks_like_stamp(tok: str) -> bool:
    """Whether a cell that is not a number reads as a date or a time (any form)."""
    return any(ch in tok for ch in ":/T") or tok.count("-") > 1


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
        self.last = 0.0
        self.count = 0

    def seconds(self, tok: str) -> float:
        """Seconds of stamp ``tok`` after the column's first stamp.

        Raises
        ------
        ValueError
            With the reason, when ``tok`` is not an ISO 8601 stamp or its form differs from
            the column's first one.
        """
        try:
            stamp = datetime.fromisoformat(tok)
            of_day = False
        except ValueError:
            try:
                clock = time.fromisoformat(tok)
            except ValueError:
                raise ValueError(f"{tok!r} is not an ISO 8601 date and time") from None
            stamp = datetime.combine(datetime(2000, 1, 1), clock)
            of_day = True
        zoned = stamp.tzinfo is not None
        if self.origin is None:
            self.origin, self.zoned, self.time_of_day = stamp, zoned, of_day
        elif of_day != self.time_of_day:
            raise ValueError(f"{tok!r}: a column's stamps are all dates with times or all "
                             "times of day, not both")
        elif zoned != self.zoned:
            raise ValueError(f"{tok!r}: a column's stamps all state a time zone or none does")
        value = (stamp - self.origin + timedelta(days=self.day)).total_seconds()
        if of_day and value < self.last - _DAY_S / 2:
            self.day += 1
            value = (stamp - self.origin + timedelta(days=self.day)).total_seconds()
        self.last = value
        self.count += 1
        return value

    def at(self, seconds: float) -> datetime | None:
        """The date and time ``seconds`` after the first stamp, in the stamps' own zone (or
        none); None for times of day, which have no date."""
        if self.origin is None or self.time_of_day:
            return None
        return self.origin + timedelta(seconds=seconds)
