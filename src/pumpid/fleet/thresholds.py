"""Thresholds of the change detectors, simulated on steady histories.

Both detectors of :mod:`pumpid.fleet.changes` judge a well against its own card-to-card
scatter, so their statistics have no closed-form distribution under heavy-tailed noise;
their thresholds are the ``1 - alpha`` quantiles of the statistic over simulated steady
histories (Student-t noise with ``tail_dof`` degrees of freedom, a fraction
``outlier_fraction`` of cards replaced by outliers of 6-12 robust noise scales of random
sign), the whole procedure simulated, the estimation of level and scale included. Of the
simulated values the order statistic that bounds the quantile from above with 95 %
confidence is taken (:func:`upper_quantile`), so the simulation's own error does not push
the false-alarm probability above ``alpha``. Seeds are fixed and results cached, in the
process and on disk (:func:`stored`: a report of a field of short histories spent 3.6 of
its 9 s simulating the same thresholds at every run).

``cusum_threshold``
    The robust two-sided CUSUM of long histories (a reference window of ``min_cards``
    cards, then monitoring).
``two_segment_threshold``
    The two-segment test of short histories (:func:`two_segment_statistic`): the largest
    difference of medians over the splits into two segments of at least 3 cards, in units
    of the within-segment scatter.
``drift_threshold``
    The drift test of short histories (:func:`drift_statistic`): the robust slope of the
    whole history over its standard error. A level falling steadily widens the scatter
    within the two-segment test's segments as much as it parts their medians, so that
    test's statistic on a straight decline does not grow with its steepness.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np
import scipy
import scipy.stats
from numpy.typing import NDArray

from ..engine.compiled import cache_base

__all__ = [
    "LENGTH_GRID",
    "MAD_TO_SD",
    "MIN_SEGMENT",
    "cusum_paths",
    "cusum_threshold",
    "drift_statistic",
    "drift_threshold",
    "reference_phases",
    "steady_noise",
    "stored",
    "two_segment_statistic",
    "two_segment_threshold",
    "upper_quantile",
]

#: MAD -> standard deviation of a normal distribution.
MAD_TO_SD = 1.482602218505602
#: History lengths the CUSUM threshold is calibrated for (19 % apart); a history is rounded up.
LENGTH_GRID = tuple(math.ceil(16 * 2 ** (j / 4)) for j in range(0, 48))
#: Fewest cards on either side of a split of the two-segment test: one wild card among
#: three cannot move a median, so a lone outlier is never a change.
MIN_SEGMENT = 3


F = TypeVar("F", bound=Callable[..., float])
#: Thresholds stored on disk, by file: read once per process.
_TABLES: dict[Path, dict[str, float]] = {}


def _store_file() -> Path:
    """The file of stored thresholds: named by this module's source and numpy's and scipy's
    versions (a change to any may change what the simulations give)."""
    digest = hashlib.sha256(Path(__file__).read_bytes())
    digest.update(f"{np.__version__} {scipy.__version__}".encode())
    return cache_base() / f"thresholds-{digest.hexdigest()[:16]}.json"


def _read_store(path: Path) -> dict[str, float]:
    """The stored table, empty where the file is missing, unreadable or not a table."""
    with contextlib.suppress(OSError, ValueError, TypeError, AttributeError):
        loaded = json.loads(path.read_text(encoding="utf-8"))
        return {str(k): float(v) for k, v in loaded.items()}
    return {}


def stored(func: F) -> F:
    """Cache a simulated threshold in the process and on disk, by its arguments.

    The simulations are seeded, so a stored value is the one the simulation would give. A
    file that cannot be read or written, or that holds anything but a table of numbers, is
    ignored (the value is simulated instead): the cache only saves time. Two processes
    writing at once may each keep only their own values (both are right).

    Parameters
    ----------
    func : callable
        A function of positional, hashable arguments whose ``repr`` is stable, returning a
        float.

    Returns
    -------
    callable
        The same function, its values cached.
    """
    @functools.lru_cache(maxsize=512)
    @functools.wraps(func)
    def wrapper(*args: object) -> float:
        path = _store_file()
        table = _TABLES.get(path)
        if table is None:
            table = _TABLES[path] = _read_store(path)
        key = f"{func.__name__}{args!r}"
        if key in table:
            return table[key]
        value = float(func(*args))
        # What another process stored meanwhile is kept: the file is read again just before
        # it is replaced (a simulation takes seconds, the read and the write a millisecond).
        table.update({k: v for k, v in _read_store(path).items() if k not in table})
        table[key] = value
        with contextlib.suppress(OSError):
            path.parent.mkdir(parents=True, exist_ok=True)
            # Written whole and renamed: a process reading it never sees half a file.
            handle, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
            try:
                with os.fdopen(handle, "w", encoding="utf-8") as out:
                    json.dump(table, out)
                os.replace(tmp, path)
            finally:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
        return value

    return wrapper  # type: ignore[return-value]


def upper_quantile(values: NDArray[np.float64], alpha: float) -> float:
    """The order statistic of simulated values that is an upper 95 % confidence bound of
    their ``1 - alpha`` quantile (about 84 instead of 100 exceedances at 100 expected)."""
    ordered = np.sort(np.asarray(values, dtype=float))
    allowed = int(scipy.stats.binom.ppf(0.05, ordered.size, alpha))
    return float(ordered[ordered.size - 1 - allowed])


def steady_noise(rng: np.random.Generator, shape: tuple[int, int], dof: float,
                 outlier_fraction: float) -> NDArray[np.float64]:
    """Steady-well noise: Student t with ``dof`` degrees of freedom (``inf``: Gaussian), a
    fraction of values replaced by outliers of 6-12 robust scales (what a MAD estimates)."""
    e = rng.standard_normal(shape) if math.isinf(dof) else rng.standard_t(dof, shape)
    if outlier_fraction > 0:
        robust = (1.0 if math.isinf(dof)
                  else float(scipy.stats.t.ppf(0.75, dof) / scipy.stats.norm.ppf(0.75)))
        hit = np.flatnonzero(rng.random(e.size) < outlier_fraction)
        e.ravel()[hit] = robust * rng.uniform(6.0, 12.0, hit.size) * rng.choice([-1.0, 1.0],
                                                                               hit.size)
    return e


def cusum_paths(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-sided CUSUM ``S_i = max(0, S_{i-1} + x_i)`` along the last axis, and ``C``.

    Lindley's recursion in closed form: with ``C`` the cumulative sum (``C_0 = 0``),
    ``S_i = C_i - min(C_0..C_i)``; no loop over cards.
    """
    c = np.cumsum(x, axis=-1)
    zero = np.zeros((*x.shape[:-1], 1))
    running_min = np.minimum.accumulate(np.concatenate([zero, c], axis=-1), axis=-1)[..., 1:]
    return c - running_min, c


def _bucket(n: int) -> int:
    for b in LENGTH_GRID:
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


def reference_phases(w: int, n: int) -> list[tuple[int, int, int]]:
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


@stored
def _threshold(
    n: int, w: int, alpha: float, k: float, c: float, dof: float, out_frac: float, reps: int,
    seed: int,
) -> float:
    rng = np.random.default_rng(seed)
    total = n + w
    maxima = []
    chunk = max(1, min(reps, 4_000_000 // total))  # bounded memory
    for first in range(0, reps, chunk):
        r = min(chunk, reps - first)
        e = steady_noise(rng, (r, total), dof, out_frac)
        z = np.empty((r, n))
        for ref_end, lo, hi in reference_phases(w, total):
            base = e[:, :ref_end]
            level = np.median(base, axis=1, keepdims=True)
            d = np.diff(base, axis=1)
            sigma = MAD_TO_SD * np.median(
                np.abs(d - np.median(d, axis=1, keepdims=True)), axis=1, keepdims=True
            ) / math.sqrt(2.0)
            z[:, lo - w:hi - w] = (e[:, lo:hi] - level) / sigma
        z = np.clip(z, -c, c)
        up, _ = cusum_paths(z - k)
        down, _ = cusum_paths(-z - k)
        maxima.append(np.maximum(up.max(axis=1), down.max(axis=1)))
    # The simulated quantile has its own error; take the order statistic that leaves the
    # true false-alarm probability below alpha with 95 % confidence (about 84 instead of
    # 100 exceedances at the default size), so the error errs on the quiet side.
    return upper_quantile(np.concatenate(maxima), alpha)




def two_segment_statistic(
    y: NDArray[np.float64], scale_floor: float | NDArray[np.float64] = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """The two-segment statistic of short histories, for each row of ``y``.

    For every split ``k`` (cards ``[0, k)`` and ``[k, n)``, each at least
    :data:`MIN_SEGMENT` cards), the difference of the two segments' medians over its
    standard error: ``T_k = |med_2 - med_1| / (s_k sqrt(1/k + 1/(n - k)))``, with ``s_k``
    the scatter of the cards about their own segment's median (``sqrt(pi/2)`` times the
    mean absolute residual, over ``n - 2`` residuals: each median has one of its own cards
    at distance zero) and never below ``scale_floor`` (the fits' own standard error: values
    identical to the last digit still have that uncertainty). A step leaves ``s_k`` at the
    true split untouched, so the statistic is largest there. Medians make one wild card
    harmless to the level; the mean absolute residual makes it widen the scale, which can
    only lower the statistic.

    Parameters
    ----------
    y : array (n,) or (r, n)
        Histories on the analysis scale, ``n >= 2 * MIN_SEGMENT``.
    scale_floor : float or array (r,)
        Smallest scale.

    Returns
    -------
    statistic : array (r,)
        ``max_k T_k``.
    split : array (r,)
        The maximising ``k``: the first card of the second segment.
    scale : array (r,)
        ``s_k`` at that split.
    """
    y2 = np.atleast_2d(np.asarray(y, dtype=float))
    r, n = y2.shape
    if n < 2 * MIN_SEGMENT:
        raise ValueError(f"the two-segment test needs {2 * MIN_SEGMENT} cards, got {n}")
    floor = np.broadcast_to(np.asarray(scale_floor, dtype=float), (r,))
    best = np.full(r, -np.inf)
    where = np.zeros(r, dtype=np.int64)
    scale = np.full(r, np.nan)
    for k in range(MIN_SEGMENT, n - MIN_SEGMENT + 1):
        m1 = np.median(y2[:, :k], axis=1, keepdims=True)
        m2 = np.median(y2[:, k:], axis=1, keepdims=True)
        resid = np.abs(y2[:, :k] - m1).sum(axis=1) + np.abs(y2[:, k:] - m2).sum(axis=1)
        s = np.maximum(math.sqrt(math.pi / 2.0) * resid / (n - 2), floor)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.abs(m2 - m1)[:, 0] / (s * math.sqrt(1.0 / k + 1.0 / (n - k)))
        t = np.where(np.isnan(t), 0.0, t)  # no scatter and no difference: nothing seen
        better = t > best
        best = np.where(better, t, best)
        where = np.where(better, k, where)
        scale = np.where(better, s, scale)
    return best, where, scale


def two_segment_threshold(
    n_cards: int,
    *,
    alpha: float = 0.01,
    tail_dof: float = 5.0,
    outlier_fraction: float = 0.01,
    replicates: int | None = None,
    seed: int = 20240612,
) -> float:
    """The two-segment test's threshold: false-alarm probability ``alpha`` on a steady
    history of ``n_cards`` cards.

    Simulates :func:`two_segment_statistic` on steady histories of exactly that length (a
    short history is tested once, as a whole, so each length has its own threshold), with
    noise of :func:`steady_noise` and no standard-error floor (a floor only lowers the
    statistic, so the false-alarm probability of a well with reported errors is at most
    ``alpha``), twice: with the heavy-tailed noise asked for and with Gaussian noise; the
    larger threshold is taken, so either kind of steady well alerts at most at ``alpha``.

    Parameters
    ----------
    n_cards : int
        Cards of the history, at least ``2 * MIN_SEGMENT``.
    alpha : float, default 0.01
        False-alarm probability per history.
    tail_dof, outlier_fraction : float, default 5 and 0.01
        The simulated steady noise.
    replicates : int, optional
        Simulated histories; default ``max(20000, 100 / alpha)``.
    seed : int
        Seed of the simulation.

    Returns
    -------
    float
        The threshold, in standard errors of the difference of medians.
    """
    # The larger of the thresholds under the heavy-tailed noise and under Gaussian noise:
    # with few cards the scale's estimate, not only the medians, sets the statistic's tail,
    # and a wild card widens that estimate, so Gaussian noise can give the heavier tail
    # (measured: at 10 cards the t5-calibrated threshold let 1.65 % of Gaussian wells alert).
    return _short_threshold("two-segment", n_cards, alpha, tail_dof, outlier_fraction,
                            replicates, seed)


def _short_threshold(kind: str, n_cards: int, alpha: float, tail_dof: float,
                     outlier_fraction: float, replicates: int | None, seed: int) -> float:
    """A short-history test's threshold: the larger of the heavy-tailed and the Gaussian
    simulations' (see :func:`two_segment_threshold`)."""
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    reps = int(replicates) if replicates is not None else int(max(20000, math.ceil(100 / alpha)))
    return max(_simulated(kind, int(n_cards), float(alpha), float(tail_dof),
                          float(outlier_fraction), reps, int(seed)),
               _simulated(kind, int(n_cards), float(alpha), math.inf, 0.0, reps, int(seed)))


@stored
def _simulated(kind: str, n: int, alpha: float, dof: float, out_frac: float, reps: int,
               seed: int) -> float:
    rng = np.random.default_rng(seed + n)
    # bounded memory: the drift test holds n^2 / 2 slopes a history
    chunk = max(1, min(reps, 2_000_000 // n if kind == "two-segment" else 4_000_000 // (n * n)))
    statistic = two_segment_statistic if kind == "two-segment" else drift_statistic
    stats = []
    for first in range(0, reps, chunk):
        e = steady_noise(rng, (min(chunk, reps - first), n), dof, out_frac)
        stats.append(statistic(e)[0])
    return upper_quantile(np.concatenate(stats), alpha)


def drift_statistic(
    y: NDArray[np.float64], scale_floor: float | NDArray[np.float64] = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
           NDArray[np.float64]]:
    """The drift test's statistic of short histories, for each row of ``y``.

    The Theil-Sen slope ``b`` per card (the median of the slopes between every two cards:
    up to 29 % of wild cards cannot carry it), the line through the median of
    ``y - b i``, the scatter ``s`` of the cards about that line (``sqrt(pi/2)`` times the
    mean absolute residual over ``n - 2`` residuals, never below ``scale_floor``), and the
    statistic ``|b| / (s / sqrt(sum (i - mean i)^2))``, the slope over its standard error.

    Parameters
    ----------
    y : array (n,) or (r, n)
        Histories on the analysis scale, in card order, ``n >= 2 * MIN_SEGMENT``.
    scale_floor : float or array (r,)
        Smallest scale (the fits' own standard error).

    Returns
    -------
    statistic : array (r,)
        ``|b|`` over its standard error (0 where there is neither slope nor scatter).
    slope : array (r,)
        ``b``, per card.
    scale : array (r,)
        ``s``.
    level : array (r,)
        The line's value at the first card.
    """
    y2 = np.atleast_2d(np.asarray(y, dtype=float))
    r, n = y2.shape
    if n < 2 * MIN_SEGMENT:
        raise ValueError(f"the drift test needs {2 * MIN_SEGMENT} cards, got {n}")
    floor = np.broadcast_to(np.asarray(scale_floor, dtype=float), (r,))
    i, j = np.triu_indices(n, 1)
    slope = _row_median((y2[:, j] - y2[:, i]) * (1.0 / (j - i)))
    x = np.arange(n, dtype=float)
    level = np.median(y2 - slope[:, None] * x, axis=1)
    resid = np.abs(y2 - level[:, None] - slope[:, None] * x).sum(axis=1)
    scale = np.maximum(math.sqrt(math.pi / 2.0) * resid / (n - 2), floor)
    spread = math.sqrt(float(np.sum((x - x.mean()) ** 2)))
    with np.errstate(divide="ignore", invalid="ignore"):
        stat = np.abs(slope) * spread / scale
    return np.where(np.isnan(stat), 0.0, stat), slope, scale, level


def drift_threshold(
    n_cards: int,
    *,
    alpha: float = 0.01,
    tail_dof: float = 5.0,
    outlier_fraction: float = 0.01,
    replicates: int | None = None,
    seed: int = 20261129,
) -> float:
    """The drift test's threshold: false-alarm probability ``alpha`` on a steady history
    of ``n_cards`` cards, in standard errors of the slope.

    Simulated as :func:`two_segment_threshold` is, with the same parameters (the same noise,
    the larger of the heavy-tailed and the Gaussian thresholds, no standard-error floor), on
    :func:`drift_statistic`; only the seed's default differs.
    """
    return _short_threshold("drift", n_cards, alpha, tail_dof, outlier_fraction, replicates,
                            seed)


def _row_median(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each row's median, by partition: a quarter of ``np.median``'s time on the drift
    test's simulated (replicates, pairs) arrays, the bulk of its threshold's cost."""
    m = a.shape[1]
    half = m // 2
    if m % 2:
        return np.partition(a, half, axis=1)[:, half]
    part = np.partition(a, (half - 1, half), axis=1)
    return 0.5 * (part[:, half - 1] + part[:, half])
