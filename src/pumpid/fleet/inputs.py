"""The inputs of a batch run: which files, and the stream of cards they hold.

Files and folders are given; folders are searched recursively for files whose name ends in
one of :data:`CARD_SUFFIXES` (hidden files and folders, names starting with ``.``, are
left out), in sorted order. A file named explicitly is always read, whatever its name. A
file is read as the Parquet long layout (:mod:`pumpid.fleet.dataset`) when its first bytes
are Parquet's magic number or its name ends in ``.parquet``/``.pq``; otherwise with
:func:`pumpid.cards.read_cards`, which detects the format.

:func:`iter_items` turns the files into one stream of items in a fixed order: every card
(:class:`CardItem`) and, in place of what could not be read, a :class:`BadItem`: one card
of a file (a NaN, an unparsable value, lists of different lengths, in any layout; the
file's other cards are read, see :func:`pumpid.cards.read_cards_and_errors`), or a whole
file (unreadable, binary, no position column). A card's id in the run is the reader's id
when no earlier item of the stream has it, else the id followed by its source in brackets,
so ids are unique in the run and the same on every run over the same inputs. A text file
refused as a whole keeps the well and card time it states in a well or timestamp column or
key, when it states a single one; an unreadable file (binary, a broken Parquet file) names
no well. Named inputs that are neither files nor folders (a named pipe, a device) are
refused before the run.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import stat
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pumpid.cards import Card, CardError, read_cards_and_errors, split_strokes

from .dataset import ParquetCardError, iter_parquet_cards

__all__ = [
    "CARD_SUFFIXES",
    "BadItem",
    "CardItem",
    "InputFile",
    "ReadOptions",
    "find_inputs",
    "is_parquet",
    "iter_items",
]

#: Name endings of the files a folder search picks up (case-insensitive).
CARD_SUFFIXES = (".csv", ".tsv", ".txt", ".dat", ".json", ".ts", ".parquet", ".pq")
_PARQUET_SUFFIXES = (".parquet", ".pq")
_PARQUET_MAGIC = b"PAR1"


@dataclass(frozen=True)
class InputFile:
    """One input file: its name in the results, where it is, and what it was when listed.

    Attributes
    ----------
    name : str
        The path as the user gave it, joined with the path below a given folder: the
        ``file`` column of the results and the start of ``source``.
    path : str
        The absolute path.
    size : int
        Bytes.
    mtime_ns : int
        Last modification, nanoseconds since the epoch.
    """

    name: str
    path: str
    size: int
    mtime_ns: int

    def to_dict(self) -> dict[str, Any]:
        """The manifest's form."""
        return {"name": self.name, "path": self.path, "size": self.size,
                "mtime_ns": self.mtime_ns}

    @classmethod
    def of(cls, name: str, path: Path) -> InputFile:
        """The file at ``path`` as it is now."""
        st = path.stat()
        return cls(name=name, path=str(path.resolve()), size=st.st_size, mtime_ns=st.st_mtime_ns)


@dataclass(frozen=True)
class ReadOptions:
    """Options of the readers, the same for every file of a run (see
    :func:`pumpid.cards.read_cards`)."""

    format: str | None = None
    position_unit: str | None = None
    load_unit: str | None = None
    spm: float | None = None
    period: float | None = None
    columns: Mapping[str, str | int | None] | None = None
    split_strokes: bool = False
    encoding: str | None = None
    #: The well of every card read (over the files' own).
    well_id: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The manifest's form."""
        return {"format": self.format, "position_unit": self.position_unit,
                "load_unit": self.load_unit, "spm": self.spm, "period": self.period,
                "columns": None if self.columns is None else dict(self.columns),
                "split_strokes": self.split_strokes, "encoding": self.encoding,
                "well_id": self.well_id}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ReadOptions:
        """The options of :meth:`to_dict`'s form (a manifest's)."""
        known = ("format", "position_unit", "load_unit", "spm", "period", "columns",
                 "split_strokes", "encoding", "well_id")
        return cls(**{k: data[k] for k in known if k in data})


@dataclass(frozen=True)
class CardItem:
    """A card of the stream, with its id in the run and where it came from."""

    card: Card
    card_id: str
    source: str
    file: str


@dataclass(frozen=True)
class BadItem:
    """Input that could not be read: a whole file (``whole_file``), or one card of it."""

    card_id: str
    source: str
    file: str
    reason: str
    well_id: str | None = None
    whole_file: bool = False
    time: str | None = None


def _hidden(rel: Path) -> bool:
    return any(part.startswith(".") for part in rel.parts)


def find_inputs(
    inputs: Sequence[str | os.PathLike[str]], *, exclude: Sequence[str | os.PathLike[str]] = ()
) -> list[InputFile]:
    """List the files of a run: named files, and the card files found in named folders.

    Parameters
    ----------
    inputs : sequence of path
        Files and folders.
    exclude : sequence of path, optional
        Folders whose files are never inputs (the run's own results and reports).

    Returns
    -------
    list of InputFile
        Each file once (the first name it was found under), folders' files in sorted order.

    Raises
    ------
    FileNotFoundError
        If an input does not exist.
    pumpid.cards.CardError
        If an input is neither a file nor a folder (a named pipe, a device).
    """
    skip = [Path(os.fspath(p)).resolve() for p in exclude]
    seen: set[str] = set()
    out: list[InputFile] = []

    def add(name: str, path: Path) -> None:
        real = path.resolve()
        if str(real) in seen or any(real == s or s in real.parents for s in skip):
            return
        seen.add(str(real))
        out.append(InputFile.of(os.path.normpath(name), path))

    for given in inputs:
        text = os.fspath(given)
        root = Path(text)
        if root.is_dir():
            found = [p for p in root.rglob("*")
                     if p.is_file() and p.name.lower().endswith(CARD_SUFFIXES)
                     and not _hidden(p.relative_to(root))]
            for p in sorted(found, key=lambda q: q.relative_to(root).as_posix()):
                add(os.path.join(text, p.relative_to(root).as_posix()), p)
        elif root.is_file():
            add(text, root)
        elif root.exists():  # a pipe or a device: reading it would block or give nothing
            raise CardError(f"not a regular file but {_kind(root)}: give card files or folders",
                            path=text)
        else:
            raise FileNotFoundError(2, "no such file or folder", text)
    return out


def _kind(path: Path) -> str:
    """What a path that is neither a file nor a folder is, in words."""
    mode = path.stat().st_mode
    for test, words in ((stat.S_ISFIFO, "a named pipe (FIFO)"),
                        (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                        (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return words
    return "a special file"


def is_parquet(path: str) -> bool:
    """Whether ``path`` is a Parquet file (by its name, else by its first bytes)."""
    if path.lower().endswith(_PARQUET_SUFFIXES):
        return True
    try:
        with open(path, "rb") as fh:
            return fh.read(4) == _PARQUET_MAGIC
    except OSError:
        return False


def _source(name: str, reader_source: str, base: str) -> str:
    """The reader's source (``"W1.csv, lines 2-101"``) with the file's name in the run."""
    if reader_source.startswith(base):
        return name + reader_source[len(base):]
    return f"{name}, {reader_source}" if reader_source else name


def _cards_of(file: InputFile, options: ReadOptions) -> Iterator[Card | CardError]:
    if is_parquet(file.path):
        for got in iter_parquet_cards(file.path, position_unit=options.position_unit,
                                      load_unit=options.load_unit, spm=options.spm,
                                      period=options.period):
            yield (dataclasses.replace(got, well_id=options.well_id)
                   if options.well_id is not None and isinstance(got, Card) else got)
        return
    # Each card on its own: a broken card is an error in its place, its neighbours are read.
    yield from read_cards_and_errors(
        file.path, format=options.format, position_unit=options.position_unit,
        load_unit=options.load_unit, spm=options.spm, period=options.period,
        columns=options.columns, encoding=options.encoding, well_id=options.well_id).items


# Column and key names (lower case, units and punctuation dropped) under which the text
# layouts state a card's well and its time; "time" alone is a sample's time in a table.
_WELL_NAMES = frozenset({"well", "well_id", "wellid", "well_name"})
_TIME_NAMES = frozenset({"timestamp", "card_time", "datetime", "date_time"})
# Enough of a file for its header and first rows; a broken card is rarely larger.
_PEEK_BYTES = 1 << 20


def _key(name: str) -> str:
    name = re.sub(r"[\(\[].*?[\)\]]", "", name).strip().lower()
    return re.sub(r"[\s.\-]+", "_", name).strip("_")


def _only(values: Sequence[Any]) -> str | None:
    seen = {str(v).strip() for v in values if v is not None and str(v).strip()}
    return seen.pop() if len(seen) == 1 else None


def _stated_identity(path: str) -> tuple[str | None, str | None]:
    """The well and card time a text file states in its own columns or keys, when it
    states one of each; (None, None) when it cannot tell.

    A reader refuses a whole file for one bad card (a NaN, a truncated list, a constant
    load) and so names no card; the file may still say plainly whose card it held, and a
    row filed under no well is lost to that well's history.
    """
    try:
        with open(path, "rb") as fh:
            raw = fh.read(_PEEK_BYTES)
    except OSError:
        return None, None
    if b"\0" in raw:
        return None, None
    text = raw.decode("utf-8", errors="replace").lstrip("\ufeff")
    if text.lstrip().startswith(("{", "[")):
        return _json_identity(text)
    return _table_identity(text)


def _json_identity(text: str) -> tuple[str | None, str | None]:
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError):  # a hostile nesting depth is no identity either
        return None, None
    cards = doc if isinstance(doc, list) else doc.get("cards", [doc]) \
        if isinstance(doc, dict) else []
    cards = [c for c in cards if isinstance(c, dict)] if isinstance(cards, list) else []
    top = {_key(k): v for k, v in doc.items()} if isinstance(doc, dict) else {}
    wells, times = [], []
    for card in cards or [top]:
        keyed = {**top, **{_key(k): v for k, v in card.items()}}
        wells += [v for k, v in keyed.items() if k in _WELL_NAMES and isinstance(v, str)]
        times += [v for k, v in keyed.items() if k in _TIME_NAMES and isinstance(v, str)]
    # a time only when the file held one card: with several, which one failed is unknown
    return _only(wells), (_only(times) if len(cards) <= 1 else None)


def _table_identity(text: str) -> tuple[str | None, str | None]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        return None, None
    delimiter = max(",;\t|", key=lines[0].count)
    header = [_key(h) for h in lines[0].split(delimiter)]
    well = [i for i, h in enumerate(header) if h in _WELL_NAMES]
    when = [i for i, h in enumerate(header) if h in _TIME_NAMES]
    if not well and not when:
        return None, None
    rows = [ln.split(delimiter) for ln in lines[1:]]

    def column(found: list[int]) -> str | None:
        if len(found) != 1:
            return None
        return _only([r[found[0]].strip().strip('"') for r in rows if len(r) > found[0]])

    return column(well), column(when)


def _bad_file(file: InputFile, error: Exception) -> BadItem:
    if isinstance(error, CardError):
        where = error.place
        source = f"{file.name}, {where}" if where else file.name
        well, when = None, None
        if not is_parquet(file.path):
            try:
                well, when = _stated_identity(file.path)
            except Exception:  # best effort: the file's row must be written whatever it holds
                well, when = None, None
        return BadItem(card_id=file.name, source=source, file=file.name, reason=error.reason,
                       whole_file=True, well_id=well, time=when)
    # A reader must raise nothing else; if one does, the run still goes on and says so.
    return BadItem(card_id=file.name, source=file.name, file=file.name,
                   reason=f"the reader failed ({type(error).__name__}: {error})",
                   whole_file=True)


def iter_items(
    files: Sequence[InputFile],
    options: ReadOptions,
    *,
    on_file: Callable[[InputFile, list[CardItem | BadItem]], None] | None = None,
) -> Iterator[CardItem | BadItem]:
    """The run's stream: every card of every file in order, a :class:`BadItem` in place of
    what could not be read.

    Parameters
    ----------
    files : sequence of InputFile
        From :func:`find_inputs`.
    options : ReadOptions
        Reader options for every file.
    on_file : callable, optional
        Called with each file and its items once the file is read (before they are
        yielded): for progress displays and the run's list of unreadable files.

    Yields
    ------
    CardItem or BadItem
        With ids unique in the stream (see the module docstring). Nothing is raised for a
        file: an unreadable one (missing, binary, any reader error) is one BadItem.
    """
    taken: set[str] = set()

    def unique(raw: str, source: str) -> str:
        cid = raw if raw not in taken else f"{raw} ({source})"
        k = 2
        while cid in taken:
            cid = f"{raw} ({source}) #{k}"
            k += 1
        taken.add(cid)
        return cid

    for file in files:
        items = list(_file_items(file, options, unique))
        if on_file is not None:
            on_file(file, items)
        yield from items


def _file_items(file: InputFile, options: ReadOptions,
                unique: Callable[[str, str], str]) -> Iterator[CardItem | BadItem]:
    """The items of one file (ids made unique with ``unique``)."""
    base = Path(file.path).name
    identity: list[tuple[str | None, str | None]] = []

    def stated() -> tuple[str | None, str | None]:
        """The well and time the file states (read once, and only for a broken card)."""
        if not identity:
            try:
                identity.append(_stated_identity(file.path))
            except Exception:  # best effort: the card's row is written whatever the file holds
                identity.append((None, None))
        return identity[0]

    def named(bad: BadItem) -> BadItem:
        """An unreadable card of a run given its well is filed under that well too."""
        return bad if options.well_id is None else dataclasses.replace(
            bad, well_id=options.well_id)

    try:
        found = list(_cards_of(file, options))
    except Exception as exc:  # one bad file never stops the run
        yield named(_renamed(_bad_file(file, exc), unique))
        return
    for item in found:
        if isinstance(item, CardError):
            yield named(_bad_card(item, file, unique, stated))
            continue
        cards = [item]
        if options.split_strokes:
            try:
                cards = split_strokes(item)
            except CardError as exc:
                source = _source(file.name, item.source, base)
                yield BadItem(card_id=unique(item.card_id or file.name, source),
                              source=source, file=file.name, reason=exc.reason,
                              well_id=item.well_id)
                continue
        for card in cards:
            source = _source(file.name, card.source, base)
            yield CardItem(card=card, card_id=unique(card.card_id or file.name, source),
                           source=source, file=file.name)


def _bad_card(error: CardError, file: InputFile, unique: Callable[[str, str], str],
              stated: Callable[[], tuple[str | None, str | None]]) -> BadItem:
    """A card that failed its checks (the rest of its file is read); an error that names
    no card is the whole file's."""
    if error.card_id is None:
        return _renamed(_bad_file(file, error), unique)
    where = error.place
    well, when = error.well_id, None
    if isinstance(error, ParquetCardError):  # no lines in Parquet: the card names the place
        source = f"{file.name}, card {error.card_id}" + (f", {where}" if where else "")
    else:
        source = f"{file.name}, {where}" if where else file.name
        # The card's time, when its file states a single one (a file of one card, say): a
        # row filed under its well and time stays in that well's history.
        stated_well, stated_time = stated()
        if well is None or well == stated_well:
            well, when = well or stated_well, stated_time
    return BadItem(card_id=unique(error.card_id, source), source=source, file=file.name,
                   reason=error.reason, well_id=well, time=when)


def _renamed(bad: BadItem, unique: Callable[[str, str], str]) -> BadItem:
    return BadItem(card_id=unique(bad.card_id, bad.source), source=bad.source, file=bad.file,
                   reason=bad.reason, well_id=bad.well_id, whole_file=bad.whole_file,
                   time=bad.time)
