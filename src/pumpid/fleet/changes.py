"""Which wells changed, when, and how: persistent shifts in fitted quantities over time.

The input is the fleet results table (one row per fitted card; see :data:`USABLE_STATUSES`
and the column conventions below); the output is one row per detected change.

Method
------
For each well and each quantity (by default every derived quantity ``d_NAME`` of the
table; model parameters ``p_NAME`` on request), the cards whose fit is usable (status
``converged``, ``boundary`` or ``poor-fit``), whose value is finite and, where the table
says so, determined by the data, are put in time order (in the table's card order when a
card of the well has no time). The analysis scale is the logarithm when every value is
positive, so that a change is relative and a constant coefficient of variation is a
constant noise level; otherwise the values themselves.

1. **Reference.** The first ``min_cards`` cards of a segment set its level and noise: the
   level is their median ``m``; the card-to-card scatter is ``sigma = 1.4826 MAD(diff) /
   sqrt(2)``, the median absolute deviation of successive differences, which a single step
   or a slow drift inside the window barely moves.
2. **Noise per card.** Part of the scatter is each fit's own uncertainty. With ``s_i`` the
   card's reported standard error on the analysis scale (for parameters the larger of the
   ordinary and the autocorrelation-robust one) and ``s_ref`` its median over the
   reference cards, the scatter between cards beyond the fits' errors is
   ``tau² = max(sigma² - s_ref², 0)`` and a card's noise is ``sigma_i = sqrt(tau² + s_i²)``,
   never below ``sigma / 2``. A missing (NaN) standard error counts as ``s_ref``; so a
   poorly determined card weighs less, and NaN errors throughout reduce to ``sigma``.
3. **Robust two-sided CUSUM.** Each later card gives ``z_i = (y_i - m) / sigma_i``,
   clipped to ``[-clip, clip]`` (Huber's rule: one wild card moves the statistic by at most
   ``clip - reference``), and the upper and lower sums
   ``S+_i = max(0, S+_{i-1} + z_i - reference)``, ``S-_i = max(0, S-_{i-1} - z_i -
   reference)``. An alarm is the first card at which either exceeds the threshold ``h``.
   With the default ``reference = 1`` the scheme is tuned to shifts of about two noise
   scales and more; smaller persistent shifts still accumulate, more slowly.
4. **Threshold.** ``h`` is the ``1 - alpha`` quantile of ``max(S+, S-)`` over a steady
   history, found by simulation (fixed seed, so reproducible) of the whole procedure,
   reference estimation included: Student-t noise with ``tail_dof`` degrees of freedom
   (default 5: heavier tails than Gaussian) with a fraction ``outlier_fraction`` (1 %) of
   cards replaced by outliers of 6-12 noise scales of random sign, over the well's own
   history length rounded up to a grid of lengths (so a longer history gets a higher
   threshold and the false-alarm probability holds whatever the length). ``alpha`` is the
   requested per-well false-alarm probability divided by the number of quantities tested
   (Bonferroni: a steady well raises any alert with probability at most ``false_alarm``;
   correlated quantities make it smaller). Of the simulated maxima the order statistic
   that bounds the quantile from above with 95 % confidence is taken, so the simulation's
   own error does not push the false-alarm rate above the target.
5. **Change point.** The change's first card, not the alarm card: the CUSUM's own estimate
   (the card after the statistic last left zero) is refined by the split that best fits
   two levels (least absolute deviations, weighted by ``1 / sigma_i``) within
   ``min_cards`` cards of it, using cards up to ``min_cards`` after the alarm.
6. **More changes.** The new level's first ``min_cards`` cards (from the change point)
   become the next reference and the search goes on, so a well can have several alerts.
   ``before`` and ``after`` are the medians of the segments on either side (up to the
   neighbouring change points), in the quantity's unit.

Assumptions: levels are piecewise constant between changes with independent card-to-card
noise; a slow drift shows as a late alert, or several alerts in the same direction. The
first ``min_cards`` cards of a segment (the reference) cannot themselves hold a change
(two changes closer than ``min_cards`` cards are seen as one); a history shorter than
``min_cards + 1`` usable cards is not tested.

Column conventions of the results table
---------------------------------------
``well_id``, ``card_id``, ``status`` (required; a row without a well, such as a file that
could not be read, counts under :data:`UNKNOWN_WELL`); ``time`` (datetime, NaT when unknown);
per derived quantity ``d_NAME``, ``d_NAME_se``, ``d_NAME_determined``, ``d_NAME_unit``;
per parameter ``p_NAME``, ``p_NAME_se``, ``p_NAME_se_hac``. Missing optional columns
are treated as unknown (NaT time, NaN standard error, determined, no unit).
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import scipy.stats
from numpy.typing import NDArray

from pumpid import model_class

__all__ = [
    "ALERT_COLUMNS",
    "STATUSES",
    "UNKNOWN_WELL",
    "USABLE_STATUSES",
    "available_quantities",
    "cusum_threshold",
    "detect_changes",
    "load_results",
    "summarise_wells",
]

#: The well of rows whose ``well_id`` is missing (files that could not be read).
UNKNOWN_WELL = "(unknown well)"
#: Every status a results row can have.
STATUSES = ("converged", "boundary", "undetermined", "poor-fit", "failed", "invalid-input")
#: Statuses whose values are trended (the others are counted only).
USABLE_STATUSES = ("converged", "boundary", "undetermined", "poor-fit")
#: Columns of :func:`detect_changes`' result, in order.
ALERT_COLUMNS = (
    "well_id", "quantity", "unit", "first_card_id", "first_time", "alarm_card_id",
    "alarm_time", "before", "after", "change", "change_rel", "change_se", "direction",
    "kind", "scale", "noise", "first_index", "alarm_index", "delay_cards", "n_before",
    "n_after", "threshold", "order",
)  # fmt: skip

# MAD -> standard deviation of a normal distribution.
_MAD_TO_SD = 1.482602218505602
# Standard error of a median relative to that of a mean, for normal data.
_MEDIAN_SE = math.sqrt(math.pi / 2.0)
# History lengths the threshold is calibrated for (19 % apart); a history is rounded up.
_LENGTH_GRID = tuple(math.ceil(16 * 2 ** (j / 4)) for j in range(0, 48))


# --------------------------------------------------------------------------- input
def load_results(results: pd.DataFrame | str | os.PathLike[str]) -> pd.DataFrame:
    """Return the results table, reading it when given a Parquet file or dataset folder.

    Parameters
    ----------
    results : pandas.DataFrame or path
        The table, or a Parquet file or folder that :func:`pandas.read_parquet` reads.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    ValueError
        If the ``well_id``, ``card_id`` or ``status`` column is missing.
    """
    table = results if isinstance(results, pd.DataFrame) else pd.read_parquet(results)
    missing = [c for c in ("well_id", "card_id", "status") if c not in table.columns]
    if missing:
        raise ValueError(
            f"the results table lacks the column(s) {', '.join(missing)}; it has "
            f"{', '.join(map(str, table.columns))}"
        )
    if table["well_id"].isna().any():
        # A file that could not be read names no well: its rows are counted, not trended.
        table = table.assign(well_id=table["well_id"].astype(object).where(
            table["well_id"].notna(), UNKNOWN_WELL))
    return table


def available_quantities(table: pd.DataFrame, *, parameters: bool = False) -> list[str]:
    """Names of the quantities a table holds: derived ones, then (optionally) parameters.

    Derived quantity ``NAME`` is the column ``d_NAME``; parameter ``NAME`` is listed as
    ``p_NAME`` (its column name), so the two kinds cannot collide.

    Parameters
    ----------
    table : pandas.DataFrame
        A results table.
    parameters : bool, default False
        Also list the model parameters.

    Returns
    -------
    list of str
    """
    suffixes = ("_se", "_se_hac", "_se_white", "_determined", "_well_property", "_unit")
    derived = [
        c[2:] for c in table.columns
        if isinstance(c, str) and c.startswith("d_") and not c.endswith(suffixes)
    ]  # fmt: skip
    params = [
        c for c in table.columns
        if parameters and isinstance(c, str) and c.startswith("p_") and not c.endswith(suffixes)
    ]  # fmt: skip
    return derived + params


def _columns(quantity: str) -> tuple[str, list[str], str | None, str | None, str]:
    """Value column, standard-error columns, determined column, unit column, kind."""
    if quantity.startswith("p_"):
        return quantity, [f"{quantity}_se", f"{quantity}_se_hac"], None, None, "parameter"
    col = f"d_{quantity}"
    return col, [f"{col}_se"], f"{col}_determined", f"{col}_unit", "derived"


def _parameter_unit(frame: pd.DataFrame, quantity: str) -> str:
    """A parameter's unit from the model's own description, when the table allows it."""
    name = quantity[2:]
    try:
        models = frame["model"].dropna().unique()
        if len(models) != 1:
            return "model units"
        info = {p.name: p for p in model_class(str(models[0])).param_info()}[name]
        load = str(frame["load_unit"].dropna().iloc[0])
        position = str(frame["position_unit"].dropna().iloc[0])
        return info.unit_for(load, position)
    except (KeyError, IndexError, ValueError, AttributeError):
        # No model column, several models, unknown units, or a model class without unit
        # descriptions: say so rather than guess.
        return "model units"


@dataclass(frozen=True)
class _Usable:
    """The usable rows of a table, each well's in its order, with per-well bounds."""

    frame: pd.DataFrame
    wells: tuple[str, ...]
    bounds: NDArray[np.int64]
    order: tuple[str, ...]  # "time" or "card order", per well
    card_id: NDArray[np.object_]
    time: NDArray[np.datetime64]  # UTC, NaT where unknown


def _prepare(frame: pd.DataFrame) -> _Usable:
    """Usable rows, sorted by well, then by time, or by table order for a well with any
    card whose time is unknown (a time order cannot place such a card)."""
    rows = frame[frame["status"].isin(USABLE_STATUSES)]
    well = rows["well_id"].astype(str).to_numpy()
    if "time" in rows.columns:
        time = pd.to_datetime(rows["time"], utc=True).dt.tz_localize(None)
        time = time.astype("datetime64[ns]").to_numpy()
    else:
        time = np.full(len(rows), np.datetime64("NaT"), dtype="datetime64[ns]")
    missing = pd.Series(np.isnat(time)).groupby(well).transform("any").to_numpy()
    key = np.where(missing, 0, time.astype(np.int64))
    idx = np.lexsort((np.arange(len(rows)), key, well))
    well, missing = well[idx], missing[idx]
    wells, starts = np.unique(well, return_index=True)
    bounds = np.append(starts, len(well)).astype(np.int64)
    sorted_rows = rows.iloc[idx]
    return _Usable(
        frame=sorted_rows,
        wells=tuple(str(w) for w in wells),
        bounds=bounds,
        order=tuple("card order" if missing[b] else "time" for b in starts),
        card_id=sorted_rows["card_id"].astype(str).to_numpy(dtype=object),
        time=time[idx],
    )


def _quantity(
    usable: _Usable, q: str, asked: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], list[str], str]:
    """One quantity over the usable rows: values, standard errors, which rows count, the
    unit of each well, and the kind (derived or parameter)."""
    frame = usable.frame
    col, se_cols, det_col, unit_col, kind = _columns(q)
    values = pd.to_numeric(frame[col], errors="coerce").to_numpy(dtype=float)
    keep = np.isfinite(values)
    if det_col is not None and det_col in frame.columns:
        keep &= frame[det_col].fillna(False).astype(bool).to_numpy()
    if not asked and f"{col}_well_property" in frame.columns:  # an echo of the stroke: skip
        keep &= frame[f"{col}_well_property"].fillna(True).astype(bool).to_numpy()
    se = np.full(values.size, np.nan)
    for c in se_cols:
        if c in frame.columns:
            other = pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float)
            se = np.fmax(se, np.where(other >= 0, other, np.nan))  # the larger error
    n_wells = len(usable.wells)
    code = np.repeat(np.arange(n_wells), np.diff(usable.bounds))
    units = [""] * n_wells
    if unit_col is not None and unit_col in frame.columns:
        stated = frame[unit_col].to_numpy(dtype=object)
        has = keep & pd.notna(stated)
        if has.any():
            counts = pd.DataFrame({"w": code[has], "u": stated[has].astype(str)}).value_counts()
            major = counts.reset_index().drop_duplicates("w")  # value_counts sorts by count
            for w, u in zip(major["w"], major["u"], strict=True):
                units[int(w)] = u
            # Values in another unit cannot be compared with these: leave them out (a row
            # that states no unit is taken to share the well's).
            well_unit = np.array(units, dtype=object)[code]
            keep &= ~pd.notna(stated) | (stated.astype(str) == well_unit)
    elif kind == "parameter":
        units = [_parameter_unit(frame.iloc[usable.bounds[i]:usable.bounds[i + 1]], q)
                 for i in range(n_wells)]  # fmt: skip
    return values, se, keep, units, kind


# --------------------------------------------------------------------------- statistics
def _robust_sigma(y: NDArray[np.float64]) -> float:
    """Card-to-card noise from successive differences (robust to one step or a drift)."""
    if y.size < 3:
        return math.nan
    d = np.diff(y)
    return float(_MAD_TO_SD * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


def _cusum(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-sided CUSUM ``S_i = max(0, S_{i-1} + x_i)`` along the last axis, and ``C``.

    Lindley's recursion in closed form: with ``C`` the cumulative sum (``C_0 = 0``),
    ``S_i = C_i - min(C_0..C_i)``; no loop over cards.
    """
    c = np.cumsum(x, axis=-1)
    zero = np.zeros((*x.shape[:-1], 1))
    running_min = np.minimum.accumulate(np.concatenate([zero, c], axis=-1), axis=-1)[..., 1:]
    return c - running_min, c


def _bucket(n: int) -> int:
    for b in _LENGTH_GRID:
        if b >= n:
            return b
    return int(2 ** math.ceil(math.log2(n)))


def cusum_threshold(
    n_cards: int,
    *,
    min_cards: int = 30,
    alpha: float = 0.01,
    reference: float = 1.0,
    clip: float = 3.0,
    tail_dof: float = 5.0,
    outlier_fraction: float = 0.01,
    replicates: int | None = None,
    seed: int = 20240611,
) -> float:
    """The CUSUM threshold with false-alarm probability ``alpha`` over a steady history.

    Simulates the whole procedure of :func:`detect_changes` on steady series (Student-t
    noise with ``tail_dof`` degrees of freedom, a fraction ``outlier_fraction`` of cards
    replaced by outliers of 6-12 robust noise scales with random sign, the reference set
    from the first ``min_cards`` cards) and returns the ``1 - alpha`` quantile of the
    largest of the two sums over the monitored cards.

    Parameters
    ----------
    n_cards : int
        Cards monitored after the reference; rounded up to a grid of lengths
        (16, 20, 23, 27, 32, ... : 19 % apart), so the probability holds for any shorter history.
    min_cards : int, default 30
        Cards in the reference window.
    alpha : float, default 0.01
        False-alarm probability per series.
    reference, clip : float
        The CUSUM's reference value and clipping level, in noise scales.
    tail_dof : float, default 5
        Degrees of freedom of the simulated noise (``inf``: Gaussian).
    outlier_fraction : float, default 0.01
        Fraction of simulated outlier cards.
    replicates : int, optional
        Simulated histories; default ``max(20000, 100 / alpha)`` (at least 100 expected
        exceedances, so the quantile's own error is about 10 % in probability).
    seed : int
        Seed of the simulation (results are cached per argument set).

    Returns
    -------
    float
        The threshold ``h``, in noise scales: the simulated maxima's order statistic that is
        an upper 95 % confidence bound of their ``1 - alpha`` quantile (so the simulation's
        own error does not raise the false-alarm probability above ``alpha``).
    """
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    reps = int(replicates) if replicates is not None else int(max(20000, math.ceil(100 / alpha)))
    return _threshold(_bucket(max(int(n_cards), 1)), int(min_cards), float(alpha),
                      float(reference), float(clip), float(tail_dof), float(outlier_fraction),
                      reps, int(seed))  # fmt: skip


def _phases(w: int, n: int) -> list[tuple[int, int, int]]:
    """Reference windows and the cards each one standardises: ``(ref_end, lo, hi)``.

    The reference grows by doubling: cards ``[w, 2w)`` are judged against the first ``w``,
    ``[2w, 4w)`` against the first ``2w``, and so on, so the level and noise are known
    better and better while a change that has just begun is still a small minority of the
    reference (a median barely moves).
    """
    out = []
    end = w
    while end < n:
        out.append((end, end, min(2 * end, n)))
        end *= 2
    return out


@functools.lru_cache(maxsize=256)
def _threshold(
    n: int, w: int, alpha: float, k: float, c: float, dof: float, out_frac: float, reps: int,
    seed: int,
) -> float:
    rng = np.random.default_rng(seed)
    # Robust scale of the noise (what the MAD estimates), to size the outliers in it.
    if math.isinf(dof):
        robust = 1.0
    else:
        robust = float(scipy.stats.t.ppf(0.75, dof) / scipy.stats.norm.ppf(0.75))
    total = n + w
    maxima = []
    chunk = max(1, min(reps, 4_000_000 // total))  # bounded memory
    for first in range(0, reps, chunk):
        r = min(chunk, reps - first)
        e = rng.standard_normal((r, total)) if math.isinf(dof) else rng.standard_t(dof, (r, total))
        if out_frac > 0:
            hit = np.flatnonzero(rng.random(r * total) < out_frac)
            e.ravel()[hit] = (robust * rng.uniform(6.0, 12.0, hit.size)
                              * rng.choice([-1.0, 1.0], hit.size))
        z = np.empty((r, n))
        for ref_end, lo, hi in _phases(w, total):
            base = e[:, :ref_end]
            level = np.median(base, axis=1, keepdims=True)
            d = np.diff(base, axis=1)
            sigma = _MAD_TO_SD * np.median(
                np.abs(d - np.median(d, axis=1, keepdims=True)), axis=1, keepdims=True
            ) / math.sqrt(2.0)
            z[:, lo - w:hi - w] = (e[:, lo:hi] - level) / sigma
        z = np.clip(z, -c, c)
        up, _ = _cusum(z - k)
        down, _ = _cusum(-z - k)
        maxima.append(np.maximum(up.max(axis=1), down.max(axis=1)))
    # The simulated quantile has its own error; take the order statistic that leaves the
    # true false-alarm probability below alpha with 95 % confidence (about 84 instead of
    # 100 exceedances at the default size), so the error errs on the quiet side.
    values = np.sort(np.concatenate(maxima))
    allowed = int(scipy.stats.binom.ppf(0.05, values.size, alpha))
    return float(values[values.size - 1 - allowed])


@dataclass(frozen=True)
class _Change:
    """One detected change within a series (indices into the series)."""

    first: int
    alarm: int
    direction: str
    threshold: float
    noise: float


def _split(y: NDArray[np.float64], wgt: NDArray[np.float64], lo: int, hi: int,
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


def _standardise(
    y: NDArray[np.float64], se: NDArray[np.float64], start: int, w: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None:
    """Scores ``z``, noise ``sigma_i`` and reference scatter for cards ``start + w`` on.

    None when the first reference has neither scatter nor standard errors.
    """
    n = y.size
    z = np.empty(n - start - w)
    sig_all = np.empty(n - start - w)
    ref_sigma = np.empty(n - start - w)
    for ref_end, lo, hi in _phases(w, n - start):
        base = y[start:start + ref_end]
        level = float(np.median(base))
        sigma = _robust_sigma(base)
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
        sig_i = np.maximum(np.sqrt(tau2 + s**2), 0.5 * sigma)
        z[lo - w:hi - w] = (y[part] - level) / sig_i
        sig_all[lo - w:hi - w] = sig_i
        ref_sigma[lo - w:hi - w] = sigma
    return z, sig_all, ref_sigma


def _scan(
    y: NDArray[np.float64], se: NDArray[np.float64], *, min_cards: int, alpha: float,
    reference: float, clip: float, tail_dof: float, outlier_fraction: float,
) -> tuple[list[_Change], str]:
    """All changes of one series on the analysis scale, and a word on why none if so."""
    n = y.size
    w = min_cards
    changes: list[_Change] = []
    start = 0
    note = ""
    while start + w < n:
        std = _standardise(y, se, start, w)
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
        up, c_up = _cusum(zc - reference)
        down, c_down = _cusum(-zc - reference)
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
        first = _split(y, weights, lo, hi, cand) if len(cand) else tau0
        first = max(start + 1, min(first, alarm))
        changes.append(_Change(first, alarm, "up" if rising else "down", h,
                               float(ref_sigma[alarm - start - w])))
        start = first
    return changes, note


# --------------------------------------------------------------------------- public API
def detect_changes(
    table: pd.DataFrame | str | os.PathLike[str],
    quantities: Sequence[str] | None = None,
    *,
    min_cards: int = 30,
    false_alarm: float = 0.01,
    parameters: bool = False,
    reference: float = 1.0,
    clip: float = 3.0,
    tail_dof: float = 5.0,
    outlier_fraction: float = 0.01,
) -> pd.DataFrame:
    """Find persistent shifts in each well's fitted quantities (see the module docstring).

    Parameters
    ----------
    table : pandas.DataFrame or path
        The results table (one row per card), or a Parquet file or folder holding it.
    quantities : sequence of str, optional
        Derived quantities by name (``"stiffness"`` for column ``d_stiffness``) and/or
        parameters by column name (``"p_k0"``). Default: every derived quantity in the
        table, plus every parameter when ``parameters`` is true.
    min_cards : int, default 30
        Cards in each reference window; a well needs ``min_cards + 1`` usable cards of a
        quantity for it to be tested, and changes closer than this are seen as one.
    false_alarm : float, default 0.01
        Probability that a steady well raises any alert over its history (split evenly
        over the quantities tested).
    parameters : bool, default False
        With ``quantities=None``, also test the model parameters.
    reference, clip : float, default 1 and 3
        The CUSUM's reference value and clipping level, in noise scales.
    tail_dof, outlier_fraction : float, default 5 and 0.01
        The steady-well noise the threshold is calibrated for (Student t and outliers).

    Returns
    -------
    pandas.DataFrame
        One row per change, columns :data:`ALERT_COLUMNS`: ``well_id``, ``quantity``,
        ``unit``, ``first_card_id`` and ``first_time`` (the change's first card),
        ``alarm_card_id`` and ``alarm_time`` (the card at which the CUSUM crossed),
        ``before`` and ``after`` (medians of the segments, in ``unit``), ``change``
        (``after - before``, in ``unit``), ``change_rel`` (``change / before``),
        ``change_se`` (``change`` over its standard error; signed), ``direction``
        (``"up"``/``"down"``), ``kind`` (``"derived"``/``"parameter"``), ``scale``
        (``"log"``/``"linear"``), ``noise`` (card-to-card noise in the reference: relative
        on the log scale, in ``unit`` otherwise), ``first_index``/``alarm_index``
        (positions among the well's usable cards of that quantity), ``delay_cards``,
        ``n_before``/``n_after`` (cards in the segments), ``threshold`` (``h``, in noise
        scales) and ``order`` (``"time"`` or ``"card order"``). Sorted by well, quantity
        and first card.

    Raises
    ------
    ValueError
        If a required column is missing, a requested quantity is not in the table, or an
        option is out of range.
    """
    frame = load_results(table)
    if not 0 < false_alarm < 1:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm}")
    if isinstance(min_cards, bool) or not isinstance(min_cards, int) or min_cards < 5:
        raise ValueError(f"min_cards must be an integer >= 5, got {min_cards!r}")
    if not (reference >= 0 and clip > reference):
        raise ValueError("need reference >= 0 and clip > reference")
    names = list(quantities) if quantities is not None else available_quantities(
        frame, parameters=parameters)  # fmt: skip
    for q in names:
        if _columns(q)[0] not in frame.columns:
            raise ValueError(
                f"no column {_columns(q)[0]!r} for quantity {q!r}; the table has "
                f"{', '.join(available_quantities(frame, parameters=True)) or 'none'}"
            )
    rows: list[dict[str, Any]] = []
    if not names or frame.empty:
        return pd.DataFrame(columns=list(ALERT_COLUMNS))
    alpha = false_alarm / len(names)
    usable = _prepare(frame)
    for q in names:
        values, se, keep, units, kind = _quantity(usable, q, asked=quantities is not None)
        for i, well in enumerate(usable.wells):
            part = slice(usable.bounds[i], usable.bounds[i + 1])
            k = keep[part]
            if k.sum() < min_cards + 1:
                continue
            rows.extend(_series_alerts(
                values[part][k], se[part][k], usable.card_id[part][k], usable.time[part][k],
                well=well, quantity=q, unit=units[i], kind=kind, order=usable.order[i],
                min_cards=min_cards, alpha=alpha, reference=reference, clip=clip,
                tail_dof=tail_dof, outlier_fraction=outlier_fraction,
            ))
    out = pd.DataFrame(rows, columns=list(ALERT_COLUMNS))
    out = out.sort_values(["well_id", "quantity", "first_index"], kind="stable")
    for col in ("first_time", "alarm_time"):
        out[col] = pd.to_datetime(out[col], utc=True).astype("datetime64[ns, UTC]")
    return out.reset_index(drop=True)


def _series_alerts(
    values: NDArray[np.float64], se: NDArray[np.float64], ids: NDArray[np.object_],
    times: NDArray[np.datetime64], *, well: str, quantity: str, unit: str, kind: str,
    order: str, min_cards: int, alpha: float, reference: float, clip: float, tail_dof: float,
    outlier_fraction: float,
) -> list[dict[str, Any]]:
    """The alerts of one well's series of one quantity (values in time order)."""
    q = quantity
    log = bool(np.all(values > 0))
    y = np.log(values) if log else values
    s = se / values if log else se
    changes, _ = _scan(y, s, min_cards=min_cards, alpha=alpha, reference=reference, clip=clip,
                       tail_dof=tail_dof, outlier_fraction=outlier_fraction)
    bounds = [0] + [c.first for c in changes] + [values.size]
    out = []
    for j, ch in enumerate(changes):
        seg_b = values[bounds[j]:bounds[j + 1]]
        seg_a = values[bounds[j + 1]:bounds[j + 2]]
        before, after = float(np.median(seg_b)), float(np.median(seg_a))
        change = after - before
        se_change = math.hypot(_median_se(seg_b), _median_se(seg_a))
        out.append({
            "well_id": well, "quantity": q, "unit": unit,
            "first_card_id": ids[ch.first], "first_time": times[ch.first],
            "alarm_card_id": ids[ch.alarm], "alarm_time": times[ch.alarm],
            "before": before, "after": after, "change": change,
            "change_rel": change / before if before != 0 else math.nan,
            "change_se": change / se_change if se_change > 0 else math.copysign(math.inf, change),
            "direction": ch.direction, "kind": kind, "scale": "log" if log else "linear",
            "noise": ch.noise, "first_index": ch.first, "alarm_index": ch.alarm,
            "delay_cards": ch.alarm - ch.first, "n_before": int(seg_b.size),
            "n_after": int(seg_a.size), "threshold": ch.threshold, "order": order,
        })  # fmt: skip
    return out


def _median_se(values: NDArray[np.float64]) -> float:
    """Standard error of a segment's median from its card-to-card scatter."""
    if values.size < 2:
        return math.nan
    sigma = _robust_sigma(values) if values.size >= 3 else float(np.std(values, ddof=1))
    if not sigma > 0:  # identical values: fall back on the plain spread
        sigma = float(np.std(values, ddof=1))
    return _MEDIAN_SE * sigma / math.sqrt(values.size)


def summarise_wells(
    table: pd.DataFrame | str | os.PathLike[str],
    alerts: pd.DataFrame | None = None,
    quantities: Sequence[str] | None = None,
) -> pd.DataFrame:
    """One row per well: cards, statuses, alerts and the latest value of each quantity.

    Parameters
    ----------
    table : pandas.DataFrame or path
        The results table.
    alerts : pandas.DataFrame, optional
        :func:`detect_changes`' result (none: no alert columns filled).
    quantities : sequence of str, optional
        Quantities whose latest values to give (default: every derived quantity).

    Returns
    -------
    pandas.DataFrame
        ``well_id``, ``cards`` (rows), ``n_<status>`` for each of :data:`STATUSES` (and
        ``n_other`` for any other or missing status), ``usable``, ``first_time``,
        ``last_time``, ``alerts``, ``alerted_quantities`` (comma-separated),
        ``max_abs_change_se``, ``largest_change`` (a phrase with quantity, size and unit),
        and per quantity ``latest_<name>``, ``latest_<name>_unit`` (its last usable,
        determined value) and ``latest_<name>_time``. Wells with alerts come first, by
        decreasing ``max_abs_change_se``, then the others by ``well_id``.
    """
    frame = load_results(table)
    names = list(quantities) if quantities is not None else available_quantities(frame)
    names = [q for q in names if _columns(q)[0] in frame.columns]
    alerts = alerts if alerts is not None else pd.DataFrame(columns=list(ALERT_COLUMNS))
    if frame.empty:
        return pd.DataFrame(columns=["well_id", "cards"])
    well = frame["well_id"].astype(str)
    status = frame["status"].where(frame["status"].isin(STATUSES), "other")
    out = pd.crosstab(well, status).reindex(columns=[*STATUSES, "other"], fill_value=0)
    out.columns = ["n_" + str(c).replace("-", "_") for c in out.columns]
    out.insert(0, "cards", out.sum(axis=1))
    out.insert(len(out.columns), "usable", out[[f"n_{st.replace('-', '_')}"
                                                for st in USABLE_STATUSES]].sum(axis=1))
    if "time" in frame.columns:
        times = pd.to_datetime(frame["time"], utc=True).groupby(well)
        out["first_time"], out["last_time"] = times.min(), times.max()
    else:
        out["first_time"] = out["last_time"] = pd.NaT
    mine = alerts.assign(_w=alerts["well_id"].astype(str),
                         _size=pd.to_numeric(alerts["change_se"], errors="coerce").abs())
    by_well = mine.groupby("_w")
    out["alerts"] = by_well.size().reindex(out.index, fill_value=0).astype(int)
    out["alerted_quantities"] = by_well["quantity"].agg(
        lambda s: ", ".join(dict.fromkeys(s.astype(str)))).reindex(out.index, fill_value="")
    out["max_abs_change_se"] = by_well["_size"].max().reindex(out.index)
    top = mine.sort_values("_size", ascending=False, kind="stable").drop_duplicates("_w")
    phrases = {
        r["_w"]: (f"{r['quantity']} {r['before']:.4g} -> {r['after']:.4g} {r['unit']} "
                  f"({r['change_rel']:+.1%}) from card {r['first_card_id']}")
        for _, r in top.iterrows()
    }
    out["largest_change"] = [phrases.get(w, "") for w in out.index]
    usable = _prepare(frame)
    code = np.repeat(np.arange(len(usable.wells)), np.diff(usable.bounds))
    for q in names:
        values, _, keep, units, _ = _quantity(usable, q)
        last = pd.DataFrame({"w": code[keep], "v": values[keep], "t": usable.time[keep]})
        last = last.groupby("w").tail(1).set_index("w")
        ids = pd.Index(usable.wells)
        latest = pd.Series(last["v"].to_numpy(), index=ids[last.index.to_numpy()])
        when = pd.Series(last["t"].to_numpy(), index=ids[last.index.to_numpy()])
        out[f"latest_{q}"] = latest.reindex(out.index)
        out[f"latest_{q}_unit"] = pd.Series(units, index=ids).reindex(out.index).fillna("")
        out[f"latest_{q}_time"] = pd.to_datetime(when.reindex(out.index), utc=True)
    out = out.reset_index(names="well_id")
    out["_has"] = out["alerts"] > 0
    out = out.sort_values(["_has", "max_abs_change_se", "well_id"],
                          ascending=[False, False, True], na_position="last", kind="stable")
    return out.drop(columns="_has").reset_index(drop=True)
