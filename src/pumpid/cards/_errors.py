"""The single error type raised by the card readers."""

from __future__ import annotations

import os

from ._printable import printable

__all__ = ["CardError"]


class CardError(ValueError):
    """A card file or card value is unusable.

    Every problem found while reading or checking a dynamometer card is reported with this
    one type, so callers can catch a single exception. It subclasses :class:`ValueError`.

    Parameters
    ----------
    message : str
        Plain-language description of what is wrong.
    path : str or os.PathLike, optional
        File (or in-memory name) the problem was found in.
    line : int, optional
        1-based line number in that file, when the problem has one.
    field : str, optional
        Column, JSON key, dimension or argument name the problem concerns.

    Attributes
    ----------
    path : str or None
    line : int or None
    field : str or None
    reason : str
        The message without the location prefix.

    Notes
    -----
    ``str(error)`` reads ``"<path>, line <n>, field '<name>': <message>"``, leaving out the
    parts that are unknown. Non-printable characters in the path and the message (control
    characters, ANSI escape codes from a hostile file or card id) are shown escaped, so the
    message is safe to print; :attr:`path` keeps the name as given.
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | os.PathLike[str] | None = None,
        line: int | None = None,
        field: str | None = None,
    ) -> None:
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.field = field
        self.reason = message
        super().__init__(self._compose())

    def _compose(self) -> str:
        where: list[str] = []
        if self.path:
            where.append(printable(str(self.path)))
        if self.line is not None:
            where.append(f"line {self.line}")
        if self.field:
            where.append(f"field {self.field!r}")
        reason = printable(self.reason)
        return f"{', '.join(where)}: {reason}" if where else reason
