"""Text helpers shared by the readers: decoding, numbers, column names."""

from __future__ import annotations

import re

from ._errors import CardError
from ._units import is_unit_spelling

__all__ = [
    "ROLE_ALIASES",
    "decode",
    "interpret_name",
    "normalize_name",
    "parse_number",
    "split_lines",
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


def split_lines(text: str) -> list[str]:
    """Split on any newline convention, keeping editor line numbering (1-based index + 1)."""
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def decode(data: bytes | str, *, path: str, encoding: str | None) -> tuple[str, list[str]]:
    """Turn file bytes into text; return the text and notes about the decoding.

    UTF-8 (with or without byte-order mark) is expected. Bytes that are not UTF-8 are read as
    Latin-1, which never fails, and a note says so. NUL bytes mean a binary file.
    """
    notes: list[str] = []
    if isinstance(data, str):
        text = data
    else:
        if b"\x00" in data:
            raise CardError("binary content (NUL bytes): not a text card file", path=path)
        if encoding is not None:
            try:
                text = data.decode(encoding)
            except LookupError as exc:
                raise CardError(f"unknown encoding {encoding!r}", path=path) from exc
            except UnicodeDecodeError as exc:
                raise CardError(
                    f"not valid {encoding} text (byte {exc.start}): {exc.reason}", path=path
                ) from exc
        else:
            try:
                text = data.decode("utf-8-sig")
            except UnicodeDecodeError:
                text = data.decode("latin-1")
                notes.append("file is not valid UTF-8; decoded as Latin-1")
    if "\x00" in text:
        raise CardError("binary content (NUL characters): not a text card file", path=path)
    return text.removeprefix("\ufeff"), notes


def parse_number(token: str) -> float:
    """Parse one number as written by common tools, Fortran included.

    Accepts ``1.25E-03``, ``.0375``, ``-5.``, ``1.0D-03`` (Fortran double exponent),
    ``nan`` and ``inf`` (these are rejected later with a clear message). Rejects Python-only
    spellings such as ``1_000``.

    Raises
    ------
    ValueError
        If the token is not a number.
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
