"""Which model structure does a card want? Fit the candidates and rank them by evidence.

Each candidate structure (a model and the output it observes) is fitted to the card by the
main job. They are ranked by an information criterion computed on the residuals' effective
sample size: residuals of a card are serially correlated (model error more than noise), and
counting every sample as independent evidence would make every extra parameter look
decisive. With ``rho`` the lag-1 autocorrelation of the best candidate's residuals,

    n_eff = n (1 - rho) / (1 + rho)   (AR(1) variance inflation; 5 <= n_eff <= n),

    -2 ln L = n_eff ln(RSS / n),   BIC = -2 ln L + k ln(n_eff),
    AICc = -2 ln L + 2 k + 2 k (k + 1) / (n_eff - k - 1),

with ``k`` the fitted values (parameters, offset, scale). The structure with the lowest
criterion is chosen (BIC by default: it picks the generating structure ever more surely as
the evidence grows, where AIC keeps a fixed chance of an extra parameter). Between nested
structures (a model and its limit, as the models declare them: mass-spring-dashpot is
Kelvin's k0 -> infinity and Maxwell's k1 -> infinity) a likelihood-ratio test on the same
effective sample size decides too: the best-ranked structure is chosen only if it rejects
every structure nested in it at the 1 % level; otherwise the smallest of those is.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.special

from ..cards import Card
from ..inference.uncertainty import lag1
from ..job import FitOptions, fit
from ..models import MODELS, model_class
from ..result import FitResult, Status, model_choice_text

__all__ = ["CANDIDATES", "Candidate", "ModelChoice", "NestedTest", "choose_model"]

#: The structures ``--model auto`` compares: (model key, observed output).
CANDIDATES: tuple[tuple[str, str], ...] = (
    ("msd", "u"), ("kelvin", "u"), ("kelvin", "u2"), ("maxwell", "u"))

_USABLE = (Status.CONVERGED, Status.BOUNDARY, Status.UNDETERMINED, Status.POOR_FIT)
#: A structure is preferred over one nested in it only when the likelihood-ratio test
#: rejects the nested one at this level.
NESTED_LEVEL = 0.01


def _label(key: str, observe: str) -> str:
    cls = model_class(key)
    return f"{key} ({observe})" if len(cls.outputs) > 1 else key


@dataclass(frozen=True)
class Candidate:
    """One candidate structure's fit and its place in the ranking."""

    name: str
    model: str
    observe: str
    result: FitResult | None
    k: int
    rss: float
    r2: float
    bic: float
    aicc: float
    delta: float
    weight: float
    status: str
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (without the fit itself)."""
        return {"name": self.name, "model": self.model, "observe": self.observe,
                "k": self.k, "rss": self.rss, "r2": self.r2, "bic": self.bic,
                "aicc": self.aicc, "delta": self.delta, "weight": self.weight,
                "status": self.status, "reason": self.reason}


@dataclass(frozen=True)
class NestedTest:
    """Likelihood-ratio test of a structure against its limit (the smaller one)."""

    small: str
    big: str
    limit: str
    statistic: float
    dof: int
    p_value: float

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {"small": self.small, "big": self.big, "limit": self.limit,
                "statistic": self.statistic, "dof": self.dof, "p_value": self.p_value}


@dataclass(frozen=True)
class ModelChoice:
    """The candidates ranked, the chosen structure's fit, and the nested tests.

    Attributes
    ----------
    chosen : FitResult
        The chosen structure's fit (the first candidate); its
        ``application["model_choice"]`` holds this ranking's JSON form, so reports and
        ``to_dict()`` show it.
    candidates : tuple of Candidate
        The chosen one first, then by the criterion.
    tests : tuple of NestedTest
    criterion : {"bic", "aicc"}
    n : int
        Samples; ``n_eff_data`` the effective sample size, ``n (1 - rho) / (1 + rho)``
        with ``rho`` the residuals' lag-1 autocorrelation, and ``n_eff`` the size the
        criteria used: the same, but never below k + 3 (largest k) nor 5.
    """

    chosen: FitResult
    candidates: tuple[Candidate, ...]
    tests: tuple[NestedTest, ...]
    criterion: str
    n: int
    n_eff: float
    rho: float
    n_eff_data: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (the ranking and the tests; the chosen fit is the result itself)."""
        return {"criterion": self.criterion, "chosen": self.candidates[0].name,
                "n": self.n, "n_eff": self.n_eff, "n_eff_data": self.n_eff_data,
                "rho": self.rho,
                "candidates": [c.to_dict() for c in self.candidates],
                "nested_tests": [t.to_dict() for t in self.tests]}

    def table(self) -> str:
        """The ranking and the tests as text."""
        return model_choice_text(self.to_dict())


def _lag1(r: np.ndarray, circular: bool) -> float:
    # Around the period on a periodic card, as the fit's own whiteness check reads it (the
    # two had said 0.954 and 0.97 of one card's residuals).
    rho = lag1(r, circular)
    return 0.0 if math.isnan(rho) else rho


def _n_fitted(res: FitResult) -> int:
    return len(res.free)


def choose_model(
    card: Card,
    candidates: Sequence[tuple[str, str]] = CANDIDATES,
    *,
    criterion: str = "bic",
    options: FitOptions | None = None,
    solver: Any = None,
) -> ModelChoice:
    """Fit each candidate structure to a card and choose by an information criterion.

    Parameters
    ----------
    card : Card
    candidates : sequence of (model key, observed output)
        Default :data:`CANDIDATES`: mass-spring-dashpot, Kelvin observing u and u2, Maxwell.
    criterion : {"bic", "aicc"}
        What ranks them (both are reported).
    options : FitOptions, optional
        The fit's options for every candidate (default :meth:`FitOptions.for_cards`); each
        candidate sets its own observed output, so ``options.observe`` must be None.
    solver : LevenbergMarquardt or PaperNewton, optional
        As for :func:`pumpid.fit`.

    Returns
    -------
    ModelChoice

    Raises
    ------
    ValueError
        For an unknown criterion or candidate, or when no candidate could be fitted.
    """
    if criterion not in ("bic", "aicc"):
        raise ValueError(f"criterion must be 'bic' or 'aicc', got {criterion!r}")
    options = FitOptions.for_cards() if options is None else options
    if options.observe is not None:
        raise ValueError("choose_model: each candidate sets its own observed output")
    for key, observe in candidates:
        if key not in MODELS or observe not in model_class(key).outputs:
            raise ValueError(f"unknown candidate structure {key!r} observing {observe!r}")
    fits: list[tuple[str, str, FitResult | None, str]] = []
    for key, observe in candidates:
        try:
            res = fit(key, card, options=options.replace(observe=observe), solver=solver)
        except ValueError as exc:
            fits.append((key, observe, None, str(exc)))
            continue
        fits.append((key, observe, res, res.reason))
    usable = [(key, obs, res) for key, obs, res, _ in fits
              if res is not None and res.status in _USABLE and math.isfinite(res.cost)
              and res.cost > 0]
    if not usable:
        reasons = "; ".join(f"{_label(k, o)}: {why}" for k, o, _r, why in fits)
        raise ValueError(f"{card.card_id}: no candidate structure could be fitted ({reasons})")
    best = min(usable, key=lambda item: item[2].cost)[2]
    n = int(best.data.size)
    rho = _lag1(np.asarray(best.fitted) - np.asarray(best.data),
                best.initial_state == "periodic")
    k_max = max(_n_fitted(r) for _k, _o, r in usable)
    n_data = float(n * (1 - rho) / (1 + rho) if rho > 0 else n)
    # The criteria need n_eff > k + 1 (AICc's correction); below that the data's own
    # effective size is reported beside the floor the ranking used.
    n_eff = float(min(n, max(n_data, k_max + 3, 5)))
    rows = []
    for key, observe, res, why in fits:
        name = _label(key, observe)
        if res is None or res.status not in _USABLE or not (res.cost > 0):
            rows.append(dict(name=name, model=key, observe=observe, result=res, k=0,
                             rss=math.nan, r2=math.nan, bic=math.inf, aicc=math.inf,
                             status=res.status.key if res is not None else "invalid-input",
                             reason=why))
            continue
        k = _n_fitted(res)
        rss = 2.0 * res.cost
        m2ll = n_eff * math.log(rss / n)
        bic = m2ll + k * math.log(n_eff)
        aicc = m2ll + 2 * k + (2 * k * (k + 1) / (n_eff - k - 1) if n_eff - k - 1 > 0
                               else math.inf)
        rows.append(dict(name=name, model=key, observe=observe, result=res, k=k, rss=rss,
                         r2=res.r2, bic=bic, aicc=aicc, status=res.status.key, reason=why))
    score = [r[criterion] for r in rows]
    top = min(score)
    weights = [math.exp(-0.5 * (s - top)) if math.isfinite(s) else 0.0 for s in score]
    total = sum(weights)
    ranked = sorted(
        (Candidate(delta=s - top, weight=w / total, **r)
         for r, s, w in zip(rows, score, weights, strict=True)),
        key=lambda c: (c.delta, c.k))
    tests = _nested_tests(ranked, n, n_eff)
    ranked = _parsimony(ranked, tests)
    chosen = ranked[0].result
    assert chosen is not None  # a finite criterion comes from a usable fit
    choice = ModelChoice(chosen=chosen, candidates=tuple(ranked), tests=tests,
                         criterion=criterion, n=n, n_eff=n_eff, rho=rho,
                         n_eff_data=min(n_data, float(n)))
    application = {**chosen.application, "model_choice": choice.to_dict()}
    return dataclasses.replace(choice, chosen=chosen.with_parts(application=application))


def _parsimony(ranked: list[Candidate], tests: Sequence[NestedTest]) -> list[Candidate]:
    """The best-ranked structure, unless a structure nested in it is not rejected.

    The criterion alone would pick a bigger structure over the one nested in it by chance
    now and then; a bigger structure must also beat its limit by the likelihood-ratio test
    at :data:`NESTED_LEVEL`. The chosen one is put first; the others keep their order.
    """
    top = ranked[0]
    kept = [t for t in tests if t.big == top.name and t.p_value > NESTED_LEVEL]
    if not kept:
        return ranked
    names = {t.small for t in kept}
    smaller = [c for c in ranked if c.name in names]
    best = min(smaller, key=lambda c: (c.k, c.delta))
    return [best, *(c for c in ranked if c is not best)]


def _nested_tests(ranked: Sequence[Candidate], n: int, n_eff: float
                  ) -> tuple[NestedTest, ...]:
    """Likelihood-ratio tests for every candidate pair the models declare nested."""
    by_structure = {(c.model, c.observe): c for c in ranked if math.isfinite(c.rss)}
    out = []
    for (key, observe), big in by_structure.items():
        for lim in model_class(key).limits:
            if not lim.reduced:
                continue
            small = by_structure.get((lim.reduced, lim.observe or observe))
            if small is None or small.k >= big.k:
                continue
            stat = max(n_eff * math.log(small.rss / big.rss), 0.0)
            dof = big.k - small.k
            out.append(NestedTest(small=small.name, big=big.name,
                                  limit=lim.named(observe), statistic=stat,
                                  dof=dof, p_value=float(scipy.special.chdtrc(dof, stat))))
    return tuple(out)
