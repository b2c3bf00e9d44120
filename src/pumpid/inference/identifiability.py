"""What the data determine, in words, from the sensitivity matrix's SVD at the solution.

Findings name the parameter combinations the data cannot determine -- structural (the
Jacobian is singular along them) or practical (the data constrain them so weakly that their
relative standard error exceeds 100 %; when the residuals fail the whiteness check, the
larger of the ordinary and the autocorrelation-robust error counts) -- the scale symmetry
when the fit had to fix the gauge C = 1, and parameters that ran to a boundary (named with
the limiting model).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .uncertainty import PRACTICAL_REL_SE, STRUCTURAL_TOL, Numbers, is_positive_quantity

__all__ = ["Findings", "describe_direction", "findings_of", "join_names"]

Array = NDArray[np.float64]

#: Loading below which a parameter is not counted as part of a direction.
_LOADING = 0.05

_STATE_WORDS = {
    "rest": "from rest",
    "equilibrium": "from a static equilibrium",
    "periodic": "from a periodic steady state",
}


def join_names(names: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    names = list(names)
    if len(names) <= 1:
        return "".join(names)
    return ", ".join(names[:-1]) + " and " + names[-1]


def describe_direction(direction: Array, names: Sequence[str],
                       additive: Sequence[str] = ()) -> tuple[str, bool, str]:
    """Plain words for a direction in (log-)parameter space the data do not see.

    Parameters
    ----------
    direction : ndarray
        Components in scaled coordinates (d ln theta for positive quantities, offset in units
        of the data range, D as is).
    names : sequence of str
        Names of the components.
    additive : sequence of str
        Names on their own scale besides D and the offset (an own model's signed ones).

    Returns
    -------
    what : str
        The undetermined combination, e.g. ``"C and the overall scale of k0, m, c1, k1"``.
    plural : bool
        True when ``what`` names several things that cannot be told apart.
    determined : str
        What remains determined along it, e.g. ``"only their ratios are"``.
    """
    v, sig = _loadings(direction)
    parts = [names[i] for i in sig]
    if len(sig) == 1:
        return parts[0], False, "the data do not depend on it"
    positive = all(is_positive_quantity(names[i], additive) for i in sig)
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
    ratio = " : ".join(f"{v[i]:+.2f}" for i in sig)
    coords = " : ".join(f"d ln {names[i]}" if is_positive_quantity(names[i], additive)
                        else f"d {names[i]}" for i in sig)
    return (f"the trade-off between {join_names(parts)} ({coords} = {ratio})", False,
            "only the combinations unchanged along it are determined")


def _loadings(direction: Array) -> tuple[Array, list[int]]:
    """A direction scaled to its largest component 1, and the components it loads."""
    v = np.asarray(direction, dtype=float)
    v = v / v[np.argmax(np.abs(v))]
    return v, [i for i in range(v.size) if abs(v[i]) >= _LOADING]


def _loaded(direction: Array, names: Sequence[str]) -> tuple[str, ...]:
    """The names a direction loads (as :func:`describe_direction` names them)."""
    return tuple(names[i] for i in _loadings(direction)[1])


def _sentence(what: str, plural: bool, practical: bool) -> str:
    verb = "are" if plural else "is"
    how = "practically not" if practical else "not"
    sep = "separately " if plural else ""
    # Parameter names keep their case (k0 is not K0); only prose openings are capitalised.
    opening = what if what.split(" ")[0] not in ("the", "a", "an") else what[0].upper() + what[1:]
    return f"{opening} {verb} {how} {sep}identifiable"


@dataclass(frozen=True)
class Findings:
    """Identifiability in words and what is determined."""

    sentences: tuple[str, ...] = ()
    determined: dict[str, Any] = field(default_factory=dict)
    #: Indices (into the fitted values) not determined at all.
    undetermined: tuple[int, ...] = ()
    #: Notes for the uncertainty table.
    notes: tuple[str, ...] = ()


def gauge_sentence(model_names: Sequence[str], initial_state: Any, residual: str) -> str:
    """The scale symmetry, when the fit had to fix the gauge C = 1."""
    names = list(model_names)
    where = (_STATE_WORDS.get(initial_state, f"initial_state={initial_state!r}")
             if isinstance(initial_state, str) else "from the given (zero) initial state")
    scale_name = "D = ln C" if residual == "log" else "C"
    return (
        f"C and the overall scale of {', '.join(names)} are not separately identifiable {where}: "
        f"only their ratios are (multiplying all of them by any lambda > 0 gives the same "
        f"fitted curve). {scale_name} was asked to be free; the parameters are reported on "
        "the gauge C = 1, i.e. as the ratios " + ", ".join(f"{n}/C" for n in names) + "."
    )


def findings_of(
    nums: Numbers | None,
    *,
    model_names: Sequence[str],
    gauge_fixed: bool,
    initial_state: Any,
    residual: str,
    boundaries: Sequence[tuple[str, str, str]] = (),
    serial: bool = False,
) -> Findings:
    """The findings of one card.

    ``boundaries``: (name, direction, limit description) of parameters at a boundary.
    ``serial``: the robust errors are shown (serially correlated residuals, or too few to
    test): practical identifiability then looks at the robust errors too.
    """
    sentences: list[str] = []
    determined: dict[str, Any] = {"gauge": None, "combinations": [], "parameters": [],
                                  "boundary": [], "not_determined": []}
    if gauge_fixed:
        sentences.append(gauge_sentence(model_names, initial_state, residual))
        determined["gauge"] = "C = 1"
        determined["combinations"].append(
            "the ratios " + ", ".join(f"{n}/C" for n in model_names)
            + " (reported as the parameters on the gauge C = 1)")
    for name, direction, limit in boundaries:
        # A model's declared bound ("lower"/"upper") leaves an interval open on the side the
        # data want, as 0 and infinity do.
        arrow, side = {"infinity": ("infinity", "a lower"), "zero": ("zero", "an upper"),
                       "lower": ("its lower bound", "an upper"),
                       "upper": ("its upper bound", "a lower")}[direction]
        sentences.append(
            f"{name} is at a boundary (it runs to {arrow}): the data are described by the "
            f"limiting model {limit}. {name} has no finite estimate and no two-sided "
            f"interval; only {side} bound exists (pumpid.profile_of(result, {name!r}) "
            "computes it).")
        determined["boundary"].append(name)
    if nums is None or not nums.usable or nums.dof <= 0:
        return Findings(tuple(sentences), determined)
    names = nums.names
    inner = list(nums.inner)
    inner_names = [names[i] for i in inner]
    qi = len(inner)
    s = nums.singular[:qi]
    vt = nums.vt[:qi, :qi]
    if qi == 0 or not (s[0] > 0) or not np.all(np.isfinite(s)):
        return Findings(tuple(sentences), determined, tuple(inner))
    rel = s / s[0]
    structural = [k for k in range(qi) if rel[k] <= STRUCTURAL_TOL]
    kept = [k for k in range(qi) if rel[k] > STRUCTURAL_TOL]
    sigma = math.sqrt(max(nums.sigma2, 0.0))
    for k in structural:
        what, plural, det = describe_direction(vt[k], inner_names, nums.additive)
        sentences.append(
            f"{_sentence(what, plural, practical=False)} from these data: {det} (structural: "
            f"the sensitivity matrix is singular along this direction, relative singular "
            f"value {rel[k]:.1e}).")
        determined["combinations"].append(f"{what}: {det}")
    robust = serial and bool(np.any(np.isfinite(nums.direction_se_hac[:qi])))
    loose_dirs: list[tuple[int, float]] = []
    for k in kept:
        se = sigma / s[k]
        if robust and math.isfinite(nums.direction_se_hac[k]):
            se = max(se, float(nums.direction_se_hac[k]))
        if se > PRACTICAL_REL_SE:
            loose_dirs.append((k, se))
    # Directions over the same values, as many as the values: every combination of them is
    # loose, said once ("the trade-off between m and k1" was listed twice, with two ratios).
    groups: dict[tuple[str, ...], list[tuple[int, float]]] = {}
    for k, se in loose_dirs:
        groups.setdefault(_loaded(vt[k], inner_names), []).append((k, se))
    for members, found in groups.items():
        if (len(members) < 2 or len(found) != len(members)
                or any(n == "offset" or n in nums.additive for n in members)):
            continue  # a signed value's error is not relative: said direction by direction
        for k, se in found:
            loose_dirs.remove((k, se))
        errors = " and ".join(f"{100 * se:.0f} %" for _k, se in found)
        sentences.append(
            f"{join_names(list(members))} are practically not identifiable, separately or "
            f"in any combination: the data constrain the {len(found)} directions they span "
            f"only to standard errors of {errors} (relative to the values"
            + (", the larger of the ordinary and the serial-correlation-robust error"
               if robust else "")
            + "), so their intervals are wide.")
    for k, se in loose_dirs:
        what, plural, _det = describe_direction(vt[k], inner_names, nums.additive)
        signed = [n for n in inner_names if n == "offset" or n in nums.additive]
        signed = [n for n in signed if re.search(rf"\b{re.escape(n)}\b", what)]
        unit = (f"relative to the values, {join_names(signed)} in units of the data range"
                if signed else "relative to the values")
        if robust:
            unit += ", the larger of the ordinary and the serial-correlation-robust error"
        sentences.append(
            f"{_sentence(what, plural, practical=True)}: the data constrain this direction "
            f"only to a standard error of {100 * se:.0f} % ({unit}; relative singular value "
            f"{rel[k]:.1e}), so the intervals of the parameters involved are wide.")
    undetermined = sorted({inner[i] for k in structural for i in range(qi)
                           if abs(vt[k, i]) >= 1e-6})
    at_bound = {n for n, _d, _l in boundaries}
    # A model parameter is determined when the error shown for it (the robust one where the
    # residuals are serially correlated) is below PRACTICAL_REL_SE of its value: the rule
    # the derived quantities follow. Its error stays finite; it is only not called known.
    shown = nums.hac_scaled if robust else nums.cov_scaled
    loose = set()
    for a, i in enumerate(inner):
        if names[i] in model_names:
            # Log coordinates: the error is relative already; a signed parameter's is taken
            # relative to its value.
            var = float(shown[a, a])
            size = (1.0 if is_positive_quantity(names[i], nums.additive)
                    else abs(float(nums.values[i]) / float(nums.scales[i])))
            if not (math.isfinite(var) and math.sqrt(max(var, 0.0)) <= PRACTICAL_REL_SE * size):
                loose.add(i)
    for i, name in enumerate(names):
        if name in at_bound:
            continue
        if i in undetermined or i in loose:
            determined["not_determined"].append(name)
        else:
            determined["parameters"].append(name)
    notes = []
    bound_idx = [i for i, n in enumerate(names) if n in at_bound]
    if bound_idx:
        notes.append(
            f"{join_names([names[i] for i in bound_idx])}: at a boundary, so no symmetric "
            "interval (None); the other values' errors are taken with it at its limit, and "
            "reach further where the model fits within the noise away from that limit (a "
            "finding then says how far)")
    if undetermined:
        notes.append(
            f"{join_names([names[i] for i in undetermined])}: not identifiable, standard "
            "error infinite and no interval (None)")
    return Findings(tuple(sentences), determined, tuple(undetermined), tuple(notes))


def whiteness_warning(check: dict[str, Any], n_obs: int, n_fitted: int,
                      shown_robust: bool = False, widened: str | None = None) -> str:
    """The warning for residuals that fail the whiteness check (``shown_robust``: the
    errors shown are the robust ones; False where none are computed or shown;
    ``widened``: how much wider than the independent-noise ones they are, "72-80x")."""
    effective = max(1, round(check["effective_samples"]))
    few = (f"; that is too few against {n_fitted} fitted values for any interval, the robust "
           f"ones included, to mean much" if effective < 3 * n_fitted else "")
    ar1 = (f"an AR(1) model of these residuals widens them about "
           f"{check['interval_factor']:.1f}x (about {effective} effective "
           f"sample{'s' if effective != 1 else ''} of {n_obs}{few})")
    if shown_robust:
        # The figure a user compares is the errors shown against the independent-noise
        # ones; the AR(1) factor alone (6.5x) sat beside robust errors 72-80x wider.
        # The range is the parameters' (a derived quantity's may differ more).
        size = (f", {widened} the independent-noise ones for the parameters of this card"
                if widened else "")
        errors = ("The errors shown (stderr, ci95) are the autocorrelation-robust ones (also "
                  f"stderr_hac, ci95_hac){size}: {ar1}, and the robust estimate is widened "
                  "further for its own spread over so few effective samples. ")
    else:
        errors = (f"For AR(1) errors they would be wider: {ar1}. No autocorrelation-robust "
                  "errors are available here, so the errors shown are these. ")
    return (
        f"the residuals are not white noise: their lag-1 autocorrelation is "
        f"{check['lag1_autocorrelation']:.2f} (white noise stays below {check['limit']:.2f} "
        f"for {n_obs} samples, 99.5 %). Errors that assume independent noise (stderr_white, "
        f"ci95_white) are too narrow here. "
        + errors
        + "Structured residuals usually mean that the model misses part of the response."
    )
