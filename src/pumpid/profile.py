"""Profile likelihood of one fitted value: refits with that value held on a grid.

For each grid value of the profiled parameter every other free value is refitted, so the
profiled cost ``E_p(v) = min over the others of 1/2 SSR`` follows the valley of the cost. Its
interval is the likelihood-ratio one: the values with

    SSR_p(v) - SSR_min <= sigma^2 * t^2,    sigma^2 = SSR_min / (N - p),

with ``t`` the two-sided Student quantile at the chosen level and N - p degrees of freedom.
For a model linear in its parameters this equals the Wald interval of
:mod:`pumpid.inference.uncertainty`; for a curved problem it follows the cost's actual shape
and, for a parameter at a boundary, it is one-sided: the profile never rises above the
threshold on the boundary's side, so that bound is ``None`` (0 or infinity). Like the Wald
interval, it assumes white, homoscedastic, Gaussian noise; when the fit's residuals fail the
whiteness check, a note says so (the interval is then too narrow).

The refits use the default solver (``method="lm"``) whatever method produced the result: the
profile is a property of the cost function, not of the solver.

The module stands above the job (each grid point is a run of it), so a result does not
profile itself: ``pumpid.profile_of(result, name)`` (this module's :func:`profile`) does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from .engine.problem import CardData, build_problem
from .engine.solvers import LevenbergMarquardt
from .inference.uncertainty import is_positive_quantity, t_quantile
from .job import JobOptions, run
from .result import FitResult

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["Profile", "profile"]

Array = NDArray[np.float64]

#: The grid is extended on a side that has not crossed the threshold, at most this many times.
_MAX_EXTEND = 4
#: Farthest a positive parameter is profiled from its estimate (factor).
_MAX_FACTOR = 1e6


@dataclass
class Profile:
    """A profile likelihood and the interval read from it.

    Attributes
    ----------
    name, unit : str
        The profiled value and its unit.
    estimate : float
        The fitted value.
    values : ndarray
        Grid of held values (ascending).
    cost : ndarray
        Profiled cost 1/2 SSR at each grid value (NaN where the refit failed).
    converged : ndarray of bool
        Whether each refit converged.
    others : dict of ndarray
        The other free values along the profile.
    cost_min, sigma2, dof : float, float, int
        Minimum cost, residual variance and degrees of freedom the threshold uses.
    level : float
        Confidence level.
    threshold : float
        Cost threshold: ``cost_min + sigma2 * t^2 / 2``.
    lower, upper : float or None
        Interval ends; None when the profile never crosses the threshold on that side
        (a one-sided interval: the parameter may run to its boundary there).
    positive : bool
        True for a positive quantity (grid and plot on a log scale).
    notes : list of str
        Plain-language remarks (one-sided interval, lower cost found, failed refits).
    """

    name: str
    unit: str
    estimate: float
    values: Array
    cost: Array
    converged: NDArray[np.bool_]
    others: dict[str, Array]
    cost_min: float
    sigma2: float
    dof: int
    level: float
    threshold: float
    lower: float | None
    upper: float | None
    positive: bool
    notes: list[str] = field(default_factory=list)

    @property
    def t_quantile(self) -> float:
        """The two-sided Student t quantile at :attr:`level`."""
        return t_quantile(0.5 + self.level / 2, self.dof)

    @property
    def deviance(self) -> Array:
        """``(SSR_p - SSR_min) / sigma^2`` along the grid (compared with ``t^2``)."""
        return 2.0 * (self.cost - self.cost_min) / self.sigma2

    @property
    def interval(self) -> tuple[float, float]:
        """``(low, high)`` with the missing ends as 0 / -inf and inf."""
        low = self.lower if self.lower is not None else (0.0 if self.positive else -math.inf)
        high = self.upper if self.upper is not None else math.inf
        return low, high

    @property
    def one_sided(self) -> bool:
        """True when one end of the interval is open (a boundary)."""
        return (self.lower is None) != (self.upper is None)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (grid included)."""
        return {
            "name": self.name, "unit": self.unit, "estimate": self.estimate,
            "level": self.level, "lower": self.lower, "upper": self.upper,
            "one_sided": self.one_sided, "values": self.values.tolist(),
            "cost": [c if math.isfinite(c) else None for c in self.cost.tolist()],
            "threshold": self.threshold, "cost_min": self.cost_min, "notes": list(self.notes),
        }

    def plot(self) -> Figure:
        """The profile (SSR - SSR_min) / sigma^2 against the held value, with the interval.

        Returns
        -------
        matplotlib.figure.Figure
            A figure not attached to pyplot (save it with ``fig.savefig``).
        """
        from matplotlib.figure import Figure

        fig = Figure(figsize=(6.4, 4.2), layout="constrained")
        ax = fig.add_subplot()
        ok = np.isfinite(self.cost)
        ax.plot(self.values[ok], self.deviance[ok], "o-", color="C0", ms=3,
                label="profile (others refitted)")
        bad = ok & ~self.converged
        if np.any(bad):
            ax.plot(self.values[bad], self.deviance[bad], "x", color="C3",
                    label="refit not converged")
        tq2 = self.t_quantile**2
        pct = f"{100 * self.level:g} %"
        ax.axhline(tq2, color="C1", ls="--", label=f"threshold t^2 = {tq2:.3g} ({pct})")
        ax.axvline(self.estimate, color="0.4", lw=0.8, label="estimate")
        for end, word in ((self.lower, "lower"), (self.upper, "upper")):
            if end is not None:
                ax.axvline(end, color="C2", lw=1.0, ls=":", label=f"{word} {end:.4g}")
        if self.positive:
            ax.set_xscale("log")
        unit = f" [{self.unit}]" if self.unit else " [-]"
        ax.set_xlabel(f"{self.name}{unit}")
        ax.set_ylabel("(SSR - SSR_min) / sigma^2 [-]")
        low, high = self.interval
        kind = "one-sided " if self.one_sided else ""
        ax.set_title(f"Profile of {self.name}: {kind}{pct} interval [{low:.4g}, {high:.4g}]",
                     fontsize=10)
        top = float(np.nanmax(self.deviance[ok])) if np.any(ok) else 1.0
        # Show the neighbourhood of the threshold: far-out points would flatten the crossing.
        y_top = 1.15 * max(min(top, 10 * tq2), tq2)
        ax.set_ylim(-0.05 * y_top, y_top)
        ax.legend(fontsize=8)
        return fig


# --------------------------------------------------------------------------- refits
def _value_of(result: FitResult, name: str) -> float:
    if name == "C":
        return result.scale
    if name == "D":
        return math.log(result.scale)
    if name == "offset":
        return result.offset
    return result.params[name]


def _unit_of(result: FitResult, name: str) -> str:
    if name in ("C", "D"):
        return ""
    if name == "offset":
        return result.units.position
    return result.param_units().get(name, "")


class _Refitter:
    """Refits of the result's problem with one value held fixed (continuation starts)."""

    def __init__(self, result: FitResult, name: str) -> None:
        problem = result.problem
        if problem is None:
            raise ValueError("profile: the result carries no problem to refit")
        self.result = result
        self.name = name
        self.problem = problem
        self.model_cls = problem.model
        k = int(result.options.get("card", 0))
        t, f, d = problem.card(k)
        period = problem.period[k]
        self.card = CardData(t, f, d, problem.initial_states[k],
                             None if not math.isfinite(period) else float(period))
        names = self.model_cls.param_names()
        self.base_fixed = {names[i]: v for i, v in problem.fixed}
        # The gauge of the scale symmetry stays as the fit chose it: profiling with C free
        # and a parameter held would move along a different, unrelated family.
        self.scale: float | str = ("free" if problem.scale_fixed is None
                                   else float(problem.scale_fixed))
        self.offset: bool | float = (True if problem.offset_fixed is None
                                     else float(problem.offset_fixed))
        self.free_names = [n for n in result.free if n != name]
        self.solver = result.options.get("solver")

    def __call__(self, value: float, start: dict[str, float]) -> tuple[float, bool, dict]:
        fixed = dict(self.base_fixed)
        scale, offset = self.scale, self.offset
        if self.name == "C":
            scale = value
        elif self.name == "D":
            scale = math.exp(value)
        elif self.name == "offset":
            offset = value
        else:
            fixed[self.name] = value
        params = {n: start[n] for n in self.model_cls.param_names()}
        if self.name in params:
            params[self.name] = value
        p = self.problem
        try:
            sub = build_problem(self.model_cls, [self.card], observe=p.observe,
                                integrator=p.integrator, residual=p.residual, scale=scale,
                                offset=offset, fixed=fixed or None)
        except ValueError:
            return math.nan, False, {}
        guess = np.array([[params[n] for n in self.model_cls.param_names()]])
        c_start = off_start = None
        if "C" in self.free_names and sub.scale_fixed is None:
            c_start = np.array([start.get("C", math.nan)])
        if "offset" in self.free_names and sub.offset_fixed is None:
            off_start = np.array([start.get("offset", math.nan)])
        solver = self.solver if isinstance(self.solver, LevenbergMarquardt) else \
            LevenbergMarquardt()
        # Continuation from the neighbouring grid point is the right start for a profile;
        # a multistart on every refit would only cost time.
        (card,) = run(sub, np.zeros(1, dtype=np.int64), guess=guess, c_start=c_start,
                      offset_start=off_start,
                      options=JobOptions(solver=solver, multistart=False))
        if not (np.all(np.isfinite(card.z)) and math.isfinite(card.cost)):
            return math.nan, False, {}
        theta = sub.full_theta(np.exp(card.z[: sub.n_free]))
        values = dict(zip(self.model_cls.param_names(), theta.tolist(), strict=True))
        j = sub.n_free
        scale_v = float(sub.scale_fixed) if sub.scale_fixed is not None else math.exp(card.z[j])
        j += sub.scale_fixed is None
        offset_v = float(sub.offset_fixed) if sub.offset_fixed is not None else float(card.z[j])
        values.update({"C": scale_v, "offset": offset_v})
        if scale_v > 0:
            values["D"] = math.log(scale_v)
        return card.cost, card.status.key in ("converged", "boundary"), values


def _crossing(x0: float, d0: float, x1: float, d1: float, level: float) -> float:
    """Where the straight line through (x0, d0), (x1, d1) reaches ``level``."""
    if d1 == d0:
        return x1
    return x0 + (level - d0) * (x1 - x0) / (d1 - d0)


def _refined(deviance: Callable[[float], float], inside: float, outside: float,
             d_in: float, d_out: float, level: float) -> float:
    """Where the profile's deviance reaches ``level`` between two grid points, found by
    refits (Brent's method to 1e-4 of the bracket): a straight line across a coarse grid
    put an interval's end 50 times too close to the estimate where the profile is curved
    (c1 of a real card: 56.86 for about 55.9, beside an estimate of 56.88). The line's
    crossing stands where a refit fails."""
    guess = _crossing(inside, d_in, outside, d_out, level)

    def gap(x: float) -> float:
        # The bracket's ends are the grid's own points: not refitted (Brent evaluates them
        # first), so the grid keeps its continuation's values there.
        if x == inside:
            return d_in - level
        if x == outside:
            return d_out - level
        d = deviance(x)
        if not math.isfinite(d):
            raise ArithmeticError
        return d - level

    try:
        return float(brentq(gap, inside, outside, xtol=1e-4 * abs(outside - inside),
                            maxiter=30))
    except (ArithmeticError, ValueError, RuntimeError):
        return guess


# --------------------------------------------------------------------------- entry point
def profile(
    result: FitResult,
    name: str,
    *,
    n_points: int = 21,
    span: float | None = None,
    level: float = 0.95,
) -> Profile:
    """Profile likelihood of one fitted value.

    Parameters
    ----------
    result : FitResult
        A fit from :func:`pumpid.fit` (its ``problem`` is used for the refits).
    name : str
        A free value: a model parameter, ``"C"``/``"D"`` or ``"offset"``.
    n_points : int
        Grid points of the first pass (odd keeps the estimate on the grid); a side that
        never crosses the threshold is extended by a few more points.
    span : float, optional
        Half-width of the first grid: a factor for positive quantities (grid from
        ``estimate / span`` to ``estimate * span``), a distance in the value's unit for D and
        the offset. Default: three times the Wald half-width (from ``result.stderr``), at
        least 2 % (or a factor 1000 for a parameter at a boundary).
    level : float
        Confidence level of the interval (0.95).

    Returns
    -------
    Profile
    """
    if name not in result.free:
        raise ValueError(f"profile: {name!r} is not a fitted value; fitted: {list(result.free)}")
    if result.model is None or not math.isfinite(result.cost):
        raise ValueError("profile: the fit has no finite solution to profile")
    if not 0 < level < 1:
        raise ValueError(f"profile: level must be in (0, 1), got {level}")
    n_points = max(int(n_points), 3)
    refit = _Refitter(result, name)
    estimate = _value_of(result, name)
    positive = is_positive_quantity(name)
    n_obs = int(result.data.size)
    dof = max(n_obs - len(result.free), 1)
    sst = float(np.sum((result.data - result.data.mean()) ** 2))
    sigma2 = max(2.0 * result.cost / dof, 1e-28 * sst / n_obs, 1e-300)
    tq = t_quantile(0.5 + level / 2, dof)
    boundary = next((b for b in result.extra.get("boundaries") or [] if b["name"] == name), None)

    # Grid coordinate: ln(value) for positive quantities, the value itself otherwise.
    def to_x(v: float) -> float:
        return math.log(v) if positive else v

    def from_x(x: float) -> float:
        return math.exp(x) if positive else x

    x_est = to_x(estimate)
    se = result.stderr.get(name, math.nan)
    if span is not None:
        half = math.log(span) if positive else float(span)
    elif boundary is not None or not (math.isfinite(se) and se > 0):
        half = math.log(1e3) if positive else 3.0 * (float(np.ptp(result.data)) or 1.0)
    else:
        half = 3.0 * tq * (se / abs(estimate) if positive else se)
        half = max(half, 0.02 if positive else 1e-3 * (float(np.ptp(result.data)) or 1.0))
    if positive:
        half = min(half, math.log(_MAX_FACTOR))
    if boundary is not None and positive:
        # Only the side away from the boundary can close; the estimate itself is arbitrary.
        lo_x, hi_x = (x_est - half, x_est) if boundary["direction"] == "infinity" else (
            x_est, x_est + half)
    else:
        lo_x, hi_x = x_est - half, x_est + half
    xs_left = list(np.linspace(x_est, lo_x, n_points // 2 + 1)[1:]) if lo_x < x_est else []
    xs_right = list(np.linspace(x_est, hi_x, n_points // 2 + 1)[1:]) if hi_x > x_est else []

    start0 = dict(result.params)
    start0.update({"C": result.scale, "offset": result.offset})
    if result.scale > 0:
        start0["D"] = math.log(result.scale)
    points: dict[float, tuple[float, bool, dict]] = {x_est: (result.cost, True, start0)}
    threshold = result.cost + 0.5 * sigma2 * tq**2

    def walk(xs: list[float]) -> None:
        prev = start0
        for x in xs:
            cost, ok, values = refit(from_x(x), prev)
            points[x] = (cost, ok, values)
            if values:
                prev = values

    def crossed(side: int) -> bool:
        xs = sorted(points)
        xs = [x for x in xs if (x <= x_est if side < 0 else x >= x_est)]
        return any(math.isfinite(points[x][0]) and points[x][0] > threshold for x in xs)

    for side, xs in ((-1, xs_left), (1, xs_right)):
        walk(xs)
        step = abs(xs[-1] - x_est) if xs else half
        # Toward a known boundary one extension shows the flat profile; it cannot close.
        toward_boundary = boundary is not None and positive and (
            (side > 0) == (boundary["direction"] == "infinity"))
        for _ in range(1 if toward_boundary else _MAX_EXTEND):
            if crossed(side):
                break
            far = min(points) if side < 0 else max(points)
            if positive and abs(far - x_est) >= math.log(_MAX_FACTOR):
                break
            nxt = far + side * step
            if positive:
                nxt = float(np.clip(nxt, x_est - math.log(_MAX_FACTOR),
                                    x_est + math.log(_MAX_FACTOR)))
            walk(list(np.linspace(far, nxt, 4)[1:]))
            step *= 2

    xs_all = sorted(points)
    costs = np.array([points[x][0] for x in xs_all])
    notes: list[str] = []
    cost_min = result.cost
    finite = costs[np.isfinite(costs)]
    if finite.size and finite.min() < result.cost * (1 - 1e-9) - 1e-300:
        cost_min = float(finite.min())
        threshold = cost_min + 0.5 * sigma2 * tq**2
        notes.append(
            f"a refit on the profile reached a lower cost ({cost_min:.6g} < {result.cost:.6g}):"
            " the fit was not at the global minimum; the interval is read from the lower cost"
        )
    dev = 2.0 * (costs - cost_min) / sigma2
    lim = tq**2
    i_est = int(np.argmin(np.where(np.isfinite(costs), costs, np.inf)))

    def end(i: int, j: int) -> float:
        """The interval's end between grid points i (inside) and j (outside), refined by
        refits started from the inside point's values."""
        start = points[xs_all[i]][2] or start0

        def deviance(x: float) -> float:
            cost, ok, values = refit(from_x(x), start)
            points[x] = (cost, ok, values)
            return 2.0 * (cost - cost_min) / sigma2

        return from_x(_refined(deviance, xs_all[i], xs_all[j], dev[i], dev[j], lim))

    lower = upper = None
    for i in range(i_est, 0, -1):
        if np.isfinite(dev[i - 1]) and dev[i - 1] > lim >= dev[i]:
            lower = end(i, i - 1)
            break
    for i in range(i_est, len(xs_all) - 1):
        if np.isfinite(dev[i + 1]) and dev[i + 1] > lim >= dev[i]:
            upper = end(i, i + 1)
            break
    # The refits that placed the ends join the profile's points.
    xs_all = sorted(points)
    costs = np.array([points[x][0] for x in xs_all])
    converged = np.array([points[x][1] for x in xs_all], dtype=bool)
    whiteness = (result.extra.get("uncertainty") or {}).get("whiteness")
    if whiteness and not whiteness.get("white", True):
        notes.append(
            f"the fit's residuals are not white (lag-1 autocorrelation "
            f"{whiteness['lag1_autocorrelation']:.2f}): like the Wald interval, this one "
            f"assumes independent errors and is too narrow, by a factor of about "
            f"{whiteness['interval_factor']:.1f} for AR(1) errors (result.ci95_hac is the "
            f"interval robust to it)"
        )
    if not converged.all():
        notes.append(f"{int((~converged).sum())} refit(s) did not converge (marked in the plot)")
    for end, word, limit in ((lower, "lower", "0" if positive else "-infinity"),
                             (upper, "upper", "infinity")):
        if end is None:
            notes.append(
                f"no {word} bound: the profile stays below the threshold out to "
                f"{from_x(xs_all[0] if word == 'lower' else xs_all[-1]):.4g}; "
                f"{name} may go to {limit} (a boundary)"
            )
    others = {n: np.array([points[x][2].get(n, math.nan) if points[x][2] else math.nan
                           for x in xs_all]) for n in refit.free_names}
    return Profile(
        name=name, unit=_unit_of(result, name), estimate=estimate,
        values=np.array([from_x(x) for x in xs_all]), cost=costs, converged=converged,
        others=others, cost_min=cost_min, sigma2=sigma2, dof=dof, level=level,
        threshold=cost_min + 0.5 * sigma2 * tq**2, lower=lower, upper=upper,
        positive=positive, notes=notes,
    )
