"""The rod string: downhole (pump) cards from surface cards by the damped wave equation.

A layer above :mod:`pumpid.cards` and below the command line and the fleet. Everything
inside works in SI units.

Public names
------------
Well, Taper, Pump, Tubing, Fluid, WellError, MATERIALS
    The well description (frozen, checked dataclasses, SI units).
read_well_file, wells_from_dict, WellFile
    The JSON well file (see the README for its schema).
"""

from .well import MATERIALS, Fluid, Pump, Taper, Tubing, Well, WellError
from .wellfile import WellFile, read_well_file, wells_from_dict

__all__ = ["MATERIALS", "Fluid", "Pump", "Taper", "Tubing", "Well", "WellError", "WellFile",
           "read_well_file", "wells_from_dict"]
