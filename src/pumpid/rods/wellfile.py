"""The JSON well file: units, then one or more wells by id.

::

    {"units": {"length": "ft", "diameter": "in"},
     "wells": {"W-12": {"rods": [{"length": 4375, "diameter": 0.875, "material": "steel"}],
                        "sinker_bars": [{"length": 250, "diameter": 1.5, "material": "steel"}],
                        "pump": {"depth": 4630, "plunger_diameter": 1.75},
                        "tubing": {"anchored": true},
                        "fluid": {"specific_gravity": 1.0}}}}

Unknown keys are refused (a typo must not pass as a default), every value is checked, and
every problem is raised as a :class:`~pumpid.rods.well.WellError` naming the file, the well
and the field.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..cards import POSITION_UNITS, PSI_PA
from .well import (
    LB_FT3,
    MATERIALS,
    WATER_DENSITY,
    Fluid,
    Pump,
    Taper,
    Tubing,
    Well,
    WellError,
)

__all__ = ["UNITS", "WellFile", "read_well_file", "wells_from_dict"]


#: Accepted units per quantity and their size in SI.
UNITS: dict[str, dict[str, float]] = {
    "length": {k: POSITION_UNITS[k] for k in ("ft", "m")},
    "diameter": {k: POSITION_UNITS[k] for k in ("in", "mm", "cm", "m")},
    "modulus": {"psi": PSI_PA, "Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9},
    "density": {"lb/ft3": LB_FT3, "kg/m3": 1.0, "g/cm3": 1000.0},
    "pressure": {"psi": PSI_PA, "Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5},
}
# Units of the quantities a file need not name, by the system its length unit implies.
_SYSTEM_DEFAULTS = {
    "us": {"modulus": "psi", "density": "lb/ft3", "pressure": "psi"},
    "metric": {"modulus": "Pa", "density": "kg/m3", "pressure": "Pa"},
}
_META = {"description", "comment", "notes", "source"}
_TOP_KEYS = {"units", "wells", *_META}
_WELL_KEYS = {"rods", "sinker_bars", "pump", "tubing", "fluid", *_META}
_TAPER_KEYS = {"length", "diameter", "material", "modulus", "density", *_META}
_PUMP_KEYS = {"depth", "plunger_diameter", *_META}
_TUBING_KEYS = {"anchored", "outer_diameter", "inner_diameter", "modulus", "head_pressure",
                *_META}
_FLUID_KEYS = {"specific_gravity", "density", *_META}
#: Ranges no rod-pumped well leaves, in SI, with the unit their message gives them in and
#: its size: a value beyond is a slip of unit or key (a specific gravity of 988, a plunger
#: of 440 mm, rods of 8.5 kg/m3 gave confident pump quantities, exit 0).
_PLAUSIBLE: dict[str, tuple[float, float, str, float, str]] = {
    "diameter": (0.005, 0.1, "mm", 1e-3, "rods and sinker bars"),
    "plunger_diameter": (0.01, 0.2, "mm", 1e-3, "rod pumps' plungers"),
    "density": (1000.0, 20000.0, "kg/m3", 1.0, "rod materials"),
    "modulus": (5e9, 5e11, "GPa", 1e9, "rod materials"),
    "fluid density": (300.0, 2500.0, "kg/m3", 1.0, "well fluids"),
}


def _unit_key(text: str) -> str:
    return text.strip().replace("^", "").replace(" ", "").replace("lbm", "lb")


@dataclass(frozen=True)
class WellFile:
    """The wells of one file, by id.

    A file with one well applies to every card; with several, a card is matched by its
    ``well_id``.
    """

    path: str
    wells: Mapping[str, Well]

    def for_card(self, well_id: str | None, card_id: str = "") -> Well:
        """The well of a card.

        Raises
        ------
        WellError
            When the file has several wells and the card's well id is missing or not among
            them.
        """
        if len(self.wells) == 1:
            return next(iter(self.wells.values()))
        known = ", ".join(repr(k) for k in list(self.wells)[:10])
        if well_id is None:
            raise WellError(f"card {card_id!r} has no well id, and the file describes "
                            f"{len(self.wells)} wells ({known}); give the card's well id "
                            "(Card.well_id: a well column of its file, or --well-id ID on "
                            "the command line) or a well file with one well", path=self.path)
        if well_id not in self.wells:
            raise WellError(f"no well {well_id!r} (card {card_id!r}); the file describes "
                            f"{known}", path=self.path)
        return self.wells[well_id]


def read_well_file(path: str | os.PathLike[str]) -> WellFile:
    """Read and check a JSON well file.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    WellFile

    Raises
    ------
    WellError
        For an unreadable file, invalid JSON, or any bad field (named).
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise WellError("no such file", path=name) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise WellError(f"cannot be read ({exc})", path=name) from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise WellError(f"not valid JSON: {exc.msg} at line {exc.lineno}, column {exc.colno}",
                        path=name) from None
    return WellFile(path=name, wells=wells_from_dict(data, source=name))


def wells_from_dict(data: Any, source: str = "") -> dict[str, Well]:
    """The wells of a well-file document already parsed from JSON (see the module doc)."""
    src = source or None
    if not isinstance(data, dict):
        raise WellError("the top level must be an object with 'units' and 'wells'", path=src)
    _check_keys(data, _TOP_KEYS, src, None, "")
    units, system, defaulted = _units(data.get("units"), src)
    wells = data.get("wells")
    if not isinstance(wells, dict) or not wells:
        raise WellError("'wells' must be an object of at least one well by id", path=src,
                        field="wells")
    out: dict[str, Well] = {}
    for well_id, spec in wells.items():
        out[str(well_id)] = _Reader(src, str(well_id), units, system, defaulted).well(spec)
    return out


def _check_keys(obj: dict[str, Any], allowed: set[str], src: str | None, well: str | None,
                where: str) -> None:
    unknown = sorted(set(obj) - allowed)
    if unknown:
        expected = ", ".join(sorted(allowed - _META))
        raise WellError(f"unknown key {unknown[0]!r} (expected {expected})", path=src,
                        well=well, field=f"{where}{unknown[0]}")


def _units(spec: Any, src: str | None) -> tuple[dict[str, float], str, dict[str, str]]:
    if not isinstance(spec, dict):
        raise WellError("'units' must be an object naming at least the length and diameter "
                        "units, e.g. {\"length\": \"ft\", \"diameter\": \"in\"}", path=src,
                        field="units")
    _check_keys(spec, set(UNITS), src, None, "units.")
    for required in ("length", "diameter"):
        if required not in spec:
            raise WellError(f"missing the {required} unit ({', '.join(UNITS[required])})",
                            path=src, field=f"units.{required}")
    factors: dict[str, float] = {}
    names: dict[str, str] = {}
    for quantity, text in spec.items():
        table = {_unit_key(k).lower(): (k, v) for k, v in UNITS[quantity].items()}
        key = _unit_key(str(text)).lower()
        if not isinstance(text, str) or key not in table:
            raise WellError(f"unknown unit {text!r}; use one of {', '.join(UNITS[quantity])}",
                            path=src, field=f"units.{quantity}")
        names[quantity], factors[quantity] = table[key]
    system = "us" if names["length"] == "ft" else "metric"
    defaulted: dict[str, str] = {}
    for quantity, unit in _SYSTEM_DEFAULTS[system].items():
        if quantity not in factors:
            factors[quantity] = UNITS[quantity][unit]
            defaulted[quantity] = (f"{quantity} values are read in {unit} (the well file "
                                   f"names no {quantity} unit; {names['length']} lengths "
                                   f"imply {system} units)")
    return factors, system, defaulted


class _Reader:
    """Reads one well's entries, each problem named by file, well and field."""

    def __init__(self, src: str | None, well: str, units: dict[str, float], system: str,
                 defaulted: dict[str, str]) -> None:
        self.src, self.well_id, self.units, self.system = src, well, units, system
        # Notes on the units a file did not name, said once each when a value uses them.
        self.defaulted = dict(defaulted)
        self.notes: list[str] = []

    def scale(self, unit: str) -> float:
        if unit in self.defaulted:
            self.notes.append(self.defaulted.pop(unit))
        return self.units[unit]

    def fail(self, message: str, where: str) -> WellError:
        return WellError(message, path=self.src, well=self.well_id, field=where)

    def obj(self, spec: Any, allowed: set[str], where: str) -> dict[str, Any]:
        if not isinstance(spec, dict):
            raise self.fail(f"must be an object, got {type(spec).__name__}", where)
        _check_keys(spec, allowed, self.src, self.well_id, f"{where}.")
        return spec

    def number(self, spec: dict[str, Any], key: str, where: str, unit: str,
               required: bool = True, allow_zero: bool = False) -> float | None:
        if key not in spec or spec[key] is None:
            if required:
                raise self.fail("missing", f"{where}.{key}")
            return None
        value = spec[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(f"must be a number, got {value!r}", f"{where}.{key}")
        x = float(value)
        if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
            raise self.fail(f"must be a positive finite number, got {value!r}", f"{where}.{key}")
        return x * self.scale(unit)

    def plausible(self, value: float | None, kind: str, where: str) -> float | None:
        """``value`` (SI) when a rod-pumped well can have it; else the field is refused."""
        lo, hi, unit, size, what = _PLAUSIBLE[kind]
        if value is not None and not lo <= value <= hi:
            raise self.fail(f"{value / size:.4g} {unit} is outside the range of {what} "
                            f"({lo / size:g} to {hi / size:g} {unit}): check the value and "
                            "the file's units", where)
        return value

    def well(self, spec: Any) -> Well:
        spec = self.obj(spec, _WELL_KEYS, "well")
        rods = spec.get("rods")
        if not isinstance(rods, list) or not rods:
            raise self.fail("must be a list of at least one taper, from the surface down",
                            "rods")
        sinkers = spec.get("sinker_bars", [])
        if not isinstance(sinkers, list):
            raise self.fail("must be a list of sections", "sinker_bars")
        tapers = [self.taper(t, f"rods[{i}]", "rod") for i, t in enumerate(rods)]
        thicker = next((i for i in range(1, len(tapers))
                        if tapers[i].diameter > tapers[i - 1].diameter), None)
        if thicker is not None:
            # A string tapers down from the polished rod, where the load is largest; a
            # file listed from the bottom gave another identification without a word
            # (R^2 0.9838 -> 0.9515 on a public card).
            self.notes.append(
                f"rods[{thicker}] is thicker than rods[{thicker - 1}] above it: a rod string "
                "is thickest at the top (sinker bars go under sinker_bars); are the rods "
                "listed from the bottom? They are taken from the polished rod down, as given")
        tapers += [self.taper(t, f"sinker_bars[{i}]", "sinker") for i, t in enumerate(sinkers)]
        if "pump" not in spec:
            raise self.fail("missing (depth and plunger_diameter)", "pump")
        p = self.obj(spec["pump"], _PUMP_KEYS, "pump")
        plunger = self.plausible(self.number(p, "plunger_diameter", "pump", "diameter"),
                                 "plunger_diameter", "pump.plunger_diameter")
        pump = Pump(depth=self.number(p, "depth", "pump", "length"),  # type: ignore[arg-type]
                    plunger_diameter=plunger)  # type: ignore[arg-type]
        tubing = self.tubing(spec.get("tubing"))
        fluid = self.fluid(spec.get("fluid"))
        total = sum(t.length for t in tapers)
        if abs(total - pump.depth) > 1e-9 * pump.depth:
            where = "above" if total < pump.depth else "below"
            # In the file's length unit, ft or m as its system says (5 ft read "1.524 m").
            unit = "ft" if self.system == "us" else "m"
            gap = abs(pump.depth - total) / UNITS["length"][unit]
            self.notes.append(f"the rod string ends {gap:.4g} {unit} {where} "
                              "the pump depth: the pump card is computed at the bottom of the "
                              "rods; the fluid load's pressures use the pump depth")
        try:
            return Well(well_id=self.well_id, tapers=tuple(tapers), pump=pump, tubing=tubing,
                        fluid=fluid, system=self.system, notes=tuple(self.notes),
                        source=self.src or "")
        except WellError as exc:
            if exc.path is not None:
                raise
            raise self.fail(exc.reason, exc.field or "well") from None

    def taper(self, spec: Any, where: str, kind: str) -> Taper:
        t = self.obj(spec, _TAPER_KEYS, where)
        length = self.number(t, "length", where, "length")
        diameter = self.number(t, "diameter", where, "diameter")
        material = t.get("material")
        modulus = self.number(t, "modulus", where, "modulus", required=False)
        density = self.number(t, "density", where, "density", required=False)
        if material is not None:
            key = str(material).strip().lower()
            if key not in MATERIALS:
                raise self.fail(f"unknown material {material!r}; use "
                                f"{' or '.join(MATERIALS)}, or give modulus and density",
                                f"{where}.material")
            e_mat, rho_mat = MATERIALS[key]
            if modulus is not None or density is not None:
                given = [n for n, v in (("modulus", modulus), ("density", density)) if v]
                verb = "replace those" if len(given) == 2 else "replaces that"
                self.notes.append(f"{where}: the given {' and '.join(given)} {verb} of {key}")
            modulus = e_mat if modulus is None else modulus
            density = rho_mat if density is None else density
        elif modulus is None or density is None:
            missing = "modulus" if modulus is None else "density"
            raise self.fail(f"give a material ({' or '.join(MATERIALS)}) or both modulus and "
                            f"density (missing {missing})", f"{where}.{missing}")
        self.plausible(diameter, "diameter", f"{where}.diameter")
        self.plausible(modulus, "modulus", f"{where}.modulus")
        self.plausible(density, "density", f"{where}.density")
        return Taper(length=length, diameter=diameter, modulus=modulus,  # type: ignore[arg-type]
                     density=density, material=None if material is None else str(material).lower(),
                     kind=kind)

    def tubing(self, spec: Any) -> Tubing:
        if spec is None:
            self.notes.append("no tubing entry: the tubing is taken as anchored (no tubing "
                              "stretch correction of the net stroke)")
            return Tubing(anchored=True)
        t = self.obj(spec, _TUBING_KEYS, "tubing")
        if "anchored" not in t:
            raise self.fail("missing (true or false)", "tubing.anchored")
        if not isinstance(t["anchored"], bool):
            raise self.fail(f"must be true or false, got {t['anchored']!r}", "tubing.anchored")
        head = None
        if t.get("head_pressure") is not None:
            value = t["head_pressure"]
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value)):
                raise self.fail(f"must be a finite number, got {value!r}",
                                "tubing.head_pressure")
            head = float(value) * self.scale("pressure")
        od = self.number(t, "outer_diameter", "tubing", "diameter", required=False)
        idia = self.number(t, "inner_diameter", "tubing", "diameter", required=False)
        if not t["anchored"] and (od is None or idia is None):
            self.notes.append("the tubing is not anchored but its outer and inner diameters "
                              "are not given: the net stroke is not corrected for tubing "
                              "stretch")
        modulus = self.number(t, "modulus", "tubing", "modulus", required=False)
        try:
            return Tubing(anchored=t["anchored"], outer_diameter=od, inner_diameter=idia,
                          modulus=MATERIALS["steel"][0] if modulus is None else modulus,
                          head_pressure=head)
        except WellError as exc:
            raise self.fail(exc.reason, exc.field or "tubing") from None

    def fluid(self, spec: Any) -> Fluid | None:
        if spec is None:
            self.notes.append("no fluid entry: the rods are taken as hanging in air (no "
                              "buoyancy) and no pump intake pressure is computed")
            return None
        f = self.obj(spec, _FLUID_KEYS, "fluid")
        sg = f.get("specific_gravity")
        if sg is not None and "density" in f:
            raise self.fail("give either specific_gravity or density, not both",
                            "fluid.density")
        if sg is not None:
            if isinstance(sg, bool) or not isinstance(sg, int | float) or not (
                    math.isfinite(sg) and sg > 0):
                raise self.fail(f"must be a positive number, got {sg!r}",
                                "fluid.specific_gravity")
            lo, hi = (v / WATER_DENSITY for v in _PLAUSIBLE["fluid density"][:2])
            if not lo <= sg <= hi:
                raise self.fail(f"{sg:g} is outside the range of well fluids ({lo:g} to "
                                f"{hi:g}; water 1): a density belongs in fluid.density, "
                                "with its unit", "fluid.specific_gravity")
            return Fluid(density=float(sg) * WATER_DENSITY)
        density = self.number(f, "density", "fluid", "density", required=False)
        if density is None:
            raise self.fail("give specific_gravity or density", "fluid")
        return Fluid(density=self.plausible(density, "fluid density",  # type: ignore[arg-type]
                                            "fluid.density"))
