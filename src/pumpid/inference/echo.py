"""A resonance on the imposed motion: what a periodic card cannot tell about the well.

A dynamometer card is one period of a motion the pumping unit imposes: its content is the
stroke frequency and a handful of its harmonics, nothing between them. A lumped model fitted
load in, position out can only place its poles where they shape those harmonics, and on
real wells it puts the oscillating pair right on them: the natural frequency comes out at
1.00-1.22 times the stroke frequency on every card of a well (median 1.06), steady from card
to card, and "determined" by every error measure. Steady and determined, but it echoes the
pumping speed, not the rod string: change the speed and it follows.

:func:`echo_of` names such fits: the natural frequency within ``ECHO_BAND`` stroke
frequencies of one of the first ``ECHO_HARMONICS`` harmonics (the stroke frequency
alone: see there why). The oscillating pair's
quantities (natural frequency, damping ratio) are then marked as not a property of the well,
with the reason in words, and the fleet's change detection leaves them out.

:func:`alias_of` names the other resonance a card cannot tell: one above half its sampling
rate. The exact discrete model of a lightly damped pair beyond that frequency rings at an
alias of it between the samples, which can follow part of what the model otherwise misses;
on public field cards of 200 samples (Nyquist frequency 10 Hz) three fits placed it at
480-680 Hz with masses of 1.5-2.1e-6 kN*s^2/m, each crawling from ripple to ripple of the
cost toward m -> 0 until the solver's budget ran out, and called the natural frequency
"determined" (478 +- 238 Hz).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from .derived import Derived

__all__ = ["ECHO_BAND", "ECHO_HARMONICS", "FUNDAMENTAL_ONLY", "FUNDAMENTAL_WORSE",
           "PAIR_QUANTITIES", "alias_of", "echo_of", "fundamental_share"]

#: Harmonics of the stroke frequency checked (1: the stroke frequency itself). Only the
#: stroke frequency: every echo seen on real cards sits there (a real well's 76 cards at
#: 1.00-1.22x, Sandia's downhole strokes at 0.88-1.00x, its surface card SX6I03 at 0.96x),
#: while a resonance the data do fix may sit near a higher harmonic by coincidence:
#: synthetic wells whose true resonance is at 2.1-3.0x the stroke frequency have it
#: recovered and its changes found (tests/fleet/test_batch.py), and marking harmonics 2-3
#: (a band of half the range 1.75-3.25) left those changes unwatched.
ECHO_HARMONICS = 1
#: Half-width of the band around the harmonic, in stroke frequencies: 0.75-1.25 holds the
#: real well's 1.00-1.22.
ECHO_BAND = 0.25
#: A fit that explains less than this share of what the stroke's fundamental leaves of the
#: position reproduces the fundamental alone, which any load gives (:func:`fundamental_share`).
#: Of 149 public real cards' Kelvin fits, 63 explain at most 0.07 % of it (all of them
#: already undetermined by their errors, or poor), the next 0.13 % and the median 4 %.
FUNDAMENTAL_ONLY = 1e-3
#: ... and no worse than it by more than this share: a fit far worse than the fundamental
#: alone (a card read backwards: R^2 0.18 against the fundamental's 0.99) does not
#: reproduce even that; the quality gate speaks for it.
FUNDAMENTAL_WORSE = -0.05
#: The quantities the oscillating pair of poles sets.
PAIR_QUANTITIES = ("natural_frequency", "damping_ratio")


def _mark_pair(out: dict[str, Derived], note: str, **also: bool) -> str:
    """Mark the pair's quantities in ``out`` (in place) not the well's, with ``note`` and
    any other changes; returns their names in words ("natural frequency and damping
    ratio")."""
    for name in PAIR_QUANTITIES:
        if name in out:
            out[name] = dataclasses.replace(out[name], well_property=False, note=note, **also)
    return " and ".join(n.replace("_", " ") for n in PAIR_QUANTITIES if n in out)


def echo_of(derived: Mapping[str, Derived], period: float | None
            ) -> tuple[dict[str, Derived], str | None]:
    """Mark the oscillating pair's quantities when its resonance sits on a harmonic.

    Parameters
    ----------
    derived : mapping of name -> Derived
        A fit's derived quantities.
    period : float or None
        The stroke period (s) of a periodic card; None or NaN for a record that is not one
        period of a periodic motion (nothing is checked).

    Returns
    -------
    derived : dict
        The quantities, those of the pair marked ``well_property=False`` with a note.
    warning : str or None
        The finding in words (None when the resonance is clear of the harmonics).
    """
    out = dict(derived)
    fn = derived.get("natural_frequency")
    if fn is None or period is None or not (math.isfinite(period) and period > 0) \
            or not (math.isfinite(fn.value) and fn.value > 0):
        return out, None
    stroke = 1.0 / period
    ratio = fn.value / stroke
    harmonic = max(1, round(ratio))
    if harmonic > ECHO_HARMONICS or abs(ratio - harmonic) > ECHO_BAND:
        return out, None
    where = "the stroke frequency" if harmonic == 1 else f"harmonic {harmonic} of the stroke " \
                                                         "frequency"
    note = (f"the fitted resonance sits on {where} (natural frequency {fn.value:.4g} Hz = "
            f"{ratio:.3f} x the stroke frequency {stroke:.4g} Hz): the model echoes the "
            f"imposed motion, and this follows the pumping speed, not the well")
    names = _mark_pair(out, note)
    warning = (f"{note[0].upper()}{note[1:]}. A card holds only the stroke frequency and its "
               f"harmonics, so it cannot tell where the rod string's own resonance is: the "
               f"{names} are not properties of the well (not trended by the fleet report)")
    return out, warning


def alias_of(derived: Mapping[str, Derived], step: float | None
             ) -> tuple[dict[str, Derived], str | None]:
    """Mark the oscillating pair's quantities when its resonance lies beyond the samples.

    Parameters
    ----------
    derived : mapping of name -> Derived
        A fit's derived quantities.
    step : float or None
        The card's sampling step (s; its median where the steps differ); None or NaN:
        nothing is checked.

    Returns
    -------
    derived : dict
        The quantities, those of the pair marked not determined and not a property of the
        well, with a note, where the pair rings (damping ratio below 1) at a natural
        frequency above half the sampling rate that has a finite error.
    warning : str or None
        The finding in words (None when the resonance lies within what the samples show).
    """
    out = dict(derived)
    fn = derived.get("natural_frequency")
    if fn is None or step is None or not (math.isfinite(step) and step > 0) \
            or not (math.isfinite(fn.value) and fn.value > 0):
        return out, None
    nyquist = 0.5 / step
    zeta = derived.get("damping_ratio")
    # Only a pair that rings has an alias to lend: past critical damping (boundary fits whose
    # "pair" is two real poles, damping ratios of 340-570 at an arbitrary k0) nothing rings.
    # A frequency with no finite error moves with a limit the fit ran to (m -> 0 at the
    # window's edge), whose own words say so.
    if not (fn.value > nyquist and math.isfinite(fn.stderr)) or zeta is None \
            or not zeta.value < 1.0:
        return out, None
    note = (f"the fitted resonance (natural frequency {fn.value:.4g} Hz) lies above the "
            f"highest frequency the card's samples can show ({nyquist:.4g} Hz, half their "
            f"rate): the samples hold only an alias of it")
    names = _mark_pair(out, note, determined=False)
    warning = (f"{note[0].upper()}{note[1:]}, which the model uses to follow part of what it "
               f"otherwise misses. The card does not determine the {names} (not properties "
               f"of the well, not trended)")
    return out, warning


def fundamental_share(position: NDArray[np.float64]) -> float:
    """R^2 of the stroke's fundamental alone: the share of a uniformly sampled period's
    position variance in its mean and first harmonic.

    A card's position is mostly its fundamental (the crank's motion: 99 % of the variance
    on most public real cards and on every synthetic crank-rocker card), and any linear
    model reproduces that from any load, by a pair of poles on the stroke frequency (the
    echo of :func:`echo_of`): so R^2 >= 0.99 says nothing of the model until it is compared
    with this. NaN for fewer than four samples or a constant position.
    """
    x = np.asarray(position, dtype=float)
    n = x.size
    if n < 4 or not np.all(np.isfinite(x)):
        return math.nan
    centred = x - x.mean()
    total = float(centred @ centred)
    if not total > 0.0:
        return math.nan
    # One period, uniformly sampled: the first harmonic's two columns are orthogonal to the
    # mean and to each other, so its share is its DFT coefficient's power.
    first = np.fft.rfft(centred)[1]
    return min(2.0 * float(abs(first) ** 2) / n / total, 1.0)
