"""Format detection and the entry points :func:`read_cards`, :func:`read_card`, :func:`parse_cards`
and their each-card-on-its-own forms :func:`read_cards_and_errors`, :func:`parse_cards_and_errors`.

Each format has its own module (``_table``, ``_scada``, ``_jsonfile``, ``_ts``) turning text
into raw records, or a :class:`CardError` in place of a card it could not read (a file's
structure problems are raised); ``_common.build`` checks each record on its own and makes
the card. :func:`read_cards` raises the first error of either kind. The text is handed to
a reader in a one-element list that the reader empties, so that the only reference to the
text (and, for :func:`read_cards`, to the file's bytes) is gone once it has been read: the
memory of a large file is not held while its cards are built.
"""

from __future__ import annotations

import inspect
import math
import os
import re
import stat
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import islice
from pathlib import Path
from typing import Any

import numpy as np

from ._common import Opts, Raw, build, meaningful
from ._errors import CardError
from ._jsonfile import read_json
from ._scada import read_scada
from ._table import COLUMN_KEYS, read_table
from ._text import decode, interpret_name, normalize_name
from ._ts import read_ts
from ._types import Card
from ._units import normalize_load_unit, normalize_position_unit

__all__ = [
    "FORMATS",
    "CardsRead",
    "detect_format",
    "parse_cards",
    "parse_cards_and_errors",
    "read_card",
    "read_cards",
    "read_cards_and_errors",
]

#: Format names accepted by ``format=`` (aliases: ``tsv`` -> csv with tabs, ``txt``/``table``
#: -> whitespace, ``pipe`` -> scada, ``sktime`` -> ts).
FORMATS = ("csv", "scada", "json", "whitespace", "ts")

_FORMAT_ALIASES = {
    "csv": "csv", "tsv": "csv", "scada": "scada", "pipe": "scada", "json": "json",
    "whitespace": "whitespace", "txt": "whitespace", "table": "whitespace", "ts": "ts",
    "sktime": "ts",
}  # fmt: skip

_SCADA_CARDS = ("surface", "downhole", "both")
_DELIMITERS = ("\t", ";", ",", "|")
# Lines looked at to detect the format and the delimiter.
_SNIFF_LINES = 30
_FIRST_CHAR = re.compile(r"\S")

ColumnSpec = Mapping[str, str | int | None]


# --------------------------------------------------------------------------- detection
def _first_lines(text: str) -> list[str]:
    return [ln for _, ln in islice(meaningful(text), _SNIFF_LINES)]


def _sniff_delimiter(lines: Sequence[str]) -> str | None:
    sample = [ln for ln in lines[:30] if ln.strip()]
    if not sample:
        return None
    for d in _DELIMITERS:  # same non-zero count on every line: the reliable signal
        counts = {ln.count(d) for ln in sample}
        if len(counts) == 1 and counts.pop() > 0:
            return d
    for d in _DELIMITERS:  # ragged file: take a delimiter present everywhere
        if all(d in ln for ln in sample):
            return d
    for d in _DELIMITERS:
        if d in sample[0]:
            return d
    return None


def _looks_scada(lines: Sequence[str]) -> bool:
    header = [normalize_name(f) for f in lines[0].strip().strip("|").split("|")]
    bases = {interpret_name(f)[1] for f in lines[0].strip().strip("|").split("|")}
    listy = {"surface_positions", "surface_loads", "downhole_positions", "downhole_loads",
             "positions", "loads", "surface_position", "surface_load"}  # fmt: skip
    if bases & listy or set(header) & listy:
        return True
    # One card per row: fields of a data row hold comma-separated lists.
    return len(lines) > 1 and any("," in f for f in lines[1].split("|"))


def detect_format(text: str, *, path: str = "<data>") -> str:
    """Guess the card format from the content of a file.

    Parameters
    ----------
    text : str
        Decoded file content.
    path : str, optional
        Name used in error messages.

    Returns
    -------
    str
        One of :data:`FORMATS`: ``"json"`` when the content starts with ``{`` or ``[``;
        ``"ts"`` when the first non-comment line is an ``@`` tag; ``"scada"`` for pipe-delimited
        one-card-per-row exports; ``"csv"`` when a comma, semicolon, tab or pipe delimiter is
        found; ``"whitespace"`` otherwise.

    Raises
    ------
    CardError
        If the content is empty or holds only comments.
    """
    first_char = _FIRST_CHAR.search(text)  # no stripped copy of a large text
    if first_char is None:
        raise CardError("empty file", path=path)
    if first_char.group() in "{[":
        return "json"
    lines = _first_lines(text)
    if not lines:
        raise CardError("no data: the file holds only comments", path=path)
    first = lines[0].strip()
    if first.startswith("@"):
        return "ts"
    if "|" in first and _looks_scada(lines):
        return "scada"
    if _sniff_delimiter(lines) is not None:
        return "csv"
    return "whitespace"


# --------------------------------------------------------------------------- entry points
def _check_options(
    path: str,
    *,
    format: str | None,
    position_unit: str | None,
    load_unit: str | None,
    spm: float | None,
    period: float | None,
    columns: ColumnSpec | None,
    well_id: str | None,
    min_samples: int,
    scada_cards: str,
) -> tuple[str | None, str | None, str | None, float | None, float | None, dict[str, Any] | None]:
    fmt = None
    if format is not None:
        if not isinstance(format, str) or format.lower() not in _FORMAT_ALIASES:
            raise CardError(
                f"unknown format {format!r}; known formats: {', '.join(FORMATS)} "
                "(aliases: tsv, txt, table, pipe, sktime)",
                path=path,
                field="format",
            )
        fmt = format.lower()
    try:
        pu = None if position_unit is None else normalize_position_unit(position_unit)
        lu = None if load_unit is None else normalize_load_unit(load_unit)
    except CardError as exc:
        raise CardError(exc.reason, path=path, field=exc.field) from exc
    rates = {}
    for name, value in (("spm", spm), ("period", period)):
        if value is None:
            rates[name] = None
            continue
        if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
            raise CardError(f"{name} must be a number", path=path, field=name)
        v = float(value)
        if not (math.isfinite(v) and v > 0):
            raise CardError(
                f"{name} must be positive and finite, got {value!r}", path=path, field=name
            )
        rates[name] = v
    if rates["spm"] is not None and rates["period"] is not None:
        if abs(60.0 / rates["spm"] - rates["period"]) > 1e-6 * rates["period"]:
            raise CardError(
                f"spm={rates['spm']:g} and period={rates['period']:g} s disagree "
                f"(60/spm = {60 / rates['spm']:g} s); give only one",
                path=path,
                field="period",
            )
        rates["period"] = None
    cols: dict[str, Any] | None = None
    if columns is not None:
        if not isinstance(columns, Mapping):
            raise CardError(
                "columns must be a mapping such as {'load': 0, 'position': 1}",
                path=path,
                field="columns",
            )
        cols = {}
        for key, spec in columns.items():
            if key not in COLUMN_KEYS:
                raise CardError(
                    f"unknown columns key {key!r}; known: {', '.join(sorted(COLUMN_KEYS))}",
                    path=path,
                    field="columns",
                )
            if spec is not None and (isinstance(spec, bool) or not isinstance(spec, str | int)):
                raise CardError(
                    f"columns[{key!r}] must be a column name, a 0-based index or None",
                    path=path,
                    field="columns",
                )
            if isinstance(spec, int) and spec < 0:
                raise CardError(f"columns[{key!r}] must be >= 0", path=path, field="columns")
            if COLUMN_KEYS[key] in {COLUMN_KEYS[k] for k in cols}:
                raise CardError(f"columns gives {key!r} twice", path=path, field="columns")
            cols[key] = spec
    if well_id is not None and not isinstance(well_id, str):
        raise CardError("well_id must be a string", path=path, field="well_id")
    if isinstance(min_samples, bool) or not isinstance(min_samples, int) or min_samples < 2:
        raise CardError("min_samples must be an integer >= 2", path=path, field="min_samples")
    if scada_cards not in _SCADA_CARDS:
        raise CardError(
            f"scada_cards must be one of {', '.join(_SCADA_CARDS)}", path=path, field="scada_cards"
        )
    return fmt, pu, lu, rates["spm"], rates["period"], cols


def _read(
    holder: list[bytes | str],
    name: str,
    *,
    format: str | None,
    position_unit: str | None,
    load_unit: str | None,
    spm: float | None,
    period: float | None,
    columns: ColumnSpec | None,
    well_id: str | None,
    min_samples: int,
    drop_closing_point: bool,
    scada_cards: str,
    encoding: str | None,
) -> list[Card]:
    """Decode, detect, read and build; ``holder`` holds the content and is emptied."""
    fmt, pu, lu, spm_v, period_v, cols = _check_options(
        name,
        format=format,
        position_unit=position_unit,
        load_unit=load_unit,
        spm=spm,
        period=period,
        columns=columns,
        well_id=well_id,
        min_samples=min_samples,
        scada_cards=scada_cards,
    )
    if encoding is not None and not isinstance(encoding, str):
        raise CardError("encoding must be a codec name such as 'utf-16'", path=name,
                        field="encoding")  # fmt: skip
    data = holder.pop()
    if isinstance(data, bytearray | memoryview):
        data = bytes(data)
    text, decode_notes = decode(data, path=name, encoding=encoding)
    del data  # the bytes are not needed any more (and nobody else holds them for read_cards)
    if not text or text.isspace():
        raise CardError("empty file", path=name)
    if fmt is None:
        fmt = detect_format(text, path=name)
    canonical = _FORMAT_ALIASES[fmt]
    delimiter: str | None = None
    if canonical == "csv":
        if fmt == "tsv":
            delimiter = "\t"
        else:
            delimiter = _sniff_delimiter(_first_lines(text))
            if delimiter is None:
                raise CardError(
                    "no delimiter (comma, semicolon, tab or '|') found: not a delimited table",
                    path=name,
                )
    how = "format given" if format else "format detected"
    if delimiter is not None:
        how += f", delimiter {delimiter!r}"
    file_name = Path(name).name or name
    o = Opts(
        path=name,
        name=file_name,
        stem=Path(file_name).stem or file_name,
        position_unit=pu,
        load_unit=lu,
        spm=spm_v,
        period=period_v,
        columns=cols,
        well_id=well_id,
        min_samples=min_samples,
        drop_closing_point=bool(drop_closing_point),
        scada_cards=scada_cards,
        delimiter=delimiter,
        file_notes=(*decode_notes, f"read as {canonical} ({how})"),
    )
    text_holder = [text]
    del text
    raws: list[Raw | CardError]
    with np.errstate(all="ignore"):  # every overflow is checked explicitly, with its line
        if canonical in ("csv", "whitespace"):
            raws = read_table(o, text_holder, delimiter)
        elif canonical == "scada":
            raws = read_scada(o, text_holder, COLUMN_KEYS)
        elif canonical == "json":
            raws = read_json(o, text_holder)
        else:
            raws = read_ts(o, text_holder, COLUMN_KEYS)
        # Build one card at a time and let go of its raw numbers as soon as it is made;
        # each card is checked on its own, so one broken card is an error in its place.
        raws.reverse()
        said: set[str] = set()
        items: list[Card | CardError] = []
        while raws:
            raw = raws.pop()
            if isinstance(raw, CardError):
                if o.well_id is not None:  # the caller's well wins, as on the good cards
                    raw.well_id = o.well_id
                items.append(raw)
                continue
            try:
                items.append(build(raw, o, said))
            except CardError as exc:
                items.append(exc.for_card(raw.card_id, o.well_id or raw.well_id))
    return items


def _not_regular(mode: int) -> str:
    """What a file that is not a regular file is, in words ('' for a regular file)."""
    if stat.S_ISREG(mode):
        return ""
    for test, words in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
                        (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                        (stat.S_ISSOCK, "a socket")):  # fmt: skip
        if test(mode):
            return words
    return "a special file"


@dataclass(frozen=True)
class CardsRead:
    """What :func:`read_cards_and_errors` found in a file: every card, each on its own.

    Attributes
    ----------
    items : tuple of Card or CardError
        In file order: each card that passed its checks, and a :class:`CardError` in place
        of each card that did not (its ``card_id``, and ``well_id`` when the file states
        it, are set; ``line`` and ``field`` say where).
    """

    items: tuple[Card | CardError, ...]

    @property
    def cards(self) -> list[Card]:
        """The cards that passed their checks, in file order."""
        return [c for c in self.items if isinstance(c, Card)]

    @property
    def errors(self) -> list[CardError]:
        """One error per refused card, in file order."""
        return [c for c in self.items if isinstance(c, CardError)]


def _first_error(items: list[Card | CardError], companion: str) -> list[Card]:
    errors = [item for item in items if isinstance(item, CardError)]
    if not errors:
        return items  # type: ignore[return-value]
    good = len(items) - len(errors)
    if not good:
        raise errors[0]
    # The strict reader refuses the file, but a user who meets this on one bad card of a
    # long export should learn at once that the rest of the file is fine and how to keep it.
    cards = "card" if good == 1 else "cards"
    others = f"{len(errors) - 1} more" if len(errors) > 1 else "no other"
    hint = (f"{errors[0].reason} ({others} refused; {good} {cards} of this file passed "
            f"their checks: {companion} keeps them and lists the refused ones)")
    raise CardError(hint, path=errors[0].path, line=errors[0].line, field=errors[0].field,
                    card_id=errors[0].card_id, well_id=errors[0].well_id) from errors[0]


def parse_cards(data: bytes | str, *, name: str = "<data>", **options: Any) -> list[Card]:
    """Read cards from file content already in memory.

    Same as :func:`read_cards`, but takes the bytes or text of the file and a ``name`` used
    in messages and in :attr:`Card.source`.

    Parameters
    ----------
    data : bytes or str
        The content of a card file.
    name : str, default "<data>"
        What to call the content in messages and in :attr:`Card.source`.
    **options
        Exactly the keywords of :func:`read_cards` (``format``, ``position_unit``,
        ``load_unit``, ``spm``, ``period``, ``columns``, ``well_id``, ``min_samples``,
        ``drop_closing_point``, ``scada_cards``, ``encoding``), with the same defaults.

    Returns
    -------
    list of Card

    Raises
    ------
    CardError
        For every problem with the content or the options' values.
    TypeError
        For a keyword that :func:`read_cards` does not take (the message names it and lists
        the known ones).
    """
    _reading_options(options, "parse_cards")  # so a misspelt keyword names this function
    return _first_error(list(parse_cards_and_errors(data, name=name, **options).items),
                        "parse_cards_and_errors")


def _options(scope: dict[str, Any]) -> dict[str, Any]:
    """The reading options among a reader's arguments (all but the data and its name)."""
    return {k: v for k, v in scope.items() if k not in ("data", "name", "path")}


def _reading_defaults() -> dict[str, Any]:
    """The keyword-only parameters of :func:`read_cards` and their defaults: the one list of
    reading options, so the in-memory readers cannot drift from the file readers."""
    return {n: p.default for n, p in inspect.signature(read_cards).parameters.items()
            if p.kind is inspect.Parameter.KEYWORD_ONLY}


def _reading_options(options: dict[str, Any], who: str) -> dict[str, Any]:
    """``options`` over :func:`read_cards`' defaults; a keyword it does not take is a
    TypeError, as Python gives for a misspelt keyword of a function that declares them."""
    known = _reading_defaults()
    unknown = [k for k in options if k not in known]
    if unknown:
        raise TypeError(f"{who}() got an unexpected keyword argument {unknown[0]!r} "
                        f"(known: name, {', '.join(known)})")
    return known | options


def parse_cards_and_errors(data: bytes | str, *, name: str = "<data>",
                           **options: Any) -> CardsRead:
    """Read cards from content in memory, each on its own (see :func:`read_cards_and_errors`).

    Parameters
    ----------
    data : bytes or str
        The content of a card file.
    name : str, default "<data>"
        What to call the content in messages and in :attr:`Card.source`.
    **options
        Exactly the keywords of :func:`read_cards`, with the same defaults.

    Returns
    -------
    CardsRead

    Raises
    ------
    CardError
        Only for a problem of the whole content or of the options' values.
    TypeError
        For a keyword that :func:`read_cards` does not take (named, with the known ones).
    """
    reading = _reading_options(options, "parse_cards_and_errors")
    if not isinstance(data, bytes | bytearray | memoryview | str):
        raise CardError(f"data must be bytes or str, got {type(data).__name__}", path=name)
    if not isinstance(name, str):
        raise CardError(f"name must be a string, got {type(name).__name__}")
    return CardsRead(tuple(_read([data], name, **reading)))


def read_cards(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    position_unit: str | None = None,
    load_unit: str | None = None,
    spm: float | None = None,
    period: float | None = None,
    columns: ColumnSpec | None = None,
    well_id: str | None = None,
    min_samples: int = 20,
    drop_closing_point: bool = True,
    scada_cards: str = "surface",
    encoding: str | None = None,
) -> list[Card]:
    """Read every dynamometer card in a file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    format : str, optional
        One of :data:`FORMATS` (or an alias: ``tsv``, ``txt``, ``table``, ``pipe``,
        ``sktime``). None detects the format from the content (see :func:`detect_format`).
    position_unit, load_unit : str, optional
        Units of the values in the file. They take precedence over units stated in the file
        (a note records any disagreement). Values are never converted here; use
        :meth:`Card.to_units`.
    spm, period : float, optional
        Strokes per minute or stroke period (s) for files without a time column. Time is then
        rebuilt assuming uniform sampling over one stroke, ``t_i = i*T/N`` for the ``N``
        distinct samples (over each stroke of a card that holds several, with a warning: see
        :func:`time_from_rate`). They override a stroke rate given in the file. A time column in
        the file always wins over both (the rate is then only stored).
    columns : mapping, optional
        Role -> column. Roles: ``t``, ``position``, ``load``, ``card``, ``well``, ``spm``,
        ``period``, ``closure``. Values: a header name, a 0-based column index, or None to
        ignore a column that would otherwise be recognised. For ``.ts`` files the values are
        dimension numbers (default position 0, load 1). Given columns always win. Without a
        header and without ``columns``, the position and load columns are recognised from
        their shapes (see :func:`detect_column_roles`); a note and
        ``metadata["column_roles"]`` say which and how sure, and below
        :data:`ROLE_CONFIDENCE_MIN` the read is refused with a message asking for
        ``columns=`` (on the command line ``--columns position=1,load=0``).
    well_id : str, optional
        Well identifier to put on every card (overrides the file's, with a note).
    min_samples : int, default 20
        Fewer samples than this in a card is an error.
    drop_closing_point : bool, default True
        For cards without a time column, drop a last sample that repeats the first one in
        both position and load (relative tolerance 1e-9), with a note.
    scada_cards : {"surface", "downhole", "both"}, default "surface"
        For SCADA exports: which card(s) of each row to return. With ``"surface"`` the
        downhole lists, if any, are kept unchecked in ``metadata["downhole_position"]`` and
        ``metadata["downhole_load"]``; ``"downhole"`` and ``"both"`` return checked downhole
        cards with ids ending in ``/downhole``.
    encoding : str, optional
        Text encoding (any Python codec name); it wins over detection. By default a
        byte-order mark decides (UTF-8, UTF-16, UTF-32), else the zero-byte pattern of
        UTF-16/UTF-32 text, else UTF-8, falling back to Latin-1 with a note.

    Returns
    -------
    list of Card
        In file order. Each card's :attr:`~Card.notes` say what was done to its data, and
        its :attr:`~Card.warnings` what looks implausible (see :mod:`pumpid.cards`).

    Raises
    ------
    CardError
        For the first problem, of the file or of any one card (use
        :func:`read_cards_and_errors` to keep the good cards of a file with broken ones):
        unreadable, undecodable or empty file, unknown format or unit,
        unparsable or complex number, NaN/inf, fewer than ``min_samples`` samples, time not
        strictly increasing, mismatched lengths, constant load or position, a card's rows in
        separate blocks, column roles that cannot be recognised. The message names the
        file, the line or field, and what is wrong; no other exception escapes.

    Notes
    -----
    Supported formats: delimited tables with or without header (comma, semicolon, tab,
    pipe; a card-id column splits the file into cards), pipe-delimited SCADA exports with
    one card per row, JSON (one card object, a list, or ``{"cards": [...]}``), whitespace
    tables (Fortran-style numbers allowed) and sktime ``.ts`` files with two dimensions.
    """
    return _first_error(list(read_cards_and_errors(path, **_options(locals())).items),
                        "read_cards_and_errors")


def read_cards_and_errors(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    position_unit: str | None = None,
    load_unit: str | None = None,
    spm: float | None = None,
    period: float | None = None,
    columns: ColumnSpec | None = None,
    well_id: str | None = None,
    min_samples: int = 20,
    drop_closing_point: bool = True,
    scada_cards: str = "surface",
    encoding: str | None = None,
) -> CardsRead:
    """Read every card of a file, each on its own: a broken card does not cost the others.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    **options
        As for :func:`read_cards` (the same keywords).

    Returns
    -------
    CardsRead
        ``.cards``: the cards that passed their checks; ``.errors``: a :class:`CardError` per
        card that did not (a NaN or unparsable value, lists of different lengths, a bad
        value even in a field not used, too few samples ...), with the file, line and field
        and the card's ``card_id`` (and ``well_id`` when stated); ``.items``: both in file
        order.

    Raises
    ------
    CardError
        Only for a problem of the whole file or of the options: unreadable, undecodable or
        empty file, unknown format or unit in a header, no position or load column, invalid
        JSON, column roles that cannot be recognised.

    Notes
    -----
    A card is a block of rows with one card id (tables), a row (SCADA exports), an object
    (JSON), a series (``.ts``). A file without a card-id column is one card, so its problem
    is the file's. A broken row of a table belongs to the card its id names (or, when its id
    cannot be read, to the card above it).
    """
    try:
        p = os.fspath(path)
    except TypeError as exc:
        raise CardError(f"path must be a string or path-like, got {type(path).__name__}") from exc
    if isinstance(p, bytes):
        p = os.fsdecode(p)
    try:
        kind = _not_regular(os.stat(p).st_mode)
        if kind:  # reading a pipe or a terminal would wait forever for its end
            raise CardError(f"not a regular file but {kind}: give a card file", path=p)
        data = Path(p).read_bytes()
    except OSError as exc:
        raise CardError(f"cannot read the file: {exc.strerror or exc}", path=p) from exc
    holder: list[bytes | str] = [data]
    del data  # _read drops the bytes once decoded
    return CardsRead(tuple(_read(
        holder,
        str(p),
        format=format,
        position_unit=position_unit,
        load_unit=load_unit,
        spm=spm,
        period=period,
        columns=columns,
        well_id=well_id,
        min_samples=min_samples,
        drop_closing_point=drop_closing_point,
        scada_cards=scada_cards,
        encoding=encoding,
    )))


def read_card(path: str | os.PathLike[str], **options: Any) -> Card:
    """Read a file that must hold exactly one card.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    **options
        As for :func:`read_cards`.

    Returns
    -------
    Card

    Raises
    ------
    CardError
        As :func:`read_cards`, and when the file holds more than one card.
    """
    cards = read_cards(path, **options)
    if len(cards) != 1:
        ids = ", ".join(repr(c.card_id) for c in cards[:5]) + (", ..." if len(cards) > 5 else "")
        raise CardError(
            f"expected exactly one card, found {len(cards)} ({ids}); use read_cards",
            path=os.fspath(path),
        )
    return cards[0]
