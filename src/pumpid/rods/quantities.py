"""Pump quantities measured on a pump card (SI in, SI out; units are the caller's business).

How each is measured (also in the README):

* the card is split at its lowest and highest plunger positions into the upstroke and the
  downstroke (in time order);
* **upper load line**: median load of the upstroke between 40 % and 90 % of the gross stroke
  (after the load pick-up, before the top);
* **lower load line**: median load of the downstroke between 5 % of the gross stroke and
  the load transfer point less 10 % (at most 30 %; a first pass uses 5-30 %);
* **fluid load**: upper minus lower load line;
* **load transfer point**: the first downstroke sample (from the top) whose load is below
  the middle of the two load lines, its position interpolated between samples;
* **gross stroke**: the plunger's travel, highest minus lowest position;
* **fillage**: travel from the transfer point down to the lowest position over the gross
  stroke (1: the load transfers at the top, a full pump);
* **net stroke**: fillage times gross stroke, less the stretch of free (unanchored) tubing
  under the fluid load when its size is known;
* **pump displacement**: plunger area times net stroke times strokes per day;
* **pump intake pressure**: tubing-head pressure plus the fluid column's pressure at the pump
  depth, less the fluid load over the plunger area.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..engine.compiled import jit
from .well import Well

__all__ = ["PumpMeasure", "measure_pump_card", "measure_pump_cards", "pump_measure"]

Array = NDArray[np.float64]

_UP_BAND = (0.4, 0.9)
_DOWN_BAND = (0.05, 0.3)


@dataclass(frozen=True)
class PumpMeasure:
    """Pump quantities of one card, SI (m, N, m^3/day, Pa); None when not measurable.

    Attributes
    ----------
    gross_stroke, net_stroke : float
        Plunger travel and its effective part, m.
    fluid_load : float
        Upper minus lower load line, N.
    upper_load, lower_load : float
        The load lines, N.
    fillage : float
        Fraction 0-1.
    transfer_position : float
        Plunger position (m, same origin as the card) where the load transfers on the
        downstroke.
    displacement : float or None
        Pump displacement, m^3/day (None without a pumping speed).
    intake_pressure : float or None
        Pump intake pressure, Pa gauge (None without fluid data).
    notes : tuple of str
        What could not be measured, and why; what was assumed.
    """

    gross_stroke: float
    net_stroke: float
    fluid_load: float
    upper_load: float
    lower_load: float
    fillage: float
    transfer_position: float
    displacement: float | None
    intake_pressure: float | None
    notes: tuple[str, ...] = ()


@jit
def _band_median(h: Array, f: Array, mask: Array, lo: float, hi: float) -> float:
    # The median load of the masked samples with lo <= h <= hi; with none in the band, of
    # the three masked samples nearest the band's middle (ties: the earlier sample).
    n = h.size
    picked = np.empty(n)
    count = 0
    for i in range(n):
        if mask[i] and lo <= h[i] <= hi:
            picked[count] = f[i]
            count += 1
    if count == 0:
        mid = 0.5 * (lo + hi)
        dist = np.full(n, np.inf)
        for i in range(n):
            if mask[i]:
                dist[i] = abs(h[i] - mid)
        for i in np.argsort(dist, kind="mergesort")[:3]:
            if mask[i]:
                picked[count] = f[i]
                count += 1
    if count == 0:
        return np.nan
    ordered = np.sort(picked[:count])
    return 0.5 * (ordered[(count - 1) // 2] + ordered[count // 2])


@jit
def _transfer(y: Array, f: Array, down_rel: Array, down: Array, level: float) -> float:
    # The position where the downstroke load first falls below level (from the top),
    # interpolated between samples; the lowest position when it never does.
    n = y.size
    k = -1
    for i in range(n):
        if down[i] and f[i] < level and (k < 0 or down_rel[i] < down_rel[k]):
            k = i
    if k < 0:
        return float(np.min(y))
    if down_rel[k] == 0:
        return float(y[k])
    prev = (k - 1) % n
    fi, fj = f[prev], f[k]
    w = (fi - level) / (fi - fj) if fi != fj else 1.0
    return float(y[prev] + min(max(w, 0.0), 1.0) * (y[k] - y[prev]))


@jit
def _lines(y: Array, f: Array) -> tuple[float, float, float]:
    # One card's upper and lower load lines and its load transfer position (the module's
    # text). Compiled: an identification measures its pump card a dozen times, and in
    # numpy the small arrays' overhead made a card cost 0.17 ms.
    n = y.size
    low = np.min(y)
    gross = np.max(y) - low
    bottom, top = np.argmin(y), np.argmax(y)
    h = (y - low) / gross
    up = np.empty(n, np.bool_)
    down = np.empty(n, np.bool_)
    down_rel = np.empty(n, np.int64)
    for i in range(n):
        up[i] = (i - bottom) % n <= (top - bottom) % n
        down_rel[i] = (i - top) % n
        down[i] = down_rel[i] <= (bottom - top) % n
    upper = _band_median(h, f, up, _UP_BAND[0], _UP_BAND[1])
    lower = _band_median(h, f, down, _DOWN_BAND[0], _DOWN_BAND[1])
    transfer = _transfer(y, f, down_rel, down, 0.5 * (upper + lower))
    # Second pass: the lower line from below the transfer point only (low fillage).
    h_tr = (transfer - low) / gross
    top_band = min(_DOWN_BAND[1], max(h_tr - 0.1, _DOWN_BAND[0] + 0.05))
    lower = _band_median(h, f, down, _DOWN_BAND[0], top_band)
    transfer = _transfer(y, f, down_rel, down, 0.5 * (upper + lower))
    return upper, lower, transfer


@jit
def _all_lines(y: Array, f: Array) -> Array:
    # _lines of every card (rows), in one call.
    out = np.empty((y.shape[0], 3))
    for i in range(y.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _lines(y[i], f[i])
    return out


def measure_pump_cards(position: Array, load: Array, wells: list[Well],
                       spm: Array | list[float | None]) -> list[PumpMeasure]:
    """Measure the pump quantities of a batch of effective pump cards in time order.

    Parameters
    ----------
    position : ndarray, shape (B, N)
        Plunger position, m, upwards, one stroke in time order.
    load : ndarray, shape (B, N)
        Effective pump load, N.
    wells : list of Well
        For the plunger area, the pump depth, the tubing and the fluid.
    spm : sequence of float or None
        Strokes per minute, for the displacement.

    Returns
    -------
    list of PumpMeasure

    Raises
    ------
    ValueError
        When a plunger does not move.
    """
    y = np.ascontiguousarray(np.atleast_2d(np.asarray(position, dtype=float)))
    f = np.ascontiguousarray(np.atleast_2d(np.asarray(load, dtype=float)))
    b = y.shape[0]
    low = y.min(axis=1)
    gross = y.max(axis=1) - low
    if not np.all(gross > 0):
        raise ValueError("the plunger does not move: no pump card to measure")
    lines = _all_lines(y, f)
    upper, lower, transfer = lines[:, 0], lines[:, 1], lines[:, 2]
    fillage = np.clip((transfer - low) / gross, 0.0, 1.0)
    return [pump_measure(wells[i], float(gross[i]), float(upper[i]), float(lower[i]),
                    float(fillage[i]), float(transfer[i]), spm[i]) for i in range(b)]


def pump_measure(well: Well, gross: float, upper: float, lower: float, fillage: float,
                 transfer: float, spm: float | None) -> PumpMeasure:
    """The pump quantities from a card's gross stroke, load lines and fillage (SI).

    The net stroke, pump displacement and intake pressure follow as the module's text says;
    ``transfer`` is only recorded. Used on measured pump cards and on fitted ones alike.
    """
    notes: list[str] = []
    fluid = upper - lower
    if not fluid > 0:
        notes.append("the pump card has no fluid load (its upstroke load is not above its "
                     "downstroke load): its fillage, net stroke, displacement and intake "
                     "pressure are not meaningful")
    net = fillage * gross
    tubing = well.tubing
    if not tubing.anchored:
        if tubing.area is not None:
            stretch = max(fluid, 0.0) * well.pump.depth / (tubing.modulus * tubing.area)
            net = max(net - stretch, 0.0)
            notes.append(f"net stroke less the free tubing's stretch under the fluid load, "
                         f"{stretch:.4g} m")
        else:
            notes.append("free tubing of unknown size: the net stroke is not corrected for "
                         "tubing stretch")
    displacement = None
    if spm is not None:
        displacement = well.pump.area * net * spm * 1440.0
    else:
        notes.append("no pumping speed: no pump displacement")
    intake = None
    if well.fluid is None:
        notes.append("no fluid data: no pump intake pressure")
    else:
        if well.tubing.head_pressure is None:
            notes.append("pump intake pressure with the tubing-head pressure taken as 0 "
                         "(not in the well file)")
        discharge = float(well.hydrostatic_pressure(well.pump.depth))
        intake = discharge - fluid / well.pump.area
        if intake < 0:
            notes.append("the pump intake pressure is negative: the fluid load exceeds the "
                         "fluid column's (check the fluid density, the plunger size, the "
                         "damping)")
    return PumpMeasure(gross_stroke=gross, net_stroke=net, fluid_load=fluid,
                       upper_load=upper, lower_load=lower, fillage=fillage,
                       transfer_position=transfer, displacement=displacement,
                       intake_pressure=intake, notes=tuple(notes))


def measure_pump_card(position: Array, load: Array, well: Well,
                      spm: float | None) -> PumpMeasure:
    """Measure one effective pump card in time order (see :func:`measure_pump_cards`)."""
    return measure_pump_cards(np.asarray(position)[None], np.asarray(load)[None], [well],
                              [spm])[0]
