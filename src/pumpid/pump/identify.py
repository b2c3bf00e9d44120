"""The pump identified from the surface card: the system model fitted through the engine.

For each card, :func:`identify_cards` fits :class:`~pumpid.pump.system.PumpSystem` (rod
string and valve pump driven by the measured position, predicting the measured load) with
:func:`pumpid.fit`: the same solver, statuses, boundary marks, errors that hold under
correlated residuals and identifiability in words as every other fit. It then

* computes the diagnostic pump card (Gibbs' Fourier method) with the damping the card chose
  (or the one given), so the downhole path uses the data's damping too, and says which;
* checks the fitted pump card against that diagnostic one (RMS difference over the load
  range, after a constant: the load offset is a constant at the pump as at the surface);
* gives each pump quantity with its standard error and unit, the damping likewise, the
  surface-load fit's R^2 and its residuals' lag-1 autocorrelation, and the card's energy
  balance (the surface card's work per stroke, the pump card's, and what the string lost).

A card whose fitted liquid fraction is near 1 is also fitted as a full pump: its barrel then
holds no gas, so the intake ratio (how hard the gas is to compress) cannot move the card;
both are held (liquid fraction 1, intake ratio at its start value). The full pump is kept when
it fits as well (a likelihood-ratio test at 95 %), and said so.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..cards import Card
from ..job import FitOptions, LevenbergMarquardt, fit
from ..result import FitResult
from ..rods import (
    DAMPING_UNIT,
    DEFAULT_DAMPING,
    DownholeResult,
    Well,
    WellFile,
    diagnose_cards,
    loop_work,
    quantity_units,
    wells_for,
)
from .system import (
    ELEMENTS,
    QUANTITIES,
    SEARCH_ELEMENTS,
    START_INTAKE_RATIO,
    PumpSystem,
    SurfaceCard,
)

__all__ = ["SHOWN", "PumpFit", "discretization_errors", "finer", "identify_card", "identify_cards",
           "solver_difference"]

Array = NDArray[np.float64]

#: The pump quantities of a card, in the order output gives them.
SHOWN = ("fluid_load", "fillage", "gross_stroke", "net_stroke", "displacement",
         "intake_pressure")
#: A fitted liquid fraction from which the card is also tried as a full pump.
FULL_PUMP = 0.98
#: 95 % quantile of chi-square with two degrees of freedom (the full pump holds two).
LR_TWO = 5.991
#: A second-order march's error against the continuous string, per unit of its change from
#: N to 2N elements: e_N = (4/3) (q_N - q_2N).
RICHARDSON = 4.0 / 3.0
#: The finer march of :func:`discretization_errors` stops when its stroke repeats to this
#: (of the load range): the change it measures is about 1e-3 of the range, so this leaves
#: it within about 1 %. Measured on 40 simulated cards against 1e-7: every parameter's and
#: quantity's estimate within 2.6 %, 3.8 strokes of the finer march instead of 5.3.
DISCRETIZATION_TOL = 1e-5
#: The solver's noise test (see :class:`pumpid.LevenbergMarquardt`): stop when a full
#: Gauss-Newton step would gain less than this fraction of the residual variance, i.e. the
#: answer is within sqrt(2 x NOISE_TOL) = 0.045 standard errors of the optimum. The
#: march's finite-difference sensitivities (relative error about 1e-3) leave a gradient
#: that never vanishes to the default's 1e-6: the fit then spent half its evaluations in
#: rejected steps at a cost already settled to six digits.
NOISE_TOL = 1e-3
#: The stop tests' relative tolerance: a cost change of 1e-7 of itself moves the answer by
#: sqrt(N x 1e-7), about 0.005 standard errors on a 200-sample card; below it MINPACK's
#: tests (default 1e-12) only chased the march's own noise.
SOLVER_TOL = 1e-7
SOLVER = LevenbergMarquardt(tol=SOLVER_TOL, noise_tol=NOISE_TOL)
#: The search's noise test (on the coarse march): within sqrt(2 x 0.05) = 0.32 standard
#: errors of its optimum, which is itself about one from the answer the final fit finds.
#: Tighter searches took more evaluations here and as many in the final fit.
SEARCH_NOISE_TOL = 0.05
#: Evaluations a search fit may take. On 120 simulated cards a search took 5 (median), 14
#: (p90), 35 at most; a full pump's free search could crawl for hundreds, its liquid
#: fraction at 1 and the intake ratio moving nothing (the full-pump fit that follows takes
#: over, and the final fit goes on from wherever a search stopped).
SEARCH_EVALUATIONS = 20
SEARCH_SOLVER = LevenbergMarquardt(tol=SOLVER_TOL, noise_tol=SEARCH_NOISE_TOL,
                                   max_evaluations=SEARCH_EVALUATIONS)


@dataclass(frozen=True, eq=False)
class PumpFit:
    """The pump identified from one surface card.

    Attributes
    ----------
    card : Card
    status : str
        The fit's status (``converged``, ``boundary``, ``poor-fit``, ...), or
        ``invalid-input`` / ``failed`` when the card could not be fitted.
    reason : str
    well : Well or None
    fit : FitResult or None
        The system model's fit (parameters, errors, identifiability, residuals).
    model : PumpSystem or None
        The fitted model (its pump card, its march).
    downhole : DownholeResult or None
        The diagnostic pump card at the damping used.
    damping_rule : str
        Where the diagnostic's damping came from.
    full_pump : bool
        The card was fitted as a full pump (liquid fraction held at 1).
    discretization : dict of str to float
        The march's own error in each parameter and pump quantity (in its unit), estimated
        from a march with twice the elements (see :func:`discretization_errors`); the errors
        shown include it.
    evaluations : int
        Model evaluations of the whole identification: the searches' and the final fit's
        (``fit.nfev`` counts the final fit's alone).
    fine : PumpSystem or None
        The fitted model on twice the elements (the march of
        :func:`discretization_errors`): it draws the pump card shown and checks the
        solvers (``agreement``, ``consistency``).
    notes : tuple of str

    Notes
    -----
    The pump card shown (:meth:`pump_card`), ``agreement`` and ``consistency`` are worked
    out when first asked for, a batch uses none of them. The card is drawn by the finer
    march at the fitted values: closer to the continuous string than the fit's own march
    (a fluid pound's sharp pickup is what the elements round most), by about the march's
    error that the quantities' errors already hold.
    """

    card: Card
    status: str
    reason: str = ""
    well: Well | None = None
    fit: FitResult | None = None
    model: PumpSystem | None = None
    downhole: DownholeResult | None = None
    damping_rule: str = ""
    fine: PumpSystem | None = field(default=None, repr=False)
    full_pump: bool = False
    discretization: dict[str, float] = field(default_factory=dict)
    evaluations: int = 0
    notes: tuple[str, ...] = field(default=())

    @functools.cached_property
    def agreement(self) -> float:
        """RMS difference between the fitted pump card (:meth:`pump_card`) and the
        diagnostic one, after a constant, over the diagnostic card's load range (NaN when
        either is missing or the diagnostic's loads are not effective ones). It holds the
        surface residual carried down the string as well as any disagreement of the two
        solvers: see :attr:`consistency`."""
        drawn, down = self._drawn, self.downhole
        if (drawn is None or down is None or not down.ok or down.pump_load is None
                or down.convention != "effective"):
            return math.nan
        return _apart(drawn[2], down, drawn[0].surface)

    @functools.cached_property
    def consistency(self) -> float:
        """The same difference as :attr:`agreement`, between the fitted pump card and the
        diagnostic pump card of the *fitted* surface load (the march's that drew the card,
        at the fitted damping, both cards in the band of the harmonics that drive the
        march): the predictive and the diagnostic solvers on one surface card, so what
        remains is their own disagreement (mostly the march's elements), not the fit's
        residual (NaN when it cannot be computed; see :func:`solver_difference`). A
        diagnostic card more, about 4 % of an identification."""
        drawn, down = self._drawn, self.downhole
        if drawn is None:
            return math.nan
        method = down.method if down is not None else "fourier"
        try:
            return float(solver_difference(drawn[0], _values(self.fit), method=method))
        except (ArithmeticError, ValueError):
            return math.nan  # the march reaches no stroke there: nothing to compare

    @functools.cached_property
    def _drawn(self) -> tuple[PumpSystem, Array, Array] | None:
        # The model that drew the card, and the card in the card's units. The finer march
        # first; the fit's own if that reaches no periodic stroke.
        if not self.ok:
            return None
        for model in (self.fine, self.model):
            if model is None:
                continue
            try:
                pos, load = model.pump_card(_values(self.fit))
            except (ArithmeticError, ValueError):
                continue
            s = model.surface
            return model, pos / s.position_factor, load / s.load_factor
        return None

    @property
    def ok(self) -> bool:
        """The system model was fitted (whatever its status says of the fit)."""
        return self.fit is not None and self.model is not None

    def quantities(self) -> dict[str, dict[str, Any]]:
        """Each pump quantity as ``{"value", "stderr", "unit", "determined"}``: the fluid
        load is the fitted parameter, the others are measured on the fitted pump card
        (errors by the delta method). ``determined`` follows the lumped fits' rule: the
        fit calls it determined and its error (the march's own included) is at most its
        value. Empty when the card was not fitted."""
        if not self.ok or self.well is None:
            return {}
        assert self.fit is not None
        units = quantity_units(self.well, self.card)
        out: dict[str, dict[str, Any]] = {}
        for name in SHOWN:
            if name == "fluid_load":
                value, se = self.fit.params[name], _stderr(self.fit, name)
                called = name in self.fit.determined.get("parameters", ())
            else:
                d = self.fit.derived.get(name)
                value = math.nan if d is None else d.value
                se = math.nan if d is None else d.stderr
                called = d is not None and d.determined
            se = math.hypot(se, self.discretization.get(name, 0.0))
            # A full pump's fillage is its held liquid fraction, not a measurement: it read
            # "1 +- 9.9e-06, determined" on a card whose identification was undetermined.
            held = name == "fillage" and self.full_pump
            if held:
                se = math.nan
            # An intake pressure of 4014 +- 1e4 kPa was shown as a used value.
            determined = bool(called and math.isfinite(se) and se <= abs(value))
            out[name] = {"value": _num(value), "stderr": _num(se), "unit": units[name][0],
                         "determined": determined, "held": held}
        return out

    def damping(self, used: bool = True) -> dict[str, Any]:
        """The damping used, ``{"value", "stderr", "unit", "rule"}`` (stderr None when given
        or not identified); with ``used=False`` the fit's own, whatever the diagnostic card
        used (a poor fit's quantities come with the damping that made them)."""
        fitted = self.fit.params["damping"] if self.fit is not None else math.nan
        value = (self.downhole.damping if self.downhole is not None and used else fitted)
        # The fit's error belongs to the fitted value only: not to a default rule's value
        # used instead, nor to a damping held in the fit.
        held = self.fit is not None and "damping" not in self.fit.free
        se = (math.hypot(_stderr(self.fit, "damping"), self.discretization.get("damping", 0.0))
              if value == fitted and not held else math.nan)
        return {"value": _num(value), "stderr": _num(se), "unit": DAMPING_UNIT,
                "rule": self.damping_rule}

    def energy(self) -> dict[str, Any]:
        """The energy balance of the stroke, in the card's load x position unit: the
        measured surface card's work, the fitted surface card's, the fitted pump card's
        (these two of the fit's own march, so that their difference is the model's loss),
        and the share of the surface work the string lost (by the fit); then the
        diagnostic pump card's work (the measured card taken down at the damping used) and
        the share of the measured work lost on the way (``measured_loss``). The two losses
        agree when the damping is consistent with the energy the measured card loses in the
        string."""
        if not self.ok:
            return {}
        assert self.fit is not None and self.model is not None
        s = self.model.surface
        kl, kp = s.load_factor, s.position_factor
        unit = f"{self.card.load_unit}*{self.card.position_unit}"
        measured = loop_work(s.position, s.load) / (kl * kp)
        fitted = loop_work(s.position, np.asarray(self.fit.fitted) * kl) / (kl * kp)
        try:
            pos, load = self.model.pump_card(_values(self.fit))
        except (ArithmeticError, ValueError):
            pump = math.nan  # no periodic stroke at the fitted values: no pump card's work
        else:
            pump = loop_work(pos, load) / (kl * kp)
        down = math.nan
        d = self.downhole
        if d is not None and d.ok and d.pump_position is not None and d.pump_load is not None:
            # In time order, as the surface card's work above (the file may run backwards).
            step = -1 if s.reversed else 1
            down = float(loop_work(np.asarray(d.pump_position, dtype=float)[None, ::step],
                                   np.asarray(d.pump_load, dtype=float)[None, ::step])[0])
        return {"surface_work": _num(measured), "fitted_surface_work": _num(fitted),
                "pump_work": _num(pump),
                "string_loss": _num((fitted - pump) / fitted if fitted else math.nan),
                "diagnostic_pump_work": _num(down),
                "measured_loss": _num((measured - down) / measured if measured else math.nan),
                # The works' unit; the two losses are shares of a work (one "unit" beside
                # them read as if they were kN*m too).
                "unit": unit, "loss_unit": "fraction"}

    def pump_card(self) -> tuple[Array, Array] | None:
        """The fitted pump card in the card's units: plunger position (from its lowest
        point) and effective pump load, at the card's samples in time order, drawn by the
        finer march (see the class's notes; by the fit's own where the finer one reaches no
        periodic stroke); None when the card was not fitted or neither march reaches one at
        the fitted values."""
        drawn = self._drawn
        return None if drawn is None else (drawn[1], drawn[2])

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: status, the pump quantities with errors, the damping, the
        surface-load fit (R^2, lag-1 autocorrelation of its residuals) and the parameters."""
        out: dict[str, Any] = {"status": self.status, "reason": self.reason}
        if not self.ok:
            return out
        assert self.fit is not None
        f = self.fit
        white = f.uncertainty.whiteness if f.uncertainty is not None else None
        units = {p.name: p.unit for p in self.model.parameters} if self.model else {}
        out.update({
            "pump": self.quantities(),
            "damping": self.damping(),
            "r2": _num(f.r2),
            "rmse": {"value": _num(f.rmse), "unit": self.card.load_unit},
            "residual_autocorrelation": None if white is None else _num(
                white.get("lag1_autocorrelation", math.nan)),
            "parameters": {n: {"value": _num(v), "stderr": _num(_stderr(f, n)),
                               "unit": units.get(n, ""),
                               "determined": n in f.determined.get("parameters", ())}
                           for n, v in f.params.items()},
            "full_pump": self.full_pump,
            "evaluations": self.evaluations,
            "agreement": _num(self.agreement),
            "consistency": _num(self.consistency),
            "energy": self.energy(),
            "identifiability": list(f.identifiability),
            "warnings": list(f.warnings),
            "notes": list(self.notes),
        })
        return out


def _num(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _stderr(result: FitResult | None, name: str) -> float:
    if result is None or result.uncertainty is None:
        return math.nan
    # The error shown (the robust one where the residuals are serially correlated).
    value = result.uncertainty.stderr.get(name, math.nan)
    return math.nan if value is None else float(value)


def _fit_one(surface: SurfaceCard, damping: float | None
             ) -> tuple[PumpSystem, FitResult, bool, int]:
    """Search on the coarse march (:data:`SEARCH_ELEMENTS`), then fit the model's own march
    (:data:`ELEMENTS`) from the search's answer.

    Returns the fitted model, its fit, whether it is the full pump and the model
    evaluations of the searches and the fits.
    """
    search = PumpSystem(surface, SEARCH_ELEMENTS, derive=False)
    final: FitResult | None = None
    spent = 0
    try:
        found, fixed, full, spent = _search(search, surface, damping)
    except (ValueError, ArithmeticError):
        pass  # no start reaches a periodic stroke of the coarse march: see below
    else:
        model = PumpSystem(surface, ELEMENTS)
        model.start_from(search)
        try:
            final = fit(model, surface, options=FitOptions(fixed=fixed), x0=found,
                        solver=SOLVER)
        except (ValueError, ArithmeticError):
            final = None
        else:
            spent += final.nfev
    if final is None or str(final.status) == "failed":
        # The coarse march found nothing, or the model's march reaches no periodic stroke
        # at the search's answer or beside it, from the search's stroke nor from rest (a
        # nonlinear pump can settle elsewhere from another start): the search again, on
        # the model's march itself, from its own starts, each march starting from the one
        # before.
        model = PumpSystem(surface, ELEMENTS, derive=False)
        found, fixed, full, more = _search(model, surface, damping)
        model.derive = True
        final = fit(model, surface, options=FitOptions(fixed=fixed), x0=found, solver=SOLVER)
        spent += more + final.nfev
    return model, final, full, spent


def _search(model: PumpSystem, surface: SurfaceCard, damping: float | None
            ) -> tuple[Array, dict[str, float], bool, int]:
    """The optimum of ``model`` from its automatic start (the damping held if given), as a
    full pump when that fits as well: the values, the parameters held, whether full, and
    the model evaluations spent."""
    fixed = {} if damping is None else {"damping": float(damping)}
    x0 = None
    if damping is not None:
        x0 = model.start(surface)
        x0[:, 1] = float(damping)
    # The search skips the boundary tests: the final fit makes them where it ends.
    quick = FitOptions(fixed=fixed, boundaries=False)
    res = fit(model, surface, options=quick, x0=x0, solver=SEARCH_SOLVER)
    if not res.params["liquid_fraction"] >= FULL_PUMP:
        return _values(res), fixed, False, res.nfev
    # Nearly full: fitted again as a full pump (no gas, so the intake ratio moves nothing;
    # both held), kept when it fits as well (likelihood ratio, 95 %, two parameters fewer).
    start = _values(res)
    start[2] = 1.0
    start[3] = START_INTAKE_RATIO
    held = {**fixed, "liquid_fraction": 1.0, "intake_ratio": float(start[3])}
    try:
        full = fit(model, surface, options=quick.replace(fixed=held), x0=start,
               solver=SEARCH_SOLVER)
    except (ValueError, ArithmeticError):
        # No periodic full-pump stroke: the free fit stands.
        return _values(res), fixed, False, res.nfev
    n, q = np.asarray(res.data).size, len(res.free)
    sigma2 = 2.0 * res.cost / max(n - q, 1)
    spent = res.nfev + full.nfev
    if math.isfinite(full.cost) and 2.0 * (full.cost - res.cost) <= LR_TWO * sigma2:
        return _values(full), held, True, spent
    return _values(res), fixed, False, spent


def _values(res: FitResult) -> Array:
    return np.array(list(res.params.values()), dtype=float)


def identify_cards(cards: Sequence[Card], wells: Well | WellFile | Sequence[Well], *,
                   damping: float | None = None, harmonics: int | None = None,
                   method: str = "fourier", convention: str = "effective",
                   workers: int = 1) -> list[PumpFit]:
    """Identify the pump of each surface card (see the module's text).

    Parameters
    ----------
    cards : sequence of Card
        Surface cards with units and time (one stroke each, uniform in time).
    wells : Well, WellFile or sequence of Well
        One well for every card, a well file (matched by well id), or one well per card.
    damping : float, optional
        Hold Gibbs' damping factor at this value instead of identifying it.
    harmonics, method, convention
        Options of the diagnostic pump card computed with the damping used
        (:func:`pumpid.rods.diagnose_cards`).
    workers : int
        Cards identified at once (threads).

    Returns
    -------
    list of PumpFit
        One per card, in order; a card that cannot be fitted has status ``invalid-input``
        or ``failed`` and the reason, and never stops the others.
    """
    if damping is not None and not (math.isfinite(damping) and damping > 0):
        raise ValueError(f"damping must be a positive number to hold it in the fit, got "
                         f"{damping}")
    diag = {"harmonics": harmonics, "method": method, "convention": convention}
    pairs = list(zip(cards, wells_for(cards, wells), strict=True))
    if workers <= 1 or len(pairs) < 2:
        return [_identify(card, well, damping, diag) for card, well in pairs]
    # Threads, not processes: the march (most of a card's time) releases the GIL, and the
    # cards' wells and results need no pickling.
    with ThreadPoolExecutor(max_workers=int(workers)) as pool:
        return list(pool.map(lambda pair: _identify(pair[0], pair[1], damping, diag), pairs))


def _identify(card: Card, well: Well | Exception, damping: float | None,
              diag: dict[str, Any]) -> PumpFit:
    if isinstance(well, Exception):
        return PumpFit(card=card, status="invalid-input", reason=str(well))
    try:
        surface = SurfaceCard.of(card, well)
    except ValueError as exc:
        return PumpFit(card=card, status="invalid-input", reason=str(exc), well=well)
    try:
        model, res, full, spent = _fit_one(surface, damping)
    except MemoryError:
        raise
    except (ValueError, ArithmeticError) as exc:
        return PumpFit(card=card, status="failed", well=well,
                       reason=f"the system model could not be fitted: {exc}")
    return _finish(card, well, surface, model, res, full, damping, diag, spent)


def identify_card(card: Card, well: Well | WellFile, **options: Any) -> PumpFit:
    """The pump of one surface card (see :func:`identify_cards` for the options)."""
    return identify_cards([card], well, **options)[0]


def _finish(card: Card, well: Well, surface: SurfaceCard, model: PumpSystem, res: FitResult,
            full: bool, damping: float | None, diag: dict[str, Any], spent: int) -> PumpFit:
    notes = list(surface.notes)
    fine = finer(model)
    try:
        grid_error = discretization_errors(surface, model, res, fine=fine)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        grid_error = {}
        notes.append(f"the march's own error could not be estimated ({exc}); the errors "
                     "shown are the statistical ones alone")
    nu = float(res.params["damping"])
    se = math.hypot(_stderr(res, "damping"), grid_error.get("damping", 0.0))
    usable = str(res.status) in ("converged", "boundary")
    if damping is not None:
        rule = f"given: nu = {damping:g}"
    elif usable and "damping" in res.determined.get("parameters", ()):
        rule = f"identified from the card: nu = {nu:.4g} +- {se:.2g}"
    elif usable:
        rule = (f"identified from the card, not determined by it: nu = {nu:.4g} (standard "
                f"error {se:.2g}); the card cannot tell the damping")
    else:
        nu = DEFAULT_DAMPING
        rule = (f"default rule: nu = {DEFAULT_DAMPING:g} (the identification's status is "
                f"{res.status}, so its damping is not used)")
    if full:
        notes.append("a full pump: fitted with the liquid fraction held at 1 (it fits as well "
                     "as with it free); the barrel then holds no gas, so the intake ratio "
                     "cannot move the card and is held too")
    down = diagnose_cards([card], well, damping=nu, **diag)[0]
    down = DownholeResult(**{**down.__dict__, "damping_rule": rule})
    return PumpFit(card=card, status=str(res.status), discretization=grid_error,
                   reason=res.reason, well=well, fit=res, model=model, downhole=down,
                   damping_rule=rule, fine=fine, full_pump=full, evaluations=spent,
                   notes=tuple(dict.fromkeys(notes)))


def solver_difference(model: PumpSystem, values: Array, method: str = "fourier") -> float:
    """How far the predictive model's pump card lies from the diagnostic solver's pump card
    of the model's own surface card: the two solvers on one surface card.

    The model's surface load at ``values`` is put in place of the card's measured load and
    taken down the string by :func:`pumpid.rods.diagnose_cards` (at the model's damping,
    with the harmonics that drive its march); both pump cards are compared in that band,
    as an RMS difference after a constant over the diagnostic card's load range. What is
    left is the solvers' own disagreement, not a fit's residual: mostly the march's
    elements (it about halves as they double).

    Parameters
    ----------
    model : PumpSystem
        The model, with its card and well.
    values : ndarray
        Its parameter values (the order of ``model.parameters``).
    method : {"fourier", "fd"}
        The diagnostic solver's method.

    Returns
    -------
    float
        The difference, as a fraction of the load range (NaN when the diagnostic cannot
        compute the card).

    Raises
    ------
    ArithmeticError, ValueError
        The march reaches no periodic stroke at ``values``, or they are out of range.
    """
    surface = model.surface
    values = np.asarray(values, dtype=float)
    load, _ = model.simulate(values, surface, False)
    got = model.pump_card(values)[1] / surface.load_factor
    own_card = surface.card.replace(load=load[::-1] if surface.reversed else load,
                                    note="the load replaced by the model's surface load")
    own = diagnose_cards([own_card], surface.well, damping=float(values[1]),
                         harmonics=surface.harmonics, method=method,
                         convention="effective")[0]
    if not own.ok or own.pump_load is None:
        return math.nan
    # Compared in the band the diagnostic carries: above it a fluid pound's sharp edge is
    # what a truncated Fourier series cannot draw (ringing), not a difference of physics.
    spectrum = np.fft.rfft(got)
    spectrum[surface.harmonics + 1:] = 0.0
    return _apart(np.fft.irfft(spectrum, n=got.size), own, surface)


def _apart(got: Array, down: DownholeResult, surface: SurfaceCard) -> float:
    # RMS after a constant over the diagnostic card's load range: the effective load's
    # level depends on the buoyancy convention, its shape does not.
    ref = np.asarray(down.pump_load, dtype=float)
    if surface.reversed:
        ref = ref[::-1]
    diff = got - ref
    return float(np.sqrt(np.mean((diff - diff.mean()) ** 2)) / np.ptp(ref))


def finer(model: PumpSystem) -> PumpSystem:
    """The same model on twice the elements, its next march warm from ``model``'s last
    (the march that estimates the march's own error and draws the pump card shown)."""
    fine = PumpSystem(model.surface, elements=2 * model.elements, tol=DISCRETIZATION_TOL)
    fine.start_from(model)
    return fine


def discretization_errors(surface: SurfaceCard, model: PumpSystem, res: FitResult,
                          fine: PumpSystem | None = None) -> dict[str, float]:
    """The march's own error in each free parameter and pump quantity of a fit.

    The fitted values are marched again with twice the elements; the fit's sensitivities
    turn the change of the predicted load into the step the fit would take with the finer
    march (one Gauss-Newton step), and the quantities are measured there. The march is
    second order, so its error against the continuous string is about 4/3 of that change.
    Added to the statistical errors (in quadrature) it keeps the intervals honest on cards
    quiet enough for the march's error to matter.

    The change from the search's march (half the elements) to the model's, which the fit
    gives for free, is no substitute: on four simulated fluid-pound and gas cards the
    fitted fillage moved 0.04-0.20 points from 15 to 30 elements, but 0.13-0.19 from 30 to
    60 and 0.08-0.14 from 60 to 120, so it would miss most of the error.
    """
    if res.jacobian is None or not res.free:
        return {}
    names = model.param_names()
    values = np.array([res.params[n] for n in names])
    if fine is None:
        fine = finer(model)
    coarse_load, _ = model.simulate(values, surface, False)
    fine_load, _ = fine.simulate(values, surface, False)
    jac = np.asarray(res.jacobian, dtype=float)
    step, *_ = np.linalg.lstsq(jac, coarse_load - fine_load, rcond=None)
    moved = values.copy()
    for k, name in enumerate(res.free):
        moved[names.index(name)] += step[k]
    lower = np.array([p.lower for p in model.parameters])
    upper = np.array([p.upper for p in model.parameters])
    moved = np.clip(moved, lower, upper)
    out = {name: RICHARDSON * abs(float(step[k])) for k, name in enumerate(res.free)}
    try:
        change = fine.quantities(moved) - model.quantities(values)
    except (ArithmeticError, ValueError):
        # The stepped values have no periodic stroke: the change at the fitted values.
        change = fine.quantities(values) - model.quantities(values)
    for name, delta in zip(QUANTITIES, change, strict=True):
        if math.isfinite(delta):
            out[name] = RICHARDSON * abs(float(delta))
    return out
