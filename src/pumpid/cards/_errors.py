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
    card_id, well_id : str, optional
        The card (and its well, when the file states it) the problem concerns, when it
        concerns one card of a file rather than the whole file (see
        :func:`pumpid.cards.read_cards_and_errors`).

    Attributes
    ----------
    path : str or None
    line : int or None
    field : str or None
    card_id : str or None
    well_id : str or None
    reason : str
        The message without the location prefix.
    place : str
        Where in the file: ``"line <n>, field '<name>'"``, the parts that are known.

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
        card_id: str | None = None,
        well_id: str | None = None,
    ) -> None:
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.field = field
        self.reason = message
        self.card_id = card_id
        self.well_id = well_id
        super().__init__(self._compose())

    def for_card(self, card_id: str | None, well_id: str | None = None) -> CardError:
        """The same problem, marked as concerning one card (its id and well)."""
        if type(self) is not CardError:  # a subclass carries its own ids already
            return self
        out = CardError(self.reason, path=self.path, line=self.line, field=self.field,
                        card_id=card_id, well_id=well_id)
        out.__cause__ = self.__cause__
        return out

    @property
    def place(self) -> str:
        """Where in its file the problem is: ``"line 39, field 'position_in'"``, either
        part left out when unknown (``""`` when both are)."""
        where: list[str] = []
        if self.line is not None:
            where.append(f"line {self.line}")
        if self.field:
            where.append(f"field {self.field!r}")
        return ", ".join(where)

    def _compose(self) -> str:
        where = ", ".join(p for p in (printable(str(self.path)) if self.path else "",
                                       self.place) if p)
        reason = printable(self.reason)
        return f"{where}: {reason}" if where else reason
