"""The whole pumping system as a model of the surface card: rod string and valve pump.

The measured polished-rod position drives the damped, tapered rod string, cut into about
:data:`ELEMENTS` elements and stepped in time (:class:`pumpid.rods.StringGrid`); at its
bottom a pump with a traveling and a standing valve (:class:`pumpid.rods.PumpModel`): the
valves open and close from the barrel's pressure, which follows the plunger's motion, so a
full pump, an incomplete fill (fluid pound) and gas compression are the same model at
different parameters and no valve timing is prescribed. The march runs until the stroke
repeats itself; the model predicts the polished-rod load, compared with the measured one.

Parameters (:class:`PumpSystem`): the fluid load on the plunger, Gibbs' damping factor of the
string, the liquid fraction of what the standing valve admits (1 is a full pump: a state the
model can be in rather than the edge of a search), the pump intake pressure over the
discharge pressure (how hard the barrel's gas is to compress: low for fluid pound, higher
for gas interference), the plunger travel over which the load transfers (the liquid's, the
pump's and free tubing's elasticity) and a load offset (the dynamometer's zero and whatever
the well file's rod weights miss). The pump quantities (fillage, strokes, displacement,
intake pressure) are measured on the fitted pump card as on a diagnostic one, with errors
by the delta method.

The march treats the pump's spring (the barrel's content while both valves are shut)
implicitly: a stiff transfer (a few centimetres of travel for the whole fluid load) is
beyond the explicit step's stability limit and would make the stroke never repeat. A valve
that opens within a step stops the spring's load at the open valve's, so the periodic
stroke is a continuous function of where the march starts (one stroke, not two).

Sensitivities are forward differences of the march, each perturbed march started from the
unperturbed one's final state (a warm start): it is then periodic again within a few
strokes. A closed-form tangent march would be exact and about twice as fast; the
differences' relative error (about 1e-3, set by :data:`FD_TOL` against :data:`STEP`) is far
below what the solver and the errors need.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..cards import LOAD_UNITS, POSITION_UNITS, Card
from ..inference.derived import delta_errors
from ..inference.uncertainty import PRACTICAL_REL_SE
from ..models import OwnModel, Parameter
from ..result import Derived
from ..rods import (
    REVERSED_NOTE,
    PumpMeasure,
    StringArrays,
    Well,
    fourier_diagnostic,
    loop_work,
    measure_pump_cards,
    quantity_units,
    surface_arrays,
)
from ..rods.predict import Run, StringGrid

__all__ = ["DRIVE_HARMONICS", "ELEMENTS", "ESTIMATE_TOL", "QUANTITIES", "SEARCH_ELEMENTS",
           "START_INTAKE_RATIO", "PumpSystem", "SurfaceCard"]

Array = NDArray[np.float64]

#: Elements of the string in the predictive march: 30 keep the march's own error near
#: 0.15 % of the load range on a 4,900 ft three-taper string at 200 samples (60: 0.05 %, at
#: about 2.5 times the cost), well below a dynamometer's noise.
ELEMENTS = 30
#: Elements of the march the identification searches on before it fits the
#: :data:`ELEMENTS` march from the search's answer. Half the elements allow twice the time
#: step, so a march costs about a quarter; its own error moves the answer by about a
#: standard error on a quiet card, which the final fit's one or two steps take back.
SEARCH_ELEMENTS = 15
#: Stop a march when the stroke repeats to this (of the load range; see
#: :func:`pumpid.rods.march.march`), for estimates that need the stroke to a few digits
#: only: the pump quantities' slopes for their errors (:meth:`PumpSystem.derived`).
ESTIMATE_TOL = 1e-7
#: Stop a march when the stroke repeats to this (of the load range): its end state is its
#: start state, or its surface load the stroke before's.
TOL = 1e-9
#: The same for a perturbed march of a forward difference: its leftover transient, relative
#: to the difference it measures (about FD_TOL / STEP), is the derivative's relative error.
FD_TOL = 1e-8
#: Largest change of a parameter, relative to its value, over which a march starts from the
#: stroke the last sensitivities predict (:meth:`PumpSystem._predicted`).
PREDICTED = 4.0
#: Periodic strokes kept by their parameter values (the last simulated ones).
KEPT_RUNS = 16
#: Low bits of each parameter's binary fraction a kept stroke's key leaves out
#: (:func:`_march_key`): 2**-44, about 6e-14 of the value, is far below any step the solver
#: or a difference takes (:data:`STEP`) and above a round trip through the solver's log scale.
KEY_BITS = 8
#: Strokes a march may take (a lightly damped string needs the most).
MAX_CYCLES = 300
#: The pump quantities each fit derives from its pump card, with errors.
QUANTITIES = ("fillage", "gross_stroke", "net_stroke", "displacement", "intake_pressure")
MEANINGS = {
    "fillage": "effective over gross plunger travel of the fitted pump card, the effective "
               "travel starting where the load transfers on the downstroke",
    "gross_stroke": "plunger travel of the fitted pump card",
    "net_stroke": "fillage x gross stroke, less free tubing's stretch",
    "displacement": "plunger area x net stroke x strokes per day",
    "intake_pressure": "discharge pressure of the fluid column less fluid load / plunger area",
}
#: Central-difference step (in the log of a parameter) of the derived quantities' errors.
DERIVED_STEP = 1e-4
#: Forward-difference step: relative for positive parameters, absolute for the fillage.
STEP = 1e-5
#: Harmonics of the measured position that drive the march. A pumping unit's crank moves
#: the polished rod smoothly: above a few tens of harmonics a card's position is the
#: transducer's resolution and noise, which the string would turn into load (acceleration
#: grows with the square of the harmonic). On the public fj2 card (1 cm resolution) all of
#: its 71 harmonics gave R^2 0.9495 with a load jitter the measured load does not show; 25
#: gave 0.984, 15 no better.
DRIVE_HARMONICS = 25
#: Damping factors the automatic start tries (Gibbs' dimensionless factor).
START_DAMPING = (0.05, 0.15, 0.4)
#: Barrel volume left below the plunger at its lowest point (as plunger travel), m: fixed,
#: the card cannot tell it from the fillage.
DEAD_SPACE = 0.01
#: Polytropic exponent of the gas in the barrel.
GAMMA = 1.2
#: Plunger travel over which the load transfers when the tubing is anchored (or its size
#: unknown), m: the start's value.
START_TRANSFER = 0.02
#: Pump intake over discharge pressure the start assumes (a fluid pound's thin gas; also
#: the value a full pump's fit holds, where the card cannot tell it).
START_INTAKE_RATIO = 0.02


def _march_key(values: Array) -> bytes:
    """The key of the stroke marched at ``values``.

    The march depends on every parameter but the load offset (the last), and values that
    went through the solver's log scale and back differ in their last bits: both still mean
    the stroke kept. Keyed exactly on all six, the search marched each of its starts twice,
    the second time warm from another damping's stroke (35 of its 216 strokes a card). Two
    values a few bits apart may still fall either side of a cut: a march more, no error.
    """
    return (np.asarray(values[:5], dtype=np.float64).view(np.int64) >> KEY_BITS).tobytes()


@dataclass(frozen=True)
class SurfaceCard:
    """One surface card made ready for the system model (SI, in time order).

    Build it with :meth:`of`; ``position`` and ``load`` are in m and N, upwards, in time order
    (a card stored in reverse time order is turned round: ``reversed`` says so); ``drive``
    is the position the march is driven with, its first ``harmonics`` harmonics.
    """

    card: Card
    well: Well
    position: Array
    load: Array
    period: float
    reversed: bool
    notes: tuple[str, ...]
    drive: Array
    harmonics: int = DRIVE_HARMONICS

    @classmethod
    def of(cls, card: Card, well: Well, harmonics: int = DRIVE_HARMONICS) -> SurfaceCard:
        """Convert and check ``card`` (ValueError naming what is missing); the march is
        driven by the position's first ``harmonics`` harmonics (:data:`DRIVE_HARMONICS`)."""
        y, f, period, notes = surface_arrays(card)
        rev = bool(loop_work(y[None], f[None])[0] < 0)
        if rev:
            y, f = y[::-1].copy(), f[::-1].copy()
            notes = [*notes, REVERSED_NOTE]
        spectrum = np.fft.rfft(y)
        spectrum[int(harmonics) + 1:] = 0.0
        drive = np.asarray(np.fft.irfft(spectrum, n=y.size), dtype=float)
        return cls(card=card, well=well, position=y, load=f, period=period, reversed=rev,
                   notes=tuple(notes), drive=drive, harmonics=int(harmonics))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.position.size)

    @property
    def load_factor(self) -> float:
        """Newtons per unit of the card's load."""
        return LOAD_UNITS[self.card.load_unit or "N"]

    @property
    def position_factor(self) -> float:
        """Metres per unit of the card's position."""
        return POSITION_UNITS[self.card.position_unit or "m"]

    @property
    def spm(self) -> float:
        """Strokes per minute."""
        return 60.0 / self.period


class PumpSystem(OwnModel):
    """Rod string and valve pump predicting one surface card's load (see the module's text).

    One instance per card: the model is the card's well driven by the card's motion, and
    keeps its last march to start the next from.

    Parameters
    ----------
    surface : SurfaceCard
        The card and its well.
    elements : int
        About this many elements over the string.
    derive : bool
        Analyse a fit and measure its pump quantities (:meth:`derived`); False for a search
        whose answer only starts another fit (the attribute may be switched between fits):
        its result has no errors, and its sensitivities at the answer are not asked for.
    tol : float
        A march stops when the stroke repeats to this (relative to the load range).
    """

    name = "rod string and pump"
    integrator = ("lumped damped wave equation of the tapered string, stepped to a periodic "
                  "stroke, driven by the measured polished-rod position")
    initial_state = "periodic (one stroke)"
    periodic = True
    output = "polished-rod load"

    def __init__(self, surface: SurfaceCard, elements: int = ELEMENTS, derive: bool = True,
                 tol: float = TOL) -> None:
        self.surface = surface
        self.elements = int(elements)
        self.derive = bool(derive)
        self.tol = float(tol)
        lu = surface.card.load_unit or "N"
        pu = surface.card.position_unit or "m"
        self.output_unit = lu
        self.input_unit = pu
        kp = surface.position_factor
        # A fluid load beyond ten times the card's whole load is no pump this card shows.
        span = 10.0 * float(np.max(np.abs(surface.load))) / surface.load_factor
        self.parameters = (
            Parameter("fluid_load", lu, 0.0, span, doc="load of the fluid column on "
                      "the plunger: (discharge - intake pressure) x plunger area"),
            Parameter("damping", "1", 0.02, 2.0, doc="Gibbs' dimensionless damping factor "
                      "nu of the rod string (c = pi nu / (2 sum L_i/a_i))"),
            Parameter("liquid_fraction", "1", 0.05, 1.0, closed=True, doc="liquid fraction "
                      "of what the standing valve admits (1: a full pump)"),
            Parameter("intake_ratio", "1", 0.002, 0.9, closed=True, doc="pump intake over "
                      "discharge pressure: how hard the barrel's gas is to compress (at its "
                      "floor the gas is too thin to resist: a plain fluid pound)"),
            Parameter("transfer", pu, 1e-4 / kp, 3.0 / kp, doc="plunger travel over which "
                      "the load transfers (liquid, pump and free-tubing elasticity)"),
            Parameter("load_offset", lu, -math.inf, math.inf, doc="measured load minus the "
                      "string's buoyant weight and the predicted dynamic load"),
        )
        self.grid = StringGrid.of(surface.well, surface.period, surface.n, elements)
        self._refined = self.grid.refine(surface.drive)
        self.weight = surface.well.buoyant_weight()
        self._last: Run | None = None
        self._runs: dict[bytes, Run] = {}
        # The last sensitivities: where they were taken, and each parameter's step with the
        # change of the periodic stroke's end state (nodes, pump) it made.
        self._slopes: dict[int, tuple[float, Array, Array]] = {}
        self._slopes_at: tuple[Array, Run] | None = None
        self._held: frozenset[int] = frozenset()

    @property  # type: ignore[override]
    def analyse(self) -> bool:
        """Whether a fit's answer is analysed: as :attr:`derive` says."""
        return self.derive

    # ------------------------------------------------------------------ the march
    def _pump(self, values: Array) -> Array:
        s = self.surface
        return np.array([values[0] * s.load_factor, values[2], values[3],
                         values[4] * s.position_factor, DEAD_SPACE, 1.0 / GAMMA])

    def run(self, values: Array, warm: Run | None = None, tol: float | None = None) -> Run:
        """The periodic march at ``values`` to ``tol`` (default: the model's; from ``warm``,
        else from the last march)."""
        values = np.asarray(values, dtype=float)
        tol = self.tol if tol is None else tol
        kept = self._runs.get(_march_key(values))
        if kept is not None:
            # The stroke these values already gave: a nonlinear pump may settle into another
            # stroke from another start, and a fit's answer is the stroke it was fitted with.
            return kept
        if warm is None:
            warm = self._predicted(values)
        got = self.grid.march(self.surface.drive, self._pump(values), float(values[1]),
                              warm, MAX_CYCLES, tol, self._refined)
        if not got.change < 1e3 * tol or not np.all(np.isfinite(got.out)):
            # Not periodic yet from a far warm start: once more from rest.
            got = self.grid.march(self.surface.drive, self._pump(values),
                                  float(values[1]), None, MAX_CYCLES, tol, self._refined)
            if not (np.all(np.isfinite(got.out)) and got.change < 1e3 * tol):
                # No periodic stroke here (too little damping for the strokes allowed, or
                # a pump that never settles): differences of it would be noise, so the
                # solver is told it cannot simulate these values and steps back.
                raise ArithmeticError(f"the march reaches no periodic stroke in {got.cycles} "
                                      f"strokes (last change {got.change:.2g} of the load "
                                      "range)")
        return got

    def _predicted(self, values: Array) -> Run | None:
        """Where a march at ``values`` starts: the stroke of the last sensitivities moved by
        their state slopes to ``values`` (its end state to first order in the change), else
        the last march. A solver's trial point then took 7 strokes instead of 9.5 on the
        coarse march (field cards of the demo's pump field). Beyond :data:`PREDICTED`
        (relative to a parameter) the first order says nothing: the sensitivities' own
        stroke, unmoved (a boundary test pushes a parameter a thousandfold)."""
        if self._slopes_at is None:
            return self._last
        at, base = self._slopes_at
        steps = {j: float(values[j] - at[j]) for j in self._slopes if values[j] != at[j]}
        if any(abs(h) > PREDICTED * abs(at[j]) for j, h in steps.items()):
            return base
        run = self._step_from(base, steps)
        state = run.state
        # A large step can carry the barrel's contents past what they can be; held inside,
        # the march starts from a state it can reach.
        state[1] = max(state[1], 0.0)
        state[2] = max(state[2], 0.0)
        state[3] = min(max(state[3], float(values[3])), 1.0)
        return run

    def _step_from(self, base: Run, steps: dict[int, float]) -> Run:
        """``base`` moved by the last sensitivities' state slopes for parameter ``steps``
        (index: change), to start a nearby march from; ``base`` itself without them."""
        if not all(j in self._slopes for j in steps):
            return base
        nodes, state = base.nodes.copy(), base.state.copy()
        for j, h in steps.items():
            h0, dn, ds = self._slopes[j]
            nodes += (h / h0) * dn
            state += (h / h0) * ds
        return Run(out=base.out, nodes=nodes, state=state, cycles=0, change=math.inf)

    def start_from(self, other: PumpSystem) -> None:
        """Start this model's next march from ``other``'s last one: the same card on another
        grid (:meth:`pumpid.rods.StringGrid.carry`), for a warm start instead of one from
        rest. Nothing happens if ``other`` has not marched yet. Its last sensitivities' state
        slopes come along the same way (the carry is linear)."""
        if other._last is not None:
            self._last = self.grid.carry(other._last, other.grid)
        for j, (h, nodes, state) in other._slopes.items():
            slope = Run(out=np.zeros((3, 0)), nodes=nodes, state=state, cycles=0, change=0.0)
            self._slopes[j] = (h, self.grid.carry(slope, other.grid).nodes, state.copy())

    def _load(self, values: Array, run: Run) -> Array:
        return np.asarray((run.out[0] + self.weight) / self.surface.load_factor
                          + values[5], dtype=float)

    def _steps(self, values: Array) -> list[tuple[int, float]]:
        """(parameter, step) of each forward difference (the offset's derivative is 1)."""
        out = []
        for j in range(5):
            if j == 2:
                out.append((j, -STEP if values[j] + STEP > 1.0 else STEP))
            else:
                out.append((j, STEP * values[j]))
        return out

    # ------------------------------------------------------------------ the protocol
    def hold(self, names: frozenset[str]) -> None:
        """The parameters the next fit holds: their sensitivities (a march each) are not
        marched. A full pump's fits hold the liquid fraction (and the intake ratio, whose
        column is zero anyway): one march of four in each of their sensitivities."""
        order = self.param_names()
        self._held = frozenset(order.index(n) for n in names)

    def observed(self, data: Any) -> Array:
        """The measured polished-rod load, in the card's unit, in time order."""
        return self.surface.load / self.surface.load_factor

    def time(self, data: Any) -> Array:
        """Sample times from the first sample, s."""
        return np.arange(self.surface.n) * self.surface.period / self.surface.n

    def driving(self, data: Any) -> Array:
        """The measured polished-rod position, in the card's unit."""
        return self.surface.position / self.surface.position_factor

    def simulate(self, values: Array, data: Any, sensitivities: bool
                 ) -> tuple[Array, Array | None]:
        """The polished-rod load (card unit) and its derivatives in the parameters."""
        values = np.asarray(values, dtype=float)
        for par, v in zip(self.parameters, values, strict=True):
            if not par.lower <= v <= par.upper:
                # Outside the declared range the march is not physical (or never periodic).
                raise ValueError(f"{par.name} = {v:g} is outside [{par.lower:g}, "
                                 f"{par.upper:g}]")
        base = self.run(values)
        self._last = base
        key = _march_key(values)
        if key not in self._runs:
            if len(self._runs) >= KEPT_RUNS:
                self._runs.pop(next(iter(self._runs)))  # the oldest
            self._runs[key] = base
        load = self._load(values, base)
        if not sensitivities:
            return load, None
        jac = np.empty((load.size, 6))
        for j, h in self._steps(values):
            if j in self._held:
                jac[:, j] = 0.0  # held in this fit: its column is never used
                continue
            if j == 3 and values[2] >= 1.0:
                # A full pump admits no gas, and without gas the intake ratio moves nothing
                # (the shut barrel's load is the liquid's spring alone): its derivative is
                # zero, not the march's rounding over the step. The rounding, taken as a
                # slope, sent a full pump's search along the intake ratio in steps that
                # gained 1e-6 of the cost each: a public field card's search spent its
                # whole budget there at a cost 20 % above the full pump's optimum.
                jac[:, j] = 0.0
                continue
            moved = values.copy()
            moved[j] += h
            # The perturbed stroke's end state as the last sensitivities predict it from
            # this base: a march from there starts a change of second order away from its
            # periodic stroke instead of a first-order one. On 40 simulated cards it took
            # 3.2-3.6 strokes instead of 4.3-4.4.
            other = self.run(moved, self._step_from(base, {j: h}), FD_TOL)
            self._slopes[j] = (h, other.nodes - base.nodes, other.state - base.state)
            jac[:, j] = (self._load(moved, other) - load) / h
        self._slopes_at = (values.copy(), base)
        jac[:, 5] = 1.0
        return load, jac

    def pump_card(self, values: Array, tol: float | None = None,
                  warm: Run | None = None) -> tuple[Array, Array]:
        """The predicted pump card: plunger position (m, from its lowest point) and
        effective pump load (N), at the card's samples in time order (the march to ``tol``,
        default the model's, from ``warm``, default the last march)."""
        run = self.run(np.asarray(values, dtype=float), warm=warm, tol=tol)
        pos = run.out[1]
        return np.asarray(pos - pos.min(), dtype=float), np.asarray(run.out[2], dtype=float)

    def measure(self, values: Array) -> PumpMeasure:
        """The pump quantities of the predicted pump card, measured as a diagnostic pump
        card's are (:func:`pumpid.rods.measure_pump_cards`)."""
        return self._measures([self.pump_card(values)])[0]

    def start(self, data: Any) -> Array:
        """Starts from the diagnostic pump card at each of :data:`START_DAMPING`: its fluid
        load and fillage, a fluid-pound and a gas-interference intake ratio, the transfer
        travel of the well's tubing, and the offset that levels the prediction."""
        s = self.surface
        last = len(s.well.tapers) - 1
        transfer = START_TRANSFER
        tubing = s.well.tubing
        # The diagnostic pump cards at every damping in one call, measured in one call.
        count = len(START_DAMPING)
        pos, ten = fourier_diagnostic(np.repeat(s.position[None], count, axis=0),
                                      np.repeat((s.load - self.weight)[None], count, axis=0),
                                      s.period, StringArrays.of([s.well] * count),
                                      np.array(START_DAMPING))
        plunger, pump = pos[:, last], ten[:, last]
        moving = np.ptp(plunger, axis=1) > 0
        measured = iter(measure_pump_cards(plunger[moving], pump[moving],
                                           [s.well] * int(moving.sum()),
                                           [s.spm] * int(moving.sum())))
        starts = []
        for i, nu in enumerate(START_DAMPING):
            if moving[i]:
                m = next(measured)
                fluid, fill = m.fluid_load, m.fillage
            else:  # no pump card to measure
                fluid, fill = float(np.ptp(pump[i])) / 2, 1.0
            fluid = max(fluid, 1e-3 * float(np.ptp(s.load)), 1e-9)
            if not tubing.anchored and tubing.area is not None:
                transfer = START_TRANSFER + fluid * s.well.pump.depth / (
                    tubing.modulus * tubing.area)
            v = np.array([fluid / s.load_factor, nu, float(np.clip(fill, 0.1, 1.0)),
                          START_INTAKE_RATIO,
                          transfer / s.position_factor, 0.0])
            try:
                pred, _ = self.simulate(v, data, False)
            except ArithmeticError:
                continue  # no periodic stroke from this start: the others may have one
            v[5] = float(np.mean(self.observed(data) - pred))
            starts.append(v)
        if not starts:
            raise ValueError("no start reaches a periodic stroke (tried damping "
                             f"{', '.join(f'{nu:g}' for nu in START_DAMPING)})")
        return np.array(starts)

    def quantities(self, values: Array) -> Array:
        """:data:`QUANTITIES` of the predicted pump card, in the units they are shown in
        (NaN where not measurable)."""
        return self._measured([self.pump_card(values)])[0]

    def _measures(self, cards: Sequence[tuple[Array, Array]]) -> list[PumpMeasure]:
        """Pump cards (plunger position, pump load) measured in one call of
        :func:`pumpid.rods.measure_pump_cards` (measured: 0.25 ms for ten cards of 200
        samples, 0.18 ms for one). Raises ValueError when a plunger does not move."""
        s = self.surface
        return measure_pump_cards(np.array([c[0] for c in cards]),
                                  np.array([c[1] for c in cards]),
                                  [s.well] * len(cards), [s.spm] * len(cards))

    def _measured(self, cards: Sequence[tuple[Array, Array]]) -> Array:
        """:data:`QUANTITIES` of pump cards, one row each, in the units they are shown in."""
        units = quantity_units(self.surface.well, self.surface.card)
        rows = []
        for m in self._measures(cards):
            raw = {"gross_stroke": m.gross_stroke, "net_stroke": m.net_stroke,
                   "fillage": m.fillage, "displacement": m.displacement,
                   "intake_pressure": m.intake_pressure}
            rows.append([math.nan if raw[q] is None else float(raw[q]) / units[q][1]
                         for q in QUANTITIES])
        return np.array(rows, dtype=float)

    def derived(self, values: Array, numbers: Any, serial: bool,
                limits: Sequence[tuple[str, str]]) -> Mapping[str, Derived]:
        """The pump quantities of the fitted pump card (:data:`QUANTITIES`), each with its
        error by the delta method over the parameters analysed at the optimum (none for a
        model made with ``derive=False``)."""
        if not self.derive:
            return {}
        values = np.asarray(values, dtype=float)
        names = self.param_names()
        try:
            base = self.quantities(values)
            # Neighbours start from the fitted stroke (the last march may be a boundary
            # test's, far away, from which a nonlinear pump can settle elsewhere or not).
            self._last = self.run(values)
        except (ArithmeticError, ValueError):
            return {}  # the fitted values have no periodic stroke: nothing to measure
        se = np.full(base.size, math.nan)
        se_hac = np.full(base.size, math.nan)
        if numbers is not None and numbers.usable and numbers.dof > 0:
            coords = [numbers.names[i] for i in numbers.inner]
            # Central differences in the analysis' coordinate (the log of a positive
            # parameter), held inside the closed bound of the liquid fraction; the pump
            # cards of every neighbour measured in one call.
            sides: list[tuple[int, float, tuple[Array, Array]]] = []
            for a, name in enumerate(coords):
                j = names.index(name)
                if name == "load_offset":
                    continue  # moves no pump quantity
                for sign in (1.0, -1.0):
                    moved = values.copy()
                    moved[j] *= math.exp(sign * DERIVED_STEP)
                    if not self.parameters[j].lower <= moved[j] <= self.parameters[j].upper:
                        continue
                    try:
                        # A neighbour's stroke to 1e-7 of the load range: its quantities
                        # move by about 1e-4 of themselves, so the slope keeps 3 digits.
                        # It starts where the sensitivities taken here predict it
                        # (:meth:`_predicted`).
                        card = self.pump_card(moved, ESTIMATE_TOL)
                    except (ArithmeticError, ValueError):
                        continue  # no periodic stroke there
                    if np.ptp(card[0]) > 0:  # else no pump card to measure
                        sides.append((a, sign, card))
            measured = self._measured([c for _, _, c in sides]) if sides else np.zeros(0)
            grad = np.zeros((base.size, len(coords)))
            for a, name in enumerate(coords):
                if name == "load_offset":
                    continue
                got = {sign: measured[k] for k, (b, sign, _) in enumerate(sides) if b == a}
                if len(got) == 2:
                    grad[:, a] = (got[1.0] - got[-1.0]) / (2.0 * DERIVED_STEP)
                elif got:
                    (sign, q), = got.items()
                    grad[:, a] = sign * (q - base) / DERIVED_STEP
                else:
                    grad[:, a] = math.nan
            se, se_hac = delta_errors(grad, numbers)
        units = quantity_units(self.surface.well, self.surface.card)
        if names.index("liquid_fraction") in self._held:
            # A full pump's fillage follows from the held liquid fraction, not from the
            # data: its delta-method error (1e-5) made it "determined" on a card whose
            # identification determined nothing.
            k = QUANTITIES.index("fillage")
            se[k] = se_hac[k] = math.nan
        out: dict[str, Derived] = {}
        for k, q in enumerate(QUANTITIES):
            shown = se_hac[k] if serial and not math.isnan(se_hac[k]) else se[k]
            value = float(base[k])
            out[q] = Derived(q, value, units[q][0], float(shown), float(se_hac[k]),
                             bool(math.isfinite(value)
                                  and shown < PRACTICAL_REL_SE * abs(value)),
                             MEANINGS[q], stderr_white=float(se[k]))
        return out
