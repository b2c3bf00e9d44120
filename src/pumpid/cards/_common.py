"""What every format reader shares: options, the raw record, number parsing and building.

Every reader turns text into a list of :class:`Raw` records (numbers plus where they came
from); :func:`build` then applies the documented clean-ups (flagged closure rows, duplicated
closing point), checks everything and makes the :class:`~pumpid.cards.Card`. Keeping the
checks in one place is what makes the error messages uniform across formats.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._errors import CardError
from ._plausible import padding_dropped, plausibility_warnings, stroke_rate_warning
from ._rises import record_stroke, several_strokes, time_from_rate
from ._strokes import split_strokes
from ._text import iter_lines, normalize_name, number_problem, parse_number
from ._types import Card
from ._units import TIME_UNITS, normalize_load_unit, normalize_position_unit, normalize_time_unit

# A duplicated closing point is an exact copy of the first sample; printed numbers are
# copied text, so anything looser than this would start eating genuine samples.
_CLOSE_RTOL = 1e-9
# A signal whose range is below this fraction of its magnitude varies only in its last
# printed digits (rounding), whatever its scale: it carries nothing to identify.
FLAT_RTOL = 1e-12

_INT_TEXT = re.compile(r"^[+-]?[0-9]{1,18}$")
_TRUE = frozenset({"1", "true", "yes", "y", "t"})
_FALSE = frozenset({"0", "false", "no", "n", "f", ""})

ColumnRoleMeta = dict[str, Any]


# --------------------------------------------------------------------------- options
@dataclass(frozen=True)
class Opts:
    """The reading options, checked, plus what the readers need to name things."""

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
class Raw:
    """Numbers of one card as read, before checks and clean-ups."""

    position: Sequence[float] | NDArray[np.float64]
    load: Sequence[float] | NDArray[np.float64]
    card_id: str
    source: str
    t: Sequence[float] | NDArray[np.float64] | None = None
    lines: Sequence[int] | NDArray[np.int64] | None = None  # line of each sample
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
    warnings: list[str] = field(default_factory=list)
    metadata: dict[str, Any] = field(default_factory=dict)
    row_arrays: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    closure_mask: NDArray[np.bool_] | None = None
    closure_field: str = ""
    roles_detected: bool = False  # position/load chosen from their shapes


# --------------------------------------------------------------------------- helpers
def fmt(x: float) -> str:
    return f"{x:.6g}"


def line_span(lines: Sequence[int] | NDArray[np.int64]) -> str:
    if len(lines) == 0:
        return ""
    lo, hi = int(min(lines)), int(max(lines))
    return f"line {lo}" if lo == hi else f"lines {lo}-{hi}"


def _kept_span(raw: Raw, lines: NDArray[np.int64] | None) -> str:
    """The raw card's source with its line span narrowed to the lines kept (a dropped
    closing point's line is not the card's)."""
    if lines is None or raw.lines is None or not len(lines):
        return raw.source
    whole = line_span(raw.lines)
    if not raw.source.endswith(whole):
        return raw.source
    return raw.source[: len(raw.source) - len(whole)] + line_span(lines)


def meaningful(text: str) -> Iterator[tuple[int, str]]:
    """Non-blank lines that are not ``#`` comments, with their line numbers, lazily."""
    for i, line in iter_lines(text):
        head = line[:1]
        if head and head not in " \t#\f\v":
            yield i, line
            continue
        s = line.strip()
        if s and not s.startswith("#"):
            yield i, line


def num(o: Opts, token: str, *, line: int | None, field: str, decimal_comma: bool = False) -> float:
    """Parse a number or raise a CardError naming the line and field."""
    tok = token.strip()
    if not tok:
        raise o.error("empty value where a number is expected", line=line, field=field)
    try:
        return parse_number(tok)
    except OverflowError as exc:  # pragma: no cover - float() of text gives inf instead
        raise o.error(f"number {tok!r} is out of range", line=line, field=field) from exc
    except ValueError as exc:
        if decimal_comma and tok.count(",") == 1:
            try:
                return parse_number(tok.replace(",", "."))
            except ValueError:
                pass
        raise o.error(number_problem(tok), line=line, field=field) from exc


def numbers(o: Opts, text: str, *, line: int, field: str, sep: str = ",") -> NDArray[np.float64]:
    """A ``sep``-separated list of numbers as a float array (``field[i]`` in errors)."""
    parts = text.split(sep)
    if "_" not in text:
        try:  # the common case in one pass; the slow path below finds the culprit
            return np.array([float(p) for p in parts], dtype=float)
        except ValueError:
            pass
    return np.array(
        [num(o, p, line=line, field=f"{field}[{i}]") for i, p in enumerate(parts)], dtype=float
    )


def rate(o: Opts, value: float, *, line: int | None, field: str, what: str) -> float:
    if math.isnan(value):
        raise o.error(f"{what} is not a number (NaN)", line=line, field=field)
    if not (math.isfinite(value) and value > 0):
        raise o.error(
            f"{what} must be a positive finite number, got {value!r}", line=line, field=field
        )
    return value


def same(a: float, b: float) -> bool:
    a, b = float(a), float(b)  # Python floats: no overflow warning near 1e308
    return abs(a - b) <= _CLOSE_RTOL * max(abs(a), abs(b))


def repeats_first(position: NDArray[np.float64], load: NDArray[np.float64]) -> bool:
    """Whether a card's last sample repeats its first: a duplicated closing point.

    Every reader drops it from a card without time (the time rebuilt from the pumping speed
    would be a sample off, and the fit another).

    Parameters
    ----------
    position, load : ndarray
        The card's samples, in order.

    Returns
    -------
    bool
        True where there are two samples or more and the last equals the first in position
        and load to a relative 1e-9 (printed numbers copied as text).
    """
    return (position.size >= 2 and same(position[0], position[-1])
            and same(load[0], load[-1]))


def file_unit(o: Opts, kind: str, text: str | None, *, line: int | None, field: str) -> str | None:
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


def time_factor(o: Opts, text: str | None, *, line: int | None, field: str) -> float:
    if text is None:
        return 1.0
    try:
        return TIME_UNITS[normalize_time_unit(text, field=field)]
    except CardError as exc:
        raise o.error(exc.reason, line=line, field=field) from exc


def parse_flag(o: Opts, token: str, *, line: int, field: str) -> bool:
    tok = token.strip().lower()
    if tok in _TRUE:
        return True
    if tok in _FALSE:
        return False
    try:
        value = parse_number(tok)
    except ValueError:
        value = math.nan
    if not math.isnan(value):
        return value != 0
    raise o.error(
        f"expected a yes/no flag (1/0, true/false), got {token!r}", line=line, field=field
    )


def scalar(token: str) -> int | float | str:
    """A metadata value: int for integers as written, float for other numbers, else text."""
    tok = token.strip()
    if _INT_TEXT.match(tok):
        return int(tok)
    try:
        return parse_number(tok)
    except ValueError:
        return tok


def flat(x: NDArray[np.float64]) -> bool:
    """True when ``x`` does not vary beyond rounding of its own magnitude (any scale)."""
    hi, lo = float(np.max(x)), float(np.min(x))
    if hi == lo:
        return True
    # Halves: the range of values near +-1e308 must not overflow.
    return (hi / 2 - lo / 2) <= 0.5 * FLAT_RTOL * max(abs(hi), abs(lo))


# Field names (normalised) that state when a card was recorded, in order of preference.
_STAMP_NAMES = ("timestamp", "time_stamp", "datetime", "date_time", "card_time", "card_date",
                "time", "first_sample_time", "date")


def card_time(meta: dict[str, Any], notes: list[str]) -> None:
    """Put the card's recording time in ``meta["time"]`` (an aware UTC ``datetime``).

    Formats name it differently (a ``timestamp`` column or JSON key, a SCADA ``Timestamp``
    or ``Date`` field); one key lets every caller find it. ISO 8601 text is understood
    (``2024-01-01T06:00:00Z``, ``2024-01-01 06:00:00``, ``2024-01-01``); a time without a
    zone is taken as UTC (noted). Other text is left alone, noted; nothing is raised.
    """
    if isinstance(meta.get("time"), datetime):
        return
    found = {normalize_name(k): k for k, v in meta.items()
             if isinstance(k, str) and isinstance(v, str) and v.strip()}
    key = next((found[n] for n in _STAMP_NAMES if n in found), None)
    if key is None:
        return
    text = meta[key].strip()
    try:
        stamp = datetime.fromisoformat(text)
    except (ValueError, OverflowError):
        notes.append(f"card time {text!r} ({key!r}) is not an ISO 8601 date and time: not used")
        return
    if stamp.tzinfo is None:
        notes.append(f"card time {text!r} has no time zone: taken as UTC")
        stamp = stamp.replace(tzinfo=UTC)
    meta["time"] = stamp.astimezone(UTC)


# --------------------------------------------------------------------------- building
def _period_of(spm: float | None, period: float | None) -> float | None:
    """The stroke period (s) a rate states, None when it states none usable (a rate out of
    range is refused further on, with its value)."""
    value = period if period is not None else (60.0 / spm if spm else None)
    return value if value is not None and math.isfinite(value) and value > 0 else None


def build(raw: Raw, o: Opts, said: set[str]) -> Card:
    """Check one raw card, apply the documented clean-ups and make the Card.

    ``said`` collects file-wide notes already given to an earlier card of the same file
    (unknown units), so that they are not repeated on every card.
    """
    notes = [*o.file_notes, *raw.notes]
    meta = dict(raw.metadata)
    with np.errstate(all="ignore"):
        pos = np.asarray(raw.position, dtype=float)
        load = np.asarray(raw.load, dtype=float)
        t = None if raw.t is None else np.asarray(raw.t, dtype=float) * raw.t_factor
    lines = None if raw.lines is None else np.asarray(raw.lines, dtype=np.int64)
    arrays = dict(raw.row_arrays)
    label = f"card {raw.card_id!r}"

    def err(msg: str, k: int | None = None, fld: str | None = None) -> CardError:
        line = raw.line
        if k is not None and lines is not None and k < lines.size:
            line = int(lines[k])
        elif k is not None and fld is not None and raw.line is None:
            fld = f"{fld}[{k}]"  # JSON: no lines, so point into the array instead
        return o.error(f"{label}: {msg}", line=line, field=fld)

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
            if arr is t and np.isfinite(raw.t[k]):  # type: ignore[index]
                raise err(f"time {raw.t[k]!r} overflows when converted to seconds", k, fld)  # type: ignore[index]
            kind = "NaN" if np.isnan(arr[k]) else "infinite"
            raise err(f"{kind} value in {fld} (sample {k})", k, fld)

    keep = np.ones(pos.size, dtype=bool)
    if raw.closure_mask is not None and raw.closure_mask.any():
        idx = np.flatnonzero(raw.closure_mask)
        keep &= ~raw.closure_mask
        where = "" if lines is None else f" ({line_span(lines[idx])})"
        notes.append(
            f"{idx.size} row(s) flagged as closure point in column {raw.closure_field!r} "
            f"dropped{where}"
        )
    # 39 of the public oilfield set's 360 cards end in 50 samples of exactly (0, 0): fitted
    # as a fifth of the stroke, with a period rebuilt from the SPM 25 % too long, their
    # statuses and values were another card's.
    kept = np.flatnonzero(keep)
    span, dropped = padding_dropped(pos[kept], load[kept], (o.position_unit or raw.pos_unit,
                                                            o.load_unit or raw.load_unit))
    padded = kept.size - (span.stop - span.start)
    keep[kept] = False
    keep[kept[span]] = True
    for where, note in dropped:
        notes.append(note + ("" if lines is None else f" ({line_span(lines[kept[where]])})"))
    if o.drop_closing_point and t is None and keep.sum() >= 2:
        first, last = np.flatnonzero(keep)[[0, -1]]
        if repeats_first(pos[[first, last]], load[[first, last]]):
            keep[last] = False
            where = "" if lines is None else f" (line {int(lines[last])})"
            notes.append(
                "duplicated closing point dropped: the last sample repeats the first in "
                f"position and load{where}"
            )
    if not keep.all():
        pos, load = pos[keep], load[keep]
        t = None if t is None else t[keep]
        lines = None if lines is None else lines[keep]
        arrays = {k: v[keep] for k, v in arrays.items()}

    if t is not None and t.size > 1:
        with np.errstate(invalid="ignore", over="ignore"):
            bad = np.flatnonzero(~(np.diff(t) > 0))
        if bad.size:
            k = int(bad[0]) + 1
            raise err(
                f"time is not strictly increasing: {fmt(t[k])} s follows {fmt(t[k - 1])} s",
                k,
                raw.t_field,
            )
    if pos.size < o.min_samples:
        first_line = None if lines is None or not lines.size else int(lines[0])
        after = f" after {padded} samples of padding were dropped" if padded else ""
        raise o.error(
            f"{label}: only {pos.size} samples{after}, at least {o.min_samples} needed",
            line=first_line if first_line is not None else raw.line,
            field=raw.pos_field,
        )
    for arr, fld, what in ((load, raw.load_field, "load"), (pos, raw.pos_field, "position")):
        if flat(arr):
            if float(arr.max()) == float(arr.min()):
                raise err(f"constant {what} ({fmt(arr[0])} in every sample)", fld=fld)
            raise err(
                f"{what} is constant to {-math.log10(FLAT_RTOL):.0f} significant digits "
                f"({fmt(arr.min())} to {fmt(arr.max())}): it varies only by rounding, nothing "
                "to identify",
                fld=fld,
            )

    # Units: the caller's declaration wins over what the file says (and a note records it).
    units: dict[str, str | None] = {}
    unknown: list[str] = []
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
            # Said once per file: the unit is a property of the file, not of each card.
            key = f"unknown {kind} unit"
            if key not in said:
                said.add(key)
                unknown.append(kind)
            units[kind] = None
    if unknown:
        # One note with the remedy: every number of such a card reads "unit not stated".
        what = " and ".join(unknown)
        them = "it" if len(unknown) == 1 else "them"
        args = " and ".join(f"{k}_unit=" for k in unknown)
        flags = ", ".join(f"--{k}-unit" for k in unknown)
        notes.append(
            f"{what} unit{'s' if len(unknown) > 1 else ''} not stated in the file nor given "
            f"by the caller: left unknown, so values and parameters are in the file's units "
            f"with the unit not stated; give {them} with {args} (command line {flags}) "
            "(noted on the first such card of the file only)"
        )
    if raw.t is not None and raw.t_factor != 1.0:
        notes.append(f"time converted to seconds (x {raw.t_factor:g})")

    # Time: file time wins; otherwise the caller's rate, then the file's rate.
    spm, period, rate_where = raw.spm, raw.period, raw.rate_where
    time_warnings: list[str] = []
    if o.spm is not None or o.period is not None:
        if spm is not None or period is not None:
            notes.append(
                f"stroke rate given by the caller overrides the one in the file ({rate_where})"
            )
            mine = _period_of(spm, period)
            given = _period_of(o.spm, o.period)
            if t is None and mine and given and not math.isclose(mine, given, rel_tol=1e-9):
                # A field's --spm re-timed every card that states its own rate (8 SPM read
                # as 4 halved the displacement) with only a note, shown under --verbose.
                time_warnings.append(
                    f"the card's time is rebuilt from the stroke rate given "
                    f"({fmt(60.0 / given)} SPM), not from the file's own "
                    f"({fmt(60.0 / mine)} SPM, {rate_where})")
        spm, period, rate_where = o.spm, o.period, "given by the caller"
    if spm is not None and period is None:
        period = 60.0 / spm
    elif period is not None and spm is None:
        spm = 60.0 / period
    if (
        spm is not None
        and period is not None
        and not (math.isfinite(spm) and math.isfinite(period) and spm > 0 and period > 0)
    ):
        raise err(f"stroke rate out of range (SPM {spm!r}, period {period!r} s)")
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
        if spm is not None:
            # The file's own time wins; a rate beside it is not used (the JSON said "spm":
            # 5.0, "period": 12.0 beside a fit on the file's 7.07 s).
            notes.append(f"the stroke rate {fmt(spm)} SPM ({rate_where}) is not used: the "
                         "card's time comes from the file")
            spm = period = None
    elif spm is not None and period is not None:
        used = "spm" if raw.spm is not None or o.spm is not None else "period"
        what = f"{fmt(spm)} SPM" if used == "spm" else f"stroke period {fmt(period)} s"
        time_source = used
        # A record of several strokes without time, given a stroke rate, was fitted as one
        # stroke with its motion three times too fast, and without a word.
        t, several = time_from_rate(raw.card_id, pos, period, f"{what} ({rate_where})")
        if several:
            time_warnings.append(several)
        else:
            periodic = True
            notes.append(
                f"time rebuilt from {what} ({rate_where}) assuming uniform sampling over one "
                f"stroke: t_i = i*T/N with T = {fmt(period)} s, N = {n}"
            )
    else:
        time_source = "none"
        notes.append(
            "no time read from the file and no SPM or period given: the card has no time "
            "axis; give the stroke rate (spm= or period=, command line --spm or --period) to "
            "rebuild it"
        )
    for name, arr in arrays.items():
        meta.setdefault(name, arr)
    card_time(meta, notes)
    warnings = [
        *raw.warnings,
        *time_warnings,
        *plausibility_warnings(
            raw.card_id,
            pos,
            load,
            units["position"],
            units["load"],
            fields=(raw.pos_field, raw.load_field),
            check_swap=not raw.roles_detected,
        ),
    ]
    try:
        card = Card(
            position=pos,
            load=load,
            t=t,
            position_unit=units["position"],
            load_unit=units["load"],
            source=_kept_span(raw, lines),
            card_id=raw.card_id,
            well_id=well_id,
            spm=spm,
            period=period,
            time_source=time_source,
            periodic=periodic,
            notes=tuple(notes),
            metadata=meta,
            warnings=tuple(warnings),
        )
    except CardError as exc:  # pragma: no cover - the checks above should catch everything
        raise o.error(f"{label}: {exc.reason}", line=raw.line, field=exc.field) from exc
    card = one_period(rounded_time(card)) if time_source == "file" else card
    # A time column in milliseconds named plainly "time" gave a stroke of 4 hours, a
    # displacement a thousand times too small and no word.
    slow = stroke_rate_warning(raw.card_id, stroke_period(card),
                               raw.t_field if time_source == "file" else None, rate_where)
    return with_record_warnings(card, slow)


def with_record_warnings(card: Card, slow: str | None) -> Card:
    """``card`` with the stroke-rate warning ``slow`` (if any) and, for a record in its own
    time, the warning that it holds several strokes (:func:`several_strokes`).

    Parameters
    ----------
    card : Card
        As read.
    slow : str or None
        :func:`stroke_rate_warning`'s word on its stroke rate.

    Returns
    -------
    Card
    """
    several = (several_strokes(card.card_id, card.position, card.t)
               if card.time_source == "file" and not card.periodic else None)
    added = tuple(w for w in (slow, several) if w)
    return card.replace(warnings=(*card.warnings, *added)) if added else card


def stroke_period(card: Card) -> float | None:
    """The duration of one of a card's strokes (s): its period where it has one (one stroke,
    or a record timed per stroke from a rate), else, for a record in its own time, the
    samples between two rises through mid-stroke times the mean step; None when unknown.

    Parameters
    ----------
    card : Card

    Returns
    -------
    float or None
    """
    if card.period is not None:
        return card.period
    return record_stroke(card.position, card.t)


#: Largest departure of a time column's steps from their mean (relative) that is still a
#: uniformly sampled stroke: a logger's jitter, not a gap (a missing sample is a step of 2).
JITTER = 0.25


def _written_to(t: NDArray[np.float64]) -> float | None:
    """The unit of the last decimal the times are written to (1e-3 for milliseconds), None
    beyond nine decimals."""
    for digits in range(10):
        scaled = t * 10.0**digits
        if np.max(np.abs(scaled - np.round(scaled))) <= 1e-6:
            return 10.0**-digits
    return None


def rounded_time(card: Card) -> Card:
    """A card whose times are a uniform grid rounded to the decimals they are written to,
    given the grid's times.

    1/30 s written to six decimals varies the steps by 3e-5 of one, to milliseconds by 3 %:
    the fit took such a card as sampled non-uniformly and simulated it step by step (21 s a
    fit instead of 0.3 s). Where every time lies within one unit of its last decimal of a
    uniform grid ``t_0 + i*dt`` (fitted by least squares), the card takes the grid's times,
    and a note says how far the file's were off. Times off the grid by more (a rate that changes,
    a logger's drift) are left as they are.

    Parameters
    ----------
    card : Card
        As read, timed by its file.

    Returns
    -------
    Card
        ``card``, or a copy on the grid with a note.
    """
    t = card.t
    if t is None or card.n < 3:
        return card
    # The grid the file rounded, by least squares: its ends are rounded too (the step from
    # the first and last of 90 times to milliseconds at 30 a second was 1e-4 of one off).
    k = np.arange(card.n) - (card.n - 1) / 2
    dt = float(np.dot(k, t - t.mean()) / np.dot(k, k))
    times = float(t.mean()) + k * dt
    off = float(np.max(np.abs(t - times)))
    spacing = 4.0 * np.finfo(float).eps * max(abs(float(t[0])), abs(float(t[-1])))
    unit = _written_to(np.asarray(t, dtype=float))
    if off <= 1e-9 * dt + spacing or unit is None or off > unit * (1 + 1e-6) + spacing:
        return card
    return card.replace(
        t=times,
        note=(f"time written to {fmt(unit)} s, a uniform grid rounded (steps equal to "
              f"{float(np.ptp(np.diff(t))) / dt:.1g} of one): taken as t_i = t_0 + i*dt with "
              f"dt = {fmt(dt)} s (the file's times at most {fmt(off)} s off), so that the "
              "card is simulated with one step"))


def one_period(card: Card) -> Card:
    """A card whose own time spans a single stroke, uniformly sampled, as one period.

    A dynamometer card is one stroke of a periodic motion, whether its export carries time
    or only the stroke rate; without this, the same stroke with a time column was fitted as
    a record from rest, without a position offset (another status and other values), and
    ``pumpid downhole`` took the same file as one stroke. A record of several strokes (two
    bottoms of stroke with the rod seen turning around) stays a record. A logger's jitter
    (every step within :data:`JITTER` of the mean step) is still uniform sampling: with 5 %
    jitter the same stroke was fitted from rest, its status and values another card's, and
    nothing said why. Such a stroke is given the uniform times its logger meant (the mean
    step from its first sample; the solvers of a stroke's harmonics need them), and the note
    says how far its own times were off.
    """
    if card.t is None or card.n < 8:
        return card
    steps = np.diff(card.t)
    dt = float(steps.mean())
    spread = float(np.max(np.abs(steps - dt))) / dt
    if not spread <= JITTER:
        return card
    try:
        strokes = split_strokes(card)
    except CardError:
        return card
    if len(strokes) != 1 or strokes[0].n != card.n:
        return card
    period = card.n * dt
    changes: dict[str, object] = {}
    apart = f"{fmt(dt)} s apart"
    if card.dt is None:
        times = card.t[0] + np.arange(card.n) * dt
        off = float(np.max(np.abs(card.t - times)))
        changes["t"] = times
        apart = (f"{fmt(dt)} s apart on average, each step within {100 * spread:.2g} % "
                 f"of it: taken as uniform, t_i = t_0 + i*dt, the file's times at most "
                 f"{fmt(off)} s off")
    return card.replace(
        periodic=True, period=period, spm=60.0 / period,
        note=(f"one stroke in the file's time ({card.n} samples, {apart}): treated as one "
              f"period of a periodic motion, period N*dt = {fmt(period)} s"), **changes)
