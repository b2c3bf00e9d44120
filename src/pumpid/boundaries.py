"""Boundary solutions: a parameter the data drive to 0 or to infinity.

A least-squares fit on log-parameters has no hard bounds, so when the data prefer a limiting
model (for example k0 -> infinity: the Kelvin model's series spring becomes rigid and the
model reduces to a mass-spring-dashpot) the parameter keeps growing while the fitted curve no
longer changes. Such a solution is not an ordinary converged answer. It is recognised here
by pushing each parameter a factor 1000 further in each direction: if the cost does not
notice, the parameter is at that boundary. Each known limit is named and, where pumpid has
the limiting model, mapped to it so that the reduced model can be fitted.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .models import FirstOrder, Kelvin, MassSpringDamper, Maxwell, Model
from .problem import Problem

__all__ = ["LIMITS", "Boundary", "find_boundaries"]

Array = NDArray[np.float64]
_PUSH = 1e3


@dataclass(frozen=True)
class Limit:
    """A named limit of a model and, when available, the map to the reduced model."""

    description: str
    reduced: type[Model] | None = None
    #: Maps the full parameters to the reduced model's start and the factor by which its
    #: output must be scaled (e.g. a massless MSD is a first-order lag with gain 1/c).
    to_reduced: Callable[[dict[str, float]], tuple[dict[str, float], float]] | None = None
    #: Observed state of the reduced model.
    observe: str | None = None
    #: Maps the reduced model's parameters back to a full-model point near the limit (used to
    #: restart a full fit that the reduced model beats).
    from_reduced: Callable[[dict[str, float]], dict[str, float]] | None = None


@dataclass(frozen=True)
class Boundary:
    """A parameter found at a boundary."""

    name: str
    direction: str  # "infinity" or "zero"
    value: float
    limit: Limit
    #: "push": moving the parameter further leaves the cost unchanged; "nested": the
    #: reduced model fits as well (likelihood-ratio test).
    evidence: str = "push"

    def describe(self) -> str:
        """Plain-language statement."""
        where = "to infinity" if self.direction == "infinity" else "to zero"
        why = (
            f"pushing it a further factor {_PUSH:g} leaves the fit unchanged"
            if self.evidence == "push"
            else "the limiting model fits the data as well (likelihood-ratio test, 95 %)"
        )
        return (
            f"{self.name} runs {where} (fitted value {self.value:.4g} is arbitrary: {why}); "
            f"the data want the limit {self.limit.description}"
        )


def _msd(m: str, c: str, k: str) -> Callable[[dict[str, float]], tuple[dict[str, float], float]]:
    return lambda p: ({"m": p[m], "c": p[c], "k": p[k]}, 1.0)


LIMITS: dict[tuple[type[Model], str, str], Limit] = {
    (Kelvin, "k0", "infinity"): Limit(
        "k0 -> inf: rigid series spring, the mass-spring-dashpot m u'' + c1 u' + k1 u = F "
        "(u = u2)", MassSpringDamper, _msd("m", "c1", "k1"), "u",
        lambda r: {"k0": 1e3 * r["k"], "m": r["m"], "c1": r["c"], "k1": r["k"]}),
    (Kelvin, "m", "zero"): Limit(
        "m -> 0: no inertia, a first-order creep c1 u2' + k1 u2 = F "
        "(u = u2 + F/k0)", FirstOrder,
        lambda p: ({"tau": p["c1"] / p["k1"]}, 1.0 / p["c1"]), "u"),
    (Kelvin, "c1", "infinity"): Limit(
        "c1 -> inf: the Kelvin element is locked, an undamped mass on the spring k0"),
    (Kelvin, "c1", "zero"): Limit(
        "c1 -> 0: no damping, a mass on the springs k0 and k1 in series"),
    (Kelvin, "k1", "zero"): Limit(
        "k1 -> 0: the Kelvin element is a bare dashpot (a Maxwell fluid in series)"),
    (Kelvin, "k1", "infinity"): Limit(
        "k1 -> inf: the Kelvin element is rigid, an undamped mass on the spring k0"),
    (Kelvin, "k0", "zero"): Limit("k0 -> 0: the load no longer reaches the Kelvin element"),
    (Maxwell, "k1", "infinity"): Limit(
        "k1 -> inf: the Maxwell arm is a bare dashpot, the mass-spring-dashpot "
        "m u'' + c1 u' + k0 u = F", MassSpringDamper, _msd("m", "c1", "k0"), "u",
        lambda r: {"k0": r["k"], "m": r["m"], "c1": r["c"], "k1": 1e3 * (r["k"] + r["c"])}),
    (Maxwell, "c1", "infinity"): Limit(
        "c1 -> inf: the Maxwell arm is a spring, an undamped mass on k0 + k1"),
    (Maxwell, "c1", "zero"): Limit(
        "c1 -> 0: the Maxwell arm carries no force, an undamped mass on k0"),
    (Maxwell, "k1", "zero"): Limit(
        "k1 -> 0: the Maxwell arm carries no force, an undamped mass on k0"),
    (Maxwell, "m", "zero"): Limit("m -> 0: no inertia (a standard linear solid)"),
    (Maxwell, "k0", "zero"): Limit(
        "k0 -> 0: no static stiffness, the mass drifts under a mean load"),
    (MassSpringDamper, "m", "zero"): Limit(
        "m -> 0: no inertia, the first-order lag c u' + k u = f", FirstOrder,
        lambda p: ({"tau": p["c"] / p["k"]}, 1.0 / p["c"]), "u"),
    (MassSpringDamper, "c", "zero"): Limit("c -> 0: an undamped oscillator"),
    (MassSpringDamper, "c", "infinity"): Limit("c -> inf: the mass is locked"),
    (FirstOrder, "tau", "infinity"): Limit("tau -> inf: a pure integrator u' = f"),
    (FirstOrder, "tau", "zero"): Limit("tau -> 0: no dynamics, u = tau f"),
}


def _generic(name: str, direction: str) -> Limit:
    arrow = "inf" if direction == "infinity" else "0"
    return Limit(f"{name} -> {arrow}")


def find_boundaries(
    problem: Problem, theta: Array, scale: float, offset: float, cost: float,
    edges: list[tuple[int, str]] | None = None,
) -> list[Boundary]:
    """Parameters at 0 or infinity.

    A parameter is at a boundary when the solver stopped on the edge of its search window
    (``edges``: index and direction) and pushing it further leaves the cost unchanged, or
    when a push by a factor 1000 leaves the cost unchanged in exactly one direction. A
    parameter that leaves the cost unchanged in *both* directions is not determined at all;
    the identifiability analysis reports those.
    """
    edge_dir = dict(edges or [])
    names = problem.model_cls.param_names()
    p = len(names)
    trials = np.repeat(theta[None, :], 2 * p, axis=0)
    for i in range(p):
        trials[2 * i, i] *= _PUSH
        trials[2 * i + 1, i] /= _PUSH
    with np.errstate(all="ignore"):
        ys = problem.outputs(trials)
    sst = float(np.sum((problem.data - problem.data.mean()) ** 2))
    tol = max(1e-3 * 2.0 * cost, 1e-10 * sst)
    found: list[Boundary] = []
    for i, name in enumerate(names):
        unchanged = []
        for j, direction in ((0, "infinity"), (1, "zero")):
            r = problem.residual_vector(ys[2 * i + j], scale, offset)
            ssr = float(r @ r) if np.all(np.isfinite(r)) else math.inf
            unchanged.append((direction, ssr - 2.0 * cost <= tol))
        hits = [d for d, same in unchanged if same]
        if i in edge_dir and edge_dir[i] in hits:
            hits = [edge_dir[i]]
        if len(hits) == 1:
            direction = hits[0]
            limit = LIMITS.get((problem.model_cls, name, direction), _generic(name, direction))
            found.append(Boundary(name, direction, float(theta[i]), limit))
    return found


#: Relative log-sensitivity below which a parameter is suspected to be heading to a limit.
SUSPICION = 1e-2


def nested_candidates(
    problem: Problem, theta: Array, log_sensitivity: Array,
    edges: list[tuple[int, str]] | None, stopped_early: bool,
) -> list[tuple[str, str, Limit]]:
    """Known limits with a reduced model that the fitted point may be heading to.

    The push test of :func:`find_boundaries` moves one parameter with the others fixed; when
    the others compensate (a curved valley toward the limit) it cannot see the boundary, so
    these candidates are decided by fitting the reduced model and comparing costs. A
    parameter is a candidate when the fit hardly depends on it any more (its relative
    log-sensitivity ``||theta_i dy/dtheta_i|| / ||y - mean y||`` is below 1 %), when the
    solver stopped on the edge of its window, or when it ran out of evaluations.
    """
    names = problem.model_cls.param_names()
    ref = problem.reference_scales()
    edge_dir = dict(edges or [])
    out = []
    for (cls, name, direction), limit in LIMITS.items():
        if cls is not problem.model_cls or limit.reduced is None:
            continue
        i = names.index(name)
        heading = "infinity" if theta[i] > ref[i] else "zero"
        weak = log_sensitivity[i] < SUSPICION and heading == direction
        if weak or edge_dir.get(i) == direction or stopped_early:
            out.append((name, direction, limit))
    return out
