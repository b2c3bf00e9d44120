"""Which column of a headerless table is position and which is load.

A polished-rod card has a recognisable shape, and the detector scores each numeric column
against it:

* position over a stroke rises from its minimum to one maximum and comes back: its total
  variation (taken round the loop, per stroke) is twice its range, and it is smooth against
  sample index (small second differences compared with the first differences);
* load is rougher: the fluid load is picked up and released within a few samples, with
  ripple on top, so its total variation exceeds twice its range and its second
  differences are large;
* the loop is traversed so that the polished rod does positive work, the integral of load
  over position round the card being positive (the well takes energy);
* positions are usually measured from the bottom of the stroke (minimum near zero), loads
  of a surface card are not;
* a monotone column (angle, sample index, time), a constant column or a column with only a
  few distinct values (a flag) is neither.

The scores of every ordered (position, load) pair are turned into probabilities with a
softmax; the best pair's probability is the confidence. The work and zero-minimum terms are
bounded so that, on their own, they cannot reach :data:`ROLE_CONFIDENCE_MIN`: when position and
load have the same shape (an elliptical loop, two smooth columns) the detector refuses rather
than rely on the direction the file happens to run in.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._errors import CardError

__all__ = ["ROLE_CONFIDENCE_MIN", "ColumnRoles", "detect_column_roles"]

#: Below this confidence the readers refuse to guess and ask for ``columns=``.
ROLE_CONFIDENCE_MIN = 0.9

#: Method recorded in ``metadata["column_roles"]`` for a detected assignment.
METHOD = (
    "detected from the shape of the columns: position is the smooth column rising once to a "
    "single maximum and back per stroke, load the rougher one forming with it a loop of "
    "positive work; monotone (angle, index, time), constant and few-valued columns excluded"
)

# A column whose steps go one way this often is monotone (angle, index, time), even with a
# few resets (a sawtooth angle over several strokes).
_MONOTONE = 0.85
# Fewer distinct values than this: a flag or a code, not a measured signal.
_MIN_DISTINCT = 5
# Hysteresis band (fractions of the range) for counting strokes, as in split_strokes.
_LOW, _HIGH = 0.35, 0.65
# Smallest number of usable samples for a decision.
_MIN_ROWS = 8
# The features look at steps of about this fraction of a stroke (see _profile).
_SCALE_DIVISOR = 40
# Regularisers of the logarithms: differences below these carry no information.
_EXCESS_FLOOR, _ROUGH_FLOOR, _SINE_FLOOR = 0.01, 0.01, 0.01
# The sinusoid-likeness counts half: pumping-unit kinematics add harmonics to the position.
_SINE_WEIGHT = 0.5
# Weights of the bounded supporting terms (see the module docstring for why they are small).
_WORK_WEIGHT, _WORK_SCALE = 0.5, 0.1
_ZERO_WEIGHT, _ZERO_TOL = 0.25, 0.05
# What a stroke position looks like at the scale of the features, with margin: on the public
# cards positions have a variation excess below 0.03, roughness below 0.25 and at least 95 %
# of their variance in one harmonic (99 % of cards); loads a roughness above 0.4, a lag-one
# autocorrelation above 0.9 and at least 66 % of their variance in one harmonic.
_POS_EXCESS, _POS_ROUGH, _POS_SINE = 0.25, 0.6, 0.85
_LOAD_RHO, _LOAD_SINE = 0.8, 0.5
_GATE_WEIGHT = 2.0


def confidence_words(confidence: float) -> str:
    """Plain words for a confidence in [0, 1]."""
    if confidence >= 0.99:
        return "very high"
    if confidence >= 0.95:
        return "high"
    if confidence >= ROLE_CONFIDENCE_MIN:
        return "moderate"
    return "low"


@dataclass(frozen=True)
class ColumnRoles:
    """The position and load columns of a table, and how sure the choice is.

    Attributes
    ----------
    position, load : int
        0-based column indices.
    confidence : float
        In [0, 1]: the probability the detector gives to this pair against every other
        ordered pair of candidate columns (1.0 when the roles were given or named).
    words : str
        ``"very high"`` (>= 0.99), ``"high"`` (>= 0.95), ``"moderate"`` (>= the threshold
        :data:`ROLE_CONFIDENCE_MIN`) or ``"low"``.
    method : str
        How the roles were decided.
    other : mapping of int to str
        The remaining columns and what they look like (``"monotone (angle, index or
        time)"``, ``"constant"`` ...).
    scores : mapping of str to float
        The evidence: for each ordered candidate pair ``"p,l"`` its score.
    """

    position: int
    load: int
    confidence: float
    words: str
    method: str
    other: Mapping[int, str] = field(default_factory=dict)
    scores: Mapping[str, float] = field(default_factory=dict)

    def to_metadata(self) -> dict[str, Any]:
        """The record kept in ``Card.metadata["column_roles"]``."""
        out: dict[str, Any] = {
            "position": self.position,
            "load": self.load,
            "confidence": self.confidence,
            "words": self.words,
            "method": self.method,
        }
        if self.other:
            out["other"] = dict(self.other)
        return out


@dataclass(frozen=True)
class _Profile:
    kind: str  # "candidate" or a description of why the column is neither role
    excess: float = math.nan  # total variation / (2 * range * strokes) - 1
    rough: float = math.nan  # ||second differences|| / ||first differences||
    rho1: float = math.nan  # lag-1 autocorrelation
    sine: float = math.nan  # share of the variance in the strongest harmonic and its neighbours
    zero_min: bool = False  # minimum within 5 % of the range from zero
    y: NDArray[np.float64] | None = None  # the column scaled to at most 1 in magnitude
    span: float = math.nan  # range of y


def _upward_crossings(y: NDArray[np.float64], lo: float, hi: float) -> int:
    state = np.where(y < lo, -1, np.where(y > hi, 1, 0))
    idx = np.where(state != 0, np.arange(y.size), 0)
    np.maximum.accumulate(idx, out=idx)
    held = state[idx]
    return int(np.count_nonzero((held[1:] == 1) & (held[:-1] == -1)))


def _profile(x: NDArray[np.float64]) -> _Profile:
    scale = float(np.max(np.abs(x)))
    if scale == 0.0:
        return _Profile("constant")
    # Scaled to [-1, 1] so that every sum below is finite whatever the magnitudes (1e308,
    # subnormals) and every feature is free of the unit.
    y = x / scale
    lo_v, hi_v = float(y.min()), float(y.max())
    span = hi_v - lo_v
    if span <= 1e-12:
        return _Profile("constant")
    ordered = np.sort(y)
    distinct = 1 + int(np.count_nonzero(ordered[1:] != ordered[:-1]))
    if distinct < _MIN_DISTINCT:
        return _Profile(f"only {distinct} distinct values (a flag or a code)")
    d = y[1:] - y[:-1]
    n_up, n_down = int(np.count_nonzero(d > 0)), int(np.count_nonzero(d < 0))
    up = n_up / (n_up + n_down)
    if max(up, 1.0 - up) >= _MONOTONE:
        return _Profile("monotone (angle, index or time)")
    closed = np.append(y, y[0])
    strokes = max(1, _upward_crossings(closed, lo_v + _LOW * span, lo_v + _HIGH * span))
    # Features at a scale of about 1/40 of a stroke, not sample to sample: sample noise on a
    # finely sampled position would otherwise look as rough as a load, while a load's
    # pickup and release stay sharp at that scale.
    lag = max(1, round(y.size / strokes / _SCALE_DIVISOR))
    ys = _smooth(y, lag)
    total = float(np.abs(ys[1:] - ys[:-1]).sum()) + abs(float(ys[0] - ys[-1]))
    excess = max(0.0, total / (2.0 * float(ys.max() - ys.min()) * strokes) - 1.0)
    d = y[lag:] - y[:-lag]
    dd = d[lag:] - d[:-lag]
    d1 = math.sqrt(float(np.dot(d, d)) / d.size)
    rough = math.sqrt(float(np.dot(dd, dd)) / dd.size) / d1 if d1 > 0 and dd.size else 0.0
    c = y - y.mean()
    den = float(np.dot(c, c))
    rho1 = float(np.dot(c[1:], c[:-1])) / den if den > 0 else 0.0
    spectrum = np.fft.rfft(c)
    power = spectrum.real**2 + spectrum.imag**2
    power[0] = 0.0
    k = int(np.argmax(power))
    whole = float(power.sum())
    sine = float(power[max(1, k - 1) : k + 2].sum()) / whole if whole > 0 else 0.0
    return _Profile(
        "candidate",
        excess=excess,
        rough=rough,
        rho1=rho1,
        sine=sine,
        zero_min=abs(lo_v) <= _ZERO_TOL * span,
        y=y,
        span=span,
    )


def _smooth(y: NDArray[np.float64], width: int) -> NDArray[np.float64]:
    """Moving average over ``width`` samples (the ends averaged over what is there)."""
    if width <= 1 or width >= y.size:
        return y
    csum = np.concatenate(([0.0], np.cumsum(y)))
    half = width // 2
    i = np.arange(y.size)
    lo = np.maximum(i - half, 0)
    hi = np.minimum(i - half + width, y.size)
    return (csum[hi] - csum[lo]) / (hi - lo)


def _position_likeness(p: _Profile) -> float:
    return (
        -math.log(p.excess + _EXCESS_FLOOR)
        - math.log(p.rough + _ROUGH_FLOOR)
        - _SINE_WEIGHT * math.log(1.0 - p.sine + _SINE_FLOOR)
    )


def _work(pp: _Profile, pl: _Profile) -> float:
    """Loop integral of load over position (trapezoids, closed), over the bounding box."""
    yp, yl = pp.y, pl.y
    assert yp is not None and yl is not None
    w = float(np.dot(yl[1:] + yl[:-1], yp[1:] - yp[:-1]))
    w += float((yl[0] + yl[-1]) * (yp[0] - yp[-1]))  # the closing segment
    return 0.5 * w / (pp.span * pl.span)


def _not_a_position(p: _Profile) -> float:
    """How far a column is from any stroke position seen in practice (0 when within)."""
    return (
        max(0.0, p.excess - _POS_EXCESS) / _POS_EXCESS
        + max(0.0, p.rough - _POS_ROUGH) / 0.2
        + max(0.0, _POS_SINE - p.sine) / 0.1
    )


def _not_a_load(p: _Profile) -> float:
    """How far a column is from a structured signal (0 for any card load seen in practice)."""
    # White noise or an unrelated jumble is not a load, however rough.
    return max(0.0, _LOAD_RHO - p.rho1) / 0.1 + max(0.0, _LOAD_SINE - p.sine) / 0.1


def _pair_score(pp: _Profile, pl: _Profile) -> float:
    assert pp.y is not None and pl.y is not None
    score = _position_likeness(pp) - _position_likeness(pl)
    score -= _GATE_WEIGHT * _not_a_position(pp)
    score -= _GATE_WEIGHT * _not_a_load(pl)
    score += _WORK_WEIGHT * max(-1.0, min(1.0, _work(pp, pl) / _WORK_SCALE))
    score += _ZERO_WEIGHT * (float(pp.zero_min) - float(pl.zero_min))
    return score


def _as_columns(values: ArrayLike | Sequence[ArrayLike]) -> list[NDArray[np.float64]]:
    try:
        if isinstance(values, np.ndarray) and values.ndim == 2:
            cols = [np.asarray(values[:, k], dtype=float) for k in range(values.shape[1])]
        else:
            cols = [np.asarray(v, dtype=float) for v in values]  # type: ignore[union-attr]
    except (TypeError, ValueError) as exc:
        raise CardError(f"columns must be numeric: {exc}") from exc
    if any(c.ndim != 1 for c in cols) or len({c.size for c in cols}) > 1:
        raise CardError("columns must be 1-D and of equal length")
    return cols


def detect_column_roles(
    values: ArrayLike | Sequence[ArrayLike], *, candidates: Sequence[int] | None = None
) -> ColumnRoles:
    """Decide which column is position and which is load, with a confidence.

    Parameters
    ----------
    values : array_like
        A 2-D array (samples x columns) or a sequence of equal-length columns, holding one
        card or one record of several strokes, in time order.
    candidates : sequence of int, optional
        Columns that may be position or load (default: all). The others are reported as
        ``"given another role"``.

    Returns
    -------
    ColumnRoles
        The most likely pair and its confidence. The caller decides what to do with a low
        confidence (the readers refuse below :data:`ROLE_CONFIDENCE_MIN`).

    Raises
    ------
    CardError
        If fewer than two columns can be position or load (the others are constant,
        monotone or few-valued), or fewer than 8 rows are finite in all of them.

    Notes
    -----
    See the module docstring for the features. Rows holding NaN or infinity in any
    candidate column are left out of the decision.
    """
    cols = _as_columns(values)
    chosen = list(range(len(cols))) if candidates is None else list(candidates)
    other: dict[int, str] = {k: "given another role" for k in range(len(cols)) if k not in chosen}
    with np.errstate(all="ignore"):
        if chosen:
            finite = np.logical_and.reduce([np.isfinite(cols[k]) for k in chosen])
        else:
            finite = np.zeros(0, dtype=bool)
        if int(np.count_nonzero(finite)) < _MIN_ROWS:
            raise CardError(
                f"only {int(np.count_nonzero(finite))} rows with finite values: too few to tell "
                "position from load"
            )
        profiles = {k: _profile(cols[k][finite]) for k in chosen}
        usable = [k for k in chosen if profiles[k].kind == "candidate"]
        other.update({k: p.kind for k, p in profiles.items() if p.kind != "candidate"})
        if len(usable) < 2:
            described = "; ".join(f"column {k}: {d}" for k, d in sorted(other.items()))
            raise CardError(
                f"{len(usable)} column(s) could be position or load, two are needed"
                + (f" ({described})" if described else "")
            )
        scores = {
            (p, q): _pair_score(profiles[p], profiles[q]) for p in usable for q in usable if p != q
        }
    best = max(scores, key=lambda pair: scores[pair])
    top = scores[best]
    # The denominator also holds "no pair is right" at score 0: when even the best pair looks
    # little like a card (noise, random walks) the confidence drops with it.
    confidence = 1.0 / (math.exp(-top) + sum(math.exp(s - top) for s in scores.values()))
    for k in usable:
        if k not in best:
            other[k] = "not chosen (neither as position nor as load)"
    return ColumnRoles(
        position=best[0],
        load=best[1],
        confidence=confidence,
        words=confidence_words(confidence),
        method=METHOD,
        other=dict(sorted(other.items())),
        scores={f"{p},{q}": round(s, 4) for (p, q), s in scores.items()},
    )
