"""Identifiability and uncertainty of a fit, from the exact sensitivity matrix at the solution.

:func:`diagnose` runs after every fit (either method) and fills ``result.extra`` with

``identifiability``
    Plain-language findings: parameter combinations the data cannot determine (structural:
    the Jacobian is singular along them; practical: the data constrain them so weakly that
    their relative standard error exceeds 100 %; when the residuals fail the whiteness check,
    the larger of the ordinary and the autocorrelation-robust error counts), the scale
    symmetry of MODEL-NOTES section 2 when the fit had to fix the gauge C = 1, and parameters
    that ran to a boundary (named with the limiting model). Empty when every fitted value is
    determined.
``determined``
    What the data do determine: the gauge, the identifiable combinations, the parameters
    with a finite two-sided interval and those at a boundary.
``sigma2``, ``uncertainty``
    Residual variance ``sigma^2 = SSR / (N - p)`` and a note of its unit and of what the
    intervals assume.
``covariance``, ``correlation``
    ``{"names": [...], "matrix": [[...]]}`` over the free values (``result.free``).
``stderr``, ``ci95``
    Standard errors and 95 % confidence intervals by name.
``stderr_hac``, ``ci95_hac``, ``uncertainty["hac"]``
    The same errors and intervals robust to serially correlated (and heteroscedastic)
    errors: a sandwich covariance whose middle is a prewhitened Bartlett-kernel estimate of
    the scores' long-run covariance (:mod:`pumpid.hac`), and what it used (bandwidth,
    prewhitening). They are the ones to read when the whiteness check below fails. For white
    noise on a long record they agree with ``stderr`` and ``ci95`` to within the estimate's
    own scatter; on a record of a few tens of samples they come out smaller (about 0.7-0.96
    of the ordinary errors at 30-60 samples), as robust estimates do with little data.
``uncertainty["whiteness"]``
    The check of the white-noise assumption (:func:`residual_whiteness`): when the residuals'
    lag-1 autocorrelation exceeds what white noise allows, a warning says that the intervals
    are too narrow and by about how much (None for an exact fit; absent, like the other
    uncertainties, when the fit has no usable solution).

The intervals are the usual linearised (Wald) ones: the noise is assumed white (independent
samples), homoscedastic and Gaussian, and the model linear in its parameters within the
interval; the quantile is Student's t with N - p degrees of freedom, since sigma^2 is
estimated from the same residuals. Positive quantities (the physical parameters and C) get
their interval on the log scale, ``value * exp(+-t se/value)``: the solver works in
log-parameters, the interval stays positive, and to first order it equals ``value +- t se``.
For a parameter at a boundary no symmetric interval is meaningful; its one-sided interval
comes from the profile likelihood (:func:`pumpid.profile.profile`).

Nothing here refits: one SVD of the N x p Jacobian and a few passes over the N scores for
the robust errors, about 0.27 ms in all for 2,001 samples, cheap enough for every fit.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.stats
from numpy.typing import NDArray

from .hac import long_run_rows

if TYPE_CHECKING:
    from .problem import Problem
    from .result import FitResult

__all__ = [
    "PRACTICAL_REL_SE",
    "STRUCTURAL_TOL",
    "WHITENESS_Z",
    "analyse_jacobian",
    "describe_direction",
    "diagnose",
    "diagnostics_text",
    "residual_whiteness",
]

Array = NDArray[np.float64]

#: Singular values of the column-scaled Jacobian below this fraction of the largest are
#: structural null directions (the exact sensitivities of an exact symmetry come out at the
#: 1e-14 level; a genuinely weak but present direction is many orders above).
STRUCTURAL_TOL = 1e-10
#: A combination whose relative standard error exceeds this (100 %) is practically not
#: identifiable: the data are compatible with changing it by a factor e or more.
PRACTICAL_REL_SE = 1.0
#: Loading below which a parameter is not counted as part of a direction.
_LOADING = 0.05
#: Residuals count as white while their lag-1 autocorrelation stays below this many standard
#: errors (1/sqrt(N) for white noise): 2.576 is its one-sided 99.5 % point.
WHITENESS_Z = 2.576
#: What the autocorrelation-robust errors are, for the result's ``uncertainty["hac"]``.
HAC_METHOD = (
    "sandwich covariance robust to serial correlation and changing variance (HAC): scores "
    "prewhitened by a VAR(1) fit, Bartlett kernel with Andrews' (1991) bandwidth, recoloured"
)
#: A residual RMS below this fraction of the data's range is rounding: an exact fit, whose
#: residuals carry no information about the noise.
_EXACT_FIT = 1e-9

_STATE_WORDS = {
    "rest": "from rest",
    "equilibrium": "from a static equilibrium",
    "periodic": "from a periodic steady state",
}


# --------------------------------------------------------------------------- helpers
def _join(names: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    names = list(names)
    if len(names) <= 1:
        return "".join(names)
    return ", ".join(names[:-1]) + " and " + names[-1]


def _free_values(result: FitResult) -> Array:
    """The fitted values in the order of ``result.free`` (D = ln C for the log residual)."""
    out = []
    for name in result.free:
        if name == "C":
            out.append(result.scale)
        elif name == "D":
            out.append(math.log(result.scale) if result.scale > 0 else math.nan)
        elif name == "offset":
            out.append(result.offset)
        else:
            out.append(result.params[name])
    return np.array(out, dtype=float)


def _is_positive_quantity(name: str) -> bool:
    """Physical parameters and C are positive (log coordinates); D and offset are additive."""
    return name not in ("D", "offset")


def _column_scales(names: Sequence[str], values: Array, data: Array) -> Array:
    """Scale of each column so that a unit step is a relative change (log coordinates).

    The offset has no natural relative size (it may be 0), so one unit is the data's range;
    D = ln C is already a log coordinate.
    """
    span = float(np.ptp(data)) or 1.0
    scales = []
    for name, value in zip(names, values, strict=True):
        if name == "offset":
            scales.append(span)
        elif name == "D":
            scales.append(1.0)
        else:
            scales.append(abs(value) if value != 0 and math.isfinite(value) else 1.0)
    return np.array(scales)


def describe_direction(direction: Array, names: Sequence[str]) -> tuple[str, bool, str]:
    """Plain words for a direction in (log-)parameter space the data do not see.

    Parameters
    ----------
    direction : ndarray
        Components in scaled coordinates (d ln theta for positive quantities, offset in units
        of the data range, D as is).
    names : sequence of str
        Names of the components.

    Returns
    -------
    what : str
        The undetermined combination, e.g. ``"C and the overall scale of k0, m, c1, k1"``.
    plural : bool
        True when ``what`` names several things that cannot be told apart ("are not
        separately identifiable"), False for one combination ("is not identifiable").
    determined : str
        What remains determined along it, e.g. ``"only their ratios are"``.
    """
    v = np.asarray(direction, dtype=float)
    v = v / v[np.argmax(np.abs(v))]
    sig = [i for i in range(v.size) if abs(v[i]) >= _LOADING]
    parts = [names[i] for i in sig]
    if len(sig) == 1:
        return parts[0], False, "the data do not depend on it"
    positive = all(_is_positive_quantity(names[i]) for i in sig)
    same = positive and all(abs(v[i] - 1.0) < 0.05 for i in sig)
    if same:
        if "C" in parts and len(parts) > 2:
            others = [p for p in parts if p != "C"]
            return (f"C and the overall scale of {', '.join(others)}", True,
                    "only their ratios are")
        if len(parts) > 2:
            return (f"the overall scale of {', '.join(parts)}", False,
                    "only their ratios are determined")
        a, b = parts
        return f"{a} and {b}", True, f"only the ratio {a}/{b} is"
    if positive and len(sig) == 2 and abs(v[sig[0]] + v[sig[1]]) < 0.05 * abs(v[sig[0]]):
        a, b = parts
        return f"{a} and {b}", True, f"only the product {a}*{b} is"
    # General case: the exponents of the motion theta_i -> theta_i * lambda^{v_i}.
    ratio = " : ".join(f"{v[i]:+.2f}" for i in sig)
    coords = " : ".join(f"d ln {names[i]}" if _is_positive_quantity(names[i]) else f"d {names[i]}"
                        for i in sig)
    return (f"the trade-off between {_join(parts)} ({coords} = {ratio})", False,
            "only the combinations unchanged along it are determined")


def _sentence(what: str, plural: bool, practical: bool) -> str:
    """``<what> are not separately identifiable`` / ``<what> is practically not identifiable``."""
    verb = "are" if plural else "is"
    how = "practically not" if practical else "not"
    sep = "separately " if plural else ""
    # Parameter names keep their case (k0 is not K0); only prose openings are capitalised.
    opening = what if what.split(" ")[0] not in ("the", "a", "an") else what[0].upper() + what[1:]
    return f"{opening} {verb} {how} {sep}identifiable"


def analyse_jacobian(
    jacobian: Array, names: Sequence[str], values: Array, data: Array, sigma2: float
) -> dict[str, Any]:
    """SVD of the column-scaled Jacobian: null and weak directions, scaled covariance.

    Parameters
    ----------
    jacobian : ndarray, shape (N, q)
        d residual / d free value, in physical coordinates.
    names, values : sequence of str, ndarray (q,)
        The free values.
    data : ndarray
        The measured data (sets the offset's scale).
    sigma2 : float
        Residual variance.

    Returns
    -------
    dict
        ``scales`` (q,), ``singular`` (relative singular values), ``structural`` and
        ``practical`` (lists of (direction, relative size, relative standard error)),
        ``cov`` (q, q physical covariance; inf on the diagonal of undetermined values),
        ``undetermined`` (indices touched by a structural direction), and ``basis`` (q, k)
        and ``kept_singular`` (k,): the determined right singular vectors of the scaled
        Jacobian and their singular values.
    """
    q = len(names)
    scales = _column_scales(names, values, data)
    js = jacobian * scales
    # Singular values and right vectors of J are those of R in J = QR: a tall N x q SVD
    # then costs one QR plus a q x q SVD, without squaring the condition number as J^T J
    # would (the small singular values are the point of this analysis).
    r_factor = np.linalg.qr(js, mode="r") if js.shape[0] > js.shape[1] else js
    _u, s, vt = np.linalg.svd(r_factor, full_matrices=False)
    if s.size == 0 or s[0] == 0 or not np.all(np.isfinite(s)):
        return {"scales": scales, "singular": s, "structural": [], "practical": [],
                "cov": np.full((q, q), math.nan), "undetermined": list(range(q)),
                "basis": np.zeros((q, 0)), "kept_singular": np.zeros(0)}
    rel = s / s[0]
    structural = []
    practical = []
    keep = []
    for k in range(s.size):
        if rel[k] <= STRUCTURAL_TOL:
            structural.append((vt[k], float(rel[k]), math.inf))
            continue
        keep.append(k)
        se_k = math.sqrt(max(sigma2, 0.0)) / s[k]  # std of the combination, log units
        if se_k > PRACTICAL_REL_SE:
            practical.append((vt[k], float(rel[k]), se_k))
    v_keep = vt[keep].T
    cov_z = sigma2 * (v_keep / s[keep] ** 2) @ v_keep.T
    cov = cov_z * np.outer(scales, scales)
    undetermined = sorted({i for v, _r, _se in structural for i in range(q)
                           if abs(v[i]) >= 1e-6})
    for i in undetermined:
        cov[i, :] = math.nan
        cov[:, i] = math.nan
        cov[i, i] = math.inf
    return {"scales": scales, "singular": rel, "structural": structural,
            "practical": practical, "cov": cov, "undetermined": undetermined,
            "basis": v_keep, "kept_singular": s[keep]}


def _interval(name: str, value: float, se: float, tq: float) -> list[float] | None:
    if not (math.isfinite(se) and math.isfinite(value)):
        return None
    if _is_positive_quantity(name) and value > 0:
        # Log-scale Wald interval: the solver's coordinates; positive by construction.
        half = tq * se / value
        if half > 700.0:  # beyond float range: the data bound this value from neither side
            return [0.0, math.inf]
        return [value * math.exp(-half), value * math.exp(half)]
    return [value - tq * se, value + tq * se]


def _embed(inner_cov: Array, q: int, inner: Sequence[int]) -> Array:
    """The inner values' covariance in the full q x q matrix; NaN for boundary values."""
    cov = np.full((q, q), math.nan)
    cov[np.ix_(inner, inner)] = inner_cov
    return cov


def _errors(
    cov: Array, names: Sequence[str], values: Array, tq: float
) -> tuple[dict[str, float], dict[str, list[float] | None]]:
    """Standard errors and 95 % intervals by name from a covariance matrix."""
    stderr: dict[str, float] = {}
    ci95: dict[str, list[float] | None] = {}
    for i, name in enumerate(names):
        var = cov[i, i]
        se = math.sqrt(var) if math.isfinite(var) and var >= 0 else (
            math.inf if var == math.inf else math.nan)
        stderr[name] = se
        ci95[name] = _interval(name, float(values[i]), se, tq)
    return stderr, ci95


def _gauge_sentence(problem: Problem) -> str:
    names = list(problem.model_cls.param_names())
    state = problem.initial_state
    where = _STATE_WORDS.get(state, f"initial_state={state!r}") if isinstance(state, str) \
        else "from the given (zero) initial state"
    scale_name = "D = ln C" if problem.residual == "log" else "C"
    return (
        f"C and the overall scale of {', '.join(names)} are not separately identifiable {where}: "
        f"only their ratios are (multiplying all of them by any lambda > 0 gives the same "
        f"fitted curve). {scale_name} was asked to be free; the parameters are reported on "
        "the gauge C = 1, i.e. as the ratios " + ", ".join(f"{n}/C" for n in names) + "."
    )


def _sigma2_unit(result: FitResult) -> str:
    if result.residual == "log":
        return "(ln of position)^2, dimensionless"
    return f"{result.units.position}^2"


def residual_whiteness(residual: Sequence[float] | Array) -> dict[str, Any]:
    """Do the residuals look like white noise? Lag-1 autocorrelation and what it implies.

    The intervals of :func:`diagnose` assume independent errors. Residuals that follow one
    another (model error on a real card, or coloured noise) make them too narrow: for errors
    that are an AR(1) process with coefficient rho, and slowly varying sensitivities, the
    variances grow by ``(1 + rho) / (1 - rho)``, as if only ``N (1 - rho) / (1 + rho)``
    samples had been taken.

    Parameters
    ----------
    residual : array_like, shape (N,)
        The residuals the fit minimized (non-finite entries are ignored).

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
    n = int(r.size)
    r = r - r.mean() if n else r
    peak = float(np.max(np.abs(r))) if n else 0.0
    r = r / peak if peak > 0 else r  # scale-free statistic: no overflow of huge residuals
    ss = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / ss if n > 2 and ss > 0 else 0.0
    limit = WHITENESS_Z / math.sqrt(max(n, 1))
    positive = min(max(rho, 0.0), 0.999)
    return {
        "lag1_autocorrelation": rho,
        "limit": limit,
        "white": bool(rho <= limit),
        "interval_factor": math.sqrt((1.0 + positive) / (1.0 - positive)),
        "effective_samples": n * (1.0 - positive) / (1.0 + positive),
    }


def _whiteness_warning(check: dict[str, Any], n_obs: int, n_fitted: int) -> str:
    effective = max(1, round(check["effective_samples"]))
    few = (f"; that is too few against {n_fitted} fitted values for any interval, the robust "
           f"ones included, to mean much" if effective < 3 * n_fitted else "")
    return (
        f"the residuals are not white noise: their lag-1 autocorrelation is "
        f"{check['lag1_autocorrelation']:.2f} (white noise stays below {check['limit']:.2f} "
        f"for {n_obs} samples, 99.5 %). The standard errors and 95 % intervals assume "
        f"independent errors and are too narrow here; for AR(1) errors they would be about "
        f"{check['interval_factor']:.1f} times wider (about {effective} effective "
        f"sample{'s' if effective != 1 else ''} of {n_obs}{few}). The autocorrelation-robust "
        f"(HAC) errors and intervals (stderr_hac, ci95_hac) allow for it, though they too run "
        f"somewhat narrow when the autocorrelation is strong. Structured "
        f"residuals usually mean that the model misses part of the response."
    )


def _fit_residual(result: FitResult) -> tuple[Array, float]:
    """The residual the fit minimized (the Jacobian's), and the data's spread on its scale."""
    data = np.asarray(result.data, dtype=float)
    if result.residual == "log":
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(result.fitted) - np.log(data), float(np.ptp(np.log(data)))
    return result.residuals, float(np.ptp(data))


def _residual_check(result: FitResult, residual: Array, spread: float) -> dict[str, Any] | None:
    """:func:`residual_whiteness` of the fit's own residuals; None for an exact fit."""
    rms = math.sqrt(2.0 * result.cost / max(residual.size, 1))
    if not rms > _EXACT_FIT * spread:
        return None
    return residual_whiteness(residual)


def _hac_covariance(
    js: Array, residual: Array, rms: float, info: dict[str, Any], dof: int
) -> tuple[Array, dict[str, Any], Array] | None:
    """Sandwich covariance robust to serial correlation (scaled coordinates in, physical out).

    ``B Omega B`` with ``B`` the pseudo-inverse of ``J^T J`` on the determined directions and
    ``Omega`` the long-run covariance of the scores ``J_t r_t`` (:mod:`pumpid.hac`), times
    ``N / dof`` as the white estimate's ``SSR / dof`` has it. ``rms`` is the residuals' root
    mean square. Also returns the robust standard error of each determined direction
    (``info["basis"]``'s columns, log units). None when there is no determined direction,
    or the residuals are not finite or all zero.
    """
    basis, kept = info["basis"], info["kept_singular"]
    if basis.shape[1] == 0 or not (rms > 0 and math.isfinite(rms)) \
            or not np.all(np.isfinite(residual)):
        return None
    # The scores along direction k are kept[k] * rms * (q_k * r / rms), q_k a unit vector:
    # build the last factor, of order one whatever the data's magnitude, and put kept and
    # rms back into the bread.
    rows = (basis.T @ js.T) / kept[:, None] * (residual / rms)
    omega, meta = long_run_rows(rows)
    inflate = js.shape[0] / dof
    direction_se = np.sqrt(np.maximum(np.diag(omega), 0.0) * inflate) * (rms / kept)
    bread = basis * (rms / kept)
    cov = (bread @ omega @ bread.T) * inflate * np.outer(info["scales"], info["scales"])
    for i in info["undetermined"]:
        cov[i, :] = math.nan
        cov[:, i] = math.nan
        cov[i, i] = math.inf
    return cov, meta, direction_se


# --------------------------------------------------------------------------- entry point
@functools.lru_cache(maxsize=256)
def t_quantile(q: float, dof: int) -> float:
    """Student-t quantile, cached: scipy's ppf costs ~0.2 ms, a few percent of a fit."""
    return float(scipy.stats.t.ppf(q, dof))


def diagnose(result: FitResult) -> None:
    """Fill ``result.extra`` with identifiability findings and uncertainties (no refits).

    Parameters
    ----------
    result : FitResult
        A result from :func:`pumpid.fit` (``result.context["problem"]`` and
        ``result.jacobian`` are used; without them only the settings-based findings are made).
    """
    problem: Problem | None = result.context.get("problem") if result.context else None
    names = list(result.free)
    findings: list[str] = []
    determined: dict[str, Any] = {"gauge": None, "combinations": [], "parameters": [],
                                  "boundary": [], "not_determined": []}
    if problem is not None and problem.gauge_fixed:
        findings.append(_gauge_sentence(problem))
        model_names = list(problem.model_cls.param_names())
        determined["gauge"] = "C = 1"
        determined["combinations"].append(
            "the ratios " + ", ".join(f"{n}/C" for n in model_names)
            + " (reported as the parameters on the gauge C = 1)"
        )

    boundaries = [b for b in result.extra.get("boundaries") or [] if b.get("name") in names]
    for b in boundaries:
        arrow = "infinity" if b["direction"] == "infinity" else "zero"
        side = "a lower" if arrow == "infinity" else "an upper"
        findings.append(
            f"{b['name']} is at a boundary (it runs to {arrow}): the data are described by the "
            f"limiting model {b['limit']}. {b['name']} has no finite estimate and no two-sided "
            f"interval; only {side} bound exists (result.profile({b['name']!r}) computes it)."
        )
        determined["boundary"].append(b["name"])

    extra = result.extra
    jac = result.jacobian
    n_obs = int(result.data.size)
    q = len(names)
    dof = n_obs - q
    usable = (result.model is not None and jac is not None and jac.shape == (n_obs, q)
              and math.isfinite(result.cost) and np.all(np.isfinite(jac)) and dof > 0)
    if not usable:
        extra.update({
            "stderr": {}, "ci95": {}, "stderr_hac": {}, "ci95_hac": {},
            "correlation": {}, "covariance": {},
            "sigma2": math.nan, "identifiability": findings, "determined": determined,
            "uncertainty": {"note": "not computed: the fit has no finite solution with a "
                                    "Jacobian, or no more samples than fitted values"},
        })
        return

    sigma2 = 2.0 * result.cost / dof
    values = _free_values(result)
    at_bound = [names.index(b["name"]) for b in boundaries]
    inner = [i for i in range(q) if i not in at_bound]
    assert jac is not None
    info = analyse_jacobian(jac[:, inner], [names[i] for i in inner], values[inner],
                            result.data, sigma2)
    inner_names = [names[i] for i in inner]
    tq = t_quantile(0.975, dof)
    cov = _embed(info["cov"], q, inner)
    stderr, ci95 = _errors(cov, names, values, tq)
    residual, spread = _fit_residual(result)
    robust = _hac_covariance(jac[:, inner] * info["scales"], residual,
                             math.sqrt(2.0 * result.cost / n_obs), info, dof)
    if robust is None:
        stderr_hac: dict[str, float] = dict.fromkeys(names, math.nan)
        ci95_hac: dict[str, list[float] | None] = dict.fromkeys(names)
        hac_meta: dict[str, Any] | None = None
    else:
        stderr_hac, ci95_hac = _errors(_embed(robust[0], q, inner), names, values, tq)
        hac_meta = {**robust[1], "method": HAC_METHOD}
    whiteness = _residual_check(result, residual, spread)
    serial = whiteness is not None and not whiteness["white"]

    for direction, rel, _se in info["structural"]:
        what, plural, det = describe_direction(direction, inner_names)
        findings.append(
            f"{_sentence(what, plural, practical=False)} from these data: {det} (structural: "
            f"the sensitivity matrix is singular along this direction, relative singular "
            f"value {rel:.1e})."
        )
        determined["combinations"].append(f"{what}: {det}")
    practical = info["practical"]
    if serial and robust is not None:
        # Serially correlated residuals: the white standard errors understate how loosely
        # the data hold a direction, so "practically not identifiable" also looks at the
        # robust ones (the larger of the two: on a short record the robust estimate can
        # itself come out too small).
        kept = info["kept_singular"]
        white_se = math.sqrt(max(sigma2, 0.0)) / kept
        practical = [(info["basis"][:, k], float(kept[k] / kept[0]), float(max(se, white)))
                     for k, (se, white) in enumerate(zip(robust[2], white_se, strict=True))
                     if max(se, white) > PRACTICAL_REL_SE]
    for direction, rel, se in practical:
        what, plural, _det = describe_direction(direction, inner_names)
        unit = ("relative to the values, the offset in units of the data range"
                if "offset" in what else "relative to the values")
        if serial and robust is not None:
            unit += ", the larger of the ordinary and the serial-correlation-robust error"
        findings.append(
            f"{_sentence(what, plural, practical=True)}: the data constrain this direction "
            f"only to a standard error of {100 * se:.0f} % ({unit}; relative singular value "
            f"{rel:.1e}), so the intervals of the parameters involved are wide."
        )

    undetermined = {inner[i] for i in info["undetermined"]}
    for i, name in enumerate(names):
        if i in at_bound:
            continue
        if i in undetermined:
            determined["not_determined"].append(name)
        else:
            determined["parameters"].append(name)
    with np.errstate(invalid="ignore", divide="ignore"):
        sd = np.sqrt(np.diag(cov))
        corr = cov / np.outer(sd, sd)
    corr[~np.isfinite(corr)] = math.nan
    np.fill_diagonal(corr, [1.0 if np.isfinite(s) else math.nan for s in sd])

    if serial:
        assert whiteness is not None
        warning = _whiteness_warning(whiteness, n_obs, q)
        if warning not in result.warnings:
            result.warnings.append(warning)
    notes = []
    if at_bound:
        notes.append(
            f"{_join([names[i] for i in at_bound])}: at a boundary, so no symmetric interval "
            "(None); the other values' uncertainties hold with it at its limit"
        )
    if undetermined:
        notes.append(
            f"{_join([names[i] for i in sorted(undetermined)])}: not identifiable, standard "
            "error infinite and no interval (None)"
        )
    extra.update({
        "sigma2": sigma2,
        "uncertainty": {
            "sigma2_unit": _sigma2_unit(result),
            "dof": dof,
            "t_quantile": tq,
            "singular_values": [float(x) for x in info["singular"]],
            "assumptions": (
                "linearised (Wald) intervals at the optimum; noise assumed white "
                "(independent samples), homoscedastic and Gaussian; sigma^2 = SSR/(N - p) "
                f"estimated from the residuals, Student t quantile with {dof} degrees of "
                "freedom; positive parameters (and C) on the log scale, value*exp(+-t se/value). "
                "stderr_hac and ci95_hac drop the independence and equal-variance assumptions "
                "(HAC sandwich, see uncertainty['hac'])"
            ),
            "notes": notes,
            "whiteness": whiteness,
            "hac": hac_meta,
        },
        "covariance": {"names": names, "matrix": cov.tolist()},
        "correlation": {"names": names, "matrix": corr.tolist()},
        "stderr": stderr,
        "ci95": ci95,
        "stderr_hac": stderr_hac,
        "ci95_hac": ci95_hac,
        "identifiability": findings,
        "determined": determined,
    })


def _error_table(
    names: Sequence[str], values: dict[str, float], units: dict[str, str],
    stderr: dict[str, Any], ci95: dict[str, Any],
) -> list[str]:
    lines = [f"  {'value':<15}  {'std. error':<12}  {'rel.':<8}  {'95 % interval':<30}  unit"]
    for name in names:
        se = stderr.get(name)
        se = math.nan if se is None else float(se)
        v = values[name]
        rel = abs(se / v) if v and math.isfinite(se) else math.nan
        ci = ci95.get(name)
        ci_txt = f"[{ci[0]:.6g}, {ci[1]:.6g}]" if ci else "none"
        rel_txt = f"{100 * rel:.3g} %" if math.isfinite(rel) else "n/a"
        se_txt = f"{se:.4g}" if math.isfinite(se) else "n/a"
        lines.append(f"  {name:<15}  {se_txt:<12}  {rel_txt:<8}  {ci_txt:<30}  "
                     f"{units.get(name, '')}")
    return lines


def diagnostics_text(result: FitResult) -> str:
    """The diagnostics as report lines (uncertainty table, correlations, findings)."""
    extra = result.extra
    if "stderr" not in extra:
        return ""
    lines: list[str] = []
    unc = extra.get("uncertainty", {})
    stderr = extra.get("stderr", {})
    if stderr:
        lines.append(
            f"  uncertainty: residual variance sigma^2 = {extra['sigma2']:.4g} "
            f"{unc.get('sigma2_unit', '')}, {unc.get('dof')} degrees of freedom"
        )
        lines.append(f"  ({unc.get('assumptions', '')})")
        values = dict(zip(result.free, _free_values(result).tolist(), strict=True))
        units = {**result.param_units(), "C": "-", "D": "-", "offset": result.units.position}
        lines += _error_table(result.free, values, units, stderr, extra.get("ci95", {}))
        whiteness = unc.get("whiteness")
        hac = unc.get("hac")
        if whiteness and not whiteness.get("white") and hac and extra.get("stderr_hac"):
            lines.append(
                "  robust to the residuals' serial correlation (HAC: prewhitened Bartlett "
                f"kernel, bandwidth {hac['bandwidth']} "
                f"sample{'s' if hac['bandwidth'] != 1 else ''}; see the warning below):"
            )
            lines += _error_table(result.free, values, units, extra["stderr_hac"],
                                  extra.get("ci95_hac", {}))
        for note in unc.get("notes", []):
            lines.append(f"  note: {note}")
        corr = extra.get("correlation", {})
        if corr.get("names"):
            lines.append("  correlation:")
            cn = corr["names"]
            lines.append("  " + " " * 8 + "".join(f"{n:>8}" for n in cn))
            for n, row in zip(cn, corr["matrix"], strict=True):
                lines.append(f"  {n:<8}" + "".join(
                    f"{x:>8.3f}" if x is not None and math.isfinite(x) else f"{'n/a':>8}"
                    for x in row))
    findings = extra.get("identifiability", [])
    lines.append("  identifiability:" if findings else
                 "  identifiability: every fitted value is determined by the data")
    lines += [f"  - {f}" for f in findings]
    return "\n".join(lines)
