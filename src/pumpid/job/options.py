"""What a fit means (:class:`FitOptions`) and how the job runs it (:class:`JobOptions`).

:class:`FitOptions` is the user's object: frozen, validated when made, and serialisable
(:meth:`FitOptions.to_dict` / :meth:`FitOptions.from_dict`), so a results table or a batch
spec can carry it and give it back unchanged. It holds what changes the answer (the observed
output, the integrator, the residual, the scale, the offset, fixed parameters, the initial
state, the multistart and the quality gate), never how fast it is reached: the solver is its
own object (:class:`~pumpid.engine.solvers.LevenbergMarquardt` or
:class:`~pumpid.engine.solvers.PaperNewton`), the threads an argument of :func:`pumpid.fit`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any, Literal

import numpy as np

from ..engine.solvers import LevenbergMarquardt, PaperNewton
from ..engine.start import StartPlan, WidePlan

__all__ = ["MIN_R2", "START_SAMPLES", "FitOptions", "JobOptions", "job_options", "solver_for"]

Method = Literal["lm", "newton-fd"]
#: The initial states a fit may name (numbers are an explicit state vector).
NAMED_STATES = ("rest", "equilibrium", "periodic")


#: The reason of a card the solver was not run on: no finite point to start from.
NO_START = ("not fitted: the starting point is not a finite number (the record's values, "
             "the output scale or the initial state are beyond what floating point can "
             "compute from: check the units, the output scale and the initial state)")

#: The automatic start looks at no more than this many samples of a card: the first ones of
#: a longer record, every k-th sample of a longer periodic stroke. The start needs the
#: record's dynamics, which a few strokes carry; ranking a hundred candidates over every
#: sample of a long record made it 97 % of the fit (a million samples: about 4 minutes). The
#: solver then runs on the whole record from the start found.
START_SAMPLES = 20_000


#: The default quality gate: a fit that explains less than 95 % of its record's variance is
#: reported as ``poor-fit``. A card the model describes leaves noise and small model errors
#: (389 public real cards, Kelvin observing u: median R^2 0.99986, 1st percentile 0.960, 4
#: below 0.95); swapped columns, a wrong model or a broken record give far less (0.5-0.72 on
#: two public card sets read with position and load exchanged).
MIN_R2 = 0.95


@dataclass(frozen=True)
class JobOptions:
    """The options of the main job that are not part of the problem."""

    method: Method = "lm"
    solver: LevenbergMarquardt = field(default_factory=LevenbergMarquardt)
    newton: PaperNewton = field(default_factory=PaperNewton)
    plan: StartPlan = field(default_factory=StartPlan)
    #: The wider search for cards whose first answer does not explain the data (None: off).
    wide: WidePlan | None = field(default_factory=WidePlan)
    multistart: bool | Literal["auto"] = "auto"
    workers: int | None = 1
    history: bool = False
    boundaries: bool = True
    #: The quality gate: an answer whose R^2 is below this is ``poor-fit``.
    min_r2: float = MIN_R2


def _bad(name: str, value: Any, wanted: str) -> ValueError:
    return ValueError(f"FitOptions.{name} must be {wanted}, got {value!r}")


@dataclass(frozen=True)
class FitOptions:
    """What a fit means: one frozen, validated object for every way a fit comes in.

    Parameters
    ----------
    observe : str, optional
        The observed state (default: the model's, e.g. ``"u"`` for Kelvin).
    integrator : {"exact", "euler"}
        The forward model: exact first-order-hold discretization, or the paper's explicit
        Euler.
    residual : {"linear", "log"}
        ``linear``: C y + offset - data. ``log``: D + ln y - ln data.
    scale : float or "free"
        The output scale factor C, fixed (default 1) or ``"free"``. For models with the
        scale symmetry started from a load-driven state a free C is not identifiable: the
        gauge C = 1 is fixed and a warning says so.
    offset : bool or float
        Fit an additive position offset (True), or subtract a fixed one (a number).
    fixed : mapping of str to float
        Model parameters held at given values; the others are fitted.
    initial_state : {"rest", "equilibrium", "periodic"}, numbers, or None
        The state at the first sample. None (the default) follows the data: the periodic
        steady state for a card that is one stroke or a record given a ``period``, rest for
        anything else.
    period : float, optional
        The stroke period (s) of a periodic record: with ``initial_state`` None it makes
        the record periodic (arrays included); a card brings its own, which this overrides
        when given. Refused beside a state that is not periodic, which would not use it.
    multistart : {"auto", True, False}
        Guard a given starting guess with the automatic start's multistart: ``"auto"`` runs
        from the guess first and falls back to the multistart when that fit failed, explains
        less than 99 % of the data's variance or stays above the data's noise level;
        ``True`` always; ``False`` never.
    min_r2 : float
        The quality gate: an answer whose R^2 is below it has status ``poor-fit`` (its
        numbers are kept, with the reason in words).
    boundaries : bool
        Detect answers at a limit of the model (a parameter running to zero or infinity)
        and test the limiting model; off only to study the raw optimum.
    joint : bool
        For many cards (or records): one parameter set shared by all of them, each keeping
        its own position level (:mod:`pumpid.job.joint`); the answer is one
        :class:`~pumpid.result.FitResult` whose ``application["joint"]`` holds each card's
        part.

    Examples
    --------
    >>> FitOptions.for_cards().offset
    True
    >>> FitOptions(observe="u", fixed={"m": 1.0}).replace(scale="free").scale
    'free'
    """

    observe: str | None = None
    integrator: Literal["exact", "euler"] = "exact"
    residual: Literal["linear", "log"] = "linear"
    scale: float | Literal["free"] = 1.0
    offset: bool | float = False
    fixed: Mapping[str, float] = field(default_factory=dict)
    initial_state: str | tuple[float, ...] | None = None
    period: float | None = None
    multistart: bool | Literal["auto"] = "auto"
    min_r2: float = MIN_R2
    boundaries: bool = True
    joint: bool = False

    def __post_init__(self) -> None:
        if self.observe is not None and not isinstance(self.observe, str):
            raise _bad("observe", self.observe, "a state name or None")
        if self.integrator not in ("exact", "euler"):
            raise _bad("integrator", self.integrator, "'exact' or 'euler'")
        if self.residual not in ("linear", "log"):
            raise _bad("residual", self.residual, "'linear' or 'log'")
        if not (self.scale == "free" or (_is_number(self.scale) and self.scale > 0)):
            raise _bad("scale", self.scale, "a positive number or 'free'")
        if not (isinstance(self.offset, bool) or _is_number(self.offset)):
            raise _bad("offset", self.offset, "True, False or a number (a fixed offset)")
        if not isinstance(self.fixed, Mapping):
            raise _bad("fixed", self.fixed, "a mapping of parameter names to values")
        fixed = {}
        for name, value in self.fixed.items():
            if not (isinstance(name, str) and _is_number(value)):
                raise _bad("fixed", dict(self.fixed), "a mapping of parameter names to numbers")
            fixed[name] = float(value)
        object.__setattr__(self, "fixed", MappingProxyType(fixed))
        state = self.initial_state
        if state is not None and not isinstance(state, str):
            try:
                state = tuple(float(v) for v in np.asarray(state, dtype=float).ravel())
            except (TypeError, ValueError):
                raise _bad("initial_state", self.initial_state,
                           f"one of {NAMED_STATES}, numbers or None") from None
            object.__setattr__(self, "initial_state", state)
        elif isinstance(state, str) and state not in NAMED_STATES:
            raise _bad("initial_state", state, f"one of {NAMED_STATES}, numbers or None")
        if self.period is not None and not (_is_number(self.period) and self.period > 0):
            raise _bad("period", self.period, "a positive number of seconds or None")
        if self.period is not None and self.initial_state not in (None, "periodic"):
            raise ValueError(f"FitOptions: period={self.period!r} is the stroke period of a "
                             f"periodic record; initial_state={self.initial_state!r} would "
                             "not use it (leave initial_state None or give 'periodic')")
        if self.multistart not in ("auto", True, False) or (isinstance(self.multistart, int) \
                and not isinstance(self.multistart, bool)):
            raise _bad("multistart", self.multistart, "'auto', True or False")
        if not (isinstance(self.min_r2, int | float | np.integer | np.floating)
                and not isinstance(self.min_r2, bool) and self.min_r2 <= 1):
            # -inf is allowed: the gate open (every answer passes).
            raise _bad("min_r2", self.min_r2, "a number at most 1 (-inf: no gate)")
        if not isinstance(self.boundaries, bool):
            raise _bad("boundaries", self.boundaries, "True or False")
        if not isinstance(self.joint, bool):
            raise _bad("joint", self.joint, "True or False")

    @classmethod
    def for_cards(cls, **changes: Any) -> FitOptions:
        """The preset for dynamometer cards: a fitted position offset (a card's position
        zero is arbitrary) and the initial state from the card (the periodic steady state
        for one stroke). ``changes`` override fields."""
        return cls(**{"offset": True, **changes})

    def replace(self, **changes: Any) -> FitOptions:
        """A copy with the given fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The options as plain JSON-ready values (inverse of :meth:`from_dict`)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["fixed"] = dict(self.fixed)
        if isinstance(self.initial_state, tuple):
            out["initial_state"] = list(self.initial_state)
        return out

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> FitOptions:
        """Options from :meth:`to_dict`'s output; an unknown key is a ValueError naming it."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"FitOptions: unknown option(s) {unknown}; known: {sorted(known)}")
        return cls(**dict(values))

    def initial_state_for(self, periodic: bool) -> str | tuple[float, ...]:
        """The initial state for a record: the one given, else the data's own (the periodic
        steady state for one stroke, rest otherwise)."""
        if self.initial_state is not None:
            return self.initial_state
        # A period given says the record is one stroke: arrays with period=T were fitted
        # from rest, at 715 times the periodic fit's cost, without a word.
        return "periodic" if periodic or self.period is not None else "rest"


def _is_number(value: Any) -> bool:
    return (isinstance(value, int | float | np.integer | np.floating)
            and not isinstance(value, bool) and math.isfinite(float(value)))


def job_options(options: FitOptions, solver: LevenbergMarquardt | PaperNewton | None, *,
                workers: int | None, history: bool) -> JobOptions:
    """The job's options for a fit: the meaning from ``options``, the solver object as given
    (default :class:`LevenbergMarquardt`; a :class:`PaperNewton` selects the paper's
    method)."""
    if solver is not None and not isinstance(solver, LevenbergMarquardt | PaperNewton):
        raise TypeError("solver must be a LevenbergMarquardt or a PaperNewton (configure the "
                        f"solver through its object), got {solver!r}")
    if isinstance(solver, LevenbergMarquardt) and solver.harmonics:
        raise ValueError(
            f"solver: harmonics={solver.harmonics} makes the solver minimise a search's "
            "approximate cost; a fit reports the exact one (the job uses the harmonic cost "
            "itself where it helps): use LevenbergMarquardt(harmonics=0)")
    newton = isinstance(solver, PaperNewton)
    return JobOptions(
        method="newton-fd" if newton else "lm",
        solver=solver if isinstance(solver, LevenbergMarquardt) else LevenbergMarquardt(),
        newton=solver if isinstance(solver, PaperNewton) else PaperNewton(),
        multistart=options.multistart, workers=workers, history=history,
        boundaries=options.boundaries, min_r2=float(options.min_r2))


def solver_for(method: str = "lm", *, tol: float | None = None, max_nfev: int | None = None,
               eps0: float | None = None, max_iter: int | None = None,
               rel_step: float | None = None) -> LevenbergMarquardt | PaperNewton:
    """The solver object of a method name and its settings (unset: the solver's defaults).

    Raises
    ------
    ValueError
        For an unknown method, or a setting of the other method's solver.
    """
    if method == "lm":
        if eps0 is not None or max_iter is not None or rel_step is not None:
            raise ValueError("eps0, max_iter and rel_step configure method 'newton-fd'")
        return LevenbergMarquardt(**({} if tol is None else {"tol": tol}),
                                  max_evaluations=max_nfev)
    if method == "newton-fd":
        if tol is not None or max_nfev is not None:
            raise ValueError("tol and max_nfev configure method 'lm'")
        given = {"eps0": eps0, "max_iter": max_iter, "rel_step": rel_step}
        return PaperNewton(**{k: v for k, v in given.items() if v is not None})
    raise ValueError(f"method must be 'lm' or 'newton-fd', got {method!r}")
