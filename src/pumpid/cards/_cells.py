"""The cells of a table: columns as they are read, a line's fields, the header test, the
columns kept beside position and load, and the recognition of a headerless table's roles.

Helpers of :mod:`pumpid.cards._table`, kept apart so that the row reader stays one page of
logic.
"""

from __future__ import annotations

import csv
from array import array
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ._common import Opts, Raw, scalar
from ._errors import CardError
from ._roles import ROLE_CONFIDENCE_MIN, ColumnRoles, detect_column_roles
from ._stamps import is_dated_stamp, is_stamp, parse_date
from ._text import is_complex_text, is_number, number_problem

__all__ = [
    "DETECT_ROWS", "Column", "cli_hint", "detect_roles", "keep_extra", "looks_like_header",
    "splitter",
]

# Rows of a headerless table looked at to recognise its columns.
DETECT_ROWS = 20_000


def cli_hint(position: int, load: int) -> str:
    """How to name a headerless table's position and load columns, in Python and on the
    command line."""
    return (
        f"name them with columns={{'position': {position}, 'load': {load}}} "
        f"(command line: --columns position={position},load={load})"
    )


class Column:
    """The cells of one column: floats, plus interned text for cells that are not numbers."""

    __slots__ = ("first_text", "ids", "names", "texts", "values")

    def __init__(self, with_values: bool = True) -> None:
        self.values: array[float] | None = array("d") if with_values else None
        self.ids: array[int] | None = None  # text id per row, -1 for numbers
        self.texts: dict[str, int] = {}
        self.names: list[str] = []
        self.first_text: tuple[int, str] | None = None  # (line, token) of the first text

    def intern(self, tok: str) -> int:
        k = self.texts.get(tok)
        if k is None:
            k = self.texts[tok] = len(self.names)
            self.names.append(tok)
        return k

    def has_text(self) -> bool:
        return self.ids is not None


def splitter(o: Opts, delimiter: str | None) -> Callable[[str, int], list[str]]:
    """A function splitting a line into its fields: on ``delimiter`` (quotes honoured), or on
    whitespace where it is None."""
    if delimiter is None:
        return lambda line, _lineno: line.split()

    def split(line: str, lineno: int) -> list[str]:
        if '"' not in line:  # no quoting: a plain split is what the csv module would do
            return [tok.strip() for tok in line.split(delimiter)]
        try:
            tokens = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))
        except (csv.Error, StopIteration) as exc:
            raise o.error(f"cannot split the line into fields: {exc}", line=lineno) from exc
        return [tok.strip() for tok in tokens]

    return split


def looks_like_header(tokens: list[str]) -> bool:
    """Whether a table's first line names its columns (any field is words, not a value)."""
    # Complex numbers are numbers written wrongly, not column names: refuse them later;
    # date/time stamps are a time column's values.
    return any(tok and not is_number(tok) and not is_complex_text(tok) and not is_stamp(tok)
               for tok in tokens)


def keep_extra(
    raw: Raw,
    name: str,
    vals: NDArray[np.float64] | None,
    ids: NDArray[np.int64] | None,
    start: int,
    end: int,
    first: str,
    notes: list[str],
    hint: bool = True,
) -> None:
    """Keep a column that is neither position nor load on the card: a value constant over
    the card as metadata, varying numbers as a per-sample array, varying text as a note
    (a column of stamps dates the card by its first; ``hint``: say how to read it as the
    time, unless the caller asked for no time column)."""
    assert vals is not None
    if name == "column_roles":  # the reader's own record keeps its key
        name = "column_roles (column)"
    v = vals[start:end]
    t = None if ids is None else ids[start:end]
    if t is not None and np.any(t >= 0):
        if np.all(t == t[0]):
            raw.metadata[name] = scalar(first)
        elif is_stamp(first) and parse_date(first) is None:
            dated = is_dated_stamp(first)
            if dated:  # its first stamp is when the card was recorded, timed by it or not
                raw.metadata.setdefault("first_sample_time", first)
            notes.append(
                f"column {name!r} has a date/time stamp per row ({first!r}, ...): not read as "
                "the card's time" + (" (its first stamp dates the card)" if dated else "")
                + (f"; to read it as the time, name it the time column (columns={{'t': "
                   f"{name!r}}}, command line --columns t={name})" if hint else ""))
        else:
            notes.append(f"column {name!r} has varying non-numeric values ({first!r}, ...); "
                         "not kept")
        return
    if np.all(v == v[0]) or np.all(np.isnan(v)):
        raw.metadata[name] = scalar(first)
    else:
        raw.row_arrays[name] = np.array(v)  # a copy: the file-wide column must not live on


def detect_roles(
    o: Opts,
    values: list[NDArray[np.float64] | None],
    cols: list[Column],
    roles: dict[str, int],
    nrows: int,
) -> ColumnRoles | None:
    """Recognise position and load in a headerless table, or refuse."""
    if nrows < o.min_samples:
        return None
    free = [c for c in range(len(cols)) if c not in roles.values()]
    # Without a header every column was a number on the first row: text further down is a
    # broken number, not a text column.
    broken = [cols[c].first_text for c in free if cols[c].first_text is not None]
    if broken:
        lineno, tok = min(broken)  # type: ignore[type-var]
        c = next(c for c in free if cols[c].first_text == (lineno, tok))
        raise o.error(
            (f"{tok!r} is a date/time stamp: name the column the time "
             f"(columns={{'t': {c}}}, command line --columns t={c})") if is_stamp(tok) else
            number_problem(tok) if tok else "empty value where a number is expected",
            line=lineno,
            field=f"column_{c}",
        )
    try:
        # A prefix of the rows decides as well as the whole (it holds many strokes), at a
        # bounded cost in memory and time for very long headerless records.
        found = detect_column_roles([values[c][:DETECT_ROWS] for c in free])  # type: ignore[index]
    except CardError as exc:
        raise o.error(
            f"no header, and the position and load columns cannot be recognised: {exc.reason}; "
            + cli_hint(free[0], free[1])
        ) from exc
    pos, load = free[found.position], free[found.load]
    other = {free[k]: d for k, d in found.other.items()}
    other.update({i: f"given role {r!r}" for r, i in roles.items()})
    scores = {}
    for pair, score in found.scores.items():
        p, q = (int(k) for k in pair.split(","))
        scores[f"{free[p]},{free[q]}"] = score
    found = ColumnRoles(
        position=pos,
        load=load,
        confidence=found.confidence,
        words=found.words,
        method=found.method,
        other=dict(sorted(other.items())),
        scores=scores,
    )
    if found.confidence < ROLE_CONFIDENCE_MIN:
        raise o.error(
            "no header, and which column is position and which is load cannot be told with "
            f"confidence: the best guess, position = column {pos} and load = column {load}, "
            f"has confidence {found.confidence:.2f} (below {ROLE_CONFIDENCE_MIN:g}); "
            + cli_hint(pos, load)
        )
    return found
