"""Surface cards in, downhole cards and pump quantities out: one card or a batch.

:func:`diagnose_cards` is the entry point: it checks each card (time, units, loop sense),
converts it to SI, subtracts the string's buoyant weight, solves the damped wave equation
for every card of the batch at once (cards with the same sample count share one
vectorised call), adds the static loads back in the chosen convention, measures the pump
card, and returns one :class:`DownholeResult` per card, a card that cannot be computed
included (its ``status`` and ``reason`` say why). ``DownholeResult.to_row`` is a flat dict
of the pump quantities with their units, for tables.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..cards import (
    BARREL_M3,
    LOAD_UNITS,
    POSITION_UNITS,
    PSI_PA,
    Card,
    loop_work,
    strokes_seen,
)
from .fd import fd_diagnostic
from .fourier import StringArrays, fourier_diagnostic, harmonic_count
from .quantities import PumpMeasure, measure_pump_cards
from .well import GRAVITY, Well
from .wellfile import WellFile

__all__ = ["CONVENTIONS", "DAMPING_UNIT", "DEFAULT_DAMPING", "METHODS", "REVERSED_NOTE",
           "DownholeResult",
           "diagnose_card", "diagnose_cards", "loop_work", "quantity_units", "surface_arrays",
           "wells_for"]

Array = NDArray[np.float64]

#: The damping rule of this release when none is given: Gibbs' dimensionless factor 0.05
#: for every well (light viscous damping, the low end of the range in use for diagnostics).
DEFAULT_DAMPING = 0.05
#: How every output states a damping factor's unit (the diagnostic's, the identification's:
#: one JSON document had said it two ways, this and "1").
DAMPING_UNIT = "dimensionless (Gibbs' nu)"
METHODS = ("fourier", "fd")
CONVENTIONS = ("effective", "true")
# Units of the pump quantities that have no card unit, by the well file's system.
_FLOW_UNITS = {"us": ("bbl/d", BARREL_M3), "metric": ("m3/d", 1.0)}
_PRESSURE_UNITS = {"us": ("psi", PSI_PA), "metric": ("kPa", 1000.0)}
# A loop that does not close by more than this fraction of the stroke is flagged.
_OPEN_LOOP = 0.05
#: What the diagnostic and the identification say of a card whose loop turns the wrong way:
#: one sentence for both (two had said it in two wordings, beside a reader's warning that
#: it was fitted as given).
REVERSED_NOTE = ("the card's loop turns the wrong way for time order (higher loads while "
                 "the position falls): it is taken as stored in reverse time order and used "
                 "reversed; a position measured downwards must be negated instead")


@dataclass(frozen=True, eq=False)
class DownholeResult:
    """The downhole card of one surface card, with its pump quantities.

    Arrays are in the card's units, at the card's samples in the order stored in the file
    (also when the card was stored in reverse time order: see :attr:`reversed`).

    Attributes
    ----------
    card : Card
        The surface card as given.
    status : {"computed", "invalid-input", "failed"}
    reason : str
        Why a card was not computed ("" when it was).
    well : Well or None
    method : str
        ``"fourier"`` or ``"fd"``.
    damping : float
        Gibbs' dimensionless damping factor used.
    damping_rule : str
        Where it came from (given, or the default rule).
    harmonics : int or None
        Highest harmonic used by the Fourier method.
    convention : str
        ``"effective"`` (rod tension plus the fluid pressure on the rod's section: the pump
        card's downstroke line sits near zero) or ``"true"`` (the rod's real axial force,
        compressed by the fluid pressure at the pump).
    reversed : bool
        True when the card was stored in reverse time order (its loop turned the wrong way)
        and was used reversed.
    depths : ndarray, shape (T,)
        Depth (m) of the bottom of each taper.
    position, load : ndarray, shape (T, N)
        Position (card unit, upwards, the pump's lowest point at 0) and load (card unit,
        :attr:`convention`) at the bottom of each taper; the last row is the pump card.
    pump : PumpMeasure or None
        Pump quantities (SI), measured on the effective card.
    true_shift : float
        What the true convention takes off the pump card's effective loads (N): the fluid
        pressure on the rod's section at the pump; 0 in the effective convention. The load
        lines are given in the convention of the card shown.
    notes : tuple of str
        Everything assumed, converted or noticed.
    """

    card: Card
    status: str
    reason: str = ""
    well: Well | None = None
    method: str = "fourier"
    damping: float = DEFAULT_DAMPING
    damping_rule: str = ""
    harmonics: int | None = None
    convention: str = "effective"
    reversed: bool = False
    depths: Array | None = None
    position: Array | None = None
    load: Array | None = None
    pump: PumpMeasure | None = None
    notes: tuple[str, ...] = field(default=())
    true_shift: float = 0.0

    @property
    def ok(self) -> bool:
        """True when the downhole card was computed."""
        return self.status == "computed"

    @property
    def pump_position(self) -> Array | None:
        """The pump card's positions (card unit), or None."""
        return None if self.position is None else self.position[-1]

    @property
    def pump_load(self) -> Array | None:
        """The pump card's loads (card unit), or None."""
        return None if self.load is None else self.load[-1]

    def quantities(self) -> dict[str, dict[str, Any]]:
        """Each pump quantity as ``{"value", "unit"}`` (empty when not computed)."""
        if self.pump is None or self.well is None:
            return {}
        units = quantity_units(self.well, self.card)
        m = self.pump
        # The load lines on the card shown: in the true convention they sat 5 kN above the
        # card they were printed with (fj2), as measured on the effective one.
        # No fluid load: no fillage, net stroke or displacement, and an intake pressure
        # above the discharge pressure; a fluid load of -200 kN printed "fillage 1" and an
        # intake pressure of 1.5e5 kPa, and the fleet trended them.
        lifts = m.fluid_load > 0
        values = {"gross_stroke": m.gross_stroke, "net_stroke": m.net_stroke if lifts else None,
                  "fluid_load": m.fluid_load, "fillage": m.fillage if lifts else None,
                  "upper_load_line": m.upper_load - self.true_shift,
                  "lower_load_line": m.lower_load - self.true_shift,
                  "displacement": m.displacement if lifts else None,
                  "intake_pressure": m.intake_pressure if lifts else None}
        return {name: {"value": None if v is None else float(v) / units[name][1],
                       "unit": units[name][0]} for name, v in values.items()}

    def to_row(self) -> dict[str, Any]:
        """A flat dict for tables: status, reason, method, damping, and each pump quantity
        as ``pump_<name>`` with its unit in ``pump_<name>_unit``."""
        row: dict[str, Any] = {"downhole_status": self.status, "downhole_reason": self.reason,
                               "downhole_method": self.method, "downhole_damping": self.damping,
                               "downhole_reversed": self.reversed}
        for name, entry in self.quantities().items():
            row[f"pump_{name}"] = entry["value"]
            row[f"pump_{name}_unit"] = entry["unit"]
        return row

    def to_dict(self) -> dict[str, Any]:
        """The JSON element of ``pumpid downhole --json``."""
        card = self.card
        out: dict[str, Any] = {
            "status": self.status, "reason": self.reason,
            # The card's own well id, else the id of the well it was computed with.
            "card": {"id": card.card_id,
                     "well": card.well_id if card.well_id is not None else (
                         self.well.well_id if self.well is not None else None),
                     "source": card.source,
                     # What the reader saw (columns that look swapped, a rate given over
                     # the file's own): pumpid fit and batch gave them, downhole did not.
                     "warnings": list(card.warnings), "notes": list(card.notes)},
        }
        if not self.ok or self.position is None or self.load is None:
            out["downhole"] = None
            out["pump"] = None
            out["notes"] = list(self.notes)
            return out
        units = {"position": card.position_unit, "load": card.load_unit}
        out["downhole"] = {
            "position": self.position[-1].tolist(), "load": self.load[-1].tolist(),
            "units": units, "convention": self.convention, "method": self.method,
            "damping": {"value": self.damping, "unit": DAMPING_UNIT,
                        "rule": self.damping_rule},
            "harmonics": self.harmonics, "reversed": self.reversed,
            "tapers": [{"depth": {"value": float(d), "unit": "m"},
                        "position": p.tolist(), "load": f.tolist()}
                       for d, p, f in zip(self.depths if self.depths is not None else [],
                                          self.position[:-1], self.load[:-1], strict=False)],
        }
        out["pump"] = self.quantities()
        out["notes"] = list(self.notes)
        return out


def quantity_units(well: Well, card: Card) -> dict[str, tuple[str, float]]:
    """Each pump quantity's unit as shown and its size in SI (``value_shown = SI / size``):
    lengths and loads in the card's units, fillage as a fraction, displacement in bbl/d or
    m3/d and pressure in psi or kPa by the well file's unit system."""
    pu, lu = card.position_unit or "m", card.load_unit or "N"
    length, load = (pu, POSITION_UNITS[pu]), (lu, LOAD_UNITS[lu])
    return {"gross_stroke": length, "net_stroke": length, "fluid_load": load,
            "fillage": ("fraction", 1.0), "upper_load_line": load, "lower_load_line": load,
            "displacement": _FLOW_UNITS[well.system],
            "intake_pressure": _PRESSURE_UNITS[well.system]}


def surface_arrays(card: Card) -> tuple[Array, Array, float, list[str]]:
    """A surface card as the wave equation takes it: SI position (m) and load (N), the stroke
    period (s) and notes on what was assumed.

    Raises
    ------
    ValueError
        Naming why the card cannot be used (no units, no time, too few samples, several
        strokes, non-uniform time).
    """
    notes: list[str] = []
    if card.position_unit is None or card.load_unit is None:
        missing = " and ".join(k for k, u in (("position", card.position_unit),
                                               ("load", card.load_unit)) if u is None)
        raise ValueError(f"the card's {missing} unit is unknown; the wave equation needs "
                         "physical units (give --position-unit / --load-unit)")
    if card.t is None:
        raise ValueError("the card has no time: give the pumping speed (--spm) or the stroke "
                         "period (--period)")
    if card.n < 8:
        raise ValueError(f"the card has {card.n} samples; at least 8 are needed")
    if card.periodic and card.period is not None and card.time_source in ("spm", "period",
                                                                          "dt"):
        # Time rebuilt from the speed: one stroke, uniform by construction.
        period = float(card.period)
    else:
        dt = card.dt
        if dt is None:
            raise ValueError("the card's sample times are not uniform; the downhole solvers "
                             "need one stroke sampled uniformly in time")
        period = dt * card.n
        passes = strokes_seen(card.position)[0]
        if not card.periodic and passes > 1:
            raise ValueError(f"the card holds several strokes ({passes} upward passes through "
                             "mid-stroke); split it into strokes first (pumpid.cards."
                             "split_strokes, or --split-strokes)")
        if not card.periodic:
            notes.append(f"the card is taken as one stroke of period {period:.6g} s "
                         f"(its {card.n} samples, {dt:.6g} s apart)")
    y = card.position * POSITION_UNITS[card.position_unit]
    f = card.load * LOAD_UNITS[card.load_unit]
    return y, f, period, notes


def wells_for(cards: Sequence[Card],
              wells: Well | WellFile | Sequence[Well]) -> list[Well | Exception]:
    """The well of each card: one well for all, a well file's match by well id (the
    WellError when a card has none), or a list with one well per card (ValueError when the
    counts differ)."""
    if isinstance(wells, Well):
        return [wells] * len(cards)
    if isinstance(wells, WellFile):
        out: list[Well | Exception] = []
        for card in cards:
            try:
                out.append(wells.for_card(card.well_id, card.card_id))
            except ValueError as exc:
                out.append(exc)
        return out
    listed = list(wells)
    if len(listed) != len(cards):
        raise ValueError(f"{len(cards)} cards but {len(listed)} wells")
    return list(listed)


def diagnose_cards(cards: Sequence[Card], wells: Well | WellFile | Sequence[Well], *,
                   damping: float | None = None, harmonics: int | None = None,
                   method: str = "fourier", convention: str = "effective",
                   refine: int | None = None) -> list[DownholeResult]:
    """Downhole cards and pump quantities of a batch of surface cards.

    Parameters
    ----------
    cards : sequence of Card
        Surface cards with units and time (one stroke each, uniform in time).
    wells : Well, WellFile or sequence of Well
        One well for every card, a well file (matched by well id), or one well per card.
    damping : float, optional
        Gibbs' dimensionless damping factor ``nu`` (``c = pi nu / (2 sum L_i/a_i)``; 0 is
        undamped). Default: :data:`DEFAULT_DAMPING` for every well.
    harmonics : int, optional
        Highest harmonic of the Fourier method (default: all the samples resolve).
    method : {"fourier", "fd"}
        Gibbs' Fourier solution (default) or the finite-difference march.
    convention : {"effective", "true"}
        Load convention of the downhole loads (the pump quantities use the effective card).
    refine : int, optional
        Time refinement of the finite-difference method.

    Returns
    -------
    list of DownholeResult
        One per card, in order; cards that cannot be computed have status
        ``invalid-input`` and the reason.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if convention not in CONVENTIONS:
        raise ValueError(f"convention must be effective or true, got {convention!r}")
    if damping is not None and not (math.isfinite(damping) and damping >= 0):
        raise ValueError(f"damping must be a non-negative number, got {damping}")
    if harmonics is not None and harmonics < 1:
        raise ValueError(f"harmonics must be at least 1, got {harmonics}")
    if harmonics is not None and method != "fourier":
        raise ValueError("harmonics applies to the Fourier method only")
    nu = DEFAULT_DAMPING if damping is None else float(damping)
    rule = ("given" if damping is not None else
            f"default rule: nu = {DEFAULT_DAMPING:g} for every well")
    matched = wells_for(cards, wells)
    results: list[DownholeResult | None] = [None] * len(cards)
    ready: dict[int, list[tuple[int, Array, Array, float, list[str], Well]]] = {}
    for i, (card, well) in enumerate(zip(cards, matched, strict=True)):
        if isinstance(well, Exception):
            results[i] = DownholeResult(card=card, status="invalid-input", reason=str(well))
            continue
        try:
            y, f, period, notes = surface_arrays(card)
        except ValueError as exc:
            results[i] = DownholeResult(card=card, status="invalid-input", reason=str(exc),
                                        well=well)
            continue
        ready.setdefault(card.n, []).append((i, y, f, period, notes, well))
    setup = _Options(nu=nu, rule=rule, method=method, harmonics=harmonics,
                     convention=convention, refine=refine)
    statics: dict[int, _Static] = {}
    for n, group in ready.items():
        try:
            solved = _solve_group(n, group, cards, setup, statics)
        except MemoryError:
            raise
        except Exception:
            # Something in one card broke the batch: each card alone, so only it fails.
            solved = []
            for member in group:
                try:
                    solved += _solve_group(n, [member], cards, setup, statics)
                except MemoryError:
                    raise
                except Exception as exc:
                    solved.append((member[0], DownholeResult(
                        card=cards[member[0]], status="failed", well=member[5],
                        reason=f"the solver stopped with an internal error "
                               f"({type(exc).__name__}: {exc}); a bug in pumpid, please "
                               "report it with the card")))
        for i, result in solved:
            results[i] = result
    return [r for r in results if r is not None]


@dataclass(frozen=True)
class _Options:
    nu: float
    rule: str
    method: str
    harmonics: int | None
    convention: str
    refine: int | None


@dataclass(frozen=True)
class _Static:
    """A well's per-taper constants, computed once per batch."""

    depths: Array
    below: Array       # buoyant weight hanging below each taper's bottom, N
    pressure_force: Array  # fluid pressure at each taper's bottom times its area, N
    weight: float

    @classmethod
    def of(cls, well: Well) -> _Static:
        per_taper = np.array([(t.density - well.fluid_density) * GRAVITY * t.area * t.length
                              for t in well.tapers])
        depths = np.cumsum([t.length for t in well.tapers])
        area = np.array([t.area for t in well.tapers])
        return cls(depths=depths, below=per_taper[::-1].cumsum()[::-1] - per_taper,
                   pressure_force=well.hydrostatic_pressure(depths) * area,
                   weight=well.buoyant_weight())


def _solve_group(n: int, group: list[tuple[int, Array, Array, float, list[str], Well]],
                 cards: Sequence[Card], opt: _Options,
                 statics: dict[int, _Static]) -> list[tuple[int, DownholeResult]]:
    """Solve the cards of one sample count together; one result per card."""
    wells = [g[5] for g in group]
    for w in wells:
        if id(w) not in statics:
            statics[id(w)] = _Static.of(w)
    static = [statics[id(w)] for w in wells]
    y = np.stack([g[1] for g in group])
    load = np.stack([g[2] for g in group])
    period = np.array([g[3] for g in group])
    # A loop that does not close rings at the join of the periodic solution: said.
    jump = np.abs(y[:, -1] - y[:, 0]) - np.max(np.abs(np.diff(y, axis=1)), axis=1)
    for k in np.flatnonzero(jump > _OPEN_LOOP * np.ptp(y, axis=1)):
        group[k][4].append("the card's last sample is far from its first: the loop does not "
                           "close, and the periodic solution will ring at the join")
    # A loop turning the wrong way was stored in reverse time order: solve it reversed.
    rev = loop_work(y, load) < 0
    y[rev], load[rev] = y[rev, ::-1], load[rev, ::-1]
    weight = np.array([s.weight for s in static])
    strings = StringArrays.of(wells)
    if opt.method == "fourier":
        pos, ten = fourier_diagnostic(y, load - weight[:, None], period, strings, opt.nu,
                                      opt.harmonics)
        used: int | None = harmonic_count(n, opt.harmonics)
    else:
        pos, ten = fd_diagnostic(y, load - weight[:, None], period, strings, opt.nu,
                                 opt.refine)
        used = None
    rows = np.arange(len(group))
    last = strings.count - 1
    pump_pos = pos[rows, last]
    pump_load = ten[rows, last] + np.array([s.below[-1] for s in static])[:, None]
    out: list[tuple[int, DownholeResult]] = []
    try:
        measures = measure_pump_cards(pump_pos, pump_load, wells, list(60.0 / period))
    except ValueError:
        # One card's plunger does not move: measure the cards one by one to name it.
        measures = []
        for k in range(len(group)):
            try:
                measures.append(measure_pump_cards(pump_pos[k:k + 1], pump_load[k:k + 1],
                                                   wells[k:k + 1], [60.0 / period[k]])[0])
            except ValueError as exc:
                measures.append(exc)  # type: ignore[arg-type]
    for k, (i, _y, _f, _per, notes, well) in enumerate(group):
        m = measures[k]
        if isinstance(m, Exception):
            out.append((i, DownholeResult(card=cards[i], status="failed", reason=str(m),
                                          well=well, notes=tuple(notes))))
            continue
        out.append((i, _result(cards[i], well, static[k], pos[k], ten[k], bool(rev[k]),
                               notes, m, opt, used)))
    return out


def _result(card: Card, well: Well, static: _Static, pos: Array, ten: Array, rev: bool,
            notes: list[str], measure: PumpMeasure, opt: _Options,
            used: int | None) -> DownholeResult:
    count = len(well.tapers)
    notes = [*well.notes, *notes]
    if card.well_id is not None and card.well_id != well.well_id:
        notes.append(f"the card's well id {card.well_id!r} differs from the well file's only "
                     f"well {well.well_id!r}, which applies to every card")
    kp = POSITION_UNITS[card.position_unit or "m"]
    kl = LOAD_UNITS[card.load_unit or "N"]
    weight = well.buoyant_weight()
    if float(np.max(card.load)) * kl < weight:
        # A polished rod carries at least the rods' weight in the fluid on the upstroke:
        # loads below it (the Sandia record against a guessed string) gave a pump card
        # whose load lines sat at -10,700 lbf, its fillage and displacement plausible.
        notes.append(f"the card's largest load is below the rods' weight in the fluid "
                     f"({weight / kl:.4g} {card.load_unit or 'N'}): the well file, the load "
                     "unit or the load cell's zero is wrong, and the pump card with it")
    if rev:
        notes += [REVERSED_NOTE, "the downhole arrays are given back in the file's order"]
    if opt.harmonics is not None and used is not None and used < opt.harmonics:
        notes.append(f"{opt.harmonics} harmonics asked, the card's {card.n} samples resolve "
                     f"{used}")
    shown = ten[:count] + static.below[:, None]
    true_shift = 0.0
    if opt.convention == "true":
        shown = shown - static.pressure_force[:, None]
        true_shift = float(static.pressure_force[count - 1])
    pos = pos[:count] - pos[count - 1].min()
    if rev:
        pos, shown = pos[:, ::-1], shown[:, ::-1]
    if well.system == "us" and card.position_unit in ("m", "cm", "mm"):
        notes.append(f"the card is in {card.position_unit}/{card.load_unit} and the well file "
                     "in US units: converted, results in the card's units")
    elif well.system == "metric" and card.position_unit in ("in", "ft"):
        notes.append(f"the card is in {card.position_unit}/{card.load_unit} and the well file "
                     "in metric units: converted, results in the card's units")
    notes.extend(measure.notes)
    return DownholeResult(
        card=card, status="computed", well=well, method=opt.method, damping=opt.nu,
        damping_rule=opt.rule, harmonics=used, convention=opt.convention, reversed=rev,
        depths=static.depths, position=pos / kp, load=shown / kl, pump=measure,
        notes=tuple(dict.fromkeys(notes)), true_shift=true_shift)


def diagnose_card(card: Card, well: Well | WellFile, **options: Any) -> DownholeResult:
    """The downhole card of one surface card (see :func:`diagnose_cards` for the options)."""
    return diagnose_cards([card], well, **options)[0]
