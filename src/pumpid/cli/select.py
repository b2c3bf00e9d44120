"""Which cards of a file a command fits: ``--card`` (given once or more) and
``--split-strokes``, with a row for each card refused on the way."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from ..cards import Card, CardError, printable, split_strokes
from .render import Row

__all__ = ["missing_rows", "refused_row", "selected"]


def refused_row(error: CardError, path: str) -> Row:
    """The row of a card of ``path`` that its reader refused (file, line and field named)."""
    return Row(card_id=error.card_id, source=", ".join(p for p in (path, error.place) if p),
               status="invalid-input", reason=str(error), well_id=error.well_id)


def selected(cards: list[Card], path: str, args: argparse.Namespace,
             errors: Sequence[CardError] = (), *, report_missing: bool = True
             ) -> tuple[list[Card], list[Row], set[str]]:
    """The cards of one file to fit (``--card``, given once or more, and
    ``--split-strokes``).

    Parameters
    ----------
    cards : list of Card
        The file's cards, in its order.
    path : str
        The file, for the rows' source.
    args : argparse.Namespace
        ``card`` (list of ids or None) and ``split_strokes``.
    errors : sequence of CardError
        The cards the reader refused.
    report_missing : bool
        Give a row for each id this file does not have (a single file's run); else the
        caller, which knows the other files, does.

    Returns
    -------
    cards : list of Card
        The cards (or strokes) to fit, in the file's order.
    rows : list of Row
        The cards refused: by the reader, by the stroke splitter, by ``--card``.
    answered : set of str
        The ids asked for that this file answers (found, or refused with a reason).
    """
    wanted: list[str] = list(dict.fromkeys(args.card or ()))
    ids = {c.card_id for c in cards}
    # A stroke's id (RECORD#k, as --split-strokes names them) is chosen after its record is
    # split; any other id names a record, looked for before.
    records: set[str] = set()
    strokes_of: dict[str, set[str]] = {}
    for want in wanted:
        record = want.rpartition("#")[0]
        if args.split_strokes and record and want not in ids:
            strokes_of.setdefault(record, set()).add(want)
        else:
            records.add(want)
    if wanted:
        # A record the reader refused answers its own id and its strokes' alike.
        errors = [e for e in errors if e.card_id in records or e.card_id in strokes_of]
    rows: list[Row] = [refused_row(e, path) for e in errors]
    refused_ids = {e.card_id for e in errors}
    answered = {w for w in wanted if w in ids or w in refused_ids
                or w.rpartition("#")[0] in refused_ids}
    if wanted:
        cards = [c for c in cards if c.card_id in records or c.card_id in strokes_of]
    if args.split_strokes:
        strokes: list[Card] = []
        for card in cards:
            try:
                pieces = split_strokes(card)
            except CardError as exc:
                rows.append(Row(card_id=card.card_id, source=card.source,
                                status="invalid-input", reason=str(exc), card=card))
                answered |= {card.card_id, *strokes_of.get(card.card_id, ())}
                continue
            names = {c.card_id for c in pieces}
            asked = strokes_of.get(card.card_id)
            strokes.extend(pieces if asked is None or card.card_id in records
                           else [c for c in pieces if c.card_id in asked])
            for want in sorted(asked or ()):
                answered.add(want)
                if want not in names:
                    listed = ", ".join(printable(c.card_id) for c in pieces)
                    rows.append(Row(card_id=want, source=path, status="invalid-input",
                                    reason=f"no stroke {printable(want)!r}: record "
                                           f"{printable(card.card_id)!r} splits into {listed}"))
        cards = strokes
    if report_missing:
        rows += missing_rows(cards_of=ids, wanted=[w for w in wanted if w not in answered],
                         where=f"in this file; its cards are: {_listed_ids(sorted(ids))}",
                         path=path)
    return cards, rows, answered


def _listed_ids(ids: Sequence[str]) -> str:
    more = f" and {len(ids) - 20} more" if len(ids) > 20 else ""
    return ", ".join(printable(c) for c in ids[:20]) + more


def missing_rows(cards_of: set[str], wanted: Sequence[str], where: str, path: str
                 ) -> list[Row]:
    """Rows for ids asked for with ``--card`` that no file has.

    Parameters
    ----------
    cards_of : set of str
        The ids of the file's cards (an id not among them that looks like ``RECORD#k`` is
        named as a stroke of ``RECORD``).
    wanted : sequence of str
        The ids not found.
    where : str
        Where they were looked for, in words ("in this file; its cards are: ...").
    path : str
        The rows' source.

    Returns
    -------
    list of Row
        One ``invalid-input`` row per id.
    """
    rows = []
    for want in wanted:
        record = want.rpartition("#")[0]
        name, of = (record, f" (of stroke {printable(want)!r})") if record and \
            want not in cards_of else (want, "")
        rows.append(Row(card_id=want, source=path, status="invalid-input",
                        reason=f"no card {printable(name)!r}{of} {where}"))
    return rows
