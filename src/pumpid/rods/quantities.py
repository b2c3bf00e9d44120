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


def _band_median(h: Array, f: Array, mask: Array, lo: Array | float,
                 hi: Array | float) -> Array:
    """Per card, the median load of the masked samples with ``lo <= h <= hi``.

    A card with no sample in its band uses the three samples of the mask nearest the
    band's middle instead.
    """
    lo_b = np.broadcast_to(np.asarray(lo, dtype=float), (h.shape[0],))[:, None]
    hi_b = np.broadcast_to(np.asarray(hi, dtype=float), (h.shape[0],))[:, None]
    sel = mask & (h >= lo_b) & (h <= hi_b)
    empty = ~sel.any(axis=1)
    if np.any(empty):
        mid = 0.5 * (lo_b + hi_b)
        dist = np.where(mask, np.abs(h - mid), np.inf)
        nearest = np.argsort(dist, axis=1)[:, :3]
        extra = np.zeros_like(sel)
        np.put_along_axis(extra, nearest, True, axis=1)
        sel = np.where(empty[:, None], extra & mask, sel)
    # The median of each row's selected samples, by one sort: np.nanmedian takes about
    # 1.5 ms for a single small card (masked arrays), and an identification measures its
    # pump card dozens of times.
    count = sel.sum(axis=1)
    ordered = np.sort(np.where(sel, f, np.inf), axis=1)
    rows = np.arange(h.shape[0])
    low_mid = ordered[rows, np.maximum(count - 1, 0) // 2]
    high_mid = ordered[rows, np.maximum(count, 1) // 2]
    return np.asarray(np.where(count > 0, 0.5 * (low_mid + high_mid), np.nan), dtype=float)


def _transfer(y: Array, f: Array, down_rel: Array, down: Array, level: Array) -> Array:
    """Per card, the position where the downstroke load first falls below ``level``."""
    n = y.shape[1]
    rows = np.arange(y.shape[0])
    hit = down & (f < level[:, None])
    order = np.where(hit, down_rel, n + 1)
    k = np.argmin(order, axis=1)
    found = hit[rows, k]
    prev = (k - 1) % n
    first = down_rel[rows, k] == 0
    fi, fj = f[rows, prev], f[rows, k]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(fi != fj, (fi - level) / (fi - fj), 1.0)
    pos = y[rows, prev] + np.clip(w, 0.0, 1.0) * (y[rows, k] - y[rows, prev])
    pos = np.where(first, y[rows, k], pos)
    # No sample below the level: the load never transfers before the bottom.
    return np.asarray(np.where(found, pos, y.min(axis=1)), dtype=float)


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
    y = np.atleast_2d(np.asarray(position, dtype=float))
    f = np.atleast_2d(np.asarray(load, dtype=float))
    b, n = y.shape
    low = y.min(axis=1)
    gross = y.max(axis=1) - low
    if not np.all(gross > 0):
        raise ValueError("the plunger does not move: no pump card to measure")
    h = (y - low[:, None]) / gross[:, None]
    idx = np.arange(n)[None, :]
    bottom, top = np.argmin(y, axis=1)[:, None], np.argmax(y, axis=1)[:, None]
    up_rel = (idx - bottom) % n
    down_rel = (idx - top) % n
    up = up_rel <= (top - bottom) % n
    down = down_rel <= (bottom - top) % n
    upper = _band_median(h, f, up, *_UP_BAND)
    lower = _band_median(h, f, down, *_DOWN_BAND)
    transfer = _transfer(y, f, down_rel, down, 0.5 * (upper + lower))
    # Second pass: the lower line from below the transfer point only (low fillage).
    h_tr = (transfer - low) / gross
    top_band = np.minimum(_DOWN_BAND[1], np.maximum(h_tr - 0.1, _DOWN_BAND[0] + 0.05))
    lower = _band_median(h, f, down, _DOWN_BAND[0], top_band)
    transfer = _transfer(y, f, down_rel, down, 0.5 * (upper + lower))
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
                     "downstroke load): fillage and net stroke are not meaningful")
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
