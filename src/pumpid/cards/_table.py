"""Delimited and whitespace tables: one sample per row, with or without a header.

The text is read one line at a time and every number goes straight into a growing float
array per column; no list of lines or of token lists is ever held. Rows of one card must be
contiguous (a card-id column splits the file into cards). Without a header the position and
load columns are recognised from their shapes (see :mod:`pumpid.cards._roles`).
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Callable
from typing import Any

import numpy as np

from ._cells import Column, cli_hint, detect_roles, keep_extra, looks_like_header, splitter
from ._common import (
    Opts,
    Raw,
    fmt,
    line_span,
    meaningful,
    num,
    parse_flag,
    rate,
    time_factor,
)
from ._common import file_unit as _file_unit
from ._errors import CardError
from ._stamps import (
    StampColumn,
    StampError,
    is_stamp,
    join_stamps,
    looks_like_stamp,
    parse_date,
    stamped_time,
)
from ._text import interpret_name, normalize_name, number_problem

__all__ = ["COLUMN_KEYS", "read_table"]

#: ``columns=`` keys and the role each one names.
COLUMN_KEYS = {
    "t": "t", "time": "t", "position": "position", "load": "load", "card": "card",
    "card_id": "card", "well": "well", "well_id": "well", "spm": "spm", "period": "period",
    "closure": "closure",
}  # fmt: skip

# How the cells of a column are read.
_NUM, _FLAG, _KEY, _ANY = "num", "flag", "key", "any"


def _card_id(cols: Any, key_i: int | None, card_i: int | None, kid: int, stem: str,
             blocks: int) -> str:
    """A card's id: its card column's, else the file's name where the file holds one card
    of one well (a per-card export with a well column: 16 files of one well had all been
    called by the well's id), else its well's."""
    if key_i is None or (card_i is None and blocks == 1):
        return stem
    return str(cols[key_i].names[kid])


def resolve_columns(
    o: Opts, header: list[str] | None, ncols: int, header_line: int | None
) -> tuple[dict[str, int], dict[str, str | None], list[str], bool]:
    """Map roles to column indices.

    Returns roles, unit text per role, notes, and whether position and load are still to be
    detected from the data (headerless table, not named by the caller).
    """
    notes: list[str] = []
    roles: dict[str, int] = {}
    units: dict[str, str | None] = {}
    disabled: set[str] = set()
    names = header if header is not None else [f"column_{k}" for k in range(ncols)]
    for key, spec in (o.columns or {}).items():
        role = COLUMN_KEYS[key]
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
    pending = False
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
                f"({', '.join(map(repr, header))}); name them e.g. 'position_in', 'load_lbf', "
                "or say which they are: columns={'position': ..., 'load': ...} (command "
                "line: --position-col NAME --load-col NAME)",
                line=header_line,
                field=missing[0],
            )
    elif "position" not in roles and "load" not in roles:
        if ncols - len(roles) < 2:
            raise o.error(
                f"only {ncols} column found; position and load need two"
                if ncols < 2
                else f"only {ncols - len(roles)} column(s) left for position and load",
                line=header_line,
            )
        pending = True
    elif "position" not in roles or "load" not in roles:
        raise o.error(
            "columns= must give both 'position' and 'load' for a file without header",
            field="columns",
        )
    if len(set(roles.values())) != len(roles):
        raise o.error(f"two roles use the same column: {roles}", field="columns")
    return roles, units, notes, pending


def read_table(o: Opts, holder: list[str], delimiter: str | None) -> list[Raw | CardError]:
    """Read a delimited or whitespace table; ``holder`` holds the text and is emptied.

    Each card is read on its own: a card's problem is a :class:`CardError` in its place
    (with its id), and the other cards are still read.
    """
    rows = meaningful(holder.pop())  # the generator holds the only reference to the text
    first = next(rows, None)
    if first is None:
        raise o.error("no data rows")
    split = splitter(o, delimiter)
    first_line, first_text = first
    first_toks = split(first_text, first_line)
    header: list[str] | None = None
    pending_row: tuple[int, list[str]] | None = None
    if looks_like_header(first_toks):
        header = [h if h else f"column_{k}" for k, h in enumerate(first_toks)]
        ncols = len(header)
    else:
        if delimiter is None:  # a stamp "2024-05-01 10:00:00" is two whitespace fields
            first_toks = join_stamps(first_toks)
        pending_row = (first_line, first_toks)
        ncols = len(first_toks)
    hl = first_line if header is not None else None
    roles, unit_text, col_notes, detect = resolve_columns(o, header, ncols, hl)
    t_given = [v for k, v in (o.columns or {}).items() if COLUMN_KEYS[k] == "t"]
    no_time = None in t_given  # the caller asked for no time column
    if header is None and "t" not in roles and not t_given:
        # A headerless table's column of date/time stamps can only be its time.
        stamped = [k for k, tok in enumerate(first_toks)
                   if k not in roles.values() and is_stamp(tok)]
        if len(stamped) == 1:
            roles["t"] = stamped[0]
            col_notes.append(f"no header: column {stamped[0]} holds date/time stamps, read "
                             "as the time")
    names = header if header is not None else [f"column_{k}" for k in range(ncols)]
    where_cols = "header" if header is not None else "first row"
    decimal_comma = delimiter == ";"

    pos_unit = load_unit = None
    if not detect:
        pos_i, load_i = roles["position"], roles["load"]
        pos_unit = _file_unit(o, "position", unit_text.get("position"), line=hl, field=names[pos_i])
        load_unit = _file_unit(o, "load", unit_text.get("load"), line=hl, field=names[load_i])
    t_i, card_i, well_i = roles.get("t"), roles.get("card"), roles.get("well")
    t_factor = 1.0
    if t_i is not None:
        t_factor = time_factor(o, unit_text.get("t"), line=hl, field=names[t_i])
    period_factor = 1.0
    if roles.get("period") is not None:
        period_factor = time_factor(
            o, unit_text.get("period"), line=hl, field=names[roles["period"]]
        )
    key_i = card_i if card_i is not None else well_i

    # ------------------------------------------------------------------ cell readers
    mode: dict[int, str] = {}
    for c in range(ncols):
        role = next((r for r, i in roles.items() if i == c), None)
        if role in ("position", "load", "t", "spm", "period"):
            mode[c] = _NUM
        elif role == "closure":
            mode[c] = _FLAG
        elif c in (card_i, well_i):
            mode[c] = _KEY
        else:
            mode[c] = _ANY
    cols = [Column(with_values=mode[c] != _KEY) for c in range(ncols)]
    line_no: array[int] = array("q")
    comma_used = [False]

    stamps = StampColumn()

    def stamp_micros(tok: str, lineno: int, c: int) -> float:
        try:
            if stamps.count == 0 and len(cols[c].values or ()):
                raise StampError(f"{tok!r} follows numbers: a column holds numbers or "
                                 "date/time stamps, not both", form=False)
            return stamps.micros(tok)
        except StampError as exc:
            fix = ("write every stamp of the column in one form" if not exc.form else
                   "every cell of a column of stamps must be one" if stamps.count else
                   "convert the column to that form (2024-05-01 10:00:00.25, or 10:00:00.25 "
                   "for a time of day) or to seconds")
            raise o.error(
                f"{exc}; {fix}, or read no time column and give the stroke rate (command "
                "line: --columns t=- --spm N; Python: columns={'t': None})",
                line=lineno,
                field=names[c],
            ) from None

    def slow_number(tok: str, lineno: int, c: int) -> float:
        if stamps.count and c == t_i:
            return stamp_micros(tok, lineno, c)
        try:
            value = num(o, tok, line=lineno, field=names[c], decimal_comma=decimal_comma)
        except CardError:
            if c == t_i and looks_like_stamp(tok):
                return stamp_micros(tok, lineno, c)
            raise
        if decimal_comma and "," in tok:
            comma_used[0] = True
        return value

    def reader(c: int) -> Callable[[str, int], None]:
        col = cols[c]
        kind = mode[c]
        if kind == _KEY:
            assert col.ids is None
            col.ids = ids = array("q")
            is_card = c == key_i

            def read_key(tok: str, lineno: int) -> None:
                if is_card and not tok:
                    raise o.error("empty card identifier", line=lineno, field=names[c])
                ids.append(col.intern(tok))

            return read_key
        assert col.values is not None
        append = col.values.append
        if kind == _NUM:
            is_t = c == t_i  # once a column, not once a cell

            def read_num(tok: str, lineno: int) -> None:
                if "_" not in tok and not (is_t and stamps.count):
                    try:
                        append(float(tok))
                        return
                    except ValueError:
                        pass
                append(slow_number(tok, lineno, c))

            return read_num
        if kind == _FLAG:

            def read_flag(tok: str, lineno: int) -> None:
                append(1.0 if parse_flag(o, tok, line=lineno, field=names[c]) else 0.0)

            return read_flag

        def read_any(tok: str, lineno: int) -> None:
            value: float | None = None
            if "_" not in tok:
                try:
                    value = float(tok)
                except ValueError:
                    # Fortran exponents and decimal commas; plain text is not tried again.
                    if "d" in tok or "D" in tok or (decimal_comma and "," in tok):
                        try:
                            value = num(
                                o, tok, line=lineno, field=names[c], decimal_comma=decimal_comma
                            )
                            comma_used[0] = comma_used[0] or "," in tok
                        except CardError:
                            value = None
            if value is not None:
                append(value)
                if col.ids is not None:
                    col.ids.append(-1)
                return
            if col.ids is None:  # the first text in this column: earlier rows were numbers
                col.ids = array("q", [-1]) * (len(col.values) if col.values is not None else 0)
                col.first_text = (lineno, tok)
            append(math.nan)
            col.ids.append(col.intern(tok))

        return read_any

    readers = [reader(c) for c in range(ncols)]
    extra = [c for c in range(ncols) if mode[c] == _ANY]

    # ------------------------------------------------------------------ the rows
    # Blocks of contiguous rows with the same card key: (key id, first row, first line,
    # first token of every extra column).
    blocks: list[tuple[int, int, int, list[str]]] = []
    block_comma: set[int] = set()
    # The first problem of each block, by block index: a broken row spoils its own card only.
    broken: dict[int, CardError] = {}
    key_ids = cols[key_i].ids if key_i is not None else None

    def all_rows() -> Any:
        if pending_row is not None:
            yield pending_row[0], pending_row[1]
        for lineno, line in rows:
            toks = split(line, lineno)
            # A whitespace table's date and time of day, one stamp split by its space; only
            # where the row has more fields than the header (a header may name both).
            yield lineno, (join_stamps(toks) if delimiter is None and len(toks) > ncols
                           else toks)

    def pad(r: int, toks: list[str], problem: CardError) -> None:
        """Bring every column of a broken row ``r`` to ``r + 1`` cells, so the columns stay
        aligned and the row still belongs to its card (by its key, else the card above)."""
        for c, col in enumerate(cols):
            if col.values is None:  # a key column: the row's key, or the one above
                ids = col.ids
                assert ids is not None
                if len(ids) > r:
                    continue
                tok = toks[c] if c < len(toks) else ""
                if tok:
                    ids.append(col.intern(tok))
                elif len(ids):
                    ids.append(ids[-1])
                elif c == key_i:  # the first row names no card: nothing to attach it to
                    raise problem
                else:
                    ids.append(col.intern(""))
                continue
            if len(col.values) <= r:
                col.values.append(math.nan)
            if col.ids is not None and len(col.ids) <= r:
                col.ids.append(-1)

    for r, (lineno, toks) in enumerate(all_rows()):
        problem: CardError | None = None
        if len(toks) != ncols:
            problem = o.error(
                f"expected {ncols} fields (as in the {where_cols}), found {len(toks)}", line=lineno
            )
        else:
            try:
                for c in range(ncols):
                    readers[c](toks[c], lineno)
            except CardError as exc:
                problem = exc
        if problem is not None:
            if key_i is None:  # the file is one card: its problem is the file's
                raise problem
            pad(r, toks, problem)
        line_no.append(lineno)
        if key_ids is not None:
            kid = key_ids[-1]
            if not blocks or kid != blocks[-1][0]:
                blocks.append((kid, r, lineno, [toks[c] if c < len(toks) else "" for c in extra]))
        elif not blocks:
            blocks.append((-1, 0, lineno, [toks[c] for c in extra]))
        if problem is not None:
            broken.setdefault(len(blocks) - 1, problem)
        if comma_used[0]:
            block_comma.add(len(blocks) - 1)
            comma_used[0] = False
    nrows = len(line_no)
    if nrows == 0:
        raise o.error("header but no data rows", line=first_line)

    values = [
        np.frombuffer(col.values, dtype=float) if col.values is not None else None for col in cols
    ]
    text_ids = [
        np.frombuffer(col.ids, dtype=np.int64) if col.ids is not None else None for col in cols
    ]
    lines_all = np.frombuffer(line_no, dtype=np.int64)

    # ------------------------------------------------------------------ roles
    column_roles: dict[str, Any]
    detected = False
    if detect:
        if broken:  # the columns' shapes decide their roles: a broken row blurs them all
            raise broken[min(broken)]
        roles_found = detect_roles(o, values, cols, roles, nrows)
        if roles_found is None:  # too few rows to judge: let the sample count refuse
            candidates = [c for c in range(ncols) if c not in roles.values()]
            roles["position"], roles["load"] = candidates[0], candidates[1]
            col_notes.append(
                f"no header: column {candidates[0]} read as position and column "
                f"{candidates[1]} as load (too few rows to recognise them)"
            )
            column_roles = {
                "position": candidates[0],
                "load": candidates[1],
                "confidence": 0.0,
                "words": "low",
                "method": "default order (too few rows)",
            }
        else:
            roles["position"], roles["load"] = roles_found.position, roles_found.load
            detected = True
            others = "; ".join(f"column {k}: {d}" for k, d in roles_found.other.items())
            col_notes.append(
                f"no header: column {roles_found.position} read as position and column "
                f"{roles_found.load} as load, recognised from their shapes with "
                f"{roles_found.words} confidence ({roles_found.confidence:.3f})"
                + (f"; other columns: {others}" if others else "")
                + "; pass columns= (command line --columns) to change"
            )
            column_roles = roles_found.to_metadata()
    else:
        named = any(
            COLUMN_KEYS[k] in ("position", "load")
            for k, v in (o.columns or {}).items()
            if v is not None
        )
        how = "given by the caller (columns=)" if named else "header names"
        column_roles = {
            "position": roles["position"],
            "load": roles["load"],
            "confidence": 1.0,
            "words": "certain",
            "method": how,
        }
    pos_i, load_i = roles["position"], roles["load"]
    for c in (pos_i, load_i):
        if cols[c].first_text is not None:
            lineno, tok = cols[c].first_text  # type: ignore[misc]
            raise o.error(
                number_problem(tok) if tok else "empty value where a number is expected",
                line=lineno,
                field=names[c],
            )
    moderate_warning = None
    if detected and column_roles["confidence"] < 0.95:
        moderate_warning = (
            f"the position and load columns of this headerless file were recognised with only "
            f"{column_roles['words']} confidence ({column_roles['confidence']:.3f}): check them, "
            f"and if they are wrong {cli_hint(load_i, pos_i)}"
        )

    # ------------------------------------------------------------------ the cards
    used = set(roles.values())
    out: list[Raw | CardError] = []
    pos_all, load_all = values[pos_i], values[load_i]
    assert pos_all is not None and load_all is not None
    t_all = values[t_i] if t_i is not None else None
    bounds = [b[1] for b in blocks] + [nrows]

    def make(b: int, kid: int, start: int, firsts: list[str]) -> Raw:
        end = bounds[b + 1]
        lines = lines_all[start:end]
        notes = list(col_notes)
        card_id = _card_id(cols, key_i, card_i, kid, o.stem, len(blocks))
        raw = Raw(
            position=pos_all[start:end],
            load=load_all[start:end],
            t=None if t_all is None else t_all[start:end],
            card_id=card_id,
            source=f"{o.name}, {line_span(lines)}",
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
            metadata={"column_roles": dict(column_roles)},
            roles_detected=detected,
        )
        if moderate_warning is not None:
            raw.warnings.append(moderate_warning)
        if well_i is not None:
            ids = text_ids[well_i]
            assert ids is not None
            wells = np.unique(ids[start:end])
            if wells.size > 1:
                shown = ", ".join(sorted(cols[well_i].names[int(w)] for w in wells))
                raise o.error(
                    f"card {card_id!r} spans several wells ({shown})",
                    line=int(lines[0]),
                    field=names[well_i],
                )
            raw.well_id = cols[well_i].names[int(wells[0])] or None
        for role in ("spm", "period"):
            col = roles.get(role)
            if col is None:
                continue
            vals = values[col]
            assert vals is not None
            vals = vals[start:end]
            bad = np.flatnonzero(~np.isfinite(vals))
            if bad.size:
                k = int(bad[0])
                rate(o, float(vals[k]), line=int(lines[k]), field=names[col], what=role)
            if np.any(vals != vals[0]):
                k = int(np.flatnonzero(vals != vals[0])[0])
                raise o.error(
                    f"{role} changes within card {card_id!r} ({fmt(vals[0])} then "
                    f"{fmt(vals[k])}); one card has one stroke rate",
                    line=int(lines[k]),
                    field=names[col],
                )
            with np.errstate(over="ignore"):
                value = float(vals[0]) * (period_factor if role == "period" else 1.0)
            value = rate(o, value, line=int(lines[0]), field=names[col], what=role)
            setattr(raw, role, value)
            raw.rate_where = raw.rate_where or f"column {names[col]!r}"
        if raw.spm is not None and raw.period is not None:
            # SPM wins; the period is kept in metadata so nothing from the file is lost.
            raw.metadata[names[roles["period"]]] = raw.period
            raw.period = None
        col = roles.get("closure")
        if col is not None:
            flags = values[col]
            assert flags is not None
            raw.closure_mask = flags[start:end] > 0.5
            raw.closure_field = names[col]
        # Everything else is kept: constant columns as scalars, varying numeric ones as arrays.
        for j, c in enumerate(extra):
            if c in used:
                continue
            keep_extra(raw, names[c], values[c], text_ids[c], start, end, firsts[j], notes,
                       hint=not no_time)
        if stamps.count and raw.t is not None and t_i is not None:
            # A time of day has no date of its own: a date column's first row gives the card
            # its recording date.
            on = next((d for j, c in enumerate(extra) if normalize_name(names[c]) == "date"
                       and (d := parse_date(firsts[j])) is not None), None)
            stamped_time(o, raw, stamps, names[t_i], on)
        if b in block_comma:
            notes.append("decimal commas read as decimal points")
        return raw

    def well_of(start: int, end: int) -> str | None:
        if well_i is None:
            return None
        ids = text_ids[well_i]
        assert ids is not None
        wells = np.unique(ids[start:end])
        return (cols[well_i].names[int(wells[0])] or None) if wells.size == 1 else None

    # A card's rows in separate blocks (A, B, A) refuse that card, not its neighbours.
    skip: set[int] = set()
    if key_i is not None:
        by_key: dict[int, list[int]] = {}
        for b, blk in enumerate(blocks):
            by_key.setdefault(blk[0], []).append(b)
        for kid, found in by_key.items():
            if len(found) < 2:
                continue
            spans = [(int(lines_all[bounds[b]]), int(lines_all[bounds[b + 1] - 1]))
                     for b in found[:2]]
            broken[found[0]] = o.error(
                f"card {cols[key_i].names[kid]!r} has rows in two separate blocks, lines "
                f"{spans[0][0]}-{spans[0][1]} and lines {spans[1][0]}-{spans[1][1]}"
                + (f" (and {len(found) - 2} more)" if len(found) > 2 else "")
                + ", with rows of other cards between; a card's rows must be contiguous: "
                "sort the file by card, or give each block its own id",
                line=spans[1][0],
                field=names[key_i],
            )
            skip.update(found[1:])
    for b, (kid, start, _line0, firsts) in enumerate(blocks):
        if b in skip:
            continue
        card_id = _card_id(cols, key_i, card_i, kid, o.stem, len(blocks))
        try:
            if b in broken:
                raise broken[b]
            out.append(make(b, kid, start, firsts))
        except CardError as exc:
            out.append(exc.for_card(card_id, well_of(start, bounds[b + 1])))
    return out
