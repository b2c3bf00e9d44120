"""Errors that hold when the residuals are serially correlated, and which error is shown.

A card's residuals are mostly model error: on real wells their lag-1 autocorrelation is
0.95-0.98, and the independent-noise (white) standard errors are several times too small.
The HAC sandwich (:mod:`pumpid.inference.hac`) allows for the correlation, but its own
estimate is noisy where the correlation is strong and the record short: the prewhitening
coefficient ``a`` it recolours by (``(1 - a)^-2``) is estimated from the record, and near 1
a small error in it is a large error in the variance. Taken with the normal (or N - q
Student) quantile such an error is too often too small, and its intervals cover less than
they say (86.5-90 % at rho = 0.5-0.95 before this calibration, see
``benchmarks/stat_coverage.py``).

:func:`calibrate_robust` widens the robust errors by the two corrections a variance
estimated this way needs:

* the estimate's own spread, as a Student t quantile with degrees of freedom matched to it
  (Satterthwaite): the log of the standard error has variance ``(1 + a) / ((1 - a) N)``
  from the prewhitening coefficient (its sampling variance ``(1 - a^2) / N`` times the
  squared sensitivity ``1 / (1 - a)`` of ``ln se``) plus ``m / (3 N)`` from the Bartlett
  kernel of bandwidth ``m``; a chi-square estimate on ``nu`` degrees of freedom has
  ``var(ln se) = 1 / (2 nu)``;
* the downward bias of a least-squares AR(1) coefficient, ``(1 + 3 a) / N`` (Kendall), which
  makes ``ln se`` too small by ``(1 + 3 a) / ((1 - a) N)``.

The robust error is scaled so that ``t_{N-q}`` times it is the interval these give; the
intervals, the practical identifiability and the derived quantities' errors all follow.

:func:`shown_errors` then makes the error a user sees by default the one that holds: the
robust error where the residuals are serially correlated (:func:`serial_test`: a one-sided
5 % test of their lag-1 autocorrelation against its exact distribution for a fit's
residuals, more eager than the whiteness warning) or too few for that test to tell, the
white one elsewhere;
the other stays available by its own name (``stderr_white``/``ci95_white``,
``stderr_hac``/``ci95_hac``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..engine.compiled import jit
from .uncertainty import (
    Numbers,
    Uncertainty,
    correlation_of,
    is_positive_quantity,
    lag1,
    t_quantile,
)

__all__ = [
    "ALTERNATIVE_RHO", "NULL_SHIFT", "POWER_Z", "ROBUST_Z", "Errors", "Robust", "SerialTest",
    "calibrate_robust", "fit_null_matters", "robust_covariance", "robust_factor",
    "robust_of", "serial_test", "serially_correlated", "shown_errors", "unbounded",
    "widening", "with_ar1_floor",
]

Array = NDArray[np.float64]

#: The robust errors are shown where the residuals' lag-1 autocorrelation exceeds its mean
#: under independent noise by ROBUST_Z of its standard deviations there (:func:`serial_test`;
#: ROBUST_Z / sqrt(N) where the fit's Jacobian is not at hand): a one-sided 5 % test, more
#: eager than the whiteness warning's 99.5 %.
#: The two mistakes are not alike: robust errors shown for white residuals are wider than
#: the independent-noise ones (on a long record about as wide; on 30 samples a median of
#: 2.4 times, widened for their own spread over so few), while independent-noise errors
#: shown for correlated ones are far too narrow. On a 60-sample card with AR(1) noise of
#: rho 0.5 (whose fitted residuals show much less: fitting absorbs part of the
#: correlation), the 99.5 % test let 43 % of the fits through (this one: 15 %), and the
#: default intervals covered 88 % (now 90.5-91.9 %; 1,000 replicates,
#: ``stat_coverage.py``).
ROBUST_Z = 1.645
#: A record too short for that test to find correlated residuals gets the robust errors
#: anyway: where residuals of AR(1) noise of lag-1 correlation ALTERNATIVE_RHO would stand,
#: on average, less than ROBUST_Z + POWER_Z null standard deviations above the null's mean
#: (a test that finds them about nine times in ten: the mean is the ratio of the forms'
#: means, a little above the ratio's). On a 30-sample periodic Kelvin card with such noise
#: the test found 67 % of them (40 samples: 79 %, 60: 95 %), and the fits it missed showed
#: independent-noise errors whose intervals held k0, m, c1 and k1 on 70-88 % of the fits
#: calling them determined (``stat_coverage.py``'s short card). The robust errors shown
#: there for white residuals are wider (a median of 2.4 times), and hold (97.7-99.3 %).
ALTERNATIVE_RHO = 0.5
POWER_Z = 1.645
#: The degrees of freedom of the robust error's reference distribution never go below
#: this: t_{0.975} on one degree of freedom is 12.7, on 1.0 it is already a Cauchy.
_MIN_DOF = 1.0


def robust_factor(persistence: float, bandwidth: float, n: int, dof: int
                  ) -> tuple[float, float]:
    """Widening of a prewhitened Bartlett HAC error for its sampling spread and bias.

    Parameters
    ----------
    persistence : float
        The prewhitening coefficient ``a`` (the VAR(1) matrix's largest singular value).
    bandwidth : float
        The Bartlett bandwidth ``m`` (samples).
    n : int
        Samples.
    dof : int
        ``N - q``, the degrees of freedom of the quantile the intervals are built with.

    Returns
    -------
    factor : float
        Multiply the HAC standard error by this.
    nu : float
        Degrees of freedom of the robust error's t reference distribution.
    """
    if not (n > 3 and dof > 0):
        return 1.0, math.nan
    a = min(max(float(persistence) if math.isfinite(persistence) else 0.0, 0.0), 0.99)
    m = max(float(bandwidth) if math.isfinite(bandwidth) else 1.0, 1.0)
    var_log_se = (1.0 + a) / ((1.0 - a) * n) + m / (3.0 * n)
    nu = max(1.0 / (2.0 * var_log_se), _MIN_DOF)
    bias = (1.0 + 3.0 * a) / ((1.0 - a) * n)
    factor = t_quantile(0.975, nu) / t_quantile(0.975, dof) * math.exp(min(bias, 1.0))
    return max(factor, 1.0), nu


def calibrate_robust(nums: Numbers) -> tuple[Numbers, dict[str, Any]]:
    """The analysis with its robust (HAC) covariance widened by :func:`robust_factor`.

    Returns the new :class:`Numbers` and what was done (``factor``, ``dof``), for the
    uncertainty's ``hac`` record.
    """
    factor, nu = robust_factor(nums.persistence, nums.bandwidth, nums.n, nums.dof)
    info = {"calibration": "widened for the robust estimate's own spread (Student t on "
                           "matched degrees of freedom) and the AR(1) coefficient's bias",
            "factor": factor, "dof": nu}
    if factor == 1.0:
        return nums, info
    return dataclasses.replace(nums, hac_scaled=nums.hac_scaled * factor**2,
                               direction_se_hac=nums.direction_se_hac * factor), info


@jit
def _ar1_correlate(x, rho, circular):
    """``R x`` for the AR(1) correlation ``R_ij = rho^|i - j|``, column by column: the
    recursion forwards plus backwards, minus ``x`` (O(N q), no N x N matrix).

    ``circular``: ``x`` is one period of a periodic series, and ``R`` the correlation of a
    stationary AR(1) process around it, ``(rho^d + rho^(N - d)) / (1 + rho^N)`` at a
    distance of ``d`` samples. Each recursion then starts from its exact state, the value
    it reaches after one period divided by ``1 - rho^N`` (the geometric sum of all the
    periods before).

    By hand rather than ``scipy.signal.lfilter`` twice: importing ``scipy.signal`` cost
    every command half a second of its start (0.55 of ``import pumpid``'s 1.13 s).
    """
    n, q = x.shape
    out = np.empty((n, q))
    wrap = 1.0 / (1.0 - rho**n) if circular else 0.0
    for j in range(q):
        acc = 0.0
        if circular:
            for i in range(n):
                acc = x[i, j] + rho * acc
            acc *= wrap
        for i in range(n):
            acc = x[i, j] + rho * acc
            out[i, j] = acc
        acc = 0.0
        if circular:
            for i in range(n - 1, -1, -1):
                acc = x[i, j] + rho * acc
            acc *= wrap
        for i in range(n - 1, -1, -1):
            acc = x[i, j] + rho * acc
            out[i, j] += acc - x[i, j]
    if circular:
        # The forward and backward sums count the sample itself (1 + rho^N) / (1 - rho^N)
        # times: scaled to a unit diagonal.
        norm = (1.0 - rho**n) / (1.0 + rho**n)
        for i in range(n):
            for j in range(q):
                out[i, j] *= norm
    return out


def with_ar1_floor(nums: Numbers, rows: Array, offset_col: int) -> tuple[Numbers, float]:
    """The robust covariance floored, per value, by the AR(1) sandwich.

    The HAC estimate learns the correlation's shape from the record and runs narrow when
    the record says little (87 % coverage for Kelvin's k0 and k1 at rho = 0.5 even after
    :func:`calibrate_robust`). Under errors that follow one another the simplest model of
    them is AR(1): covariance ``gamma0 rho^|i - j|``, with ``rho`` the residuals' lag-1
    autocorrelation, bias-corrected by ``(1 + 3 rho) / N`` (Kendall), and ``gamma0`` their
    variance. Its sandwich ``B J^T Sigma J B`` (``B`` the pseudo-inverse of ``J^T J`` on
    the determined directions) is exact for AR(1) errors. Each value's robust variance is
    the larger of the two; the correlations are the AR(1) sandwich's, so the covariance
    stays positive semi-definite (a diagonal rescaling of one).

    ``rows`` (q + 1, N): the solver's Jacobian columns and the residual last (as
    :func:`~pumpid.inference.uncertainty.analyse_rows` takes them); ``offset_col`` the
    offset's column (-1: none), scaled like the analysis by the data's range. On a card
    that is one period of a steady state (``nums.circular``) the correlation runs around
    the period.
    Returns the new numbers and the AR(1) coefficient used.
    """
    inner = list(nums.inner)
    qi = len(inner)
    n = rows.shape[1]
    if qi == 0 or nums.dof <= 0 or n < 4:
        return nums, math.nan
    rho = lag1(rows[-1], nums.circular)
    if math.isnan(rho):
        return nums, math.nan
    rho = min(max(rho + (1.0 + 3.0 * rho) / n, 0.0), 0.99)
    span = float(nums.scales[-1]) if offset_col >= 0 else 1.0
    js = np.array([rows[j] * (span if j == offset_col else 1.0) for j in inner]).T
    s = nums.singular[:qi]
    vt = nums.vt[:qi, :qi]
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(vt)) and s[0] > 0):
        return nums, rho
    kept = s > 1e-10 * s[0]
    bread = (vt[kept].T / s[kept] ** 2) @ vt[kept]
    gamma0 = 2.0 * nums.cost / nums.dof
    meat = gamma0 * (js.T @ _ar1_correlate(np.ascontiguousarray(js), rho, nums.circular))
    ar1 = bread @ meat @ bread
    hac = nums.hac_scaled[:qi, :qi]
    var = np.fmax(np.diag(hac), np.diag(ar1))
    sd_ar1 = np.sqrt(np.clip(np.diag(ar1), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = ar1 / np.outer(sd_ar1, sd_ar1)
    if not np.all(np.isfinite(corr)) or not np.all(np.isfinite(var)):
        return nums, rho
    sd = np.sqrt(var)
    out = nums.hac_scaled.copy()
    out[:qi, :qi] = corr * np.outer(sd, sd)
    dse = nums.direction_se_hac.copy()
    for c in np.flatnonzero(kept):
        dse[c] = math.sqrt(max(float(vt[c] @ out[:qi, :qi] @ vt[c]), 0.0))
    return dataclasses.replace(nums, hac_scaled=out, direction_se_hac=dse), rho


@dataclass(frozen=True)
class Errors(Uncertainty):
    """An :class:`Uncertainty` whose ``stderr``/``ci95``/``covariance`` are the errors shown.

    ``shown`` says which: ``"robust"`` (the residuals are serially correlated or too few to
    test, the calibrated HAC errors are shown) or ``"white"``. The independent-noise errors stay in
    ``stderr_white``/``ci95_white``/``covariance_white`` whatever is shown.
    """

    stderr_white: Mapping[str, float] = field(default_factory=dict)
    ci95_white: Mapping[str, tuple[float, float] | None] = field(default_factory=dict)
    covariance_white: Array | None = None
    shown: str = "white"

    def to_dict(self) -> dict[str, Any]:
        """The JSON form, with the name of the errors shown."""
        return {**super().to_dict(), "shown": self.shown}


_ROBUST_WORDS = (
    "the errors shown (stderr, ci95) are the autocorrelation-robust ones (HAC sandwich, "
    "widened for its own estimate's spread); the independent-noise errors are stderr_white "
    "and ci95_white")
#: Why the robust errors are shown, by whether the test found the correlation.
_WHY_ROBUST = {True: ("the residuals are serially correlated", "serially correlated residuals"),
               False: ("the record is too short to test the residuals' independence",
                       "too few samples to test the residuals' independence")}


#: How far (in its standard deviations) a fit's share of the residuals must move the lag-1
#: autocorrelation's null before :func:`serial_test` is worth its price. The shift is about
#: ``q / sqrt(N)``: 1.1 on a 30-sample card with six fitted values, 0.006 on a record of a
#: million samples, where the test's Jacobian rows and their SVD cost 0.5-0.8 s (a 50-60 %
#: longer fit of white-noise data from rest) for nothing the large-sample test misses.
NULL_SHIFT = 0.05


def fit_null_matters(n: int, q: int) -> bool:
    """Whether ``q`` fitted values move the lag-1 null of ``n`` residuals enough
    (:data:`NULL_SHIFT`) to test against the fit's own null (:func:`serial_test`) rather
    than the large-sample one (:func:`serially_correlated`)."""
    return q > NULL_SHIFT * math.sqrt(max(n, 1))


def serially_correlated(rho: float, n: int) -> bool:
    """Whether residuals of lag-1 autocorrelation ``rho`` over ``n`` samples get the robust
    errors shown, where the fit's own null is not needed (:func:`fit_null_matters`) or its
    Jacobian is not at hand (:data:`ROBUST_Z` against the large-sample null,
    ``N(0, 1/N)``); NaN counts as correlated."""
    return not rho <= ROBUST_Z / math.sqrt(max(n, 1))


@dataclass(frozen=True)
class SerialTest:
    """The residuals' lag-1 autocorrelation against its distribution under independent
    noise, for the residuals of the fit that made them (:func:`serial_test`)."""

    #: ``sum r_t r_(t+1) / sum r_t^2`` of the centred residuals.
    lag1: float
    #: Its mean and standard deviation under independent Gaussian noise.
    white_mean: float
    white_sd: float
    #: Its mean for the residuals of AR(1) noise of lag-1 correlation
    #: :data:`ALTERNATIVE_RHO` (the ratio of the two forms' means).
    alternative: float = math.nan

    @property
    def z(self) -> float:
        """Standard deviations above the independent-noise mean."""
        return (self.lag1 - self.white_mean) / self.white_sd

    @property
    def power_z(self) -> float:
        """How many null standard deviations the alternative's mean stands above the
        null's."""
        return (self.alternative - self.white_mean) / self.white_sd

    @property
    def weak(self) -> bool:
        """The record is too short for the test to find residuals of AR(1) noise of
        correlation :data:`ALTERNATIVE_RHO` (:data:`POWER_Z`)."""
        return not self.power_z >= ROBUST_Z + POWER_Z

    @property
    def serial(self) -> bool:
        """The robust errors are shown: the test finds the residuals correlated (one-sided
        5 %, :data:`ROBUST_Z`), or it is too weak to tell (:attr:`weak`)."""
        return not self.z <= ROBUST_Z or self.weak

    def to_dict(self) -> dict[str, float | bool]:
        """The JSON form."""
        return {"lag1": self.lag1, "white_mean": self.white_mean,
                "white_sd": self.white_sd, "z": self.z, "alternative": self.alternative,
                "power_z": self.power_z, "alternative_rho": ALTERNATIVE_RHO,
                "found": not self.z <= ROBUST_Z, "weak": self.weak, "serial": self.serial}


def serial_test(rows: Array, circular: bool = False) -> SerialTest | None:
    """Are a fit's residuals serially correlated? Their lag-1 autocorrelation against its
    exact distribution under independent noise for residuals of this fit.

    A fit takes its residuals' share along the Jacobian's columns, and that share is
    smooth: what is left swings more from sample to sample than the noise did, so its
    lag-1 autocorrelation sits below zero (about ``-q / N``) and varies less than
    ``1 / sqrt(N)``. Against ``ROBUST_Z / sqrt(N)``, a short card's correlated residuals
    passed as white: on a 30-sample card with AR(1) noise of rho 0.5 / 0.8 / 0.95 that test
    showed the independent-noise errors of 65 / 27 / 16 % of the fits (this one: 32 / 8 /
    4 %), errors whose intervals cover 65-83 % there (``stat_coverage.py``). Here the
    residuals are ``r = M e`` (``M`` the projection off the Jacobian's columns and the
    mean, rank ``nu``) and the statistic is ``e' M D M e / e' M e`` (``D`` half the lag-1
    shift, both ways): the ratio of two quadratic forms in the same Gaussian vector, whose
    denominator is independent of the ratio (the two are the direction and the length of
    ``M e``), so its moments are the ratio of the forms' moments: mean ``tr(A) / nu`` and
    variance ``2 (nu tr(A^2) - tr(A)^2) / (nu^2 (nu + 2))`` with ``A = M D M``.
    ``tr(A) = -tr(Q' D Q)`` and ``tr(A^2) = (N - 1) / 2 - 2 |D Q|^2 + |Q' D Q|^2`` from an
    orthonormal basis ``Q`` of the columns: O(N q), no N x N matrix. Around a period
    (``circular``) ``D`` also joins the last sample to the first, and ``tr(D^2)`` is
    ``N / 2``. Under AR(1) noise of correlation matrix ``R`` the statistic's mean is about
    ``tr(A R) / tr(M R)`` (:data:`ALTERNATIVE_RHO`; ``R Q`` by the recursion of
    :func:`with_ar1_floor`): how far it stands from the null says whether the record is long
    enough for the test to mean anything (:attr:`SerialTest.weak`).

    Parameters
    ----------
    rows : ndarray, shape (q + 1, N)
        The Jacobian's columns at the answer, then the residual.
    circular : bool, optional
        The card is one period of a steady state: its last sample is the first one's
        neighbour (:func:`~pumpid.inference.uncertainty.lag1`).

    Returns
    -------
    SerialTest or None
        None when the record leaves fewer than three degrees of freedom or the residual
        is zero.
    """
    n = rows.shape[1]
    r = rows[-1] - rows[-1].mean()
    ss = float(r @ r)
    cols = np.column_stack([rows[:-1].T, np.ones(n)])
    if not (ss > 0 and np.all(np.isfinite(cols))):
        return None
    norms = np.linalg.norm(cols, axis=0)
    cols = cols[:, norms > 0] / norms[norms > 0]
    u, sv, _ = np.linalg.svd(cols, full_matrices=False)
    q = u[:, sv > 1e-9 * sv[0]]
    nu = n - q.shape[1]
    if nu < 3:
        return None
    if circular:
        dq = 0.5 * (np.roll(q, 1, axis=0) + np.roll(q, -1, axis=0))
    else:
        dq = np.zeros_like(q)
        dq[1:] += 0.5 * q[:-1]
        dq[:-1] += 0.5 * q[1:]
    qdq = q.T @ dq
    tr_a = -float(np.trace(qdq))
    tr_d2 = 0.5 * n if circular else 0.5 * (n - 1)
    tr_a2 = tr_d2 - 2.0 * float(np.sum(dq * dq)) + float(np.sum(qdq * qdq))
    var = 2.0 * (nu * tr_a2 - tr_a**2) / (nu**2 * (nu + 2.0))
    if not var > 0:
        return None
    # tr(A R) = tr(D R) - 2 tr(Q' D R Q) + tr(Q' D Q Q' R Q), D and R symmetric.
    rho = ALTERNATIVE_RHO
    rq = _ar1_correlate(np.ascontiguousarray(q), rho, circular)
    if circular:
        drq = 0.5 * (np.roll(rq, 1, axis=0) + np.roll(rq, -1, axis=0))
        tr_dr = n * (rho + rho ** (n - 1)) / (1.0 + rho**n)
    else:
        drq = np.zeros_like(rq)
        drq[1:] += 0.5 * rq[:-1]
        drq[:-1] += 0.5 * rq[1:]
        tr_dr = (n - 1) * rho
    qrq = q.T @ rq
    tr_mr = n - float(np.trace(qrq))
    tr_mdmr = tr_dr - 2.0 * float(np.sum(q * drq)) + float(np.sum(qdq * qrq))
    return SerialTest(lag1(rows[-1], circular), tr_a / nu, math.sqrt(var), tr_mdmr / tr_mr)


def shown_errors(unc: Uncertainty | None, serial: bool, robust_cov: Array | None = None,
                 calibration: Mapping[str, Any] | None = None) -> Errors | None:
    """The uncertainty with the error that holds shown by default.

    Parameters
    ----------
    unc : Uncertainty or None
    serial : bool
        The robust errors are shown: the residuals are serially correlated
        (:func:`serially_correlated`, :func:`serial_test`) or too few to tell
        (``calibration``'s ``serial_test`` then says so).
    robust_cov : ndarray, optional
        The robust covariance (:func:`robust_covariance`); without it the white
        correlations are scaled to the robust errors.
    calibration : mapping, optional
        :func:`calibrate_robust`'s record, added to ``hac``.
    """
    if unc is None:
        return None
    base = {f.name: getattr(unc, f.name) for f in dataclasses.fields(Uncertainty)}
    hac = dict(unc.hac) if unc.hac is not None else None
    if hac is not None and calibration:
        hac.update(calibration)
    base["hac"] = MappingProxyType(hac) if hac is not None else None
    white = {"stderr_white": unc.stderr, "ci95_white": unc.ci95,
             "covariance_white": unc.covariance}
    robust_ok = serial and hac is not None and any(
        math.isfinite(v) for v in unc.stderr_hac.values())
    if not robust_ok:
        return Errors(**base, **white, shown="white")
    if robust_cov is None:
        se = np.array([unc.stderr_hac.get(n, math.nan) for n in unc.names], dtype=float)
        with np.errstate(invalid="ignore"):
            robust_cov = unc.correlation * np.outer(se, se)
    cov = np.array(robust_cov, dtype=float)
    corr = correlation_of(cov)
    test = (hac or {}).get("serial_test") or {}
    sentence, short = _WHY_ROBUST[bool(test.get("found", True))]
    base.update(stderr=unc.stderr_hac, ci95=unc.ci95_hac, covariance=cov, correlation=corr,
                notes=(*unc.notes, f"{sentence}, so {_ROBUST_WORDS}"),
                assumptions=unc.assumptions + f"; SHOWN: the robust errors ({short})")
    return Errors(**base, **white, shown="robust")


def widening(unc: Uncertainty | None) -> str | None:
    """How much wider the errors shown are than the independent-noise ones, in words
    ("72-80x"; "up to 24x" where some value's two errors agree), where the robust ones are
    shown (None elsewhere, or where no value has both errors finite)."""
    if not isinstance(unc, Errors) or unc.shown != "robust":
        return None
    ratios = [unc.stderr[n] / w for n, w in unc.stderr_white.items()
              if n in unc.stderr and 0 < w < math.inf and math.isfinite(unc.stderr[n])]
    if not ratios:
        return None

    def times(x: float) -> str:
        return f"{x:.0f}" if x >= 10 else f"{x:.2g}"

    low, high = times(min(ratios)), times(max(ratios))
    if low == high:
        return f"{low}x"
    # "1-24x smaller": a value whose two errors agree is not smaller at all.
    return f"up to {high}x" if low == "1" else f"{low}-{high}x"


def unbounded(unc: Uncertainty, name: str) -> Uncertainty:
    """The uncertainty with ``name``'s errors infinite and its interval none, in every kind
    (shown, robust, independent-noise): for a value found undetermined after its local
    errors were made (they describe another coordinate's spread, not its own)."""
    if name not in unc.names:
        return unc
    i = list(unc.names).index(name)
    changes: dict[str, Any] = {}
    for se_name, ci_name in (("stderr", "ci95"), ("stderr_hac", "ci95_hac"),
                             ("stderr_white", "ci95_white")):
        if hasattr(unc, se_name):
            changes[se_name] = MappingProxyType({**getattr(unc, se_name), name: math.inf})
            changes[ci_name] = MappingProxyType({**getattr(unc, ci_name), name: None})
    for cov_name in ("covariance", "covariance_white"):
        cov = getattr(unc, cov_name, None)
        if cov is not None:
            cov = np.array(cov, dtype=float)
            cov[i, :] = cov[:, i] = math.nan
            cov[i, i] = math.inf
            changes[cov_name] = cov
    if "covariance" in changes:
        changes["correlation"] = correlation_of(changes["covariance"])
    return dataclasses.replace(unc, **changes)


def robust_covariance(nums: Numbers, undetermined: Sequence[int]) -> Array:
    """The robust (HAC) covariance in the reported coordinates (the layout of
    :attr:`Uncertainty.covariance`: NaN rows and an infinite variance for values the data
    do not determine, NaN for values at a boundary)."""
    names = nums.names
    q = len(names)
    inner = list(nums.inner)
    qi = len(inner)
    scales = nums.scales[inner]
    hac_in = nums.hac_scaled[:qi, :qi] * np.outer(scales, scales)
    und = set(undetermined)
    for a, i in enumerate(inner):
        if i in und:
            hac_in[a, :] = math.nan
            hac_in[:, a] = math.nan
            hac_in[a, a] = math.inf
    cov = np.full((q, q), math.nan)
    cov[np.ix_(inner, inner)] = hac_in
    return cov


@dataclass(frozen=True)
class Robust:
    """A fit's robust errors and whether they are the ones shown (:func:`robust_of`)."""

    #: The numbers with their robust covariance calibrated (and floored where shown).
    numbers: Numbers
    serial: bool
    calibration: Mapping[str, Any]

    @property
    def inflation(self) -> float:
        """How many times its independent-noise variance a model value's robust error is,
        at most over the analysed positive values (the offset, a nuisance, left out), before
        any reach widens them; 1 where the independent-noise errors are shown: the factor a
        likelihood-ratio threshold made for independent noise needs to describe the noise
        the errors shown describe."""
        if not self.serial:
            return 1.0
        nums = self.numbers
        keep = [a for a, i in enumerate(nums.inner)
                if is_positive_quantity(nums.names[i], nums.additive)]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.diag(nums.hac_scaled)[keep] / np.diag(nums.cov_scaled)[keep]
        ratio = ratio[np.isfinite(ratio)]
        return max(1.0, float(ratio.max())) if ratio.size else 1.0


def robust_of(num: Numbers, rows_of: Callable[[], Array | None], offset_col: int) -> Robust:
    """The robust errors of one fit's numbers, calibrated, and whether they are shown.

    Where the residuals are serially correlated, or too few to tell (tested against the
    distribution of a fit's residuals where the fit moves it, which needs the Jacobian's
    rows: ``rows_of`` computes them then, and for the floor), the robust errors are
    floored by an AR(1) fit to the residuals and shown by default.

    Parameters
    ----------
    num : Numbers
        The fit's analysis.
    rows_of : callable
        Returns the (q + 1, N) rows (Jacobian columns, then the residual), or None.
    offset_col : int
        The offset's coordinate (-1: none).
    """
    num, calibration = calibrate_robust(num)
    own_null = not num.exact and fit_null_matters(num.n, len(num.names))
    rows = rows_of() if own_null else None
    test = None if rows is None else serial_test(rows, num.circular)
    if test is not None:
        calibration["serial_test"] = test.to_dict()
        serial = test.serial
    else:
        serial = not num.exact and serially_correlated(num.rho, num.n)
    if serial and rows is None:
        rows = rows_of()
    if serial and rows is not None:
        num, calibration["ar1"] = with_ar1_floor(num, rows, offset_col)
    return Robust(num, serial, calibration)
