"""Card file readers and the :func:`read_cards` entry point.

Every reader turns text into a list of :class:`_Raw` records (numbers plus where they came
from); :func:`_build` then applies the documented clean-ups (flagged closure rows, duplicated
closing point), checks everything and makes the :class:`~pumpid.cards.Card`. Keeping the
checks in one place is what makes the error messages uniform across formats.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._errors import CardError
from ._text import (
    decode,
    interpret_name,
    is_number,
    normalize_name,
    parse_number,
    split_lines,
)
from ._types import Card
from ._units import (
    TIME_UNITS,
    normalize_load_unit,
    normalize_position_unit,
    normalize_time_unit,
)

__all__ = ["FORMATS", "detect_format", "parse_cards", "read_card", "read_cards"]

#: Format names accepted by ``format=`` (aliases: ``tsv`` -> csv with tabs, ``txt``/``table``
#: -> whitespace, ``pipe`` -> scada, ``sktime`` -> ts).
FORMATS = ("csv", "scada", "json", "whitespace", "ts")

_FORMAT_ALIASES = {
    "csv": "csv", "tsv": "csv", "scada": "scada", "pipe": "scada", "json": "json",
    "whitespace": "whitespace", "txt": "whitespace", "table": "whitespace", "ts": "ts",
    "sktime": "ts",
}  # fmt: skip

_COLUMN_KEYS = {
    "t": "t", "time": "t", "position": "position", "load": "load", "card": "card",
    "card_id": "card", "well": "well", "well_id": "well", "spm": "spm", "period": "period",
    "closure": "closure",
}  # fmt: skip

_SCADA_CARDS = ("surface", "downhole", "both")
_DELIMITERS = ("\t", ";", ",", "|")
_TRUE = frozenset({"1", "true", "yes", "y", "t"})
_FALSE = frozenset({"0", "false", "no", "n", "f", ""})

# A duplicated closing point is an exact copy of the first sample; printed numbers are
# copied text, so anything looser than this would start eating genuine samples.
_CLOSE_RTOL = 1e-9

ColumnSpec = Mapping[str, str | int | None]

_INT_TEXT = re.compile(r"^[+-]?[0-9]{1,18}$")


# --------------------------------------------------------------------------- options
@dataclass(frozen=True)
class _Opts:
    path: str  # label used in error messages
    name: str  # file name used in Card.source
    stem: str  # default card id
    position_unit: str | None
    load_unit: str | None
    spm: float | None
    period: float | None
    columns: dict[str, str | int | None] | None
    well_id: str | None
    min_samples: int
    drop_closing_point: bool
    scada_cards: str
    delimiter: str | None
    file_notes: tuple[str, ...]

    def error(
        self, message: str, *, line: int | None = None, field: str | None = None
    ) -> CardError:
        return CardError(message, path=self.path, line=line, field=field)


@dataclass
class _Raw:
    """Numbers of one card as read, before checks and clean-ups."""

    position: Sequence[float] | NDArray[np.float64]
    load: Sequence[float] | NDArray[np.float64]
    card_id: str
    source: str
    t: Sequence[float] | NDArray[np.float64] | None = None
    lines: Sequence[int] | None = None  # line of each sample (None for JSON)
    line: int | None = None  # line of the whole card (one-line formats)
    pos_field: str = "position"
    load_field: str = "load"
    t_field: str = "t"
    t_factor: float = 1.0
    pos_unit: str | None = None  # canonical unit stated by the file
    pos_unit_where: str = ""
    load_unit: str | None = None
    load_unit_where: str = ""
    well_id: str | None = None
    spm: float | None = None
    period: float | None = None
    rate_where: str = ""
    notes: list[str] = field(default_factory=list)
    metadata: dict[str, Any] = field(default_factory=dict)
    row_arrays: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    closure_mask: NDArray[np.bool_] | None = None
    closure_field: str = ""


# --------------------------------------------------------------------------- helpers
def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _line_span(lines: Sequence[int]) -> str:
    if not lines:
        return ""
    lo, hi = min(lines), max(lines)
    return f"line {lo}" if lo == hi else f"lines {lo}-{hi}"


def _num(
    o: _Opts, token: str, *, line: int | None, field: str, decimal_comma: bool = False
) -> float:
    """Parse a number or raise a CardError naming the line and field."""
    tok = token.strip()
    if not tok:
        raise o.error("empty value where a number is expected", line=line, field=field)
    try:
        return parse_number(tok)
    except OverflowError as exc:
        raise o.error(f"number {tok!r} is out of range", line=line, field=field) from exc
    except ValueError as exc:
        if decimal_comma and tok.count(",") == 1:
            try:
                return parse_number(tok.replace(",", "."))
            except ValueError:
                pass
        shown = tok if len(tok) <= 40 else tok[:37] + "..."
        raise o.error(f"unparsable number {shown!r}", line=line, field=field) from exc


def _rate(o: _Opts, value: float, *, line: int | None, field: str, what: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise o.error(
            f"{what} must be a positive finite number, got {value!r}", line=line, field=field
        )
    return value


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= _CLOSE_RTOL * max(abs(a), abs(b))


def _file_unit(
    o: _Opts, kind: str, text: str | None, *, line: int | None, field: str
) -> str | None:
    """Validate a unit written in the file (column name, JSON units ...)."""
    if text is None:
        return None
    caller = o.position_unit if kind == "position" else o.load_unit
    norm = normalize_position_unit if kind == "position" else normalize_load_unit
    try:
        return norm(text, field=field)
    except CardError as exc:
        if caller is not None:  # the caller's declaration wins; nothing to validate
            return None
        raise o.error(exc.reason, line=line, field=field) from exc


def _time_factor(o: _Opts, text: str | None, *, line: int | None, field: str) -> float:
    if text is None:
        return 1.0
    try:
        return TIME_UNITS[normalize_time_unit(text, field=field)]
    except CardError as exc:
        raise o.error(exc.reason, line=line, field=field) from exc


# --------------------------------------------------------------------------- building
def _build(raw: _Raw, o: _Opts) -> Card:
    """Check one raw card, apply the documented clean-ups and make the Card."""
    notes = [*o.file_notes, *raw.notes]
    meta = dict(raw.metadata)
    with np.errstate(over="ignore", invalid="ignore"):
        pos = np.asarray(raw.position, dtype=float)
        load = np.asarray(raw.load, dtype=float)
        t = None if raw.t is None else np.asarray(raw.t, dtype=float) * raw.t_factor
    lines = None if raw.lines is None else np.asarray(raw.lines, dtype=int)
    arrays = dict(raw.row_arrays)

    def err(msg: str, k: int | None = None, fld: str | None = None) -> CardError:
        line = raw.line
        if k is not None and lines is not None:
            line = int(lines[k])
        elif k is not None and fld is not None and raw.line is None:
            fld = f"{fld}[{k}]"  # JSON: no lines, so point into the array instead
        return o.error(f"card {raw.card_id!r}: {msg}", line=line, field=fld)

    if pos.size == 0 and load.size == 0:
        raise err("no samples", fld=raw.pos_field)
    if pos.size != load.size:
        raise err(
            f"{raw.pos_field} has {pos.size} values but {raw.load_field} has {load.size}",
            fld=raw.load_field,
        )
    if t is not None and t.size != pos.size:
        raise err(
            f"{raw.t_field} has {t.size} values but {raw.pos_field} has {pos.size}", fld=raw.t_field
        )
    for arr, fld in ((pos, raw.pos_field), (load, raw.load_field), (t, raw.t_field)):
        if arr is None:
            continue
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            k = int(bad[0])
            kind = "NaN" if np.isnan(arr[k]) else "infinite"
            raise err(f"{kind} value in {fld} (sample {k})", k, fld)

    keep = np.ones(pos.size, dtype=bool)
    if raw.closure_mask is not None and raw.closure_mask.any():
        idx = np.flatnonzero(raw.closure_mask)
        keep &= ~raw.closure_mask
        where = "" if lines is None else f" ({_line_span([int(lines[i]) for i in idx])})"
        notes.append(
            f"{idx.size} row(s) flagged as closure point in column {raw.closure_field!r} "
            f"dropped{where}"
        )
    if (
        o.drop_closing_point
        and t is None
        and keep.sum() >= 2
        and _same(pos[keep][0], pos[keep][-1])
        and _same(load[keep][0], load[keep][-1])
    ):
        last = int(np.flatnonzero(keep)[-1])
        keep[last] = False
        where = "" if lines is None else f" (line {int(lines[last])})"
        notes.append(
            "duplicated closing point dropped: the last sample repeats the first in position "
            f"and load{where}"
        )
    if not keep.all():
        pos, load = pos[keep], load[keep]
        t = None if t is None else t[keep]
        lines = None if lines is None else lines[keep]
        arrays = {k: v[keep] for k, v in arrays.items()}

    if t is not None and t.size > 1:
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.diff(t) > 0))
        if bad.size:
            k = int(bad[0]) + 1
            raise err(
                f"time is not strictly increasing: {_fmt(t[k])} s follows {_fmt(t[k - 1])} s",
                k,
                raw.t_field,
            )
    if pos.size < o.min_samples:
        first = None if lines is None or not lines.size else int(lines[0])
        raise o.error(
            f"card {raw.card_id!r}: only {pos.size} samples, at least {o.min_samples} needed",
            line=first if first is not None else raw.line,
            field=raw.pos_field,
        )
    if load.max() == load.min():
        raise err(f"constant load ({_fmt(load[0])} in every sample)", fld=raw.load_field)
    if pos.max() == pos.min():
        raise err(f"constant position ({_fmt(pos[0])} in every sample)", fld=raw.pos_field)

    # Units: the caller's declaration wins over what the file says (and a note records it).
    units: dict[str, str | None] = {}
    for kind, caller, stated, where in (
        ("position", o.position_unit, raw.pos_unit, raw.pos_unit_where),
        ("load", o.load_unit, raw.load_unit, raw.load_unit_where),
    ):
        if caller is not None:
            if stated is not None and stated != caller:
                notes.append(
                    f"{kind} unit {caller} given by the caller overrides {stated} ({where})"
                )
            units[kind] = caller
        elif stated is not None:
            notes.append(f"{kind} unit {stated} taken from {where}")
            units[kind] = stated
        else:
            notes.append(
                f"{kind} unit not stated in the file nor given by the caller: left unknown"
            )
            units[kind] = None
    if raw.t is not None and raw.t_factor != 1.0:
        notes.append(f"time converted to seconds (x {raw.t_factor:g})")

    # Time: file time wins; otherwise the caller's rate, then the file's rate.
    spm, period, rate_where = raw.spm, raw.period, raw.rate_where
    if o.spm is not None or o.period is not None:
        if spm is not None or period is not None:
            notes.append(
                f"stroke rate given by the caller overrides the one in the file ({rate_where})"
            )
        spm, period, rate_where = o.spm, o.period, "given by the caller"
    if spm is not None and period is None:
        period = 60.0 / spm
    elif period is not None and spm is None:
        spm = 60.0 / period
    well_id = raw.well_id
    if o.well_id is not None:
        if well_id is not None and well_id != o.well_id:
            notes.append(
                f"well id {o.well_id!r} given by the caller overrides {well_id!r} from the file"
            )
        well_id = o.well_id
    periodic = False
    n = int(pos.size)
    if t is not None:
        time_source = "file"
        notes.append(f"time taken from the file ({raw.t_field})")
    elif spm is not None and period is not None:
        used = "spm" if raw.spm is not None or o.spm is not None else "period"
        what = f"{_fmt(spm)} SPM" if used == "spm" else f"stroke period {_fmt(period)} s"
        t = np.arange(n) * (period / n)
        time_source = used
        periodic = True
        notes.append(
            f"time rebuilt from {what} ({rate_where}) assuming uniform sampling over one stroke: "
            f"t_i = i*T/N with T = {_fmt(period)} s, N = {n}"
        )
    else:
        time_source = "none"
        notes.append("no time in the file and no SPM or period given: t is None")
    for name, arr in arrays.items():
        meta.setdefault(name, arr)
    try:
        return Card(
            position=pos,
            load=load,
            t=t,
            position_unit=units["position"],
            load_unit=units["load"],
            source=raw.source,
            card_id=raw.card_id,
            well_id=well_id,
            spm=spm,
            period=period,
            time_source=time_source,
            periodic=periodic,
            notes=tuple(notes),
            metadata=meta,
        )
    except CardError as exc:  # pragma: no cover - the checks above should catch everything
        raise o.error(
            f"card {raw.card_id!r}: {exc.reason}", line=raw.line, field=exc.field
        ) from exc


# --------------------------------------------------------------------------- detection
def _meaningful(text: str) -> list[tuple[int, str]]:
    """Non-blank lines that are not ``#`` comments, with their line numbers."""
    out = []
    for i, line in enumerate(split_lines(text), 1):
        s = line.strip()
        if s and not s.startswith("#"):
            out.append((i, line))
    return out


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
    stripped = text.strip()
    if not stripped:
        raise CardError("empty file", path=path)
    if stripped[0] in "{[":
        return "json"
    rows = _meaningful(text)
    if not rows:
        raise CardError("no data: the file holds only comments", path=path)
    first = rows[0][1].strip()
    if first.startswith("@"):
        return "ts"
    lines = [ln for _, ln in rows]
    if "|" in first and _looks_scada(lines):
        return "scada"
    if _sniff_delimiter(lines) is not None:
        return "csv"
    return "whitespace"


# --------------------------------------------------------------------------- tables
def _tokenize(o: _Opts, text: str, delimiter: str | None) -> list[tuple[int, list[str]]]:
    rows: list[tuple[int, list[str]]] = []
    for lineno, line in _meaningful(text):
        if delimiter is None:
            tokens = line.split()
        else:
            try:
                tokens = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))
            except (csv.Error, StopIteration) as exc:
                raise o.error(f"cannot split the line into fields: {exc}", line=lineno) from exc
            tokens = [tok.strip() for tok in tokens]
        rows.append((lineno, tokens))
    return rows


def _resolve_table_columns(
    o: _Opts, header: list[str] | None, ncols: int, header_line: int | None
) -> tuple[dict[str, int], dict[str, str | None], list[str]]:
    """Map roles to column indices; return (roles, unit text per role, notes)."""
    notes: list[str] = []
    roles: dict[str, int] = {}
    units: dict[str, str | None] = {}
    disabled: set[str] = set()
    names = header if header is not None else [f"column_{k}" for k in range(ncols)]
    given = o.columns or {}
    for key, spec in given.items():
        role = _COLUMN_KEYS[key]
        if spec is None:
            disabled.add(role)
            continue
        if isinstance(spec, int):
            if not 0 <= spec < ncols:
                raise o.error(
                    f"column index {spec} is out of range: the file has {ncols} columns "
                    "(numbered from 0)",
                    line=header_line,
                    field=f"columns[{key!r}]",
                )
            idx = spec
        else:
            if header is None:
                raise o.error(
                    f"the file has no header row, so column {spec!r} cannot be found by name; "
                    "give column numbers (from 0)",
                    field=f"columns[{key!r}]",
                )
            want = spec.strip().lower()
            matches = [k for k, h in enumerate(header) if h.strip().lower() == want]
            if not matches:
                matches = [
                    k for k, h in enumerate(header) if normalize_name(h) == normalize_name(spec)
                ]
            if not matches:
                raise o.error(
                    f"no column named {spec!r}; the header has: {', '.join(map(repr, header))}",
                    line=header_line,
                    field=f"columns[{key!r}]",
                )
            idx = matches[0]
        roles[role] = idx
        units[role] = interpret_name(names[idx])[2] if header is not None else None
    if header is not None:
        for idx, name in enumerate(header):
            role, _base, unit = interpret_name(name)
            if role is None or role in disabled or idx in roles.values():
                continue
            if role in roles:
                notes.append(f"column {name!r} also looks like {role}; not used")
                continue
            roles[role] = idx
            units[role] = unit
        if "position" not in roles or "load" not in roles:
            missing = [r for r in ("position", "load") if r not in roles]
            raise o.error(
                f"no {' or '.join(missing)} column recognised in the header "
                f"({', '.join(map(repr, header))}); name them e.g. 'position_in', 'load_lbf' "
                "or pass columns={'position': ..., 'load': ...}",
                line=header_line,
                field=missing[0],
            )
    elif "position" not in roles and "load" not in roles:
        if ncols < 2:
            raise o.error(
                f"only {ncols} column found; position and load need two", line=header_line
            )
        roles["position"], roles["load"] = 0, 1
        notes.append(
            "no header: column 0 read as position and column 1 as load (default order; pass "
            "columns= to change)"
        )
    elif "position" not in roles or "load" not in roles:
        raise o.error(
            "columns= must give both 'position' and 'load' for a file without header",
            field="columns",
        )
    if len(set(roles.values())) != len(roles):
        raise o.error(f"two roles use the same column: {roles}", field="columns")
    return roles, units, notes


def _parse_flag(o: _Opts, token: str, *, line: int, field: str) -> bool:
    tok = token.strip().lower()
    if tok in _TRUE:
        return True
    if tok in _FALSE:
        return False
    if is_number(tok):
        return parse_number(tok) != 0
    raise o.error(
        f"expected a yes/no flag (1/0, true/false), got {token!r}", line=line, field=field
    )


def _scalar(token: str) -> int | float | str:
    """A metadata value: int for integers as written, float for other numbers, else text."""
    tok = token.strip()
    if _INT_TEXT.match(tok):
        return int(tok)
    if is_number(tok):
        return parse_number(tok)
    return tok


def _read_table(o: _Opts, text: str, delimiter: str | None) -> list[_Raw]:
    rows = _tokenize(o, text, delimiter)
    if not rows:
        raise o.error("no data rows")
    first_line, first = rows[0]
    has_header = any(tok.strip() and not is_number(tok) for tok in first)
    header = [tok.strip() for tok in first] if has_header else None
    if header is not None:
        header = [h if h else f"column_{k}" for k, h in enumerate(header)]
        rows = rows[1:]
        if not rows:
            raise o.error("header but no data rows", line=first_line)
    ncols = len(header) if header is not None else len(rows[0][1])
    roles, unit_text, col_notes = _resolve_table_columns(
        o, header, ncols, first_line if header else None
    )
    names = header if header is not None else [f"column_{k}" for k in range(ncols)]
    where_cols = "header" if header is not None else "first row"
    for lineno, toks in rows:
        if len(toks) != ncols:
            raise o.error(
                f"expected {ncols} fields (as in the {where_cols}), found {len(toks)}", line=lineno
            )
    decimal_comma = delimiter == ";"

    pos_i, load_i = roles["position"], roles["load"]
    t_i, card_i, well_i = roles.get("t"), roles.get("card"), roles.get("well")
    hl = first_line if header is not None else None
    pos_unit = _file_unit(o, "position", unit_text.get("position"), line=hl, field=names[pos_i])
    load_unit = _file_unit(o, "load", unit_text.get("load"), line=hl, field=names[load_i])
    t_factor = 1.0
    if t_i is not None:
        t_factor = _time_factor(o, unit_text.get("t"), line=hl, field=names[t_i])
    period_factor = 1.0
    if roles.get("period") is not None:
        period_factor = _time_factor(
            o, unit_text.get("period"), line=hl, field=names[roles["period"]]
        )

    # Group rows into cards, keeping the order of first appearance.
    key_i = card_i if card_i is not None else well_i
    groups: dict[str, list[tuple[int, list[str]]]] = {}
    order: dict[str, list[int]] = {}
    for r, (lineno, toks) in enumerate(rows):
        key = toks[key_i].strip() if key_i is not None else ""
        if key_i is not None and not key:
            raise o.error("empty card identifier", line=lineno, field=names[key_i])
        groups.setdefault(key, []).append((lineno, toks))
        order.setdefault(key, []).append(r)

    used = set(roles.values())
    out: list[_Raw] = []
    for key, grows in groups.items():
        lines = [ln for ln, _ in grows]
        notes = list(col_notes)
        idx = order[key]
        if idx[-1] - idx[0] + 1 != len(idx):
            # Interleaved rows are unusual; they are kept in file order, but say so.
            notes.append(f"rows of card {key!r} are not contiguous in the file")
        used_comma = False

        def num(tok: str, ln: int, col: int) -> float:
            nonlocal used_comma
            try:
                v = _num(o, tok, line=ln, field=names[col], decimal_comma=decimal_comma)
            except CardError as exc:
                if col == t_i and (any(c in tok for c in ":/T") or tok.count("-") > 1):
                    raise o.error(
                        f"{exc.reason}: date/time stamps are not read as time; convert them "
                        "to seconds, or ignore the column with columns={'t': None}",
                        line=ln,
                        field=names[col],
                    ) from exc
                raise
            if decimal_comma and "," in tok:
                used_comma = True
            return v

        pos = [num(tk[pos_i], ln, pos_i) for ln, tk in grows]
        load = [num(tk[load_i], ln, load_i) for ln, tk in grows]
        t = None if t_i is None else [num(tk[t_i], ln, t_i) for ln, tk in grows]
        card_id = key if key_i is not None else o.stem
        raw = _Raw(
            position=pos,
            load=load,
            t=t,
            card_id=card_id,
            source=f"{o.name}, {_line_span(lines)}",
            lines=lines,
            pos_field=names[pos_i],
            load_field=names[load_i],
            t_field=names[t_i] if t_i is not None else "t",
            t_factor=t_factor,
            pos_unit=pos_unit,
            pos_unit_where=f"column name {names[pos_i]!r}",
            load_unit=load_unit,
            load_unit_where=f"column name {names[load_i]!r}",
            notes=notes,
        )
        if well_i is not None:
            wells = {tk[well_i].strip() for _, tk in grows}
            if len(wells) > 1:
                raise o.error(
                    f"card {key!r} spans several wells ({', '.join(sorted(wells))})",
                    line=lines[0],
                    field=names[well_i],
                )
            raw.well_id = wells.pop() or None
        for role in ("spm", "period"):
            col = roles.get(role)
            if col is None:
                continue
            vals = [num(tk[col], ln, col) for ln, tk in grows]
            if any(v != vals[0] for v in vals):
                k = next(i for i, v in enumerate(vals) if v != vals[0])
                raise o.error(
                    f"{role} changes within card {key or card_id!r} ({_fmt(vals[0])} then "
                    f"{_fmt(vals[k])}); one card has one stroke rate",
                    line=lines[k],
                    field=names[col],
                )
            value = vals[0] * (period_factor if role == "period" else 1.0)
            value = _rate(o, value, line=lines[0], field=names[col], what=role)
            setattr(raw, role, value)
            raw.rate_where = raw.rate_where or f"column {names[col]!r}"
        if raw.spm is not None and raw.period is not None:
            # SPM wins; the period is kept in metadata so nothing from the file is lost.
            raw.metadata[names[roles["period"]]] = raw.period
            raw.period = None
        col = roles.get("closure")
        if col is not None:
            raw.closure_mask = np.array(
                [_parse_flag(o, tk[col], line=ln, field=names[col]) for ln, tk in grows], dtype=bool
            )
            raw.closure_field = names[col]
        # Everything else is kept: constant columns as scalars, varying numeric ones as arrays.
        for col in range(ncols):
            if col in used:
                continue
            toks = [tk[col].strip() for _, tk in grows]
            if all(tok == toks[0] for tok in toks):
                raw.metadata[names[col]] = _scalar(toks[0])
            elif all(is_number(tok) for tok in toks):
                raw.row_arrays[names[col]] = np.array([parse_number(tok) for tok in toks])
            else:
                notes.append(f"column {names[col]!r} has varying non-numeric values; not kept")
        if used_comma:
            notes.append("decimal commas read as decimal points")
        out.append(raw)
    return out


# --------------------------------------------------------------------------- SCADA
_SCADA_ROLES: dict[str, frozenset[str]] = {
    "well": frozenset({"well", "well_id", "wellid", "well_name", "wellname", "well_tag"}),
    "card": frozenset({"card", "card_id", "card_no", "card_number", "id"}),
    "stamp": frozenset({"date", "timestamp", "datetime", "date_time", "time", "card_date",
                        "card_time", "time_stamp"}),
    "spm": frozenset({"spm", "strokes_per_minute", "stroke_rate"}),
    "period": frozenset({"stroke_period", "period"}),
    "sp": frozenset({"surface_positions", "surface_position", "positions", "position",
                     "surface_pos"}),
    "sl": frozenset({"surface_loads", "surface_load", "loads", "load"}),
    "dp": frozenset({"downhole_positions", "downhole_position", "pump_positions",
                     "pump_position"}),
    "dl": frozenset({"downhole_loads", "downhole_load", "pump_loads", "pump_load"}),
}  # fmt: skip


def _split_pipe(line: str) -> list[str]:
    s = line.strip()
    if s.startswith("|") and s.endswith("|") and len(s) > 1:
        s = s[1:-1]  # table drawn with outer pipes
    return [f.strip() for f in s.split("|")]


def _scada_role(name: str) -> tuple[str | None, str | None]:
    raw = name
    _, base, unit = interpret_name(raw)
    full = normalize_name(raw)
    for role, names in _SCADA_ROLES.items():
        if full in names:
            return role, None
        if base in names:
            return role, unit
    return None, None


def _read_scada(o: _Opts, text: str) -> list[_Raw]:
    rows = _meaningful(text)
    if not rows:
        raise o.error("no data rows")
    hline, htext = rows[0]
    header = _split_pipe(htext)
    roles: dict[str, int] = {}
    units: dict[str, str | None] = {}
    for k, name in enumerate(header):
        role, unit = _scada_role(name)
        if role is not None and role not in roles:
            roles[role], units[role] = k, unit
    # Caller overrides by header name (position/load are the surface lists).
    for key, spec in (o.columns or {}).items():
        target = {"position": "sp", "load": "sl", "card": "card", "well": "well", "spm": "spm",
                  "period": "period", "t": None, "closure": None}[_COLUMN_KEYS[key]]  # fmt: skip
        if target is None:
            raise o.error(f"columns[{key!r}] does not apply to SCADA exports", field="columns")
        if spec is None:
            roles.pop(target, None)
            continue
        idx = (
            spec
            if isinstance(spec, int)
            else next((k for k, h in enumerate(header) if h.lower() == spec.strip().lower()), None)
        )
        if idx is None or not 0 <= idx < len(header):
            raise o.error(f"no field {spec!r} in the header", line=hline, field=f"columns[{key!r}]")
        roles[target], units[target] = idx, interpret_name(header[idx])[2]
    want = {"surface": ("sp", "sl"), "downhole": ("dp", "dl"), "both": ("sp", "sl", "dp", "dl")}
    for role in want[o.scada_cards]:
        if role not in roles:
            label = {"sp": "Surface Positions", "sl": "Surface Loads",
                     "dp": "Downhole Positions", "dl": "Downhole Loads"}[role]  # fmt: skip
            raise o.error(
                f"no {label!r} field in the header ({', '.join(map(repr, header))})",
                line=hline,
                field=label,
            )
    if len(rows) < 2:
        raise o.error("header but no card rows", line=hline)
    period_factor = 1.0
    if "period" in roles:
        period_factor = _time_factor(
            o, units.get("period"), line=hline, field=header[roles["period"]]
        )
    list_roles = {"sp", "sl", "dp", "dl"}

    def parse_list(value: str, line: int, name: str) -> list[float]:
        parts = value.split(",")
        if not value.strip():
            raise o.error("empty list of values", line=line, field=name)
        return [_num(o, p, line=line, field=f"{name}[{i}]") for i, p in enumerate(parts)]

    out: list[_Raw] = []
    seen: dict[str, int] = {}
    for r, (lineno, text_row) in enumerate(rows[1:]):
        fields = _split_pipe(text_row)
        if len(fields) != len(header):
            raise o.error(
                f"expected {len(header)} '|'-separated fields (as in the header), found "
                f"{len(fields)}",
                line=lineno,
            )
        meta: dict[str, Any] = {}
        for k, (name, value) in enumerate(zip(header, fields, strict=True)):
            if k in {roles[x] for x in list_roles if x in roles}:
                continue
            meta[name] = _scalar(value) if value else None
        well = fields[roles["well"]] or None if "well" in roles else None
        stamp = fields[roles["stamp"]] if "stamp" in roles else ""
        if "card" in roles and fields[roles["card"]]:
            base_id = fields[roles["card"]]
        elif well and stamp:
            base_id = f"{well}@{stamp}"
        else:
            base_id = well or stamp or f"row {r}"
        seen[base_id] = seen.get(base_id, 0) + 1
        if seen[base_id] > 1:
            base_id = f"{base_id} ({seen[base_id]})"  # keep ids unique within the file
        notes: list[str] = []
        spm = period = None
        rate_where = ""
        if "spm" in roles and fields[roles["spm"]]:
            name = header[roles["spm"]]
            spm = _rate(
                o,
                _num(o, fields[roles["spm"]], line=lineno, field=name),
                line=lineno,
                field=name,
                what="SPM",
            )
            rate_where = f"field {name!r}"
        if "period" in roles and fields[roles["period"]]:
            name = header[roles["period"]]
            value = _num(o, fields[roles["period"]], line=lineno, field=name) * period_factor
            period = _rate(o, value, line=lineno, field=name, what="stroke period")
            if spm is None:
                rate_where = f"field {name!r}"
            else:
                if abs(60.0 / spm - period) > 0.01 * period:
                    notes.append(
                        f"{header[roles['spm']]!r} ({_fmt(spm)}, i.e. {_fmt(60 / spm)} s) and "
                        f"{name!r} ({_fmt(period)} s) disagree; SPM used"
                    )
                period = None  # SPM wins; the period stays in metadata
        kinds = {"surface": [("sp", "sl", "")], "downhole": [("dp", "dl", "/downhole")],
                 "both": [("sp", "sl", ""), ("dp", "dl", "/downhole")]}[o.scada_cards]  # fmt: skip
        for pr, lr, suffix in kinds:
            pname, lname = header[roles[pr]], header[roles[lr]]
            raw = _Raw(
                position=parse_list(fields[roles[pr]], lineno, pname),
                load=parse_list(fields[roles[lr]], lineno, lname),
                card_id=base_id + suffix,
                source=f"{o.name}, line {lineno}",
                line=lineno,
                lines=None,
                pos_field=pname,
                load_field=lname,
                pos_unit=_file_unit(o, "position", units.get(pr), line=hline, field=pname),
                pos_unit_where=f"field name {pname!r}",
                load_unit=_file_unit(o, "load", units.get(lr), line=hline, field=lname),
                load_unit_where=f"field name {lname!r}",
                well_id=well,
                spm=spm,
                period=period,
                rate_where=rate_where,
                notes=list(notes),
                metadata={**meta, "card_type": "surface" if pr == "sp" else "downhole"},
            )
            raw.lines = [lineno] * len(raw.position)
            if o.scada_cards == "surface" and "dp" in roles and "dl" in roles:
                dpn, dln = header[roles["dp"]], header[roles["dl"]]
                if fields[roles["dp"]] or fields[roles["dl"]]:
                    raw.metadata["downhole_position"] = np.array(
                        parse_list(fields[roles["dp"]], lineno, dpn)
                    )
                    raw.metadata["downhole_load"] = np.array(
                        parse_list(fields[roles["dl"]], lineno, dln)
                    )
                    raw.notes.append(
                        "downhole card kept unchecked in metadata['downhole_position'] and "
                        "metadata['downhole_load'] (read with scada_cards='both' to check it)"
                    )
            out.append(raw)
    return out


# --------------------------------------------------------------------------- JSON
_JSON_ROLE_EXTRA = {
    "units": "units", "position_unit": "position_unit", "load_unit": "load_unit",
    "time_unit": "time_unit", "t_unit": "time_unit", "name": "card",
}  # fmt: skip


def _json_numbers(o: _Opts, value: Any, where: str) -> list[float]:
    if not isinstance(value, list):
        raise o.error(f"expected a list of numbers, got {type(value).__name__}", field=where)
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float):
            shown = repr(v) if len(repr(v)) <= 40 else repr(v)[:37] + "..."
            raise o.error(f"expected a number, got {shown}", field=f"{where}[{i}]")
        try:
            out.append(float(v))
        except OverflowError as exc:
            raise o.error("number out of range", field=f"{where}[{i}]") from exc
    return out


def _json_rate(o: _Opts, value: Any, where: str, what: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise o.error(f"{what} must be a number, got {type(value).__name__}", field=where)
    try:
        return _rate(o, float(value), line=None, field=where, what=what)
    except OverflowError as exc:
        raise o.error(f"{what} out of range", field=where) from exc


def _json_str(o: _Opts, value: Any, where: str) -> str:
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise o.error(f"expected a string, got {type(value).__name__}", field=where)
    return str(value)


def _read_json(o: _Opts, text: str) -> list[_Raw]:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise o.error(f"invalid JSON: {exc.msg} (column {exc.colno})", line=exc.lineno) from exc
    except (ValueError, RecursionError) as exc:
        raise o.error(f"invalid JSON: {exc}") from exc
    shared: dict[str, Any] = {}
    prefix = "cards"
    if isinstance(doc, list):
        items: Any = doc
        prefix = ""
    elif isinstance(doc, dict):
        cards_key = next((k for k in doc if isinstance(k, str) and k.lower() == "cards"), None)
        if cards_key is not None:
            items = doc[cards_key]
            if not isinstance(items, list):
                raise o.error("'cards' must be a list of card objects", field=cards_key)
            shared = {k: v for k, v in doc.items() if k != cards_key}
        else:
            items, prefix = [doc], ""
    else:
        raise o.error(f"top level must be an object or a list, got {type(doc).__name__}")
    if not items:
        raise o.error("no cards in the JSON document", field=prefix or None)
    out = []
    for k, item in enumerate(items):
        where = f"{prefix}[{k}]" if (prefix or len(items) > 1 or isinstance(doc, list)) else ""
        if not isinstance(item, dict):
            raise o.error(
                f"a card must be an object, got {type(item).__name__}", field=where or None
            )
        out.append(_json_card(o, {**shared, **item}, where, k, len(items)))
    return out


def _json_card(o: _Opts, obj: dict[str, Any], where: str, k: int, count: int) -> _Raw:
    def at(key: str) -> str:
        return f"{where}.{key}" if where else key

    found: dict[str, tuple[str, Any, str | None]] = {}
    meta: dict[str, Any] = {}
    notes: list[str] = []
    for key, value in obj.items():
        norm = normalize_name(key)
        role: str | None = _JSON_ROLE_EXTRA.get(norm)
        unit = None
        if role is None:
            role, _base, unit = interpret_name(key)
        if role is None or role in found:
            meta[key] = value
            continue
        found[role] = (key, value, unit)
    for role in ("position", "load"):
        if role not in found:
            raise o.error(f"missing {role!r} array", field=where or None)
    units_obj: dict[str, Any] = {}
    if "units" in found:
        ukey, uval, _ = found["units"]
        if not isinstance(uval, dict):
            raise o.error('\'units\' must be an object like {"position": "in"}', field=at(ukey))
        for uk, uv in uval.items():
            nk = normalize_name(uk)
            nk = {"time": "t", "pos": "position", "force": "load"}.get(nk, nk)
            if nk not in ("position", "load", "t"):
                notes.append(f"unit for {uk!r} in 'units' not used")
                continue
            units_obj[nk] = (_json_str(o, uv, at(f"{ukey}.{uk}")), at(f"{ukey}.{uk}"))
    for role, kind in (("position_unit", "position"), ("load_unit", "load"), ("time_unit", "t")):
        if role in found and found[role][1] is not None:
            units_obj.setdefault(
                kind, (_json_str(o, found[role][1], at(found[role][0])), at(found[role][0]))
            )
    for role in ("position", "load", "t"):
        if role in found and found[role][2] is not None:
            units_obj.setdefault(role, (found[role][2], at(found[role][0])))

    pkey, lkey = found["position"][0], found["load"][0]
    pos = _json_numbers(o, found["position"][1], at(pkey))
    load = _json_numbers(o, found["load"][1], at(lkey))
    t = t_field = None
    t_factor = 1.0
    if "t" in found and found["t"][1] is not None:
        t_field = at(found["t"][0])
        t = _json_numbers(o, found["t"][1], t_field)
        if "t" in units_obj:
            t_factor = _time_factor(o, units_obj["t"][0], line=None, field=units_obj["t"][1])
    if "card" in found:
        card_id = _json_str(o, found["card"][1], at(found["card"][0]))
    else:
        card_id = o.stem if count == 1 else f"{o.stem}[{k}]"
    well_id = None
    if "well" in found and found["well"][1] is not None:
        well_id = _json_str(o, found["well"][1], at(found["well"][0]))
    spm = period = None
    rate_where = ""
    if "spm" in found:
        spm = _json_rate(o, found["spm"][1], at(found["spm"][0]), "spm")
        rate_where = f"key {found['spm'][0]!r}"
    if "period" in found:
        period = _json_rate(o, found["period"][1], at(found["period"][0]), "period")
        if spm is not None and period is not None:
            meta[found["period"][0]] = period
            period = None
        elif period is not None:
            rate_where = f"key {found['period'][0]!r}"
    if "closure" in found:
        meta[found["closure"][0]] = found["closure"][1]
    pu = units_obj.get("position")
    lu = units_obj.get("load")
    return _Raw(
        position=pos,
        load=load,
        t=t,
        t_field=t_field or "t",
        t_factor=t_factor,
        card_id=card_id,
        source=f"{o.name}, {where or 'top level'}",
        pos_field=at(pkey),
        load_field=at(lkey),
        pos_unit=None if pu is None else _file_unit(o, "position", pu[0], line=None, field=pu[1]),
        pos_unit_where="" if pu is None else f"JSON {pu[1]!r}",
        load_unit=None if lu is None else _file_unit(o, "load", lu[0], line=None, field=lu[1]),
        load_unit_where="" if lu is None else f"JSON {lu[1]!r}",
        well_id=well_id,
        spm=spm,
        period=period,
        rate_where=rate_where,
        notes=notes,
        metadata=meta,
    )


# --------------------------------------------------------------------------- sktime .ts
def _read_ts(o: _Opts, text: str) -> list[_Raw]:
    tags: dict[str, str] = {}
    series: list[tuple[int, str]] = []
    in_data = False
    for lineno, line in enumerate(split_lines(text), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if in_data:
            series.append((lineno, s))
        elif s.startswith("@"):
            parts = s[1:].split(None, 1)
            key = parts[0].lower() if parts else ""
            if key == "data":
                in_data = True
            else:
                tags[key] = parts[1].strip() if len(parts) > 1 else ""
        else:
            raise o.error("expected an '@' tag or '#' comment before the '@data' line", line=lineno)
    if not in_data:
        raise o.error("no '@data' line: not a complete sktime .ts file")
    if not series:
        raise o.error("no series after '@data'")
    if tags.get("timestamps", "false").lower().startswith("true"):
        raise o.error("time-stamped .ts files are not supported", field="@timeStamps")
    has_label = any(
        tags.get(t, "false").split()[:1] == ["true"] for t in ("classlabel", "targetlabel")
    )
    ndims: int | None = None
    if "dimensions" in tags:
        try:
            ndims = int(tags["dimensions"])
        except ValueError as exc:
            raise o.error(
                f"bad @dimensions value {tags['dimensions']!r}", field="@dimensions"
            ) from exc
    if tags.get("univariate", "false").lower().startswith("true") or (
        ndims is not None and ndims < 2
    ):
        raise o.error(
            "univariate series: a card needs two dimensions (position and load)",
            field="@univariate",
        )
    dims = {"position": 0, "load": 1}
    given = {_COLUMN_KEYS[k]: v for k, v in (o.columns or {}).items()}
    if given:
        for role, v in given.items():
            if role not in ("position", "load") or not isinstance(v, int):
                raise o.error(
                    "for .ts files columns= maps 'position' and 'load' to dimension numbers",
                    field="columns",
                )
            dims[role] = v
    out = []
    for k, (lineno, s) in enumerate(series):
        parts = s.split(":")
        label = None
        if has_label:
            if len(parts) < 2:
                raise o.error("expected dimensions and a class label separated by ':'", line=lineno)
            label = parts[-1].strip()
            parts = parts[:-1]
        if ndims is not None and len(parts) != ndims:
            raise o.error(
                f"expected {ndims} dimensions (from @dimensions), found {len(parts)}", line=lineno
            )
        for role, d in dims.items():
            if not 0 <= d < len(parts):
                raise o.error(
                    f"{role} is dimension {d} but the series has {len(parts)}",
                    line=lineno,
                    field=f"dim{d}",
                )

        def values(d: int, lineno: int = lineno, parts: list[str] = parts) -> list[float]:
            vals = []
            for i, tok in enumerate(parts[d].split(",")):
                if tok.strip() == "?":
                    raise o.error("missing value '?'", line=lineno, field=f"dim{d}[{i}]")
                vals.append(_num(o, tok, line=lineno, field=f"dim{d}[{i}]"))
            return vals

        pos, load = values(dims["position"]), values(dims["load"])
        meta: dict[str, Any] = {"series_index": k}
        if label is not None:
            meta["label"] = label
        if "problemname" in tags:
            meta["problem_name"] = tags["problemname"]
        raw = _Raw(
            position=pos,
            load=load,
            card_id=f"{o.stem}[{k}]",
            source=f"{o.name}, line {lineno}",
            line=lineno,
            pos_field=f"dim{dims['position']}",
            load_field=f"dim{dims['load']}",
            metadata=meta,
        )
        raw.lines = [lineno] * len(pos) if len(pos) == len(load) else None
        if (dims["position"], dims["load"]) == (0, 1) and not given:
            raw.notes.append("dimension 0 read as position and dimension 1 as load (default)")
        out.append(raw)
    return out


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
            if key not in _COLUMN_KEYS:
                raise CardError(
                    f"unknown columns key {key!r}; known: {', '.join(sorted(_COLUMN_KEYS))}",
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
            if _COLUMN_KEYS[key] in {_COLUMN_KEYS[k] for k in cols}:
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


def parse_cards(
    data: bytes | str,
    *,
    name: str = "<data>",
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
    """Read cards from file content already in memory.

    Same as :func:`read_cards` (see there for all parameters), but takes the bytes or text
    of the file and a ``name`` used in messages and in :attr:`Card.source`.

    Returns
    -------
    list of Card

    Raises
    ------
    CardError
        For every problem with the content or the options.
    """
    if not isinstance(data, bytes | bytearray | str):
        raise CardError(f"data must be bytes or str, got {type(data).__name__}", path=name)
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
    text, decode_notes = decode(
        bytes(data) if isinstance(data, bytearray) else data, path=name, encoding=encoding
    )
    if not text.strip():
        raise CardError("empty file", path=name)
    if fmt is None:
        fmt = detect_format(text, path=name)
    canonical = _FORMAT_ALIASES[fmt]
    delimiter: str | None = None
    if canonical == "csv":
        if fmt == "tsv":
            delimiter = "\t"
        else:
            delimiter = _sniff_delimiter([ln for _, ln in _meaningful(text)])
            if delimiter is None:
                raise CardError(
                    "no delimiter (comma, semicolon, tab or '|') found: not a delimited table",
                    path=name,
                )
    how = "format given" if format else "format detected"
    if delimiter is not None:
        how += f", delimiter {delimiter!r}"
    file_name = Path(name).name or name
    o = _Opts(
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
    if canonical in ("csv", "whitespace"):
        raws = _read_table(o, text, delimiter)
    elif canonical == "scada":
        raws = _read_scada(o, text)
    elif canonical == "json":
        raws = _read_json(o, text)
    else:
        raws = _read_ts(o, text)
    return [_build(raw, o) for raw in raws]


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
        distinct samples. They override a stroke rate given in the file. A time column in
        the file always wins over both (the rate is then only stored).
    columns : mapping, optional
        Role -> column. Roles: ``t``, ``position``, ``load``, ``card``, ``well``, ``spm``,
        ``period``, ``closure``. Values: a header name, a 0-based column index, or None to
        ignore a column that would otherwise be recognised. For ``.ts`` files the values are
        dimension numbers (default position 0, load 1). Without a header and without
        ``columns``, column 0 is position and column 1 is load (and a note says so).
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
        Text encoding. Default: UTF-8 (BOM allowed), falling back to Latin-1 with a note.

    Returns
    -------
    list of Card
        In file order. Each card's :attr:`~Card.notes` say what was done to its data.

    Raises
    ------
    CardError
        For every problem: unreadable or empty file, unknown format or unit, unparsable
        number, NaN/inf, fewer than ``min_samples`` samples, time not strictly increasing,
        mismatched lengths, constant load or position. The message names the file, the line
        or field, and what is wrong.

    Notes
    -----
    Supported formats: delimited tables with or without header (comma, semicolon, tab,
    pipe; a card-id column splits the file into cards), pipe-delimited SCADA exports with
    one card per row, JSON (one card object, a list, or ``{"cards": [...]}``), whitespace
    tables (Fortran-style numbers allowed) and sktime ``.ts`` files with two dimensions.
    """
    try:
        p = os.fspath(path)
    except TypeError as exc:
        raise CardError(f"path must be a string or path-like, got {type(path).__name__}") from exc
    try:
        data = Path(p).read_bytes()
    except OSError as exc:
        raise CardError(f"cannot read the file: {exc.strerror or exc}", path=p) from exc
    return parse_cards(
        data,
        name=str(p),
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
    )


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
