"""Plausibility of a card's magnitudes for a polished-rod dynamometer card.

Nothing here changes or refuses data: a value that is possible but unlikely for a sucker-rod
pump (a stroke of kilometres, a load of a few millinewtons) becomes a warning naming the
card and the value with its unit. When a unit is unknown, a value is flagged only if it is
implausible in every unit it could be in.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._errors import CardError
from ._rises import strokes_seen
from ._roles import detect_column_roles
from ._units import LOAD_UNITS, POSITION_UNITS

__all__ = [
    "MAX_LOAD_N",
    "MAX_POSITION_M",
    "MAX_STROKE_M",
    "MIN_LOAD_N",
    "MIN_LOAD_SWING",
    "MIN_STROKE_M",
    "PADDING_SHARE",
    "SPM_PLAUSIBLE",
    "SWAP_CONFIDENCE",
    "leading_padding",
    "loop_work",
    "open_stroke",
    "padding_dropped",
    "plausibility_warnings",
    "stroke_rate_warning",
    "trailing_padding",
]

#: Longest plausible polished-rod stroke (the longest long-stroke units reach about 10 m).
MAX_STROKE_M = 15.0
#: Shortest plausible stroke: below a centimetre the "card" is not a pump stroke.
MIN_STROKE_M = 0.01
#: Largest plausible distance of any position sample from zero.
MAX_POSITION_M = 30.0
#: Largest plausible polished-rod load in magnitude (about 100,000 lbf).
MAX_LOAD_N = 450e3
#: Smallest plausible largest load magnitude (about 2 lbf): a rod string weighs far more.
MIN_LOAD_N = 10.0
#: Smallest plausible load swing (range over the card) as a fraction of the mean load.
MIN_LOAD_SWING = 0.01
#: Confidence above which a card's position and load are said to look swapped.
SWAP_CONFIDENCE = 0.95


def _fmt(x: float) -> str:
    # A range of values near +-1e308 overflows: say so rather than print "inf".
    return f"{x:.4g}" if math.isfinite(x) else "beyond 1.8e+308"


def _position_checks(label: str, pos: NDArray[np.float64], unit: str | None) -> list[str]:
    out: list[str] = []
    stroke = float(np.max(pos) / 2 - np.min(pos) / 2) * 2  # no overflow near 1e308
    reach = float(np.max(np.abs(pos)))
    if unit is not None:
        k = POSITION_UNITS[unit]
        s_m, r_m = stroke * k, reach * k
        if s_m > MAX_STROKE_M:
            out.append(
                f"{label}: stroke length {_fmt(stroke)} {unit} ({_fmt(s_m)} m) is implausible "
                f"for a polished rod (more than {MAX_STROKE_M:g} m); check the position unit"
            )
        elif s_m < MIN_STROKE_M:
            out.append(
                f"{label}: stroke length {_fmt(stroke)} {unit} ({_fmt(s_m)} m) is implausible "
                f"for a polished rod (less than {MIN_STROKE_M:g} m); check the position unit"
            )
        if r_m > MAX_POSITION_M and s_m <= MAX_STROKE_M:
            out.append(
                f"{label}: positions reach {_fmt(reach)} {unit} ({_fmt(r_m)} m) from zero, "
                f"more than {MAX_POSITION_M:g} m: a polished-rod position stays within a "
                "stroke of its bottom"
            )
        return out
    smallest, largest = min(POSITION_UNITS.values()), max(POSITION_UNITS.values())
    small_name = min(POSITION_UNITS, key=POSITION_UNITS.__getitem__)
    large_name = max(POSITION_UNITS, key=POSITION_UNITS.__getitem__)
    if stroke * smallest > MAX_STROKE_M:
        out.append(
            f"{label}: stroke length {_fmt(stroke)} (position unit unknown) is implausible in "
            f"any position unit (more than {MAX_STROKE_M:g} m even in {small_name})"
        )
    elif stroke * largest < MIN_STROKE_M:
        out.append(
            f"{label}: stroke length {_fmt(stroke)} (position unit unknown) is implausible in "
            f"any position unit (less than {MIN_STROKE_M:g} m even in {large_name})"
        )
    elif reach * smallest > MAX_POSITION_M:
        out.append(
            f"{label}: positions reach {_fmt(reach)} (position unit unknown) from zero: "
            f"more than {MAX_POSITION_M:g} m even in {small_name}"
        )
    return out


def _load_checks(label: str, load: NDArray[np.float64], unit: str | None) -> list[str]:
    out: list[str] = []
    peak = float(np.max(np.abs(load)))
    if unit is not None:
        p_n = peak * LOAD_UNITS[unit]
        if p_n > MAX_LOAD_N:
            out.append(
                f"{label}: load reaches {_fmt(peak)} {unit} ({_fmt(p_n)} N), implausible for "
                f"a rod string (more than {MAX_LOAD_N:g} N, about 100,000 lbf); check the "
                "load unit"
            )
        elif p_n < MIN_LOAD_N:
            out.append(
                f"{label}: load never exceeds {_fmt(peak)} {unit} ({_fmt(p_n)} N) in "
                f"magnitude, implausible for a rod string (less than {MIN_LOAD_N:g} N); check "
                "the load unit"
            )
    else:
        smallest, largest = min(LOAD_UNITS.values()), max(LOAD_UNITS.values())
        if peak * smallest > MAX_LOAD_N:
            out.append(
                f"{label}: load reaches {_fmt(peak)} (load unit unknown), implausible in any "
                f"load unit (more than {MAX_LOAD_N:g} N even in N)"
            )
        elif peak * largest < MIN_LOAD_N:
            out.append(
                f"{label}: load never exceeds {_fmt(peak)} (load unit unknown) in magnitude, "
                f"implausible in any load unit (less than {MIN_LOAD_N:g} N even in klbf)"
            )
    mean = float(np.mean(load / 2)) * 2  # halves: no overflow near 1e308
    swing = float(np.max(load) / 2 - np.min(load) / 2) * 2
    if mean != 0 and math.isfinite(swing) and swing < MIN_LOAD_SWING * abs(mean):
        shown = "" if unit is None else f" {unit}"
        out.append(
            f"{label}: load varies by only {_fmt(swing)}{shown} around a mean of "
            f"{_fmt(mean)}{shown} ({_fmt(100 * swing / abs(mean))} %, less than "
            f"{100 * MIN_LOAD_SWING:g} %): a pump card's load swings with the fluid load"
        )
    return out


def loop_work(position: NDArray[np.float64], load: NDArray[np.float64]) -> Any:
    """Signed area of the closed card loop (last axis), load times position step summed.

    Positive when the loop turns as a pumping card does in time: higher loads while the
    position rises. A float for one card, an array for a batch (units' product).
    """
    p = np.asarray(position, dtype=float)
    f = np.asarray(load, dtype=float)
    dp = np.roll(p, -1, axis=-1) - p
    work = np.sum(0.5 * (f + np.roll(f, -1, axis=-1)) * dp, axis=-1)
    return float(work) if np.ndim(work) == 0 else work


#: A stroke read as one period is open when it ends this share of its stroke from where it
#: began ...
OPEN_SHARE = 0.1
#: ... and that is this many times its median step: a coarse card's closing step is one of
#: its steps (Sandia's 93-sample surface cards close within 6-7 % of the stroke, 2.6-3.1
#: median steps), while 3 of the 360 oilfield cards end 85 % of their stroke from their
#: start (111-126 median steps) and one stroke cut from a Sandia record 12 % (23 steps).
OPEN_STEPS = 3.0
#: Fewest samples judged: below this a stroke's steps are a large share of it anyway.
OPEN_MIN_SAMPLES = 8


def open_stroke(position: NDArray[np.float64]) -> tuple[float, float] | None:
    """How far a stroke read as one period ends from where it began, when that is a gap
    no sampling explains.

    A card taken as one period of a periodic motion is joined end to start; a partial or
    mis-cut stroke then has a jump there that the model must make, and fits as a poor fit
    whose reason points elsewhere.

    Parameters
    ----------
    position : array (N,)
        The stroke's positions, in time order.

    Returns
    -------
    tuple of float, or None
        The gap as a share of the stroke and in median steps (``inf`` where the median step
        is zero: long dwells at the ends), when it is over :data:`OPEN_SHARE` of the stroke
        and :data:`OPEN_STEPS` median steps; None when the stroke closes, or has fewer than
        :data:`OPEN_MIN_SAMPLES` samples.
    """
    p = np.asarray(position, dtype=float)
    if p.size < OPEN_MIN_SAMPLES:
        return None
    stroke = float(np.ptp(p))
    gap = abs(float(p[-1] - p[0]))
    step = float(np.median(np.abs(np.diff(p))))
    if stroke > 0 and gap > OPEN_SHARE * stroke and gap > OPEN_STEPS * step:
        return gap / stroke, (gap / step if step > 0 else math.inf)
    return None


def _turns_backwards(position: NDArray[np.float64], load: NDArray[np.float64]) -> bool:
    """A loop that clearly turns the wrong way for time order: negative work of more than
    a tenth of the rectangle the stroke and the load's swing span (a flat or tangled card
    stays unsaid)."""
    span = float(np.ptp(position)) * float(np.ptp(load))
    return bool(span > 0 and loop_work(position, load) < -0.1 * span)


#: A run of identical samples at a card's end at least this share of it (and 3 samples)
#: reads as padding: a stroke's own turn-around holds a point for a sample or two.
PADDING_SHARE = 0.05


def trailing_padding(position: NDArray[np.float64], load: NDArray[np.float64]) -> int:
    """How many samples at a card's end are padding: a run of at least 3 samples that
    repeat the card's last (position, load) point exactly and jump to it from the stroke
    (a fill of zeros: 5 rows of (0, 0) after a stroke ending at 28 kN), or, where the run
    continues the stroke without a jump (an export that repeats its last sample), a run of
    at least :data:`PADDING_SHARE` of the card, less its first sample (the stroke's own).
    A moving rod never holds both its position and its load to every digit for that long.

    Parameters
    ----------
    position, load : ndarray
        The card's samples, of equal length.

    Returns
    -------
    int
        The number of padding samples at the end (0: none).
    """
    if position.size == 0:
        return 0
    same = (position == position[-1]) & (load == load[-1])
    run = int(np.argmin(same[::-1])) if not same.all() else position.size
    if run < 3 or run == position.size:
        return 0
    before = position.size - run
    if before >= 3:
        step_p, step_l = np.abs(np.diff(position[:before])), np.abs(np.diff(load[:before]))
        jump_p = abs(float(position[-1] - position[before - 1]))
        jump_l = abs(float(load[-1] - load[before - 1]))
        # Against a high percentile of the card's steps, not its largest: a valve's
        # opening can be one step as large as the jump to a fill of zeros.
        if (jump_p <= 3.0 * float(np.percentile(step_p, 95))
                and jump_l <= 3.0 * float(np.percentile(step_l, 95))):
            return run - 1 if run >= PADDING_SHARE * position.size else 0
    return run


def leading_padding(position: NDArray[np.float64], load: NDArray[np.float64]) -> int:
    """How many samples at a card's start are padding: :func:`trailing_padding` of the card
    read backwards (an export that fills the start of a fixed-length record).

    Parameters
    ----------
    position, load : ndarray
        The card's samples in time order (its first samples are the ones looked at).

    Returns
    -------
    int
        How many of its first samples are padding (0: none).
    """
    return trailing_padding(position[::-1], load[::-1])


def padding_dropped(position: NDArray[np.float64], load: NDArray[np.float64],
                    units: tuple[str | None, str | None] = (None, None)
                    ) -> tuple[slice, list[tuple[slice, str]]]:
    """The samples left once the padding at a card's end, then at its start, is dropped
    (:func:`trailing_padding`, :func:`leading_padding`), and for each run dropped the
    samples it held and a note saying so (without where they are in the file, which the
    reader adds).

    Parameters
    ----------
    position, load : ndarray
        The card's samples, of equal length.
    units : tuple of str or None
        The position and load units, for the notes.

    Returns
    -------
    kept : slice
    dropped : list of (slice, str)
    """
    n = position.size
    last = trailing_padding(position, load)
    first = leading_padding(position[: n - last], load[: n - last])
    pu, lu = (f" {u}" if u else "" for u in units)
    dropped = []
    for end, run, where, size in (("last", last, slice(n - last, n), n),
                                  ("first", first, slice(0, first), n - last)):
        if run:
            k = where.start
            dropped.append((where, f"padding dropped: the {end} {run} of {size} samples "
                                   f"repeated one point (position {_fmt(float(position[k]))}"
                                   f"{pu}, load {_fmt(float(load[k]))}{lu})"))
    return slice(first, n - last), dropped


def _held_run(position: NDArray[np.float64], load: NDArray[np.float64]) -> tuple[int, int]:
    """The longest run of consecutive samples that repeat one (position, load) point
    exactly: (first index, length); length 1 where none repeats."""
    same = (position[1:] == position[:-1]) & (load[1:] == load[:-1])
    if not same.any():
        return 0, 1
    # Runs of True in ``same``: a run of k Trues is k + 1 equal samples.
    edges = np.diff(np.r_[0, same.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    k = int(np.argmax(ends - starts))
    return int(starts[k]), int(ends[k] - starts[k]) + 1


#: Pumping speeds of rod-pumping units (strokes per minute): long-stroke and hydraulic units
#: run down to about 1, small beam units up to about 20-30; a card outside this range was
#: most likely timed in the wrong unit.
SPM_PLAUSIBLE = (0.5, 40.0)


def stroke_rate_warning(card_id: str, period: float | None, column: str | None,
                        rate_where: str = "") -> str | None:
    """A warning for a stroke period no pumping unit has (see :data:`SPM_PLAUSIBLE`).

    Parameters
    ----------
    card_id : str
    period : float or None
        The duration of one stroke (s); None: nothing to say.
    column : str or None
        The time column the period comes from (None: from a stroke rate).
    rate_where : str
        Where the stroke rate comes from, in words, when ``column`` is None.

    Returns
    -------
    str or None
    """
    if period is None or not period > 0:
        return None
    spm = 60.0 / period
    lo, hi = SPM_PLAUSIBLE
    if lo <= spm <= hi:
        return None
    if column is None:
        where, hint = f"the stroke rate ({rate_where})", "check the stroke rate"
    else:
        where = f"its time column {column!r}"
        hint = ("a time in milliseconds read as seconds? The column's unit is taken as "
                "seconds; name it with its unit (t_ms, 'time (ms)')" if spm < lo
                else "check the time column's unit")
    return (f"card {card_id!r}: its stroke lasts {_fmt(period)} s ({_fmt(spm)} strokes/min) "
            f"by {where}: no pumping unit runs at that speed ({lo:g}-{hi:g} strokes/min); "
            f"{hint}")


def plausibility_warnings(
    card_id: str,
    position: NDArray[np.float64],
    load: NDArray[np.float64],
    position_unit: str | None,
    load_unit: str | None,
    *,
    fields: tuple[str, str] = ("position", "load"),
    check_swap: bool = True,
) -> list[str]:
    """Warnings about magnitudes and shapes implausible for a polished-rod card.

    Parameters
    ----------
    card_id : str
        Named in every message (shown escaped if it holds control characters).
    position, load : ndarray
        Finite samples of equal length.
    position_unit, load_unit : str or None
        Canonical units, None when unknown.
    fields : tuple of str
        Names of the position and load columns, for the swap message.
    check_swap : bool
        Also check whether the two look swapped (skip it when the roles were just detected
        from the same shapes).

    Returns
    -------
    list of str
    """
    label = f"card {card_id!r}"
    if position.size == 0 or load.size == 0:
        return []
    with np.errstate(all="ignore"):  # extreme magnitudes are what is being looked for
        out = _position_checks(label, position, position_unit)
        out += _load_checks(label, load, load_unit)
    if position.size >= 8 and _turns_backwards(position, load):
        # A card read backwards fits as a poor fit with an absurd offset and no word of why
        # (pumpid downhole read the same file reversed and said so).
        out.append(
            f"{label}: its loop turns the wrong way for a card in time order (higher loads "
            "while the position falls): stored in reverse time order, or the position "
            "measured downwards (then negate it)? The lumped fit takes it as given; the "
            "rod string's model reads it in reverse time order")
    first, held = _held_run(position, load)
    # 5 % of a stroke, not of the record: on a record of seven strokes a stretch frozen for
    # a third of one stroke went unsaid. (Strokes counted only for a run worth weighing.)
    stroke = float(position.size)
    if held >= 3:
        rises, per_stroke = strokes_seen(position)
        stroke = per_stroke if rises >= 2 and math.isfinite(per_stroke) else stroke
    if held >= max(3, PADDING_SHARE * stroke):
        # A frozen transmitter or a stopped unit: a moving rod never holds both its
        # position and its load to every digit for 5 % of a stroke. (At the card's end or
        # start such a run is padding, dropped by the readers.)
        pu = f" {position_unit}" if position_unit else ""
        lu = f" {load_unit}" if load_unit else ""
        out.append(
            f"{label}: its samples {first}-{first + held - 1} (counted from 0, {held} of "
            f"{position.size}) repeat "
            f"one point (position {_fmt(float(position[first]))}{pu}, load "
            f"{_fmt(float(load[first]))}{lu}): a frozen sensor or a stopped unit? It is "
            "fitted as given")
    if check_swap and position.size >= 8:
        try:
            roles = detect_column_roles([position, load])
        except CardError:
            roles = None
        if roles is not None and roles.position == 1 and roles.confidence >= SWAP_CONFIDENCE:
            out.append(
                f"{label}: position and load look swapped: {fields[1]!r} has the shape of a "
                f"stroke position and {fields[0]!r} that of a load (confidence "
                f"{roles.confidence:.3f}); check which column is which (columns=)"
            )
    return out
