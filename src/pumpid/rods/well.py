"""The well as the wave equation sees it: rod tapers, pump, tubing and fluid, in SI units.

Every value is stored in SI (m, Pa, kg/m^3, N); the well file reader
(:mod:`pumpid.rods.wellfile`) converts from the file's units. The dataclasses are frozen and
check themselves: a bad value raises :class:`WellError` naming the well and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..cards import PSI_PA

__all__ = [
    "GRAVITY",
    "LB_FT3",
    "MATERIALS",
    "WATER_DENSITY",
    "Fluid",
    "Pump",
    "Taper",
    "Tubing",
    "Well",
    "WellError",
]

#: Standard gravity, m/s^2.
GRAVITY = 9.80665
#: Density of water for specific gravities, kg/m^3.
WATER_DENSITY = 1000.0
#: One pound per cubic foot in kg/m^3 (0.45359237 kg over 0.3048^3 m^3, to the last digit).
LB_FT3 = 16.01846337396014
#: Rod materials by name: (Young's modulus in Pa, density in kg/m^3). Steel: 30.5e6 psi and
#: 490 lb/ft^3, the values rod-pumping practice uses; fiberglass: 7.2e6 psi and 2000 kg/m^3
#: (about 125 lb/ft^3), a typical glass-fibre sucker rod body.
MATERIALS: dict[str, tuple[float, float]] = {
    "steel": (30.5e6 * PSI_PA, 490.0 * LB_FT3),
    "fiberglass": (7.2e6 * PSI_PA, 2000.0),
}
# How far the rod string's bottom may sit above the pump depth (fraction of the depth)
# before it is an error: the pump's own length and a pull tube take a few metres.
_GAP_TOLERANCE = 0.02
# How far the rods may reach below the stated pump depth (a depth given to the seating
# nipple while the rods and plunger reach into the barrel) before it is an error.
_OVERSHOOT_TOLERANCE = 0.02


class WellError(ValueError):
    """A well description or well file is unusable; the message names file, well and field.

    Parameters
    ----------
    message : str
        What is wrong.
    path : str, optional
        The well file.
    well : str, optional
        The well id.
    field : str, optional
        The field, as a path such as ``rods[1].diameter``.
    """

    def __init__(self, message: str, *, path: str | None = None, well: str | None = None,
                 field: str | None = None) -> None:
        self.path, self.well, self.field, self.reason = path, well, field, message
        where = [p for p in (path, None if well is None else f"well {well!r}",
                             None if field is None else f"field {field!r}") if p]
        super().__init__(f"{', '.join(where)}: {message}" if where else message)


def _positive(value: float, what: str, well: str | None, allow_zero: bool = False) -> float:
    x = float(value)
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise WellError(f"must be a {'non-negative' if allow_zero else 'positive'} finite "
                        f"number, got {value!r}", well=well, field=what)
    return x


@dataclass(frozen=True)
class Taper:
    """One section of the rod string (a rod taper or a sinker bar section).

    Parameters
    ----------
    length : float
        Length in m.
    diameter : float
        Rod body diameter in m.
    modulus : float
        Young's modulus in Pa.
    density : float
        Material density in kg/m^3.
    material : str or None
        The material's name when it came from :data:`MATERIALS`.
    kind : {"rod", "sinker"}
        Rods or sinker bars.
    """

    length: float
    diameter: float
    modulus: float
    density: float
    material: str | None = None
    kind: str = "rod"

    def __post_init__(self) -> None:
        for name in ("length", "diameter", "modulus", "density"):
            object.__setattr__(self, name, _positive(getattr(self, name), name, None))
        if self.kind not in ("rod", "sinker"):
            raise WellError(f"kind must be 'rod' or 'sinker', got {self.kind!r}", field="kind")

    @property
    def area(self) -> float:
        """Cross-section in m^2."""
        return math.pi * self.diameter**2 / 4.0

    @property
    def stiffness(self) -> float:
        """Axial stiffness E*A in N."""
        return self.modulus * self.area

    @property
    def wave_speed(self) -> float:
        """Speed of sound in the rod, sqrt(E/rho), m/s."""
        return math.sqrt(self.modulus / self.density)

    @property
    def weight_in_air(self) -> float:
        """Weight of the section in air, N."""
        return self.density * GRAVITY * self.area * self.length


@dataclass(frozen=True)
class Pump:
    """The downhole pump: setting depth (m) and plunger diameter (m)."""

    depth: float
    plunger_diameter: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "depth", _positive(self.depth, "pump.depth", None))
        object.__setattr__(self, "plunger_diameter",
                           _positive(self.plunger_diameter, "pump.plunger_diameter", None))

    @property
    def area(self) -> float:
        """Plunger area in m^2."""
        return math.pi * self.plunger_diameter**2 / 4.0


@dataclass(frozen=True)
class Tubing:
    """The tubing: anchored or free, its size (m) when free, and the tubing-head pressure.

    Parameters
    ----------
    anchored : bool
        True when a tubing anchor holds the tubing (no tubing stretch at the pump).
    outer_diameter, inner_diameter : float or None
        Tubing body diameters in m; needed to correct the net stroke for the stretch of free
        tubing.
    modulus : float
        Young's modulus of the tubing in Pa (steel by default).
    head_pressure : float or None
        Tubing-head (flowline) pressure in Pa, gauge; None when not given (taken as 0 for the
        pump intake pressure, said in the result's notes).
    """

    anchored: bool = True
    outer_diameter: float | None = None
    inner_diameter: float | None = None
    modulus: float = MATERIALS["steel"][0]
    head_pressure: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.anchored, bool):
            raise WellError(f"must be true or false, got {self.anchored!r}",
                            field="tubing.anchored")
        for name in ("outer_diameter", "inner_diameter"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _positive(value, f"tubing.{name}", None))
        if (self.outer_diameter is not None and self.inner_diameter is not None
                and self.inner_diameter >= self.outer_diameter):
            raise WellError("the inner diameter must be smaller than the outer diameter",
                            field="tubing.inner_diameter")
        object.__setattr__(self, "modulus", _positive(self.modulus, "tubing.modulus", None))
        if self.head_pressure is not None:
            hp = float(self.head_pressure)
            if not math.isfinite(hp):
                raise WellError(f"must be a finite number, got {self.head_pressure!r}",
                                field="tubing.head_pressure")
            object.__setattr__(self, "head_pressure", hp)

    @property
    def area(self) -> float | None:
        """Steel cross-section of the tubing in m^2, or None when its size is not given."""
        if self.outer_diameter is None or self.inner_diameter is None:
            return None
        return math.pi * (self.outer_diameter**2 - self.inner_diameter**2) / 4.0


@dataclass(frozen=True)
class Fluid:
    """The produced fluid in the tubing: its density in kg/m^3."""

    density: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "density", _positive(self.density, "fluid.density", None))

    @property
    def specific_gravity(self) -> float:
        """Density over that of water (1000 kg/m^3)."""
        return self.density / WATER_DENSITY


@dataclass(frozen=True)
class Well:
    """One well: rod string (tapers from the surface down), pump, tubing, fluid.

    Parameters
    ----------
    well_id : str
        The well's id (matched with a card's ``well_id``).
    tapers : tuple of Taper
        From the polished rod down; sinker bars are the last sections.
    pump : Pump
    tubing : Tubing
    fluid : Fluid or None
        None when the file gives no fluid: the rods are then taken as hanging in air (no
        buoyancy, said in :attr:`notes`) and no pump intake pressure is computed.
    system : {"us", "metric"}
        The unit system of the file the well came from: pump quantities that have no card
        unit (displacement, pressure) are reported in it.
    notes : tuple of str
        What was assumed or noticed while reading.
    source : str
        The file the well came from.

    Raises
    ------
    WellError
        When the string is empty, or its length differs from the pump depth by more than
        2 % of it.
    """

    well_id: str
    tapers: tuple[Taper, ...]
    pump: Pump
    tubing: Tubing = field(default_factory=Tubing)
    fluid: Fluid | None = None
    system: str = "us"
    notes: tuple[str, ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "tapers", tuple(self.tapers))
        object.__setattr__(self, "notes", tuple(self.notes))
        src = self.source or None
        if not self.tapers:
            raise WellError("the rod string has no taper", path=src, well=self.well_id,
                            field="rods")
        if self.system not in ("us", "metric"):
            raise WellError(f"system must be 'us' or 'metric', got {self.system!r}",
                            path=src, well=self.well_id, field="units")
        total, depth = self.rod_length, self.pump.depth
        if total > depth * (1 + _OVERSHOOT_TOLERANCE):
            raise WellError(f"the rod string ({total:.6g} m) reaches below the pump depth "
                            f"({depth:.6g} m) by more than {100 * _OVERSHOOT_TOLERANCE:g} % "
                            "of it: a length is wrong", path=src, well=self.well_id,
                            field="pump.depth")
        if total < depth * (1 - _GAP_TOLERANCE):
            raise WellError(f"the rod string ({total:.6g} m) ends {depth - total:.6g} m above "
                            f"the pump depth ({depth:.6g} m), more than "
                            f"{100 * _GAP_TOLERANCE:g} % of it: a taper is missing or a "
                            "length is wrong", path=src, well=self.well_id, field="rods")

    # ------------------------------------------------------------------ derived
    @property
    def rod_length(self) -> float:
        """Total length of the string (rods and sinker bars), m."""
        return float(sum(t.length for t in self.tapers))

    @property
    def travel_time(self) -> float:
        """One-way travel time of a stress wave from the polished rod to the pump, s."""
        return float(sum(t.length / t.wave_speed for t in self.tapers))

    @property
    def fluid_density(self) -> float:
        """Fluid density for buoyancy, kg/m^3 (0 without fluid data: rods in air)."""
        return 0.0 if self.fluid is None else self.fluid.density

    def damping_coefficient(self, nu: float) -> float:
        """Gibbs' viscous coefficient c (1/s) from his dimensionless factor ``nu``.

        ``c = pi * nu / (2 * sum(L_i / a_i))``: ``nu`` is the damping relative to the
        string's first free-fixed mode, whatever the tapers.
        """
        return math.pi * float(nu) / (2.0 * self.travel_time)

    def buoyant_weight(self) -> float:
        """Weight of the string in the fluid, N (the static load of the effective convention)."""
        rho_f = self.fluid_density
        return float(sum((t.density - rho_f) * GRAVITY * t.area * t.length
                         for t in self.tapers))

    def hydrostatic_pressure(self, depth: float | NDArray[np.float64]) -> NDArray[np.float64]:
        """Pressure of the fluid column in the tubing at ``depth`` (m), Pa, gauge."""
        head = self.tubing.head_pressure or 0.0
        return head + self.fluid_density * GRAVITY * np.asarray(depth, dtype=float)

    def arrays(self) -> dict[str, NDArray[np.float64]]:
        """Per-taper arrays (``length``, ``stiffness``, ``wave_speed``, ``area``, ``density``)."""
        return {
            "length": np.array([t.length for t in self.tapers]),
            "stiffness": np.array([t.stiffness for t in self.tapers]),
            "wave_speed": np.array([t.wave_speed for t in self.tapers]),
            "area": np.array([t.area for t in self.tapers]),
            "density": np.array([t.density for t in self.tapers]),
        }
