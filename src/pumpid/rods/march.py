"""The compiled march of the predictive solver: a lumped rod string and a valve pump, stepped
in time until the stroke repeats itself.

Written by hand because no library steps a wave equation whose bottom boundary is a pump
with valves (a state that switches with the pressure); compiled because the march takes
thousands of steps per stroke and an identification runs it hundreds of times per card.
See :mod:`pumpid.rods.predict` for the physics; this module only holds the loop.

The march's state (node positions now and one step before, and the pump's lowest plunger
position, liquid and gas content and pressure) is read at the start and written back at the
end, so a later march at nearby parameters can start from a stroke that is already nearly
periodic (a warm start) and needs only a stroke or two more.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..engine.compiled import copy_into, jit

__all__ = ["PUMP_STATE", "STALL", "march"]

Array = NDArray[np.float64]

#: Layout of the pump's state vector: lowest plunger position so far (m), liquid and gas
#: content at intake pressure (as plunger travel, m), barrel pressure (fraction of the
#: discharge pressure).
PUMP_STATE = ("floor", "liquid", "gas", "pressure")
#: A march whose change has not halved over this many strokes stops: the stroke does not
#: repeat (an undamped string, whose free vibration never dies out). A damped string's
#: transient falls geometrically; the slowest periodic march seen (gas at nu 0.05) still
#: fell 18-fold over 20 strokes, while a non-repeating one stays within a few per cent of
#: its level for hundreds of strokes.
STALL = 20
#: The shut barrel's Newton iteration stops at a step (in the pressure over the discharge
#: pressure) below this; the pressure is then within about 1e-12 of exact. Against a
#: Newton run to rounding, 40 strokes from rest on 15 simulated cards at 15-60 elements
#: gave surface loads within 1.7e-12 of the load range.
NEWTON_DONE = 1e-7


@jit(inline=True)
def _pump_load(y: float, pump: Array, state: Array, top: float,
               carried: float) -> tuple[float, float, float]:
    # One step of the valve pump (see pumpid.rods.predict.PumpModel); updates state.
    # Returns the load, its derivative in the plunger position (0 while a valve is open) and
    # the gas's volume at the barrel's pressure while both valves are shut (else -1), which
    # the next step takes as `carried`.
    # `top` is intake_ratio ** (1 / gamma): the gas's volume at discharge pressure per unit
    # at intake pressure, the same for the whole march (a power costs as much as the
    # string's update of several nodes).
    fo, fill, ri, delta, dead, inv_gamma = pump[0], pump[1], pump[2], pump[3], pump[4], pump[5]
    span = 1.0 - ri
    if y < state[0]:
        state[0] = y
    volume = y - state[0] + dead
    liquid, gas, p = state[1], state[2], state[3]
    # The barrel content's volume minus the barrel's, at intake and at discharge pressure
    # (it decreases with the pressure).
    low = liquid + gas - volume
    high = liquid + gas * top - delta - volume
    if low <= 0.0:
        # Standing valve open: the deficit enters as liquid and gas at intake pressure.
        liquid += fill * (-low)
        gas += (1.0 - fill) * (-low)
        p = ri
        stiffness = 0.0
        expanded = -1.0
    elif high >= 0.0:
        # Traveling valve open: the excess leaves, liquid and gas in proportion.
        at_top = liquid + gas * top
        keep = 1.0 - high / max(at_top, 1e-300)
        liquid *= keep
        gas *= keep
        p = 1.0
        stiffness = 0.0
        expanded = -1.0
    else:
        # Both valves shut: the excess at pressure q is convex and decreasing in q; Newton
        # from either side. It stops once a step is below NEWTON_DONE: the next would be
        # of its square's order, so the pressure is as exact as one more power would make
        # it, and the slope at the last point is carried to the new one to first order
        # instead of a power more (a power costs as much as several nodes' update; the
        # shut barrel took four a step before, about a fifth of a fluid pound's march).
        # The first point is the last step's pressure; while the valves stay shut the gas is
        # the same, so its volume there is the one the last step ended with (to first order
        # in its last Newton step, within about 1e-14 of itself) instead of a power: 11 %
        # less time over the identification's 2,469 marches of 32 simulated field cards,
        # their loads 1e-13 of the load range apart (median), 1.5e-9 at most for marches
        # to 1e-8 or tighter.
        q = min(max(p, ri), 1.0)
        if carried >= 0.0 and q == p:
            expanded = carried
        else:
            expanded = gas * (ri / q) ** inv_gamma
        for _ in range(30):
            f = liquid + expanded - delta * (q - ri) / span - volume
            slope = -expanded * inv_gamma / q - delta / span
            step = min(max(q - f / slope, ri), 1.0)
            moved = step - q
            if abs(moved) < NEWTON_DONE:
                expanded *= 1.0 - inv_gamma * moved / q
                q = step
                break
            q = step
            expanded = gas * (ri / q) ** inv_gamma
        p = q
        slope = -expanded * inv_gamma / q - delta / span
        stiffness = -fo / (span * slope)
    state[1], state[2], state[3] = liquid, gas, p
    return fo * (1.0 - p) / span, stiffness, expanded


@jit
def _state_change(stiff: Array, mass: Array, dt: float, pump: Array, u: Array, u_prev: Array,
                  state: Array, u0: Array, prev0: Array, state0: Array) -> float:
    # How far the state at the stroke's end is from the state it started in, as a load (N):
    # the largest change of an element's tension (now and one step before), of a node's
    # momentum flux (velocity times the string's impedance, sqrt(E A rho A), taken with the
    # node's whole mass so the end nodes count double) and of the pump's contents (times
    # the load that the transfer travel takes up) and pressure.
    e = stiff.size
    worst = 0.0
    for i in range(e):
        worst = max(worst, stiff[i] * abs(u[i] - u[i + 1] - u0[i] + u0[i + 1]),
                    stiff[i] * abs(u_prev[i] - u_prev[i + 1] - prev0[i] + prev0[i + 1]))
    for i in range(e + 1):
        z = math.sqrt(2.0 * mass[i] * stiff[min(i, e - 1)])
        worst = max(worst, z * abs(u[i] - u_prev[i] - u0[i] + prev0[i]) / dt)
    k_pump = pump[0] / max(pump[3], 1e-300)
    for i in range(3):
        worst = max(worst, k_pump * abs(state[i] - state0[i]))
    worst = max(worst, pump[0] * abs(state[3] - state0[3]) / max(1.0 - pump[2], 1e-300))
    return worst


@jit
def march(sf: Array, factor: int, stiff: Array, mass: Array, c: float, dt: float,
          pump: Array, u: Array, u_prev: Array, state: Array, max_cycles: int, tol: float,
          out: Array) -> tuple[int, float]:
    """Step one card's string and pump until the stroke repeats to ``tol``: its end state
    is its start state (a stroke is enough when the start is periodic already), or its
    surface load is the stroke before's.

    Parameters
    ----------
    sf : ndarray, shape (N * factor,)
        Surface position at every time step of one stroke, m.
    factor : int
        Time steps per card sample.
    stiff : ndarray, shape (E,)
        Element stiffness E A / dx, N/m.
    mass : ndarray, shape (E + 1,)
        Node masses, kg (node 0 is the polished rod).
    c : float
        Viscous damping coefficient, 1/s.
    dt : float
        Time step, s.
    pump : ndarray, shape (6,)
        Fluid load (N), fillage, intake ratio, transfer (m), dead space (m), 1/gamma.
    u, u_prev : ndarray, shape (E + 1,)
        Node positions now and one step before (read and written back).
    state : ndarray, shape (4,)
        The pump's state (:data:`PUMP_STATE`, read and written back).
    max_cycles : int
        Most strokes stepped.
    tol : float
        Largest change, relative to the surface load's range, to stop: of the state over a
        stroke (as a load, see ``_state_change``) or of the surface load from one stroke to
        the next.
    out : ndarray, shape (3, N)
        Written: dynamic surface load (N), plunger position (m), pump load (N) at the card's
        samples, of the last stroke.

    Returns
    -------
    cycles : int
        Strokes stepped (fewer than ``max_cycles`` when the change stalls, see
        :data:`STALL`).
    change : float
        The last change measured (relative to the load range): of the state over the last
        stroke where that one stopped the march, else of the surface load.
    """
    steps = sf.size
    e = stiff.size
    damp = 0.5 * c * dt
    n = out.shape[1]
    last = np.zeros(n)
    change = math.inf
    cycles = 0
    new = np.empty(e + 1)
    history = np.full(STALL, math.inf)
    top = pump[2] ** pump[5]
    # The central difference with the damping taken half implicitly, its factors out of the
    # loop: new = gain_i * force + 2 u / (1 + damp) - (1 - damp) / (1 + damp) u_prev.
    gain = np.empty(e + 1)
    for i in range(e + 1):
        gain[i] = dt * dt / mass[i] / (1.0 + damp)
    now_factor = 2.0 / (1.0 + damp)
    prev_factor = (1.0 - damp) / (1.0 + damp)
    r_pump = dt * dt / mass[e]
    start_u = np.empty(e + 1)
    start_prev = np.empty(e + 1)
    start_state = np.empty(4)
    # The loop below is the march's whole cost, and most of a step's is fixed (the pump's
    # logic and the bookkeeping), not per element; the choices that follow took the
    # identification's marches 22 % less time with the same results to the bit (2,469
    # marches of 32 simulated field cards): the pump's step compiled into the loop; the
    # drive padded by a step each side (no remainder per step); three node buffers taking
    # turns instead of a copy of the string per step; the elements' tensions in a pass of
    # their own, so that both passes run without a value carried from one element to the
    # next.
    drive = np.empty(steps + 2)
    drive[0] = sf[steps - 1]
    for j in range(steps):
        drive[j + 1] = sf[j]
    drive[steps + 1] = sf[0]
    cur = u.copy()
    prv = u_prev.copy()
    tension = np.empty(e)
    while cycles < max_cycles:
        cycles += 1
        lowest = math.inf
        for i in range(e + 1):
            start_u[i] = cur[i]
            start_prev[i] = prv[i]
        for i in range(4):
            start_state[i] = state[i]
        sample = 0
        k = 0
        gas_volume = -1.0  # none carried into a stroke: its start state may have moved
        for step in range(steps):
            lowest = min(lowest, cur[e])
            pload, kp, gas_volume = _pump_load(cur[e], pump, state, top, gas_volume)
            for i in range(e):
                tension[i] = stiff[i] * (cur[i] - cur[i + 1])
            nxt = drive[step + 2]
            if sample == 0:
                acc0 = (nxt - 2.0 * drive[step + 1] + drive[step]) / dt**2
                vel0 = (nxt - drive[step]) / (2.0 * dt)
                out[0, k] = tension[0] + mass[0] * (acc0 + c * vel0)
                out[1, k] = cur[e]
                out[2, k] = pload
                k += 1
            sample += 1
            if sample == factor:
                sample = 0
            new[0] = nxt
            for i in range(1, e):
                new[i] = (gain[i] * (tension[i - 1] - tension[i]) + now_factor * cur[i]
                          - prev_factor * prv[i])
            t_prev = tension[e - 1]
            # The pump's spring (the barrel's content while both valves are shut) taken
            # implicitly: it can be far stiffer than the explicit step allows.
            force = t_prev - pload
            new[e] = (force * r_pump + 2.0 * cur[e] - (1.0 - damp) * prv[e]
                      + kp * r_pump * cur[e]) / (1.0 + damp + kp * r_pump)
            if kp > 0.0:
                # A valve that opens within the step: the spring's load stops at the open
                # valve's (the fluid load, or none), so the step is the implicit one with
                # the load clipped there, whose root is unique. Extrapolated past it, the
                # load kicked the plunger by an amount that depended on where in the step
                # the valve opened: the march's stroke was not a continuous function of its
                # start, and a fluid pound could repeat two strokes 1e-3 to 1e-2 of the
                # load range apart (from rest and from a nearby stroke), which made the
                # solver crawl between them.
                reached = pload + kp * (new[e] - cur[e])
                if reached > pump[0] or reached < 0.0:
                    held = min(max(reached, 0.0), pump[0])
                    new[e] = ((t_prev - held) * r_pump + 2.0 * cur[e]
                              - (1.0 - damp) * prv[e]) / (1.0 + damp)
            prv, cur, new = cur, new, prv
        # The barrel's reference is the plunger's lowest point of the stroke just stepped,
        # not of all history: a warm start from other parameters then forgets theirs.
        # Raising the reference by `rise` shrinks the barrel by as much at every plunger
        # position, so as much content leaves it (liquid and gas in proportion, at the
        # barrel's pressure): the pressure, hence the load, is unchanged by the new
        # reference. Kept in the barrel instead, a full pump's liquid became a pressure kick
        # and the march alternated between two strokes for ever (0.2 % of the load range).
        rise = lowest - state[0]
        if rise > 0.0:
            held = state[1] + state[2] * (pump[2] / state[3]) ** pump[5]
            keep = max(1.0 - rise / max(held, 1e-300), 0.0)
            state[1] *= keep
            state[2] *= keep
        state[0] = lowest
        lo, hi, worst = out[0, 0], out[0, 0], 0.0
        for k in range(n):
            lo = min(lo, out[0, k])
            hi = max(hi, out[0, k])
            worst = max(worst, abs(out[0, k] - last[k]))
        span = max(hi - lo, 1e-12)
        # Periodic once the stroke ends where it began: a start that is already periodic
        # (a warm start predicted from the last sensitivities) stops after one stroke
        # instead of two. Measured on 253 warm marches of simulated cards, the load of the
        # stroke just stepped was off the periodic one by 0.6 (median) to 2.0 (largest)
        # times this change.
        change = _state_change(stiff, mass, dt, pump, cur, prv, state, start_u, start_prev,
                               start_state) / span
        if change < tol:
            break
        if cycles > 1:
            change = worst / span
            if change < tol:
                break
            slot = cycles % STALL
            if cycles > 2 * STALL and change > 0.5 * history[slot]:
                break
            history[slot] = change
        for k in range(n):
            last[k] = out[0, k]
    copy_into(u, cur)
    copy_into(u_prev, prv)
    return cycles, change
