"""Uncertainty of a fit from the exact sensitivity matrix at the solution (no refits).

For every card the compiled :func:`diagnose_items` forms the Jacobian in scaled coordinates
(``d ln`` of the positive values, the offset in units of the data's range, ``D`` as is: a
unit step is a relative change), reduces it to its triangular factor and takes the factor's
SVD. From that:

* the covariance ``sigma^2 (J^T J)^+`` on the determined directions (singular values above
  ``STRUCTURAL_TOL`` of the largest), with ``sigma^2 = SSR / (N - q)``;
* the autocorrelation-robust (HAC) sandwich ``B Omega B`` with ``Omega`` the long-run
  covariance of the scores along the determined directions (:mod:`pumpid.inference.hac`),
  times ``N / dof`` as the white estimate's ``SSR / dof`` has it;
* the residuals' lag-1 autocorrelation, the check of the white-noise assumption.

The intervals are linearised (Wald) ones: noise white, homoscedastic and Gaussian, the model
linear in its parameters within the interval; Student's t with ``N - q`` degrees of freedom.
Positive quantities get their interval on the log scale, ``value * exp(+-t se/value)``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.special
from numpy.typing import NDArray

from ..engine import drive, lm
from ..engine.compiled import copy_into, jit
from ..engine.problem import Problem
from ..result import Uncertainty
from ..result.text import ADDITIVE
from .hac import long_run_rows, sandwich

__all__ = [
    "HAC_METHOD",
    "PRACTICAL_REL_SE",
    "STRUCTURAL_TOL",
    "WHITENESS_Z",
    "Numbers",
    "Uncertainty",
    "analyse_rows",
    "closes_period",
    "correlation_of",
    "diagnose_items",
    "lag1",
    "residual_whiteness",
    "t_quantile",
    "uncertainty_of",
    "whole_period",
    "widened",
]

Array = NDArray[np.float64]

#: Singular values of the column-scaled Jacobian below this fraction of the largest are
#: structural null directions (an exact symmetry's come out at the 1e-14 level; a genuinely
#: weak but present direction is many orders above).
STRUCTURAL_TOL = 1e-10
#: A combination whose relative standard error exceeds this (100 %) is practically not
#: identifiable: the data are compatible with changing it by a factor e or more.
PRACTICAL_REL_SE = 1.0
#: Residuals count as white while their lag-1 autocorrelation stays below this many standard
#: errors (1/sqrt(N) for white noise): 2.576 is its one-sided 99.5 % point.
WHITENESS_Z = 2.576
#: A residual RMS below this fraction of the data's range is rounding: an exact fit, whose
#: residuals carry no information about the noise.
EXACT_FIT = 1e-9
HAC_METHOD = (
    "sandwich covariance robust to serial correlation and changing variance (HAC): scores "
    "prewhitened by a VAR(1) fit, Bartlett kernel with Andrews' (1991) bandwidth, recoloured"
)


@jit
def analyse_rows(rows, inner, offset_col, span, circular, prewhiten=True, bandwidth=0):
    """The numbers behind one fit's uncertainty from its Jacobian columns and residual.

    ``rows`` (q + 1, N): d r / d z for the solver coordinates z (ln of the positive values,
    D, the offset) and the residual r last. ``inner`` (q,): the coordinates analysed (those
    at a boundary left out); ``offset_col``: the offset's column (-1 when none), scaled by
    ``span`` so that a unit step is the data's range. Returns singular values (q,), right
    singular vectors (q, q), the covariance and the HAC covariance in scaled coordinates
    over the inner coordinates (q, q; first ``qi`` rows), the robust standard error of each
    direction (q,) and statistics (6,): usable, residual RMS, lag-1 autocorrelation, HAC
    bandwidth, prewhitening persistence, capped. ``circular``: the rows are one period of a
    steady state, the last sample the first one's neighbour (the serial statistics run
    around it and do not depend on where the card starts). ``prewhiten`` and ``bandwidth``
    (0: Andrews' rule) configure the long-run covariance (:func:`long_run_rows`).
    """
    q = rows.shape[0] - 1
    n = rows.shape[1]
    s_out = np.full(q, math.nan)
    vt_out = np.full((q, q), math.nan)
    cov_s = np.full((q, q), math.nan)
    hac_s = np.full((q, q), math.nan)
    dir_se = np.full(q, math.nan)
    stats = np.full(6, math.nan)
    stats[0] = 0.0
    idx = np.flatnonzero(inner)
    qi = idx.size
    r = rows[q].copy()
    cost = 0.0
    for t in range(n):
        cost += r[t] * r[t]
    cost *= 0.5
    js = np.empty((qi + 1, n))
    for jj in range(qi):
        j = idx[jj]
        factor = span if j == offset_col else 1.0
        for t in range(n):
            js[jj, t] = rows[j, t] * factor
    copy_into(js[qi], r)
    jsc = js.copy()
    rr = np.zeros((qi, qi))
    cc = np.zeros(qi)
    lm.householder(jsc, qi, rr, cc)
    rms = math.sqrt(2.0 * cost / n)
    stats[1] = rms
    # Residuals' lag-1 autocorrelation (scale-free: divided by their peak first).
    mean = 0.0
    for t in range(n):
        mean += r[t]
    mean /= n
    peak = 0.0
    for t in range(n):
        peak = max(peak, abs(r[t] - mean))
    ss = 0.0
    cross = 0.0
    if peak > 0.0:
        prev = (r[0] - mean) / peak
        ss = prev * prev
        for t in range(1, n):
            cur = (r[t] - mean) / peak
            ss += cur * cur
            cross += cur * prev
            prev = cur
        if circular:
            cross += prev * (r[0] - mean) / peak
    stats[2] = cross / ss if (n > 2 and ss > 0.0) else 0.0
    if qi == 0 or not np.all(np.isfinite(rr)):
        stats[0] = 1.0
        return s_out, vt_out, cov_s, hac_s, dir_se, stats
    _u, s, vt = lm.small_svd(rr)
    for a in range(qi):
        s_out[a] = s[a]
        for b in range(qi):
            vt_out[a, b] = vt[a, b]
    stats[0] = 1.0
    dof = n - q
    if dof <= 0 or not s[0] > 0.0:
        return s_out, vt_out, cov_s, hac_s, dir_se, stats
    sigma2 = 2.0 * cost / dof
    kept = np.flatnonzero(s > STRUCTURAL_TOL * s[0])
    nk = kept.size
    for a in range(qi):
        for b in range(qi):
            acc = 0.0
            for kk in range(nk):
                c = kept[kk]
                acc += vt[c, a] * vt[c, b] / (s[c] * s[c])
            cov_s[a, b] = sigma2 * acc
    finite = True
    for t in range(n):
        if not math.isfinite(r[t]):
            finite = False
    if nk == 0 or not (rms > 0.0 and math.isfinite(rms)) or not finite:
        return s_out, vt_out, cov_s, hac_s, dir_se, stats
    # Scores along direction c: s_c * rms * (q_c * r / rms), q_c a unit vector; build the
    # last factor (of order one whatever the data's magnitude) and put s_c and rms back
    # into the bread.
    scores = np.zeros((nk, n))
    for kk in range(nk):
        c = kept[kk]
        for jj in range(qi):
            w = vt[c, jj]
            if w != 0.0:
                for t in range(n):
                    scores[kk, t] += w * js[jj, t]
        for t in range(n):
            scores[kk, t] *= r[t] / (rms * s[c])
    omega, m, persistence, capped = long_run_rows(scores, prewhiten, bandwidth, circular)
    stats[3] = m
    stats[4] = persistence
    stats[5] = 1.0 if capped else 0.0
    inflate = n / dof
    bread = np.zeros((qi, nk))
    for jj in range(qi):
        for kk in range(nk):
            c = kept[kk]
            bread[jj, kk] = vt[c, jj] * rms / s[c]
    for kk in range(nk):
        c = kept[kk]
        dir_se[c] = math.sqrt(max(omega[kk, kk], 0.0) * inflate) * rms / s[c]
    cov = sandwich(bread, omega)
    for a in range(qi):
        for b in range(qi):
            hac_s[a, b] = cov[a, b] * inflate
    return s_out, vt_out, cov_s, hac_s, dir_se, stats


def diagnose_items(cards: NDArray[np.int64], z: Array, inner: NDArray[np.bool_], span: Array,
                   circular: NDArray[np.bool_], data: Any, model: Any, settings: Any
                   ) -> tuple[Array, ...]:
    """The numbers behind the uncertainty of many (card, optimum) items.

    ``inner`` (m, q): the coordinates analysed (boundary parameters left out); ``span``
    (m,): the data's range per item (the offset's unit step); ``circular`` (m,): the item's
    card is one period of a steady state (:func:`analyse_rows`). Returns singular values
    (m, q), right singular vectors (m, q, q), the covariance and the HAC covariance in
    scaled coordinates (m, q, q; over the inner coordinates, first ``qi`` rows), the robust
    standard error of each direction (m, q) and statistics (m, 6): usable, residual RMS,
    lag-1 autocorrelation, HAC bandwidth, prewhitening persistence, capped.
    """
    # The rows come from the engine's one compiled simulation with sensitivities (shared
    # with the fit's summary): a compiled loop here would compile that simulation again,
    # the largest part of a fresh install's first run, to save microseconds per card.
    m, q = z.shape
    buffer, starts, ok = drive.rows_items(cards, z, data, model, settings)
    s = np.empty((m, q))
    vt = np.empty((m, q, q))
    cov = np.empty((m, q, q))
    hac = np.empty((m, q, q))
    dse = np.empty((m, q))
    stats = np.empty((m, 6))
    offset_col = q - 1 if settings[5] else -1
    for i in range(m):
        if ok[i]:
            out = analyse_rows(drive.item_rows(buffer, starts, i, q), inner[i], offset_col,
                               float(span[i]), bool(circular[i]))
        else:
            nan_stats = np.full(6, math.nan)
            nan_stats[0] = 0.0
            out = (np.full(q, math.nan), np.full((q, q), math.nan),
                   np.full((q, q), math.nan), np.full((q, q), math.nan),
                   np.full(q, math.nan), nan_stats)
        s[i], vt[i], cov[i], hac[i], dse[i], stats[i] = out
    return s, vt, cov, hac, dse, stats


@functools.lru_cache(maxsize=1024)
def t_quantile(q: float, dof: int) -> float:
    """Student-t quantile, cached: scipy's ppf costs ~0.2 ms."""
    # scipy.special's inverse t distribution: scipy.stats costs 0.35 s to import.
    return float(scipy.special.stdtrit(dof, q))


def residual_whiteness(residual: Sequence[float] | Array) -> dict[str, Any]:
    """Do the residuals look like white noise? Lag-1 autocorrelation and what it implies.

    For errors that are an AR(1) process with coefficient rho, and slowly varying
    sensitivities, the variances grow by ``(1 + rho) / (1 - rho)``, as if only
    ``N (1 - rho) / (1 + rho)`` samples had been taken.

    Returns
    -------
    dict
        ``lag1_autocorrelation`` (rho), ``limit`` (``WHITENESS_Z / sqrt(N)``: white noise
        stays below it with probability 99.5 %), ``white`` (rho <= limit),
        ``interval_factor`` (``sqrt((1 + rho) / (1 - rho))`` for rho > 0, else 1) and
        ``effective_samples``.
    """
    r = np.asarray(residual, dtype=float)
    r = r[np.isfinite(r)]
    rho = lag1(r) if r.size > 2 else 0.0
    return _whiteness(0.0 if math.isnan(rho) else rho, int(r.size))


def lag1(residual: Array, circular: bool = False) -> float:
    """The lag-1 autocorrelation ``sum r_t r_(t+1) / sum r_t^2`` of the centred residuals
    (NaN for a constant or empty series): the one estimate every whiteness and serial test
    of pumpid reads. ``circular``: the residuals are one period of a periodic series, the
    last sample the first one's neighbour (the sum then takes that pair too)."""
    r = np.asarray(residual, dtype=float)
    if r.size == 0:
        return math.nan
    r = r - r.mean()
    # Scaled by the peak: squares of very large residuals would overflow.
    peak = float(np.max(np.abs(r)))
    if not peak > 0 or not math.isfinite(peak):
        return math.nan
    r = r / peak
    cross = float(r[1:] @ r[:-1]) + (float(r[-1] * r[0]) if circular else 0.0)
    return cross / float(r @ r)


def _whiteness(rho: float, n: int) -> dict[str, Any]:
    limit = WHITENESS_Z / math.sqrt(max(n, 1))
    positive = min(max(rho, 0.0), 0.999)
    return {
        "lag1_autocorrelation": rho,
        "limit": limit,
        "white": bool(rho <= limit),
        "interval_factor": math.sqrt((1.0 + positive) / (1.0 - positive)),
        "effective_samples": n * (1.0 - positive) / (1.0 + positive),
    }


def is_positive_quantity(name: str, additive: Sequence[str] = ()) -> bool:
    """Physical parameters and C are positive (log coordinates); D, offset and the names in
    ``additive`` (an own model's signed parameters) are additive."""
    return name not in ADDITIVE and name not in additive


def _interval(name: str, value: float, se: float, tq: float,
              additive: Sequence[str] = ()) -> tuple[float, float] | None:
    if not (math.isfinite(se) and math.isfinite(value)):
        return None
    if is_positive_quantity(name, additive) and value > 0:
        half = tq * se / value
        if half > 700.0:  # beyond float range: the data bound this value from neither side
            return (0.0, math.inf)
        return (value * math.exp(-half), value * math.exp(half))
    return (value - tq * se, value + tq * se)


@dataclass(frozen=True)
class Numbers:
    """The raw numbers of one card's analysis (from :func:`diagnose_items`)."""

    names: tuple[str, ...]
    inner: tuple[int, ...]
    values: Array
    scales: Array
    singular: Array
    vt: Array
    cov_scaled: Array
    hac_scaled: Array
    direction_se_hac: Array
    rms: float
    rho: float
    bandwidth: float
    persistence: float
    capped: bool
    n: int
    cost: float
    usable: bool
    #: The data's range on the residual's scale (an exact fit's RMS is rounding of it).
    spread: float = 1.0
    #: Names analysed on their own scale besides D and the offset (an own model's signed
    #: parameters); every other name is positive, analysed on the log scale.
    additive: tuple[str, ...] = ()
    #: The card is one period of a steady state: its serial statistics run around it.
    circular: bool = False

    @property
    def exact(self) -> bool:
        """An exact fit: the residuals are rounding and carry nothing about the noise."""
        return not self.rms > EXACT_FIT * self.spread

    @property
    def dof(self) -> int:
        """Degrees of freedom N - q."""
        return self.n - len(self.names)

    @property
    def sigma2(self) -> float:
        """Residual variance SSR / (N - q)."""
        return 2.0 * self.cost / self.dof if self.dof > 0 else math.nan


def correlation_of(cov: Array) -> Array:
    """The correlation matrix of a covariance (NaN where a variance is not finite); both
    arrays are made read-only, as a result's parts are.

    Parameters
    ----------
    cov : ndarray, shape (q, q)

    Returns
    -------
    ndarray, shape (q, q)
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        sd = np.sqrt(np.diag(cov))
        corr = cov / np.outer(sd, sd)
    corr[~np.isfinite(corr)] = math.nan
    np.fill_diagonal(corr, [1.0 if np.isfinite(s) else math.nan for s in sd])
    for a in (cov, corr):
        a.flags.writeable = False
    return corr


def _embed(inner_cov: Array, q: int, inner: Sequence[int]) -> Array:
    cov = np.full((q, q), math.nan)
    cov[np.ix_(inner, inner)] = inner_cov
    return cov


def uncertainty_of(nums: Numbers, undetermined: Sequence[int], notes: Sequence[str],
                   sigma2_unit: str) -> Uncertainty | None:
    """Assemble the :class:`Uncertainty` of one card from its numbers (None if unusable)."""
    if not nums.usable or nums.dof <= 0:
        return None
    names = nums.names
    q = len(names)
    inner = list(nums.inner)
    qi = len(inner)
    scales = nums.scales[inner]
    outer = np.outer(scales, scales)
    cov_in = nums.cov_scaled[:qi, :qi] * outer
    hac_in = nums.hac_scaled[:qi, :qi] * outer
    und = set(undetermined)
    for a, i in enumerate(inner):
        if i in und:
            for m in (cov_in, hac_in):
                m[a, :] = math.nan
                m[:, a] = math.nan
                m[a, a] = math.inf
    cov = _embed(cov_in, q, inner)
    hac_cov = _embed(hac_in, q, inner)
    tq = t_quantile(0.975, nums.dof)

    def errors(c: Array) -> tuple[dict[str, float], dict[str, tuple[float, float] | None]]:
        se: dict[str, float] = {}
        ci: dict[str, tuple[float, float] | None] = {}
        for i, name in enumerate(names):
            var = c[i, i]
            val = math.sqrt(var) if math.isfinite(var) and var >= 0 else (
                math.inf if var == math.inf else math.nan)
            se[name] = val
            ci[name] = _interval(name, float(nums.values[i]), val, tq, nums.additive)
        return se, ci

    stderr, ci95 = errors(cov)
    hac_ok = bool(np.any(np.isfinite(nums.hac_scaled[:qi, :qi])))
    if hac_ok:
        stderr_hac, ci95_hac = errors(hac_cov)
        hac_meta: dict[str, Any] | None = {
            "bandwidth": int(nums.bandwidth), "prewhitening": float(nums.persistence),
            "capped": bool(nums.capped), "method": HAC_METHOD}
    else:
        stderr_hac = dict.fromkeys(names, math.nan)
        ci95_hac = dict.fromkeys(names)
        hac_meta = None
    whiteness = None if nums.exact else _whiteness(nums.rho, nums.n)
    corr = correlation_of(cov)
    return Uncertainty(
        names=names, stderr=MappingProxyType(stderr), ci95=MappingProxyType(ci95),
        stderr_hac=MappingProxyType(stderr_hac), ci95_hac=MappingProxyType(ci95_hac),
        covariance=cov, correlation=corr, sigma2=nums.sigma2, dof=nums.dof, t_quantile=tq,
        singular_values=tuple(float(x) / float(nums.singular[0])
                              for x in nums.singular[:qi] if math.isfinite(x))
        if qi and nums.singular[0] > 0 else (),
        whiteness=MappingProxyType(whiteness) if whiteness is not None else None,
        hac=MappingProxyType(hac_meta) if hac_meta is not None else None,
        notes=tuple(notes), sigma2_unit=sigma2_unit,
        assumptions=Uncertainty.assumptions.replace(
            "Student t quantile", f"Student t quantile with {nums.dof} degrees of freedom"),
    )


def whole_period(problem: Problem, k: int) -> bool:
    """Whether the problem's card ``k`` is one whole period of a steady state, sampled
    uniformly: its last sample is its first one's neighbour (not so where a period given
    leaves a gap after it). Its serial statistics then run around the period, and its
    fundamental's share of the data is measured."""
    if problem.initial_states[k] != "periodic" or not problem.uniform[k]:
        return False
    return closes_period(problem.card(k)[0], float(problem.period[k]))


def closes_period(t: Array, period: float | None) -> bool:
    """Whether uniformly spaced sample times ``t`` (s) cover one period of ``period`` s
    whole: the sample after the last would be the first's one period on (no gap).

    Parameters
    ----------
    t : numpy.ndarray
        The sample times, uniformly spaced (the caller's test).
    period : float or None
        The period (s).

    Returns
    -------
    bool
    """
    t = np.asarray(t, dtype=float)
    if t.size < 2 or period is None or not (math.isfinite(period) and period > 0):
        return False
    step = float(t[-1] - t[0]) / (t.size - 1)
    return abs(period - t.size * step) <= 1e-6 * period


def numbers(problem: Problem, cards: NDArray[np.int64], z: Array, inner: NDArray[np.bool_],
            ) -> list[Numbers]:
    """:func:`diagnose_items` for many (card, optimum) items, as :class:`Numbers`."""
    m = cards.size
    span = np.array([float(np.ptp(problem.card(int(k))[2])) or 1.0 for k in cards])
    circular = np.array([whole_period(problem, int(k)) for k in cards], dtype=np.bool_)
    data, model, settings = problem.arrays
    s, vt, cov, hac, dse, stats = diagnose_items(
        np.ascontiguousarray(cards, dtype=np.int64), np.ascontiguousarray(z),
        np.ascontiguousarray(inner), span, circular, data, model, settings)
    names = problem.free_names
    p = problem.n_free
    out = []
    for i in range(m):
        values = np.empty(len(names))
        values[:p] = np.exp(z[i, :p])
        j = p
        scales = np.empty(len(names))
        scales[:p] = values[:p]
        if problem.scale_fixed is None:
            if problem.residual == "log":
                values[j] = z[i, j]
                scales[j] = 1.0
            else:
                values[j] = math.exp(z[i, j])
                scales[j] = values[j]
            j += 1
        if problem.offset_fixed is None:
            values[j] = z[i, j]
            scales[j] = span[i]
        n = problem.n_samples(int(cards[i]))
        rms = float(stats[i, 1])
        d = problem.card(int(cards[i]))[2]
        spread = float(np.ptp(np.log(d))) if problem.residual == "log" else float(np.ptp(d))
        out.append(Numbers(
            names=names, inner=tuple(int(a) for a in np.flatnonzero(inner[i])), values=values,
            scales=scales, singular=s[i], vt=vt[i], cov_scaled=cov[i], hac_scaled=hac[i],
            direction_se_hac=dse[i], rms=rms, rho=float(stats[i, 2]),
            bandwidth=float(stats[i, 3]), persistence=float(stats[i, 4]),
            capped=bool(stats[i, 5] == 1.0), n=n, cost=0.5 * rms * rms * n,
            usable=bool(stats[i, 0] == 1.0), spread=spread, circular=bool(circular[i])))
    return out


def widened(nums: Numbers, index: int, se: float, robust_only: bool = False) -> Numbers:
    """The analysis with coordinate ``index``'s standard error raised to at least ``se``
    (in the analysis' scaled coordinates: relative for a positive parameter), in the white
    and the robust covariances alike (``robust_only``: in the robust one alone), its
    correlations kept; unchanged where it is larger already, not finite, or the coordinate
    is not analysed.

    A local error is the cost's curvature at the answer; where the cost is known to stay
    within the noise much farther away (a flat, rippled direction), the error that holds
    is at least that distance's.
    """
    inner = list(nums.inner)
    if index not in inner or not (math.isfinite(se) and se > 0):
        return nums
    a = inner.index(index)
    out = []
    for kind, cov in enumerate((nums.cov_scaled, nums.hac_scaled)):
        var = float(cov[a, a])
        if (robust_only and kind == 0) or not (math.isfinite(var) and 0 < var < se * se):
            out.append(cov)
            continue
        factor = se / math.sqrt(var)
        cov = cov.copy()
        cov[a, :] *= factor
        cov[:, a] *= factor
        out.append(cov)
    return dataclasses.replace(nums, cov_scaled=out[0], hac_scaled=out[1])
