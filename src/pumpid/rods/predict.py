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
from .well import Well

__all__ = ["Prediction", "PumpModel", "predict_surface"]

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


class _PumpState:
    """Barrel content and pressure of B pumps, stepped with the plunger position."""

    def __init__(self, model: PumpModel, count: int, start: Array) -> None:
        p = model.arrays(count)
        self.fo, self.fill, self.ri = p["fluid_load"], p["fillage"], p["intake_ratio"]
        self.delta, self.dead, self.inv = p["transfer"], p["dead_space"], 1.0 / model.gamma
        self.span = 1.0 - self.ri
        self.floor = start.copy()         # the plunger's lowest position so far
        self.liquid = self.dead.copy()    # liquid volume at intake pressure (travel units)
        self.gas = np.zeros(count)        # gas volume at intake pressure (travel units)
        self.p = self.ri.copy()

    def _excess(self, p: Array, volume: Array) -> Array:
        """Content volume at pressure p minus the barrel volume (decreasing in p)."""
        return (self.liquid + self.gas * (self.ri / p) ** self.inv
                - self.delta * (p - self.ri) / self.span - volume)

    def load(self, y: Array) -> Array:
        """Pump load (N) for plunger positions ``y`` (m), updating valves and content."""
        self.floor = np.minimum(self.floor, y)
        volume = y - self.floor + self.dead
        low = self._excess(self.ri, volume)
        high = self._excess(np.ones_like(volume), volume)
        filling = low <= 0
        emptying = high >= 0
        # Standing valve open: the deficit enters as liquid and gas at intake pressure.
        deficit = np.where(filling, -low, 0.0)
        self.liquid = self.liquid + self.fill * deficit
        self.gas = self.gas + (1.0 - self.fill) * deficit
        # Traveling valve open: the excess leaves, liquid and gas in proportion.
        at_top = self.liquid + self.gas * self.ri**self.inv
        keep = np.where(emptying, 1.0 - high / np.maximum(at_top, 1e-300), 1.0)
        self.liquid, self.gas = self.liquid * keep, self.gas * keep
        shut = ~(filling | emptying)
        p = np.where(filling, self.ri, np.where(emptying, 1.0, self.p))
        if np.any(shut):
            # Both valves closed: solve excess(p) = 0; it is convex and decreasing in p, so
            # Newton converges from either side; bounded to the valves' pressures.
            q = np.clip(self.p, self.ri, 1.0)
            for _ in range(12):
                f = self._excess(q, volume)
                slope = (-self.gas * self.inv * (self.ri / q) ** self.inv / q
                         - self.delta / self.span)
                step = np.clip(q - f / slope, self.ri, 1.0)
                done = np.max(np.abs(step - q)) < 1e-13
                q = step
                if done:
                    break
            p = np.where(shut, q, p)
        self.p = p
        return np.asarray(self.fo * (1.0 - p) / self.span, dtype=float)


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
        Largest change of the surface load over the last stroke, relative to its range.
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
        Stop when the surface load changes less than this (relative to its range) over a
        stroke.

    Returns
    -------
    Prediction
    """
    s = np.atleast_2d(np.asarray(position, dtype=float))
    b, n = s.shape
    if not nu > 0:
        raise ValueError("the predictive solver needs some damping (nu > 0) to reach a "
                         "periodic state")
    arr = well.arrays()
    seg = well.rod_length / elements
    counts = np.maximum(2, np.rint(arr["length"] / seg)).astype(int)
    dx = np.repeat(arr["length"] / counts, counts)
    ea = np.repeat(arr["stiffness"], counts)
    rho_a = np.repeat(arr["density"] * arr["area"], counts)
    stiff = ea / dx                                            # per element, N/m
    mass = np.zeros(dx.size + 1)
    mass[:-1] += rho_a * dx / 2
    mass[1:] += rho_a * dx / 2
    dt_max = float(np.min(dx / np.repeat(arr["wave_speed"], counts)))
    factor = max(1, math.ceil(period / n / dt_max))
    dt = period / (n * factor)
    c = well.damping_coefficient(nu)
    sf = trig_refine(s, factor)
    steps = n * factor
    state = _PumpState(pump, b, s[:, 0].copy())
    u_prev = np.repeat(s[:, :1], mass.size, axis=1)
    u = u_prev.copy()
    m = mass[1:]
    damp = 0.5 * c * dt
    last: Array | None = None
    change = math.inf
    cycles = 0
    out_load = np.empty((b, n))
    out_pos = np.empty((b, n))
    out_pump = np.empty((b, n))
    while cycles < max_cycles:
        cycles += 1
        for step in range(steps):
            tension = stiff * (u[:, :-1] - u[:, 1:])
            pload = state.load(u[:, -1])
            force = np.empty_like(u[:, 1:])
            force[:, :-1] = tension[:, :-1] - tension[:, 1:]
            force[:, -1] = tension[:, -1] - pload
            if step % factor == 0:
                k = step // factor
                acc0 = (sf[:, (step + 1) % steps] - 2 * sf[:, step] + sf[:, step - 1]) / dt**2
                vel0 = (sf[:, (step + 1) % steps] - sf[:, step - 1]) / (2 * dt)
                out_load[:, k] = tension[:, 0] + mass[0] * (acc0 + c * vel0)
                out_pos[:, k] = u[:, -1]
                out_pump[:, k] = pload
            new = np.empty_like(u)
            new[:, 0] = sf[:, (step + 1) % steps]
            new[:, 1:] = (force * dt**2 / m + 2 * u[:, 1:] - (1 - damp) * u_prev[:, 1:]) / (
                1 + damp)
            u_prev, u = u, new
        if last is not None:
            span = np.maximum(np.ptp(out_load, axis=-1), 1e-12)
            change = float(np.max(np.max(np.abs(out_load - last), axis=-1) / span))
            if change < tol:
                break
        last = out_load.copy()
    return Prediction(surface_load=out_load, pump_position=out_pos, pump_load=out_pump,
                      cycles=cycles, change=change)
