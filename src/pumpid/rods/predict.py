"""The predictive solver: surface position and a pump with valves -> surface load.

The rod string is cut into short elements (about 1/60 of its length, at least two per taper)
with their mass lumped at the nodes and their stiffness ``E A / dx`` between them; the
viscous damping ``c`` acts on every node's mass. Central differences in time, with a step at
the stability limit of the stiffest element, drive the top node with the surface position
(interpolated trigonometrically between the card's samples) and load the bottom node with
the pump (:class:`PumpModel`), until the stroke repeats itself. On a uniform taper at the
stability limit this lumped scheme is exact at its nodes; elsewhere it is second order.

Loads are dynamic (effective) loads: the polished-rod load a dynamometer would read is the
result plus the string's buoyant weight (:meth:`pumpid.rods.well.Well.buoyant_weight`).
For a pump load given as a function of time, :func:`pumpid.rods.fourier.fourier_predict`
solves the same problem exactly in the frequency domain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .fourier import trig_refine
from .march import march
from .well import Well

__all__ = ["Prediction", "PumpModel", "Run", "StringGrid", "predict_surface", "pump_vector"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PumpModel:
    """A pump with a traveling and a standing valve, for a batch of cards (arrays of B).

    The barrel between the valves holds liquid and gas; its pressure ``p`` (a fraction of
    the discharge pressure) sets the plunger's effective load
    ``fluid_load * (1 - p) / (1 - intake_ratio)``. The valves act on the pressure alone:
    the standing valve lets fluid in while ``p`` would fall below the intake ratio, the
    traveling valve lets the barrel's content out while ``p`` would rise above 1; between
    the two the content is shut in and ``p`` follows from the barrel volume: the gas as
    ``p V^gamma`` constant, the liquid with a compliance that changes its volume by
    ``transfer`` (as plunger travel) over the full pressure span (the liquid's and the
    pump's elasticity). What enters through the standing valve is ``fillage`` liquid and
    the rest gas at intake pressure. A small intake ratio with ``fillage < 1`` is fluid
    pound (the load holds on the downstroke until the plunger meets the liquid); a larger
    one is gas interference (the load falls gradually). No valve timing is prescribed:
    the card's corners come from the plunger's motion.

    Parameters
    ----------
    fluid_load : array_like
        ``(p_discharge - p_intake) * plunger area``, N.
    fillage : array_like
        Liquid fraction of what the standing valve admits (0-1].
    intake_ratio : array_like
        Pump intake over discharge pressure, in (0, 1).
    transfer : array_like
        Plunger travel over which a barrel of liquid changes pressure by the full span, m.
    dead_space : array_like
        Barrel volume left at the plunger's lowest point, as plunger travel, m.
    gamma : float
        Polytropic exponent of the gas.
    """

    fluid_load: ArrayLike
    fillage: ArrayLike = 1.0
    intake_ratio: ArrayLike = 0.01
    transfer: ArrayLike = 0.02
    dead_space: ArrayLike = 0.01
    gamma: float = 1.2

    def arrays(self, count: int) -> dict[str, Array]:
        """The parameters broadcast to ``count`` cards, checked."""
        out = {name: np.broadcast_to(np.asarray(getattr(self, name), dtype=float),
                                     (count,)).copy()
               for name in ("fluid_load", "fillage", "intake_ratio", "transfer", "dead_space")}
        if np.any(out["fillage"] <= 0) or np.any(out["fillage"] > 1):
            raise ValueError("fillage must be in (0, 1]")
        if np.any(out["intake_ratio"] <= 0) or np.any(out["intake_ratio"] >= 1):
            raise ValueError("intake_ratio must be in (0, 1)")
        if np.any(out["transfer"] <= 0) or np.any(out["dead_space"] <= 0):
            raise ValueError("transfer and dead_space must be positive")
        if not self.gamma >= 1:
            raise ValueError("gamma must be at least 1")
        return out


@dataclass(frozen=True)
class Prediction:
    """What :func:`predict_surface` returns, at the card's sample times.

    Attributes
    ----------
    surface_load : ndarray, shape (B, N)
        Dynamic polished-rod load, N (add the buoyant weight for a dynamometer's reading).
    pump_position : ndarray, shape (B, N)
        Plunger position, m, upwards (same origin as the surface position).
    pump_load : ndarray, shape (B, N)
        Effective pump load, N.
    cycles : int
        Strokes simulated.
    change : float
        The last stroke's change, relative to the load range (of its state, or of its
        surface load against the stroke before; see :func:`pumpid.rods.march.march`).
    """

    surface_load: Array
    pump_position: Array
    pump_load: Array
    cycles: int
    change: float


def predict_surface(well: Well, position: ArrayLike, period: float, pump: PumpModel,
                    nu: float, elements: int = 60, max_cycles: int = 80,
                    tol: float = 1e-7) -> Prediction:
    """Surface load of B cards of one well from their surface positions and pumps.

    Parameters
    ----------
    well : Well
    position : array_like, shape (B, N) or (N,)
        Polished-rod position over one stroke, m, uniform in time.
    period : float
        Stroke period, s.
    pump : PumpModel
        The pump of each card.
    nu : float
        Gibbs' dimensionless damping factor (> 0: without damping the start-up transient
        never dies out).
    elements : int
        About this many elements over the string (at least two per taper).
    max_cycles : int
        Most strokes simulated.
    tol : float
        Stop when the stroke repeats to this (relative to the load range): its end state
        is its start state, or its surface load the stroke before's.

    Returns
    -------
    Prediction
    """
    s = np.atleast_2d(np.asarray(position, dtype=float))
    b, n = s.shape
    if not nu > 0:
        raise ValueError("the predictive solver needs some damping (nu > 0) to reach a "
                         "periodic state")
    params = pump.arrays(b)
    out_load = np.empty((b, n))
    out_pos = np.empty((b, n))
    out_pump = np.empty((b, n))
    cycles, change = 0, 0.0
    grid = StringGrid.of(well, period, n, elements)
    for i in range(b):
        run = grid.march(s[i], pump_vector(params, i, pump.gamma), nu, None, max_cycles, tol)
        out_load[i], out_pos[i], out_pump[i] = run.out
        cycles = max(cycles, run.cycles)
        change = max(change, run.change)
    return Prediction(surface_load=out_load, pump_position=out_pos, pump_load=out_pump,
                      cycles=cycles, change=change)


def pump_vector(params: dict[str, Array], i: int, gamma: float) -> Array:
    """The march's pump vector of card ``i`` (see :func:`pumpid.rods.march.march`)."""
    return np.array([params["fluid_load"][i], params["fillage"][i], params["intake_ratio"][i],
                     params["transfer"][i], params["dead_space"][i], 1.0 / gamma])


@dataclass(frozen=True)
class Run:
    """One march: its last stroke (surface load, plunger position, pump load; (3, N)), the
    state it ended in (for a warm start), the strokes stepped and the last change."""

    out: Array
    nodes: Array
    state: Array
    cycles: int
    change: float


@dataclass(frozen=True)
class StringGrid:
    """A well's string cut into elements, with the time step for a card's sampling.

    Build with :meth:`of`; :meth:`march` steps one card; :meth:`carry` takes another grid's
    march of the same card over, to start from.
    """

    well: Well
    stiff: Array
    mass: Array
    factor: int
    dt: float
    n: int
    #: Each node's distance from the polished rod along the string, m.
    depth: Array

    @classmethod
    def of(cls, well: Well, period: float, n: int, elements: int = 60) -> StringGrid:
        """About ``elements`` elements (at least two per taper), the time step at the
        stiffest element's stability limit, a whole number of steps per sample."""
        arr = well.arrays()
        seg = well.rod_length / elements
        counts = np.maximum(2, np.rint(arr["length"] / seg)).astype(int)
        dx = np.repeat(arr["length"] / counts, counts)
        ea = np.repeat(arr["stiffness"], counts)
        rho_a = np.repeat(arr["density"] * arr["area"], counts)
        mass = np.zeros(dx.size + 1)
        mass[:-1] += rho_a * dx / 2
        mass[1:] += rho_a * dx / 2
        dt_max = float(np.min(dx / np.repeat(arr["wave_speed"], counts)))
        factor = max(1, math.ceil(period / n / dt_max))
        return cls(well=well, stiff=ea / dx, mass=mass, factor=factor,
                   dt=period / (n * factor), n=n, depth=np.concatenate([[0.0], np.cumsum(dx)]))

    def carry(self, run: Run, source: StringGrid) -> Run:
        """``run``, a march of the same card on ``source`` (the same string cut otherwise),
        as a warm start on this grid: the node positions interpolated along the string, the
        positions one step before from the nodes' velocities at this grid's time step, the
        pump's state as it was. Nearly periodic already, so a march from it needs a few
        strokes where one from rest needs ten or more."""
        now, before = run.nodes
        u = np.interp(self.depth, source.depth, now)
        velocity = np.interp(self.depth, source.depth, (now - before) / source.dt)
        return Run(out=run.out, nodes=np.array([u, u - velocity * self.dt]),
                   state=run.state.copy(), cycles=0, change=math.inf)

    def refine(self, position: Array) -> Array:
        """The card's N surface positions interpolated to the march's time steps (what
        :meth:`march` is driven with; compute it once for many marches of one card)."""
        return trig_refine(position, self.factor)

    def march(self, position: Array, pump: Array, nu: float, warm: Run | None,
              max_cycles: int = 80, tol: float = 1e-7, refined: Array | None = None) -> Run:
        """Step one card (``position``: its N surface positions, m) until periodic.

        ``pump`` is the march's pump vector (:func:`pump_vector`); ``warm`` a previous run
        of the same card to start from (None: the string at rest at the first position, the
        barrel holding its dead space of liquid at intake pressure); ``refined`` the
        position's :meth:`refine`, when already computed.
        """
        sf = self.refine(position) if refined is None else refined
        if warm is None:
            nodes = np.full((2, self.mass.size), float(position[0]))
            state = np.array([float(position[0]), float(pump[4]), 0.0, float(pump[2])])
        else:
            nodes, state = warm.nodes.copy(), warm.state.copy()
        out = np.empty((3, self.n))
        c = self.well.damping_coefficient(nu)
        cycles, change = march(sf, self.factor, self.stiff, self.mass, c, self.dt, pump,
                               nodes[0], nodes[1], state, max_cycles, tol, out)
        return Run(out=out, nodes=nodes, state=state, cycles=int(cycles), change=float(change))
