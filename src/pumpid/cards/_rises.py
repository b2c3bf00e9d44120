"""Strokes seen in a position: how often the rod rises through mid-stroke.

The splitter of multi-stroke records and the readers' time rule (one stroke, or a record of
several) share this test.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["BAND_HIGH", "BAND_LOW", "SEVERAL", "mid_stroke_band", "record_stroke",
           "several_strokes", "strokes_seen", "time_from_rate",
           "upward_crossings"]

# Hysteresis levels, as fractions of the robust position range. A stroke boundary needs the
# rod to go below LOW and then above HIGH, so noise around mid-stroke (or a wiggle at the
# bottom) cannot create extra strokes.
BAND_LOW, BAND_HIGH = 0.35, 0.65


#: What the readers' warnings say of a record of several strokes (a stroke cut from it by
#: :func:`~pumpid.cards.split_strokes` does not carry them).
SEVERAL = "holds several strokes"


def upward_crossings(pos: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Indices where the position, having been below ``lo``, first gets above ``hi``.

    Parameters
    ----------
    pos : ndarray
        The position, in time order.
    lo, hi : float
        The band's levels.

    Returns
    -------
    ndarray of int
    """
    state = np.where(pos < lo, -1, np.where(pos > hi, 1, 0))
    idx = np.where(state != 0, np.arange(pos.size), 0)
    np.maximum.accumulate(idx, out=idx)  # carry the last decided state through the band
    held = state[idx]
    return np.flatnonzero((held[1:] == 1) & (held[:-1] == -1)) + 1


def mid_stroke_band(raw: np.ndarray) -> tuple[np.ndarray, float, float, np.ndarray]:
    """The position scaled by its largest magnitude (every level below is then finite and
    meaningful at any scale, 1e-300 or 1e300, and the boundaries found are the same sample
    indices), its robust bottom and range, and its upward crossings of the mid-stroke
    band.

    Parameters
    ----------
    raw : ndarray
        The position, in time order, not constant.

    Returns
    -------
    scaled : ndarray
    bottom, span : float
        The scaled position's 1st percentile and its range to the 99th.
    crossings : ndarray of int
        :func:`upward_crossings` of the band from 35 % to 65 % of the range.
    """
    with np.errstate(all="ignore"):
        pos = raw / np.max(np.abs(raw))
        p_lo, p_hi = (float(v) for v in np.percentile(pos, [1.0, 99.0]))
    span = p_hi - p_lo
    if not span > 0:
        p_lo, p_hi = float(pos.min()), float(pos.max())
        span = p_hi - p_lo
    ups = upward_crossings(pos, p_lo + BAND_LOW * span, p_lo + BAND_HIGH * span)
    return pos, p_lo, span, ups


def strokes_seen(position: np.ndarray) -> tuple[int, float]:
    """How many times the rod rises through mid-stroke (from below 35 % to above 65 % of
    the position's robust range), and the median number of samples between two rises.

    0 or 1 rise is a single stroke, wherever it starts; 2 or more, a record of several
    strokes, one every that many samples (NaN with fewer than 2 rises).

    Parameters
    ----------
    position : ndarray
        The samples, in time order.

    Returns
    -------
    rises : int
    samples_per_stroke : float
    """
    position = np.asarray(position, dtype=float)
    if position.size < 3 or not np.all(np.isfinite(position)) or np.ptp(position) == 0:
        return 0, math.nan
    ups = mid_stroke_band(position)[3]
    return int(ups.size), float(np.median(np.diff(ups))) if ups.size >= 2 else math.nan


def time_from_rate(card_id: str, position: np.ndarray, period: float, what: str
                   ) -> tuple[np.ndarray, str | None]:
    """Time for a card that has none, from its stroke period, sampled uniformly.

    One stroke: ``t_i = i T / N`` over its ``N`` samples. A record whose position rises
    through mid-stroke twice or more (:func:`strokes_seen`) holds several strokes: each gets
    the period, ``t_i = i T / S`` with ``S`` the median number of samples between two rises
    (given a stroke rate, such a record was read as one stroke, its motion several times too
    fast).

    Parameters
    ----------
    card_id : str
    position : ndarray
    period : float
        The stroke period (s).
    what : str
        Where the rate comes from, in words ("6 SPM (given by the caller)").

    Returns
    -------
    t : ndarray
    several : str or None
        For a record of several strokes, the warning that says so (None for one stroke).
    """
    n = position.size
    rises, per_stroke = strokes_seen(position)
    if rises < 2:
        return np.arange(n) * (period / n), None
    return np.arange(n) * (period / per_stroke), (
        f"card {card_id!r} {SEVERAL}, not one: its position rises through "
        f"mid-stroke {rises} times, one every {per_stroke:.6g} samples; its time is rebuilt "
        f"from {what} for each stroke (t_i = i*T/{per_stroke:.6g}, T = {period:.6g} s) and "
        "it is a record, not one period (split_strokes, on the command line --split-strokes, "
        "fits its strokes one by one)")


def record_stroke(position: np.ndarray, t: np.ndarray | None) -> float | None:
    """The duration of one stroke of a record in its own time (s): the median samples
    between two rises through mid-stroke (:func:`strokes_seen`) times the mean step; None
    without time or with fewer than two rises.

    Parameters
    ----------
    position : ndarray
        The samples, in time order.
    t : ndarray or None
        Their times (s).

    Returns
    -------
    float or None
    """
    return _stroke_of(position, t)[2]


def _stroke_of(position: np.ndarray, t: np.ndarray | None
               ) -> tuple[int, float, float | None]:
    """Rises through mid-stroke, samples per stroke and the stroke's duration (s; None
    without time or with fewer than two rises)."""
    if t is None or t.size < 3:
        return 0, math.nan, None
    rises, per_stroke = strokes_seen(position)
    if rises < 2:
        return rises, per_stroke, None
    return rises, per_stroke, per_stroke * float(t[-1] - t[0]) / (t.size - 1)


def several_strokes(card_id: str, position: np.ndarray, t: np.ndarray | None
                    ) -> str | None:
    """The warning for a record in its own time that holds several strokes (None for one
    stroke, or without time).

    Such a record is fitted from rest, as one transient, a start a pumping well never had:
    three copies of one stroke were ``converged`` with the natural frequency, damping ratio
    and stiffness called determined where the stroke alone determines none of them, and
    nothing said it held several strokes.

    Parameters
    ----------
    card_id : str
    position : ndarray
        The samples, in time order.
    t : ndarray or None
        Their times (s).

    Returns
    -------
    str or None
    """
    rises, per_stroke, stroke = _stroke_of(position, t)
    if stroke is None:
        return None
    return (f"card {card_id!r} {SEVERAL} in its own time: its position rises "
            f"through mid-stroke {rises} times, one every {per_stroke:.6g} samples (a stroke "
            f"of about {stroke:.4g} s); a lumped fit takes it as one record from rest, a start "
            "a pumping well never had, and pumpid downhole refuses it (split_strokes, on the "
            "command line --split-strokes, makes each stroke a card of one period)")

