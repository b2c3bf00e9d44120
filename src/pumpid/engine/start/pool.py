"""The candidate pool: every point the automatic start considers for a card.

No single source of starting points is reliable on every card, so the pool mixes kinds
whose failures differ:

* equation-error estimates (:mod:`.equation_error`) at several filter bandwidths, and
  their refinements -- close to the answer when the model explains the data;
* the limiting models' own estimates, mapped next to the limit, so that a fit whose data
  want a limit starts near it instead of crawling toward it;
* the model's shape grid at the card's fundamental frequency, amplitude-matched to it;
* a heuristic from the record's amplitude ratio and length, the one kind every residual
  has.

:mod:`.multistart` ranks and polishes them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..problem import Problem
from .equation_error import equation_error_items

__all__ = ["candidates", "fundamental"]

Array = NDArray[np.float64]

#: Filter bandwidths of the equation-error candidates, in record fundamentals.
_BANDWIDTHS = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0)


def _bandwidths(problem: Problem, cards: NDArray[np.int64]) -> Array:
    """The state-variable filters' bandwidths per card (NaN where a card has fewer)."""
    lams = np.full((cards.size, len(_BANDWIDTHS)), math.nan)
    for i, k in enumerate(cards):
        t, _f, _d = problem.card(int(k))
        base = 2 * math.pi / float(t[-1] - t[0])
        dt_min = float(np.min(np.diff(t)))
        ok = [base * b for b in _BANDWIDTHS if base * b * dt_min < 0.5] or [0.5 / dt_min]
        lams[i, : len(ok)] = ok
    return lams


def _equation_error(problem: Problem, cards: NDArray[np.int64], lams: Array,
                    model: type, observe: str | None) -> Array | None:
    """Parameter rows (cards x bandwidths, p) of a model's equation-error estimates on the
    problem's cards, or None when the model has no form for that output."""
    form = model.equation_error.get(observe or model.default_output)
    if form is None:
        return None
    data, _model, _settings = problem.arrays
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    packed = (form.target[0] == "f", int(form.target[1]),
              np.array(form.y_orders, dtype=np.int64),
              np.array(form.f_orders, dtype=np.int64), int(form.order))
    coefs = equation_error_items(cards, lams, data, packed, float(scale),
                                 problem.offset_fixed is None)
    return form.to_theta(coefs.reshape(-1, form.n_coef))


def fundamental(problem: Problem, k: int) -> float:
    """The angular frequency (rad/s) of card ``k``'s fundamental: one period of a periodic
    card, else the record's length.

    The scale at which the model's shape grid is laid out, for the candidates here and for
    the wider search's dense grid alike.
    """
    t, _f, _d = problem.card(k)
    span = float(t[-1] - t[0])
    if np.isfinite(problem.period[k]):
        span = float(problem.period[k])
    return 2 * math.pi / span


def _heuristic(problem: Problem, k: int) -> Array:
    """A rough physical guess from the record's amplitude ratio and length."""
    _t, f, d = problem.card(k)
    scale = problem.scale_fixed if problem.scale_fixed is not None else 1.0
    gain = float(np.ptp(d / scale)) / max(float(np.ptp(f)), 1e-300)
    gain = gain if gain > 0 else 1.0
    omega = 3 * fundamental(problem, k)
    stiff = 1.0 / gain
    shapes = problem.model.shape_grid(omega)
    # The middle shape of the model's grid, at the record's stiffness level.
    mid = shapes[shapes.shape[0] // 2]
    return mid * _stiffness_factor(problem, stiff)


def _stiffness_factor(problem: Problem, stiff: float) -> Array:
    """Multiplier per parameter bringing unit-stiffness shapes to stiffness ``stiff``."""
    out = np.ones(problem.n_params)
    for i, info in enumerate(problem.model.param_info()):
        if info.unit.startswith("{load}"):
            out[i] = stiff
    return out


def candidates(problem: Problem, cards: NDArray[np.int64]
               ) -> tuple[Array, NDArray[np.int64], list[str], NDArray[np.int64]]:
    """Candidate parameter sets for the given cards.

    Returns the candidates (m, p), the card of each (m,), the kinds present and the kind of
    each candidate (m,) as an index into them.
    """
    model = problem.model
    rows: list[Array] = []
    owners: list[NDArray[np.int64]] = []
    kinds: list[str] = []
    kind_of: list[NDArray[np.int64]] = []
    if problem.residual == "linear":
        lams = _bandwidths(problem, cards)
        theta = _equation_error(problem, cards, lams, model, problem.observe)
        if theta is not None:
            kinds.append("equation error")
            good = np.all(np.isfinite(theta) & (theta > 0), axis=1)
            rows.append(theta[good])
            owners.append(np.repeat(cards, 2 * lams.shape[1])[good])
            kind_of.append(np.full(int(good.sum()), len(kinds) - 1, dtype=np.int64))
        # The limiting models: their own equation-error estimates, mapped to a full-model
        # point next to the limit (the model's own map: a factor 1000 toward it). When the
        # data want a limit the fit starts near it instead of crawling toward it, and it can
        # still come back when they do not.
        names = model.param_names()
        for lim in model.limits:
            if lim.reduced is None or not lim.from_reduced or lim.param not in names:
                continue
            from ...models import model_class

            reduced = model_class(lim.reduced)
            red = _equation_error(problem, cards, lams, reduced, lim.observe)
            if red is None:
                continue
            owner = np.repeat(cards, 2 * lams.shape[1])
            mapped = []
            for row, k in zip(red, owner, strict=True):
                if not np.all(np.isfinite(row) & (row > 0)):
                    continue
                point = lim.full_point(dict(zip(reduced.param_names(), row.tolist(),
                                                strict=True)))
                if point is None:
                    continue
                mapped.append((np.array([point[n] for n in names]), k))
            if mapped:
                arrow = "inf" if lim.direction == "infinity" else "0"
                kinds.append(f"limit {lim.param} -> {arrow}")
                rows.append(np.array([m for m, _k in mapped]))
                owners.append(np.array([k for _m, k in mapped], dtype=np.int64))
                kind_of.append(np.full(len(mapped), len(kinds) - 1, dtype=np.int64))
    if problem.residual == "linear":
        kinds.append("shape grid")
        for k in cards:
            shapes = model.shape_grid(fundamental(problem, int(k)))
            rows.append(shapes)
            owners.append(np.full(shapes.shape[0], k, dtype=np.int64))
            kind_of.append(np.full(shapes.shape[0], len(kinds) - 1, dtype=np.int64))
    kinds.append("heuristic")
    rows.append(np.array([_heuristic(problem, int(k)) for k in cards]))
    owners.append(np.asarray(cards, dtype=np.int64))
    kind_of.append(np.full(cards.size, len(kinds) - 1, dtype=np.int64))
    theta = np.concatenate(rows)
    owner = np.concatenate(owners)
    if problem.fixed:
        for i, value in problem.fixed:
            theta[:, i] = value
    return theta, owner, kinds, np.concatenate(kind_of)
