"""Text helpers shared by the readers: decoding, numbers, column names."""

from __future__ import annotations

import codecs
import re
from collections.abc import Iterator

from ._errors import CardError
from ._printable import printable
from ._units import is_unit_spelling

__all__ = [
    "ROLE_ALIASES",
    "decode",
    "interpret_name",
    "is_complex_text",
    "iter_lines",
    "normalize_name",
    "number_problem",
    "parse_number",
    "printable",
    "sniff_wide_encoding",
]

# Column / key names recognised for each role, after normalize_name(). Deliberately exact
# names (not substrings): a column such as "t_s_uniform" is a derived quantity and must not
# be taken for measured time unless the caller says so with columns={"t": ...}.
ROLE_ALIASES: dict[str, frozenset[str]] = {
    "t": frozenset(
        {"t", "time", "times", "sec", "secs", "seconds", "elapsed", "elapsed_time",
         "time_elapsed", "relative_time"}
    ),
    "position": frozenset(
        {"position", "positions", "pos", "x", "displacement", "disp", "rod_position",
         "polished_rod_position", "pr_position", "surface_position", "stroke_position"}
    ),
    "load": frozenset(
        {"load", "loads", "force", "f", "rod_load", "polished_rod_load", "pr_load", "prl",
         "surface_load"}
    ),
    "card": frozenset(
        {"card", "card_id", "cardid", "card_tag", "card_no", "card_number", "card_name",
         "record", "record_id", "record_tag", "record_no", "series", "series_id", "id", "tag"}
    ),
    "well": frozenset({"well", "well_id", "wellid", "well_name", "wellname", "well_tag"}),
    "spm": frozenset({"spm", "strokes_per_minute", "strokes_per_min", "stroke_rate"}),
    "period": frozenset({"period", "stroke_period", "cycle_time"}),
    "closure": frozenset(
        {"is_closure_point", "closure_point", "is_closure", "closure", "closing_point",
         "is_closing_point"}
    ),
}  # fmt: skip

_NAME_WITH_BRACKET_UNIT = re.compile(r"^(.*?)\s*[\[({]\s*([^\])}]*?)\s*[\])}]\s*$")
_FORTRAN_D = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))[dD]([+-]?\d+)$")


def iter_lines(text: str) -> Iterator[tuple[int, str]]:
    r"""Yield ``(line number, line)`` for every line of ``text``, one at a time.

    Lines end at ``\n``, ``\r\n`` or a lone ``\r`` and are numbered as an editor does. They
    are never all held at once: a 50 MB table would become millions of small strings,
    several times the size of the text itself.
    """
    n_cr = text.count("\r")
    if n_cr and n_cr != text.count("\r\n"):
        # A lone carriage return ends a line too (old Mac files, or mixed endings). Rare
        # enough that normalising a copy is cheaper than handling it line by line.
        text = text.replace("\r\n", "\n").replace("\r", "\n")
        n_cr = 0
    find = text.find
    start, lineno = 0, 1
    while True:
        end = find("\n", start)
        line = text[start:] if end < 0 else text[start:end]
        if n_cr and line.endswith("\r"):
            line = line[:-1]
        yield lineno, line
        if end < 0:
            return
        start, lineno = end + 1, lineno + 1


# Byte-order marks, longest first: the UTF-32-LE mark starts with the UTF-16-LE one.
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32-le", "UTF-32 (little-endian)"),
    (codecs.BOM_UTF32_BE, "utf-32-be", "UTF-32 (big-endian)"),
    (codecs.BOM_UTF8, "utf-8", "UTF-8"),
    (codecs.BOM_UTF16_LE, "utf-16-le", "UTF-16 (little-endian)"),
    (codecs.BOM_UTF16_BE, "utf-16-be", "UTF-16 (big-endian)"),
)
_WIDE_NAMES = {
    "utf-32-le": "UTF-32 (little-endian)",
    "utf-32-be": "UTF-32 (big-endian)",
    "utf-16-le": "UTF-16 (little-endian)",
    "utf-16-be": "UTF-16 (big-endian)",
}
# Share of zero bytes expected at the high-byte offsets of mostly-ASCII UTF-16/32 text, and
# the share tolerated at the offset holding the character. Card files are numbers and a few
# words, so their wide encodings show this pattern almost perfectly; binary data does not.
_ZERO_HIGH, _ZERO_LOW = 0.9, 0.05
_SNIFF_BYTES = 4096


def sniff_wide_encoding(data: bytes) -> str | None:
    """Name the UTF-16/UTF-32 variant whose zero-byte pattern ``data`` shows, or None.

    Text made mostly of ASCII characters, encoded in UTF-16 or UTF-32 without a byte-order
    mark, has zero bytes at fixed offsets (the high bytes of each code unit). This looks at
    the first few kilobytes only.
    """
    sample = data[:_SNIFF_BYTES]
    if len(sample) < 4:
        return None
    zeros = [0, 0, 0, 0]
    counts = [0, 0, 0, 0]
    for k in range(4):
        part = sample[k::4]
        counts[k] = len(part)
        zeros[k] = part.count(0)
    frac = [z / c if c else 0.0 for z, c in zip(zeros, counts, strict=True)]
    hi, lo = _ZERO_HIGH, _ZERO_LOW
    if min(frac[1], frac[2], frac[3]) >= hi and frac[0] <= lo:
        return "utf-32-le"
    if min(frac[0], frac[1], frac[2]) >= hi and frac[3] <= lo:
        return "utf-32-be"
    even = (zeros[0] + zeros[2]) / max(1, counts[0] + counts[2])
    odd = (zeros[1] + zeros[3]) / max(1, counts[1] + counts[3])
    if odd >= hi and even <= lo:
        return "utf-16-le"
    if even >= hi and odd <= lo:
        return "utf-16-be"
    return None


def _decode_with(data: bytes, encoding: str, label: str, path: str, skip: int = 0) -> str:
    try:
        return data[skip:].decode(encoding) if skip else data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise CardError(
            f"cannot decode the file as {label}: {exc.reason} at byte offset {exc.start + skip}",
            path=path,
        ) from exc


def decode(data: bytes | str, *, path: str, encoding: str | None) -> tuple[str, list[str]]:
    """Turn file bytes into text; return the text and notes about the decoding.

    Parameters
    ----------
    data : bytes or str
        File content; text is returned as it is.
    path : str
        Name used in messages.
    encoding : str or None
        A codec name given by the caller; it wins over any detection.

    Returns
    -------
    text : str
    notes : list of str

    Notes
    -----
    Without ``encoding``: a byte-order mark (UTF-8, UTF-16 or UTF-32, either byte order)
    decides; otherwise the regular zero-byte pattern of UTF-16/UTF-32 text decides; otherwise
    UTF-8 is expected, and bytes that are not UTF-8 are read as Latin-1 (which never fails),
    with a note. Other NUL bytes mean a binary file.

    Raises
    ------
    CardError
        For an unknown encoding, undecodable bytes (naming the encoding tried and the byte
        offset) and binary content.
    """
    notes: list[str] = []
    if isinstance(data, str):
        text = data
    elif encoding is not None:
        try:
            codec = codecs.lookup(encoding)
        except LookupError as exc:
            raise CardError(f"unknown encoding {encoding!r}", path=path) from exc
        if not getattr(codec, "_is_text_encoding", True):
            raise CardError(f"{encoding!r} is not a text encoding", path=path)
        text = _decode_with(data, codec.name, repr(encoding), path)
        notes.append(f"decoded as {encoding} (encoding given by the caller)")
    else:
        text = ""
        for bom, codec_name, label in _BOMS:
            if data.startswith(bom):
                text = _decode_with(data, codec_name, label, path, skip=len(bom))
                if codec_name != "utf-8":
                    notes.append(f"decoded as {label}, detected from its byte-order mark")
                break
        else:
            wide = sniff_wide_encoding(data) if b"\x00" in data[:_SNIFF_BYTES] else None
            if wide is not None:
                label = _WIDE_NAMES[wide]
                text = _decode_with(data, wide, label, path)
                notes.append(
                    f"decoded as {label}, detected from its pattern of zero bytes (no "
                    "byte-order mark)"
                )
            elif data[:4] == b"PAR1":
                raise CardError(
                    "a Parquet file, not a text card file: read Parquet card datasets with "
                    "pumpid.fleet.read_parquet_cards (the pumpid commands read them "
                    "themselves)",
                    path=path,
                )
            elif b"\x00" in data:
                k = data.index(b"\x00")
                raise CardError(
                    f"binary content (NUL byte at byte offset {k}): not a text card file; if it "
                    "is text in another encoding, give it with encoding=",
                    path=path,
                )
            else:
                try:
                    text = data.decode("utf-8")
                except UnicodeDecodeError:
                    text = data.decode("latin-1")
                    notes.append("file is not valid UTF-8; decoded as Latin-1")
    if text.startswith("\ufeff"):
        text = text[1:]
    if "\x00" in text:
        raise CardError(
            f"binary content (NUL character at offset {text.index(chr(0))} of the text): not a "
            "text card file",
            path=path,
        )
    return text, notes


_COMPLEX_HINT = re.compile(r"[0-9.]\s*[jJ]\s*\)?\s*$")


def is_complex_text(token: str) -> bool:
    """True when the token is a complex number such as ``1+2j`` or ``(3-4J)``."""
    s = token.strip()
    if not s or not _COMPLEX_HINT.search(s):
        return False
    try:
        complex(s.replace(" ", ""))
    except ValueError:
        return False
    return True


def number_problem(token: str) -> str:
    """Plain-language reason why ``token`` is not a number a card can hold."""
    tok = token.strip()
    shown = tok if len(tok) <= 40 else tok[:37] + "..."
    if is_complex_text(tok):
        return f"complex number {shown!r}: a card holds real numbers only"
    return f"unparsable number {shown!r}"


def parse_number(token: str) -> float:
    """Parse one number as written by common tools, Fortran included.

    Accepts ``1.25E-03``, ``.0375``, ``-5.``, ``1.0D-03`` (Fortran double exponent),
    ``nan`` and ``inf`` (these are rejected later with a clear message). Rejects Python-only
    spellings such as ``1_000`` and complex numbers such as ``1+2j``.

    Raises
    ------
    ValueError
        If the token is not a number.
    OverflowError
        Never for text (``float`` turns huge values into ``inf``); kept for callers' safety.
    """
    s = token.strip()
    if not s or "_" in s:
        raise ValueError(token)
    try:
        return float(s)
    except ValueError:
        m = _FORTRAN_D.match(s)
        if m is None:
            raise
        return float(f"{m.group(1)}e{m.group(2)}")


def is_number(token: str) -> bool:
    """True when :func:`parse_number` accepts the token."""
    try:
        parse_number(token)
    except (ValueError, OverflowError):
        return False
    return True


def normalize_name(name: str) -> str:
    """Lower-case a column name and join its words with ``_`` (``"Stroke Period"`` ->
    ``"stroke_period"``)."""
    s = name.strip().strip("\"'").strip().lower()
    s = re.sub(r"[\s\-./]+", "_", s)
    return s.strip("_")


def interpret_name(name: str) -> tuple[str | None, str, str | None]:
    """Find the role and unit in a column name.

    Parameters
    ----------
    name : str
        Raw column name, e.g. ``"position_in"``, ``"load (kN)"``, ``"t_s"``, ``"Position[m]"``.

    Returns
    -------
    role : str or None
        One of the keys of :data:`ROLE_ALIASES`, or None.
    base : str
        Normalised name without the unit.
    unit : str or None
        Unit text as written (not validated), or None.
    """
    raw = name.strip().strip("\"'")
    unit: str | None = None
    m = _NAME_WITH_BRACKET_UNIT.match(raw)
    if m and m.group(1).strip():
        raw, unit = m.group(1), m.group(2).strip() or None
    base = normalize_name(raw)
    role = role_of(base)
    if role is None and unit is None and "_" in base:
        head, _, tail = base.rpartition("_")
        if head and is_unit_spelling(tail):
            head_role = role_of(head)
            if head_role is not None:
                return head_role, head, tail
    return role, base, unit


def role_of(base: str) -> str | None:
    """Role of a normalised name, or None."""
    for role, names in ROLE_ALIASES.items():
        if base in names:
            return role
    return None
