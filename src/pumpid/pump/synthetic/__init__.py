"""Synthetic dynamometer cards and fields of wells, with the truth they were made from.

Three layers, each usable alone and each a module of this package (``kinematics``,
``card``, ``field``; the files a field is written in are ``layouts``):

Pumping-unit kinematics (:class:`CrankRocker`, :func:`polished_rod_position`)
    A conventional (crank-rocker) beam pumping unit is a four-bar linkage: the gearbox crank
    (radius R) turns at constant speed, the pitman (length P) pulls the rear arm (length C)
    of the walking beam, which pivots on the saddle bearing; the horsehead at the end of the
    front arm (length A) is an arc centred on the saddle bearing, so the polished rod moves
    by exactly ``A`` times the beam's change of angle. The linkage is solved exactly at each
    crank angle (no small-angle or harmonic approximation). Sampling is uniform in time over
    one stroke, from bottom dead centre, ``N`` samples, the closing sample (which repeats
    the first) left out: ``t_i = i T / N``, ``T = 60 / SPM``.

Load from a model (:func:`periodic_load`, :func:`synthetic_card`)
    The load a linear model needs to move the polished rod along that path in the periodic
    steady state, computed exactly per harmonic from the model's transfer function ``H``
    (:meth:`pumpid.Model.transfer_function`): ``F_k = X_k / H_k``, plus a constant static
    load (the buoyant rod weight). A constant load only moves the model's position by the
    constant ``H(0) W``, which a fit absorbs in its position offset; the card keeps the
    kinematic position. ``H_k`` is, by default (``hold="linear"``), the response at the
    sample instants to a load whose samples are joined by straight lines, which is what a
    recorder's samples mean to :func:`pumpid.simulate`::

        H_k = sum over all integers m of  sinc²(w_m / 2) H(i w_m / h),
        w_m = 2 pi k / N + 2 pi m,  h = T / N,  sinc(x) = sin(x) / x

    (the hat function's spectrum folded onto the sample grid). The sum is taken over
    ``|m| <= 64`` and its tail from the transfer function's high-frequency asymptote
    ``c / s^r`` in closed form (Hurwitz zeta), so ``pumpid.simulate(model, t, load,
    initial_state="periodic")`` gives back the kinematic position to about 1e-12 of the
    stroke. With ``hold="none"`` ``H_k = H(i k 2 pi / T)``: the band-limited load of the
    continuous model, which a simulation on the card's own samples reproduces only up to
    the straight-line error, of order ``(k 2 pi / N)² / 12`` relative at harmonic ``k``.

Fields of wells (:func:`synthetic_field`)
    Many wells, each with its own parameters, rod weight, stroke and SPM, cards at regular
    times with a small card-to-card jitter, optional step changes at known cards and broken
    cards, written in the file layouts pumpid reads, and returned with the truth table.

The file layouts and the kinds of broken card are described in
:mod:`pumpid.pump.synthetic.layouts`.
"""

from __future__ import annotations

from .card import CardLabel, periodic_load, synthetic_card
from .field import FieldCards, StepChange, synthetic_field
from .kinematics import CrankRocker, polished_rod_position
from .layouts import BROKEN_KINDS, FIELD_FORMATS

__all__ = [
    "BROKEN_KINDS",
    "FIELD_FORMATS",
    "CardLabel",
    "CrankRocker",
    "FieldCards",
    "StepChange",
    "periodic_load",
    "polished_rod_position",
    "synthetic_card",
    "synthetic_field",
]
