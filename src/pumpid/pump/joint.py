"""Joint fits: one parameter set shared by several cards of a well.

Consecutive strokes of a steady well are the same system under slightly different loads. A
joint fit asks for the parameters all of them share, each card keeping its own position
offset (a card's zero is arbitrary): more data behind the same few numbers, so their
errors shrink (about as 1 / sqrt(number of cards) when the cards are alike) and the
directions one card leaves open can be closed by the others.

The residuals and exact Jacobian of every card come from the engine's compiled kernel (the
same problem the single-card fits solve); scipy's ``least_squares`` (trust-region
reflective, log-parameters) runs the joint problem, started from each card's own answer
and the median of them, keeping the best. Errors: the Gauss-Newton covariance of the
stacked problem, and the same inflated for serially correlated residuals by the AR(1)
factor sqrt((1 + rho) / (1 - rho)) with rho the pooled lag-1 autocorrelation (a card's
residuals are mostly model error, seldom white).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from ..cards import Card
from ..engine import drive
from ..inference.derived import derived_gradient, moved_by_limits
from ..inference.uncertainty import PRACTICAL_REL_SE, WHITENESS_Z
from ..job import FitOptions, fit
from ..models import Kelvin, Model, model_class
from ..result import Units

__all__ = ["JointFit", "fit_joint"]

Array = NDArray[np.float64]

#: The chi-square (one degree of freedom) 95 % point of the likelihood-ratio test.
_LR_95 = 3.841


@dataclass(frozen=True)
class JointFit:
    """One parameter set fitted to several cards jointly.

    Attributes
    ----------
    model_name, observe : the structure.
    params, stderr, stderr_white, stderr_ar1 : shared parameters (the user's units), the
        standard errors shown (``shown``: ``"robust"``, the AR(1)-inflated ones, where the
        pooled residuals fail the whiteness check, else ``"white"``), the errors for white
        residuals and the AR(1)-inflated ones.
    derived : name -> (value, stderr, stderr_ar1, unit) of the model's derived quantities.
    cards, offsets, r2, rmse : per card, in order.
    single : per card, the parameters its own fit gave (for comparison).
    cost, n_samples, rho, status, message, units.
    """

    model_name: str
    observe: str
    params: dict[str, float]
    stderr: dict[str, float]
    stderr_white: dict[str, float]
    shown: str
    stderr_ar1: dict[str, float]
    derived: dict[str, tuple[float, float, float, str]]
    cards: tuple[str, ...]
    offsets: tuple[float, ...]
    r2: tuple[float, ...]
    rmse: tuple[float, ...]
    single: tuple[dict[str, float], ...]
    cost: float
    n_samples: int
    rho: float
    status: str
    message: str
    units: Units
    param_units: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {
            "joint": True, "model": self.model_name, "observe": self.observe,
            "status": self.status, "message": self.message, "cards": list(self.cards),
            "params": self.params, "stderr": self.stderr, "stderr_white": self.stderr_white,
            "errors_shown": self.shown, "stderr_ar1": self.stderr_ar1,
            "param_units": self.param_units,
            "derived": {k: {"value": v[0], "stderr": v[1], "stderr_ar1": v[2], "unit": v[3]}
                        for k, v in self.derived.items()},
            "offsets": list(self.offsets), "r2": list(self.r2), "rmse": list(self.rmse),
            "single": [dict(s) for s in self.single], "cost": self.cost,
            "n_samples": self.n_samples, "rho": self.rho,
            "units": {"load": self.units.load, "position": self.units.position},
        }

    def report(self) -> str:
        """The joint fit in words and numbers."""
        pos = self.units.position
        lines = [f"joint fit: {self.model_name} observing {self.observe}, one parameter set "
                 f"for {len(self.cards)} cards ({self.n_samples} samples), a position "
                 f"offset per card; status {self.status}: {self.message}",
                 f"  parameters (+/- standard error; robust to the residuals' serial "
                 f"correlation, lag-1 autocorrelation {self.rho:.3f}):"]
        def errors(value: float, se: float, se_ar1: float) -> str:
            if se == math.inf:
                return "(at a limit: not determined)"
            flag = "" if abs(se_ar1 if self.shown == "robust" else se) <= abs(value) else \
                " (not determined: error over 100 %)"
            if self.shown == "robust":
                return f"(robust +/- {se_ar1:.3g}; independent-noise +/- {se:.3g}){flag}"
            return f"(+/- {se:.3g}; robust +/- {se_ar1:.3g}){flag}"

        for name, value in self.params.items():
            lines.append(f"  {name:<6} = {value:.6g} {self.param_units.get(name, '')} "
                         f"{errors(value, self.stderr_white[name], self.stderr_ar1[name])}")
        for name, (value, se, se_ar1, unit) in self.derived.items():
            lines.append(f"  {name.replace('_', ' ')} = {value:.6g} {unit} "
                         f"{errors(value, se, se_ar1)}")
        lines.append("  per card: offset, R^2, RMSE, and the card's own fit:")
        for i, card in enumerate(self.cards):
            own = ", ".join(f"{k} = {v:.4g}" for k, v in self.single[i].items())
            lines.append(f"  {card}: offset = {self.offsets[i]:.6g} {pos}, R^2 = "
                         f"{self.r2[i]:.6f}, RMSE = {self.rmse[i]:.4g} {pos}; alone: {own}")
        return "\n".join(lines)


def fit_joint(
    cards: Sequence[Card],
    model: str | type[Model] = Kelvin,
    *,
    observe: str | None = None,
    max_nfev: int = 2000,
) -> JointFit:
    """Fit one parameter set to several single-stroke cards, each with its own offset.

    Parameters
    ----------
    cards : sequence of Card
        Single strokes (periodic) of one well, two or more, in the same units.
    model : str or Model class
    observe : str, optional
        The observed output (default the model's).
    max_nfev : int
        Evaluations of the joint problem allowed to each start.

    Returns
    -------
    JointFit

    Raises
    ------
    ValueError
        Fewer than two cards, cards in different units, or a card that cannot be fitted.
    """
    cls = model_class(model) if isinstance(model, str) else model
    if len(cards) < 2:
        raise ValueError("a joint fit needs at least two cards")
    units = {(c.load_unit, c.position_unit) for c in cards}
    if len(units) > 1:
        raise ValueError(f"joint fit: the cards are in different units {sorted(units)}; "
                         "convert them first (Card.to_units)")
    batch = fit(cls, list(cards), options=FitOptions.for_cards(observe=observe))
    results = list(batch.results)
    bad = [c.card_id for c, r in zip(cards, results, strict=True) if r is None
           or not np.all(np.isfinite(list(r.params.values())))]
    if bad:
        raise ValueError(f"joint fit: card(s) {', '.join(map(str, bad))} could not be fitted "
                         "alone; leave them out")
    first = results[0]
    assert first is not None and first.problem is not None
    problem = first.problem
    if problem.fixed or problem.scale_fixed is None or problem.offset_fixed is not None:
        raise ValueError("joint fit: needs the fixed scale and a fitted offset")
    p = problem.n_free
    ks = [int(r.options["card"]) for r in results if r is not None]
    n_cards = len(ks)
    data, model_code, settings = problem.arrays
    sizes = [problem.n_samples(k) for k in ks]
    rows_of = [np.empty((problem.q + 1, n)) for n in sizes]

    def stacked(x: Array) -> tuple[Array, Array]:
        r = np.empty(sum(sizes))
        jac = np.zeros((r.size, p + n_cards))
        at = 0
        for i, k in enumerate(ks):
            rows = rows_of[i]
            z = np.concatenate([x[:p], [x[p + i]]])
            if not drive.rows_at(z, k, data, model_code, settings, rows):
                r[at:at + sizes[i]] = 1e150
                return r, jac
            r[at:at + sizes[i]] = rows[-1]
            jac[at:at + sizes[i], :p] = rows[:p].T
            jac[at:at + sizes[i], p + i] = rows[p]
            at += sizes[i]
        return r, jac

    cache: dict[bytes, tuple[Array, Array]] = {}

    def evaluate(x: Array) -> tuple[Array, Array]:
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = stacked(x)
        return cache[key]

    def offsets_for(theta: Array) -> Array:
        # Each card's own offset, in the solver's coordinates at theta.
        return np.array([res.offset + float(problem.offset_gap(k, theta, 1.0))
                         for k, res in zip(ks, results, strict=True)
                         if res is not None])

    logs = np.array([np.log([r.params[n] for n in problem.free_names[:p]])
                     for r in results if r is not None])
    starts = [*logs[: min(len(logs), 6)], np.median(logs, axis=0)]
    # The engine's window on every card: a parameter the data drive to 0 or infinity
    # stops at its edge, as in the single fits, and is reported at its limit.
    lo_all, hi_all = problem.window(np.array(ks), np.column_stack(
        [logs, np.zeros((len(logs), problem.q - p))]))
    lo = np.concatenate([lo_all[:, :p].min(axis=0), np.full(n_cards, -np.inf)])
    hi = np.concatenate([hi_all[:, :p].max(axis=0), np.full(n_cards, np.inf)])
    # A parameter every card's own fit puts at the same limit is held at that edge.
    for i in range(p):
        name = problem.free_names[i]
        directions = {b.direction for r in results if r is not None and r.boundary is not None
                      for b in r.boundary.limits if b.name == name}
        every = all(r is not None and r.boundary is not None
                    and any(b.name == name for b in r.boundary.limits) for r in results)
        if every and len(directions) == 1:
            edge = hi[i] if directions == {"infinity"} else lo[i]
            lo[i], hi[i] = edge - 1e-8, edge
    def solve(x0: Array, low: Array, high: Array) -> Any:
        return scipy.optimize.least_squares(
            lambda x: evaluate(x)[0], x0, jac=lambda x: evaluate(x)[1], bounds=(low, high),
            method="trf", x_scale="jac", max_nfev=max_nfev, xtol=1e-12, ftol=1e-12,
            gtol=1e-12)

    best: Any = None
    for z0 in starts:
        z0 = np.clip(z0, lo[:p] + 1e-9 * (hi[:p] - lo[:p]), hi[:p] - 1e-9 * (hi[:p] - lo[:p]))
        x0 = np.concatenate([z0, offsets_for(problem.full_theta(np.exp(z0)))])
        sol = solve(x0, lo, hi)
        if best is None or sol.cost < best.cost:
            best = sol
    best = _limits(best, solve, stacked, lo, hi, p)
    x = best.x
    at_limit = [i for i in range(p) if min(x[i] - lo[i], hi[i] - x[i]) < 1e-3]
    r, jac = stacked(x)
    n_total = r.size
    dof = max(n_total - x.size, 1)
    sigma2 = float(r @ r) / dof
    # A parameter at its limit is held there (as in the single fits): no column, no error.
    inner = [i for i in range(x.size) if i not in at_limit]
    _u, s, vt = np.linalg.svd(jac[:, inner], full_matrices=False)
    keep = s > s[0] * 1e-12
    cov = np.full((x.size, x.size), np.nan)
    cov[np.ix_(inner, inner)] = (vt[keep].T / s[keep] ** 2) @ vt[keep] * sigma2
    for i in at_limit:
        cov[i, :] = cov[:, i] = 0.0
        cov[i, i] = math.inf
    pieces = np.split(r, np.cumsum(sizes)[:-1])
    num = sum(float(a[1:] @ a[:-1]) for a in pieces)
    den = sum(float(a @ a) for a in pieces)
    rho = num / den if den > 0 else 0.0
    inflate = math.sqrt((1 + rho) / (1 - rho)) if 0 < rho < 1 else 1.0
    # The robust error is the one shown where the residuals fail the whiteness check.
    serial = rho > WHITENESS_Z / math.sqrt(n_total)
    theta = problem.full_theta(np.exp(x[:p]))
    names = cls.param_names()
    se_log = np.sqrt(np.clip(np.diag(cov)[:p], 0, None))
    params = {n: float(theta[i]) for i, n in enumerate(names)}
    stderr = {n: float(theta[i] * se_log[i]) for i, n in enumerate(names)}
    derived = _derived(cls, theta, problem.observe, cov[:p, :p], inflate, first.units,
                       [(names[int(problem.free_idx[i])],
                         "infinity" if x[i] >= hi[i] - 1e-3 else "zero") for i in at_limit])
    offsets, r2s, rmses = [], [], []
    for i, k in enumerate(ks):
        d = problem.card(k)[2]
        res_i = pieces[i]
        offsets.append(float(x[p + i]) - float(problem.offset_gap(k, theta, 1.0)))
        r2s.append(1.0 - float(res_i @ res_i) / float(np.sum((d - d.mean()) ** 2)))
        rmses.append(math.sqrt(float(res_i @ res_i) / d.size))
    names_at = [names[int(problem.free_idx[i])] for i in at_limit]
    shown = {n: v * inflate if serial else v for n, v in stderr.items()}
    known = [n for n in problem.free_names[:p] if n not in names_at
             and shown[n] <= PRACTICAL_REL_SE * abs(params[n])]
    if best.status <= 0:
        status = "failed"
    elif not known:
        status = "undetermined"
    elif names_at:
        status = "boundary"
    else:
        status = "converged"
    held = (f"; {', '.join(names_at)} at a limit (the others fit as well there): held at "
            "its limit" if names_at else "")
    none = ("; the data determine none of the parameters (each at a limit or with an error "
            "over 100 % of its value)" if status == "undetermined" else "")
    message = str(best.message).rstrip(".") + held + none
    return JointFit(
        model_name=cls.__name__, observe=problem.observe, params=params, stderr=shown,
        stderr_white=stderr, shown="robust" if serial else "white",
        stderr_ar1={n: v * inflate for n, v in stderr.items()}, derived=derived,
        cards=tuple(str(c.card_id) for c in cards), offsets=tuple(offsets), r2=tuple(r2s),
        rmse=tuple(rmses),
        single=tuple(dict(r.params) for r in results if r is not None),
        cost=0.5 * float(r @ r), n_samples=n_total, rho=rho, status=status,
        message=message, units=first.units, param_units=first.param_units())


def _limits(best: Any, solve: Any, stacked: Any, lo: Array, hi: Array, p: int) -> Any:
    """Move parameters the data do not hold to their limit, as the single fits do.

    A parameter is tried at both edges of the window (the others refitted there); it is
    held at the better one when the joint cost rises by less than the 95 % likelihood-ratio point
    (chi-square, one degree of freedom), i.e. when the limit fits as well: a value like
    k0 = 3.6e10 +- 9.3e13 is a limit, not an estimate. The noise variance in the test is
    the residuals' long-run one (AR(1)), as serially correlated residuals carry less
    evidence than their count says.
    """
    for _round in range(p):
        x = best.x
        r, jac = stacked(x)
        rho = float(r[1:] @ r[:-1]) / float(r @ r) if float(r @ r) > 0 else 0.0
        rho = min(max(rho, 0.0), 0.999)
        sigma2 = float(r @ r) / max(r.size - x.size, 1) * (1 + rho) / (1 - rho)
        # Only a parameter the data do not pin down (log-error over PRACTICAL_REL_SE) is
        # tried at its limit: a determined one stays where the data put it.
        free = [i for i in range(x.size) if not (i < p and min(x[i] - lo[i], hi[i] - x[i])
                                                 < 1e-3)]
        _u, sv, vt = np.linalg.svd(jac[:, free], full_matrices=False)
        keep = sv > sv[0] * 1e-12
        var = np.full(x.size, np.inf)
        var[free] = np.sum((vt[keep] / sv[keep, None]) ** 2, axis=0) * sigma2
        tried = None
        for i in range(p):
            if min(x[i] - lo[i], hi[i] - x[i]) < 1e-3 or not np.isfinite(hi[i] - lo[i]) \
                    or math.sqrt(var[i]) <= PRACTICAL_REL_SE:
                continue
            for edge in (lo[i], hi[i]):
                low, high = lo.copy(), hi.copy()
                low[i], high[i] = edge - 1e-8, edge
                x0 = np.clip(x, low, high)
                x0[i] = edge - 5e-9
                sol = solve(x0, low, high)
                if sol.status > 0 and sol.cost - best.cost <= 0.5 * _LR_95 * sigma2 and (
                        tried is None or sol.cost < tried.cost):
                    tried = sol
        if tried is None:
            return best
        best = tried
    return best


def _derived(cls: type[Model], theta: Array, observe: str, cov: Array, inflate: float,
             units: Units, limits: Sequence[tuple[str, str]]
             ) -> dict[str, tuple[float, float, float, str]]:
    """Derived quantities with delta-method errors over the log-parameters; a quantity that
    still moves when a parameter at its limit goes further has none."""
    infos = cls.derived_info()
    values = cls.derived_values(theta, observe)
    cov = np.where(np.isfinite(cov), cov, 0.0)
    moved = moved_by_limits(cls, theta, observe, 1.0, values, limits)
    grad = derived_gradient(cls, theta, observe, 1.0, cls.param_names())
    out = {}
    for j, info in enumerate(infos):
        g = grad[j]
        var = float(g @ cov @ g) if np.all(np.isfinite(g)) else math.nan
        se = math.inf if moved[j] else (math.sqrt(var) if var >= 0 else math.nan)
        out[info.name] = (float(values[j]), se, se * inflate,
                          info.unit_for(units.load, units.position))
    return out
