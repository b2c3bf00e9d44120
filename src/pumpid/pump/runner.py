"""The card runner: how every card of a run is fitted, by ``pumpid fit`` and ``pumpid batch``.

:class:`FitSpec` says what to fit to every card (a manifest keeps it, so a resumed run fits
as the first did); :func:`fit_cards_each` fits a list of cards with it and gives one
:class:`CardOutcome` per card, never an exception for one card's sake: cards sharing their
options are fitted as one batch through :func:`pumpid.fit` (a card's answer does not depend
on its neighbours), an error of the batch is redone card by card, and a card that still
raises is a ``failed`` row saying what was raised. Both commands call it, so they give the
same answers and the same rows.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..cards import Card
from ..job import FitOptions, LevenbergMarquardt, PaperNewton, fit, solver_for
from ..models import Model, model_class
from ..result import FitResult
from .choose import CANDIDATES, choose_model

__all__ = ["FIT_OPTIONS", "CardOutcome", "FitSpec", "fit_cards_each"]


# Options a spec may carry (x0 is the spec's own field): FitOptions' fields and the solver's.
FIT_OPTIONS = ("observe", "integrator", "scale", "residual", "fixed", "solver", "multistart",
               "method", "tol", "max_nfev", "min_r2")


@dataclass(frozen=True)
class FitSpec:
    """What to fit to every card (the options of :func:`pumpid.fit`, as a manifest keeps them).

    Attributes
    ----------
    model : str
        Model name (``"kelvin"``, ``"maxwell"``, ``"msd"``, ...), or ``"auto"``: each card's
        structure chosen by evidence (:func:`pumpid.pump.choose_model`).
    x0 : mapping of str to float, optional
        A shared starting guess (every parameter, and optionally ``C`` / ``D`` and
        ``offset``, which start each card on its own); default: the automatic start.
    initial_state : str or tuple of float, optional
        Default: periodic for single-stroke cards, else rest.
    offset : {"auto", "yes", "no"}
        Fit a position offset; ``"auto"``: for single-stroke (periodic) cards, as ``pumpid
        fit`` does.
    options : mapping
        Further :class:`pumpid.FitOptions` fields (``observe``, ``integrator``,
        ``scale``, ``residual``, ``fixed``, ``multistart``, ``min_r2``) and the solver's
        (``method``: ``"lm"`` or ``"newton-fd"``, ``tol``, ``max_nfev``, or a ``solver``
        object).
    """

    model: str = "kelvin"
    x0: Mapping[str, float] | None = None
    initial_state: str | tuple[float, ...] | None = None
    offset: str = "auto"
    options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def auto(self) -> bool:
        """Each card's structure is chosen by evidence."""
        return self.model == "auto"

    def model_class(self) -> type[Model]:
        """The model class (ValueError for an unknown name; Kelvin, the first candidate's
        family, for ``auto``)."""
        return model_class("kelvin" if self.auto else self.model)

    def model_classes(self) -> tuple[type[Model], ...]:
        """The classes a run's rows may hold: the model's, or every candidate's (auto)."""
        if not self.auto:
            return (self.model_class(),)
        return tuple(dict.fromkeys(model_class(key) for key, _observe in CANDIDATES))

    def start(self) -> Model | type[Model]:
        """The model to fit: the class (automatic start) or the shared starting guess."""
        cls = self.model_class()
        if self.x0 is None:
            return cls
        return cls(**{n: float(self.x0[n]) for n in cls.param_names()})

    def extras(self) -> dict[str, float] | None:
        """The starting scale and offset in ``x0`` (``C``, ``D``, ``offset``), if any."""
        if self.x0 is None:
            return None
        return {k: float(v) for k, v in self.x0.items() if k in ("C", "D", "offset")} or None

    def offset_for(self, card: Card) -> bool:
        """Fit a position offset for this card (auto: for single strokes)."""
        return bool(card.periodic) if self.offset == "auto" else self.offset == "yes"

    def check(self) -> None:
        """Refuse options no card could be fitted with, before any work is done."""
        unknown = sorted(set(self.options) - set(FIT_OPTIONS))
        if unknown:
            raise ValueError(f"unknown fit option(s) {', '.join(unknown)}; known: "
                             f"{', '.join(FIT_OPTIONS)}")
        cls = self.model_class()
        observe = self.options.get("observe")
        cls.output_index(observe)  # ValueError naming the choices
        if self.offset not in ("auto", "yes", "no"):
            raise ValueError(f"offset must be auto, yes or no, got {self.offset!r}")
        if self.auto and (self.x0 is not None or "observe" in self.options):
            raise ValueError("model auto compares the structures and their observed outputs "
                             "itself: give neither observe nor x0")
        if self.options.get("method", "lm") not in ("lm", "newton-fd"):
            raise ValueError(f"method must be lm or newton-fd, got {self.options['method']!r}")
        if self.x0 is not None:
            missing = [n for n in cls.param_names() if n not in self.x0]
            extra = [n for n in self.x0 if n not in (*cls.param_names(), "C", "D", "offset")]
            if missing or extra:
                raise ValueError(f"x0: give exactly the parameters {list(cls.param_names())} "
                                 f"(missing {missing}, unknown {extra})")
            cls(**{n: float(self.x0[n]) for n in cls.param_names()})

    def fit_options(self, offset: bool) -> FitOptions:
        """What the fit of a card means (:meth:`FitOptions.for_cards` with the spec's)."""
        given = {k: v for k, v in self.options.items()
                 if k not in ("solver", "method", "tol", "max_nfev")}
        if "fixed" in given and given["fixed"] is None:
            given.pop("fixed")
        return FitOptions.for_cards(offset=offset, initial_state=self.initial_state, **given)

    def solver(self) -> LevenbergMarquardt | PaperNewton:
        """The solver of the spec's ``solver``, or of ``method`` / ``tol`` / ``max_nfev``."""
        given = self.options.get("solver")
        if given is not None:
            return given
        return solver_for(self.options.get("method", "lm"), tol=self.options.get("tol"),
                          max_nfev=self.options.get("max_nfev"))

    def to_dict(self) -> dict[str, Any]:
        """The manifest's form."""
        return {"model": self.model, "x0": None if self.x0 is None else dict(self.x0),
                "initial_state": (list(self.initial_state)
                                  if isinstance(self.initial_state, tuple)
                                  else self.initial_state),
                "offset": self.offset, "options": dict(self.options)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FitSpec:
        """The spec of :meth:`to_dict`'s form (a manifest's)."""
        state = data.get("initial_state")
        return cls(model=str(data.get("model", "kelvin")), x0=data.get("x0"),
                   initial_state=tuple(state) if isinstance(state, list) else state,
                   offset=str(data.get("offset", "auto")),
                   options=dict(data.get("options") or {}))


@dataclass(frozen=True)
class CardOutcome:
    """One card's answer in a run: its result (None when it could not be fitted), its
    status key and the reason in words."""

    result: FitResult | None
    status: str
    reason: str


def _internal(exc: BaseException) -> str:
    return (f"the fit stopped with an internal error ({type(exc).__name__}: {exc}); this is "
            "a bug in pumpid, please report it with the card")


def _alone(card: Card, spec: FitSpec, offset: bool) -> CardOutcome:
    """One card by itself (model choice, a start with its scale or offset, or a retry)."""
    try:
        options = spec.fit_options(offset)
        if spec.auto:
            res: Any = choose_model(card, options=options, solver=spec.solver()).chosen
        else:
            # x0 with a starting scale or offset: the whole mapping starts this card.
            x0 = dict(spec.x0) if spec.extras() is not None and spec.x0 else None
            res = fit(spec.start(), card, options=options, solver=spec.solver(), x0=x0)
    except MemoryError:
        raise
    except ValueError as exc:
        return CardOutcome(None, "invalid-input", str(exc))
    except Exception as exc:
        return CardOutcome(None, "failed", _internal(exc))
    return CardOutcome(res, res.status.key, res.reason)


def fit_cards_each(cards: Sequence[Card], spec: FitSpec, *, workers: int | None = 1
                   ) -> list[CardOutcome]:
    """Fit every card with ``spec``; one outcome per card, in order.

    Parameters
    ----------
    cards : sequence of Card
    spec : FitSpec
    workers : int, optional
        Threads for a batch (None: every core this process may use).

    Returns
    -------
    list of CardOutcome
        ``invalid-input`` for a card that cannot be fitted as asked (no time, a bad value),
        ``failed`` with the error for one the engine raised on.
    """
    out: list[CardOutcome | None] = [None] * len(cards)
    groups: dict[bool, list[int]] = {}
    for i, card in enumerate(cards):
        groups.setdefault(spec.offset_for(card), []).append(i)
    one_by_one = spec.auto or spec.extras() is not None
    for offset, idx in groups.items():
        # A lone card is fitted as one (the same answer as in a list): its result then
        # keeps the solver's path, which a list's results do not (``pumpid fit
        # --history`` fits the cards one at a time through here).
        if one_by_one or len(idx) == 1:
            for i in idx:
                out[i] = _alone(cards[i], spec, offset)
            continue
        try:
            batch = fit(spec.start(), [cards[i] for i in idx],
                        options=spec.fit_options(offset), solver=spec.solver(),
                        workers=workers)
        except MemoryError:
            raise
        except Exception:
            # An error of the batch must not cost the other cards.
            for i in idx:
                out[i] = _alone(cards[i], spec, offset)
            continue
        for j, i in enumerate(idx):
            res = batch.results[j]
            out[i] = (CardOutcome(None, "invalid-input", batch.invalid[j]) if res is None
                      else CardOutcome(res, res.status.key, res.reason))
    return [o for o in out if o is not None]
