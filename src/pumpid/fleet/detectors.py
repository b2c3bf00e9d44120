"""The change detectors on one series: a well's values of one quantity, in time order.

:func:`scan_cusum` (histories longer than the reference window) and
:func:`scan_two_segments` (short histories: a step or a steady drift) return the changes
they find as :class:`Change` records (indices into the series);
:mod:`pumpid.fleet.changes` applies them to every well and quantity of a results table and
describes the method. Values are on the analysis scale (logarithms of positive quantities),
with each card's standard error on that scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .thresholds import (
    MAD_TO_SD,
    cusum_paths,
    cusum_threshold,
    drift_statistic,
    drift_threshold,
    reference_phases,
    two_segment_statistic,
    two_segment_threshold,
)

__all__ = ["MEDIAN_SE", "Change", "best_split", "median_se", "robust_sigma", "scan_cusum",
           "scan_two_segments", "standardise"]

#: Standard error of a median relative to that of a mean, for normal data.
MEDIAN_SE = math.sqrt(math.pi / 2.0)


def robust_sigma(y: NDArray[np.float64]) -> float:
    """Card-to-card noise from successive differences (robust to one step or a drift)."""
    if y.size < 3:
        return math.nan
    d = np.diff(y)
    return float(MAD_TO_SD * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


@dataclass(frozen=True)
class Change:
    """One detected change within a series (indices into the series).

    ``drift``: found by a short history's drift test (a steady rise or fall over the
    history, under way from its first card: ``first`` is 0); ``line`` is then the fitted
    line on the analysis scale (its value at the first card, its slope per card) and
    ``size`` the slope over its standard error, signed.
    """

    first: int
    alarm: int
    direction: str
    threshold: float
    noise: float
    drift: bool = False
    line: tuple[float, float] | None = None
    size: float = math.nan


def best_split(y: NDArray[np.float64], wgt: NDArray[np.float64], lo: int, hi: int,
           candidates: range) -> int:
    """The split into two constant levels with the least weighted absolute deviation."""
    best, best_cost = candidates.start, math.inf
    for k in candidates:
        left, right = y[lo:k], y[k:hi]
        cost = float(np.sum(wgt[lo:k] * np.abs(left - np.median(left)))
                     + np.sum(wgt[k:hi] * np.abs(right - np.median(right))))
        if cost < best_cost - 1e-12 * abs(best_cost if math.isfinite(best_cost) else 1.0):
            best, best_cost = k, cost
    return best


def standardise(
    y: NDArray[np.float64], se: NDArray[np.float64], start: int, w: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None:
    """Scores ``z``, noise ``sigma_i`` and reference scatter for cards ``start + w`` on.

    None when the first reference has neither scatter nor standard errors.
    """
    n = y.size
    z = np.empty(n - start - w)
    sig_all = np.empty(n - start - w)
    ref_sigma = np.empty(n - start - w)
    for ref_end, lo, hi in reference_phases(w, n - start):
        base = y[start:start + ref_end]
        level = float(np.median(base))
        sigma = robust_sigma(base)
        base_se = se[start:start + ref_end]
        finite = np.isfinite(base_se)
        s_ref = float(np.median(base_se[finite])) if finite.any() else math.nan
        if not (math.isfinite(sigma) and sigma > 0):
            # Identical reference values: only the reported errors can give a scale.
            sigma = s_ref if math.isfinite(s_ref) and s_ref > 0 else math.nan
        if not math.isfinite(sigma):
            return None
        tau2 = max(sigma**2 - (s_ref**2 if math.isfinite(s_ref) else 0.0), 0.0)
        part = slice(start + lo, start + hi)
        s = np.where(np.isfinite(se[part]), se[part], s_ref if math.isfinite(s_ref) else 0.0)
        sig_i = np.sqrt(tau2 + s**2)
        if math.isfinite(s_ref) and s_ref > sigma:
            # Errors wider than the cards' own scatter (a model error's robust errors: 4-100
            # times the spread of consecutive real strokes) weigh the cards against each
            # other, on the scatter's scale: as noise they hid a pump's fluid load falling
            # by 14 times its scatter (errors of +-14 kN against a scatter of 0.08 kN).
            sig_i = sig_i * (sigma / s_ref)
        sig_i = np.maximum(sig_i, 0.5 * sigma)
        z[lo - w:hi - w] = (y[part] - level) / sig_i
        sig_all[lo - w:hi - w] = sig_i
        ref_sigma[lo - w:hi - w] = sigma
    return z, sig_all, ref_sigma


def scan_cusum(
    y: NDArray[np.float64], se: NDArray[np.float64], *, min_cards: int, alpha: float,
    reference: float, clip: float, tail_dof: float, outlier_fraction: float,
) -> tuple[list[Change], str]:
    """All changes of one series on the analysis scale, and a word on why none if so."""
    n = y.size
    w = min_cards
    changes: list[Change] = []
    start = 0
    note = ""
    while start + w < n:
        std = standardise(y, se, start, w)
        if std is None:
            note = "no scatter in the reference cards and no standard errors: not tested"
            break
        z, sig_i, ref_sigma = std
        # After a change the search resumes at the alarm: cards of the new level already
        # seen between the change point and the alarm are its reference, not tested again.
        skip = max(0, (changes[-1].alarm + 1 - start - w) if changes else 0)
        h = cusum_threshold(n - start - w, min_cards=w, alpha=alpha, reference=reference,
                            clip=clip, tail_dof=tail_dof,
                            outlier_fraction=outlier_fraction)  # fmt: skip
        zc = np.clip(z[skip:], -clip, clip)
        up, c_up = cusum_paths(zc - reference)
        down, c_down = cusum_paths(-zc - reference)
        hit_up = np.flatnonzero(up > h)
        hit_down = np.flatnonzero(down > h)
        if not hit_up.size and not hit_down.size:
            break
        a_up = int(hit_up[0]) if hit_up.size else n
        a_down = int(hit_down[0]) if hit_down.size else n
        rising = a_up <= a_down
        a = min(a_up, a_down)
        csum = c_up if rising else c_down
        # The CUSUM's own change point: the card after the cumulative sum's last minimum
        # (counting the empty sum before the first monitored card) up to the alarm.
        path = np.concatenate([[0.0], csum[: a + 1]])
        offset = start + w + skip
        tau0 = offset + int(path.size - 1 - np.argmin(path[::-1]))
        alarm = offset + a
        weights = np.full(n, 1.0 / ref_sigma[0])
        weights[start + w:] = 1.0 / sig_i
        lo = max(start, tau0 - w)
        hi = min(n, alarm + 1 + w)
        cand = range(max(lo + 2, start + 1), min(alarm, hi - 2) + 1)
        first = best_split(y, weights, lo, hi, cand) if len(cand) else tau0
        first = max(start + 1, min(first, alarm))
        changes.append(Change(first, alarm, "up" if rising else "down", h,
                               float(ref_sigma[alarm - start - w])))
        start = first
    return changes, note



def scan_two_segments(y: NDArray[np.float64], se: NDArray[np.float64], *, alpha: float,
                  tail_dof: float, outlier_fraction: float) -> list[Change]:
    """The change of a short history (at most one): a step by the two-segment test, or a
    steady drift by the drift test, each at half of ``alpha``.

    The whole history is tested at once, so the alarm is its last card. Where both tests
    alert, the one further beyond its threshold names the change (a step parts two
    segments' medians more than a line explains it, a drift the other way round). Scales
    are never below the median of the fits' standard errors, nor that floor above the
    cards' own scatter (:func:`robust_sigma`; errors wider than the scatter hid a step of
    14 times it); with neither scatter nor errors the history is not tested.
    """
    finite = np.isfinite(se)
    floor = float(np.median(se[finite])) if finite.any() else 0.0
    scatter = robust_sigma(y)
    if math.isfinite(scatter) and scatter > 0:
        floor = min(floor, scatter)
    stat, split, scale = two_segment_statistic(y, floor)
    if not (math.isfinite(float(stat[0])) and scale[0] > 0):
        return []
    # A straight decline widens the two-segment test's scatter as much as it parts the
    # medians (its statistic is 5.2 at 14 cards however steep the fall), so a drift needs
    # a test of its own; the two share alpha (Bonferroni).
    h = two_segment_threshold(y.size, alpha=alpha / 2, tail_dof=tail_dof,
                              outlier_fraction=outlier_fraction)
    t_drift, slope, d_scale, level = drift_statistic(y, floor)
    h_drift = drift_threshold(y.size, alpha=alpha / 2, tail_dof=tail_dof,
                              outlier_fraction=outlier_fraction)
    step_beyond, drift_beyond = float(stat[0]) / h, float(t_drift[0]) / h_drift
    k = int(split[0])
    if d_scale[0] == 0 and slope[0] != 0:
        drift_beyond = math.inf  # an exact line: nothing about it but the slope
    if drift_beyond > 1.0 and drift_beyond > step_beyond:
        # A drift has no change point within the history: it is under way from the first
        # card, and its size is the line's, first card to last (the medians of two halves
        # gave half of it, "from" the middle card).
        return [Change(0, y.size - 1, "up" if slope[0] > 0 else "down", h_drift,
                       float(d_scale[0]), drift=True,
                       line=(float(level[0]), float(slope[0])),
                       size=math.copysign(float(t_drift[0]), float(slope[0])))]
    if not step_beyond > 1.0:
        return []
    rising = bool(np.median(y[k:]) > np.median(y[:k]))
    return [Change(k, y.size - 1, "up" if rising else "down", h, float(scale[0]))]


def median_se(values: NDArray[np.float64], errors: NDArray[np.float64],
               noise: float = math.inf) -> float:
    """Standard error of a segment's median from its card-to-card scatter, at least the
    one its cards' own errors give, those errors taken at most at the well's card-to-card
    ``noise`` (in the values' unit).

    Two or three cards' scatter can be far below what each card is known to within: a
    fillage drop of 24 % on a pump field read -2.65, -692 and -934 standard errors as the
    history grew by one and two cards (one card after the change: no scatter at all). Errors
    far wider than the well's scatter (a model error's robust errors) made a fluid load's
    fall by 14 times its scatter read -0.17 standard errors.

    Parameters
    ----------
    values : ndarray
        The segment's values.
    errors : ndarray
        Their cards' standard errors (NaN where unknown).
    noise : float
        The well's card-to-card scatter, in the values' unit.

    Returns
    -------
    float
        NaN for a single card without errors.
    """
    own = errors[np.isfinite(errors) & (errors > 0)]
    floor = (MEDIAN_SE * min(float(np.median(own)), noise) / math.sqrt(values.size)
             if own.size else 0.0)
    if values.size < 2:
        return floor if floor > 0 else math.nan
    sigma = robust_sigma(values) if values.size >= 3 else float(np.std(values, ddof=1))
    if not sigma > 0:  # identical values: fall back on the plain spread
        sigma = float(np.std(values, ddof=1))
    return max(MEDIAN_SE * sigma / math.sqrt(values.size), floor)
