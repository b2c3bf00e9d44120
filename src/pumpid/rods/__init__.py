"""The rod string: downhole (pump) cards from surface cards by the damped wave equation.

A layer above :mod:`pumpid.cards` (it reads :class:`~pumpid.cards.Card`) and below the
command line and the fleet. Everything inside works in SI units; cards are converted on the
way in and results given back in the card's units.

Public names
------------
Well, Taper, Pump, Tubing, Fluid, WellError, MATERIALS
    The well description (frozen, checked dataclasses, SI units).
read_well_file, wells_from_dict, WellFile
    The JSON well file (see the README for its schema).
diagnose_cards, diagnose_card, DownholeResult, DEFAULT_DAMPING, loop_work
    Surface cards -> downhole cards and pump quantities, batched.
fourier_diagnostic, fd_diagnostic, fourier_predict, string_transfer, StringArrays
    The solvers on arrays: Gibbs' Fourier method, the finite-difference march, the exact
    frequency-domain predictive solution for a pump load given in time, and the string's
    transfer matrix per harmonic.
PumpModel, predict_surface, Prediction
    The predictive solver with a valve pump model (surface position -> surface load).
measure_pump_card, measure_pump_cards, pump_measure, PumpMeasure
    Pump quantities of a pump card (or of its load lines and fillage).
quantity_units
    The unit each pump quantity is shown in, by the card and the well file.
wells_for
    The well of each card (one for all, a well file's match, or one per card).
surface_arrays
    A surface card in SI units with its period, as the solvers take it.
"""

from .diagnose import (
    CONVENTIONS,
    DAMPING_UNIT,
    DEFAULT_DAMPING,
    METHODS,
    REVERSED_NOTE,
    DownholeResult,
    diagnose_card,
    diagnose_cards,
    loop_work,
    quantity_units,
    surface_arrays,
    wells_for,
)
from .fd import fd_diagnostic
from .fourier import (
    StringArrays,
    fourier_diagnostic,
    fourier_predict,
    harmonic_count,
    string_transfer,
)
from .predict import Prediction, PumpModel, predict_surface
from .quantities import PumpMeasure, measure_pump_card, measure_pump_cards, pump_measure
from .well import MATERIALS, Fluid, Pump, Taper, Tubing, Well, WellError
from .wellfile import WellFile, read_well_file, wells_from_dict

__all__ = [
    "CONVENTIONS",
    "DAMPING_UNIT",
    "DEFAULT_DAMPING",
    "MATERIALS",
    "METHODS",
    "REVERSED_NOTE",
    "DownholeResult",
    "Fluid",
    "Prediction",
    "Pump",
    "PumpMeasure",
    "PumpModel",
    "StringArrays",
    "Taper",
    "Tubing",
    "Well",
    "WellError",
    "WellFile",
    "diagnose_card",
    "diagnose_cards",
    "fd_diagnostic",
    "fourier_diagnostic",
    "fourier_predict",
    "harmonic_count",
    "loop_work",
    "measure_pump_card",
    "measure_pump_cards",
    "predict_surface",
    "pump_measure",
    "quantity_units",
    "read_well_file",
    "string_transfer",
    "surface_arrays",
    "wells_for",
    "wells_from_dict",
]
