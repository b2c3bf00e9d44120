"""Pipe-delimited SCADA / controller exports: one card per row, samples as lists in fields.

Units: a list field may carry its unit in its name (``Surface Positions (in)``). Otherwise the
export's own summary fields can state them: a ``Stroke Length (in)`` field whose value is the
stroke (or the top position) of the row's positions, a ``Peak Load (lbf)`` / ``Min Load
(lbf)`` field equal to the row's largest / smallest load, or a unit-system field (``Units =
English``: inches and pounds-force, the oilfield convention). Each inference is checked on
the row's own numbers and noted; without one the unit stays unknown, said once per file.

Each row is read on its own: a row with the wrong number of fields or a bad value in any of
its fields (the downhole lists included, used or not) is an error in place of its card(s),
named by its line and field; the other rows are read.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._common import Opts, Raw, file_unit, fmt, meaningful, num, numbers, rate, scalar, time_factor
from ._errors import CardError
from ._text import interpret_name, is_unit_spelling, normalize_name
from ._units import normalize_load_unit, normalize_position_unit

__all__ = ["read_scada"]

_ROLES: dict[str, frozenset[str]] = {
    "well": frozenset({"well", "well_id", "wellid", "well_name", "wellname", "well_tag"}),
    "card": frozenset({"card", "card_id", "card_no", "card_number", "id"}),
    "stamp": frozenset({"date", "timestamp", "datetime", "date_time", "time", "card_date",
                        "card_time", "time_stamp"}),
    "spm": frozenset({"spm", "strokes_per_minute", "stroke_rate"}),
    "period": frozenset({"stroke_period", "period"}),
    "sp": frozenset({"surface_positions", "surface_position", "positions", "position",
                     "surface_pos"}),
    "sl": frozenset({"surface_loads", "surface_load", "loads", "load"}),
    "dp": frozenset({"downhole_positions", "downhole_position", "pump_positions",
                     "pump_position"}),
    "dl": frozenset({"downhole_loads", "downhole_load", "pump_loads", "pump_load"}),
    # Summary fields that state units (see the module docstring).
    "stroke": frozenset({"stroke_length", "stroke", "surface_stroke_length", "surface_stroke",
                         "stroke_len", "polished_rod_stroke"}),
    "peak": frozenset({"peak_load", "max_load", "maximum_load", "pprl", "peak_polished_rod_load",
                       "max_polished_rod_load", "peak_surface_load", "max_surface_load"}),
    "minload": frozenset({"min_load", "minimum_load", "mprl", "min_polished_rod_load",
                          "minimum_polished_rod_load", "min_surface_load"}),
    "system": frozenset({"units", "unit", "unit_system", "units_system", "measurement_system",
                         "system_of_units"}),
}  # fmt: skip
_LABELS = {"sp": "Surface Positions", "sl": "Surface Loads", "dp": "Downhole Positions",
           "dl": "Downhole Loads"}  # fmt: skip
# Unit systems whose position and load units are fixed by convention in rod pumping.
_ENGLISH = frozenset({"english", "imperial", "us", "usc", "us_customary", "field", "oilfield"})
# A summary field "matches" the samples within this fraction of the stroke or load range:
# exports round these fields to a few digits.
_MATCH_RTOL = 0.02


def _split_pipe(line: str) -> list[str]:
    s = line.strip()
    if s.startswith("|") and s.endswith("|") and len(s) > 1:
        s = s[1:-1]  # table drawn with outer pipes
    return [f.strip() for f in s.split("|")]


def field_role(name: str) -> tuple[str | None, str | None]:
    """Role and unit text of a header field of a SCADA export."""
    _, base, unit = interpret_name(name)
    full = normalize_name(name)
    for role, names in _ROLES.items():
        if full in names:
            return role, None
        if base in names:
            return role, unit
    head, _, tail = full.rpartition("_")  # "stroke_length_in"
    if head and is_unit_spelling(tail):
        for role, names in _ROLES.items():
            if head in names:
                return role, tail
    return None, None


def _unit_or_none(kind: str, text: str | None) -> str | None:
    if text is None:
        return None
    try:
        return (normalize_position_unit if kind == "position" else normalize_load_unit)(text)
    except CardError:
        return None


def _close(a: float, b: float, scale: float) -> bool:
    return abs(a - b) <= _MATCH_RTOL * scale


class _UnitClues:
    """What the header says about units, and the checks that turn it into units per row."""

    def __init__(self, header: list[str], roles: dict[str, int], units: dict[str, str | None]):
        self.header = header
        self.roles = roles
        self.stroke = _unit_or_none("position", units.get("stroke")) if "stroke" in roles else None
        self.peak = _unit_or_none("load", units.get("peak")) if "peak" in roles else None
        self.minload = _unit_or_none("load", units.get("minload")) if "minload" in roles else None

    def _value(self, o: Opts, fields: list[str], role: str, line: int) -> float | None:
        text = fields[self.roles[role]]
        if not text:
            return None
        try:
            value = num(o, text, line=line, field=self.header[self.roles[role]])
        except CardError:
            return None  # a summary field is not data: a bad one just gives no clue
        return value if np.isfinite(value) else None

    def position(
        self, o: Opts, fields: list[str], line: int, pos: np.ndarray, notes: list[str]
    ) -> tuple[str | None, str]:
        if self.stroke is not None and pos.size:
            value = self._value(o, fields, "stroke", line)
            if value is not None:
                name = self.header[self.roles["stroke"]]
                with np.errstate(all="ignore"):
                    stroke, top = float(np.ptp(pos)), float(np.max(pos))
                if stroke > 0 and (_close(value, stroke, stroke) or _close(value, top, stroke)):
                    return self.stroke, (
                        f"field {name!r}, whose value {fmt(value)} is the stroke of the row's "
                        f"positions ({fmt(stroke)})"
                    )
                notes.append(
                    f"field {name!r} ({fmt(value)}) is not the stroke of the row's positions "
                    f"({fmt(stroke)}): its unit is not taken for the positions"
                )
        return self.system(fields, "position")

    def load(
        self, o: Opts, fields: list[str], line: int, load: np.ndarray, notes: list[str]
    ) -> tuple[str | None, str]:
        if load.size:
            with np.errstate(all="ignore"):
                lo, hi = float(np.min(load)), float(np.max(load))
            swing = hi - lo
            for role, unit, target, what in (
                ("peak", self.peak, hi, "largest"),
                ("minload", self.minload, lo, "smallest"),
            ):
                if unit is None:
                    continue
                value = self._value(o, fields, role, line)
                if value is None:
                    continue
                name = self.header[self.roles[role]]
                if swing > 0 and _close(value, target, swing):
                    return unit, (
                        f"field {name!r}, whose value {fmt(value)} is the {what} of the row's "
                        f"loads ({fmt(target)})"
                    )
                notes.append(
                    f"field {name!r} ({fmt(value)}) is not the {what} of the row's loads "
                    f"({fmt(target)}): its unit is not taken for the loads"
                )
        return self.system(fields, "load")

    def system(self, fields: list[str], kind: str) -> tuple[str | None, str]:
        if "system" not in self.roles:
            return None, ""
        value = fields[self.roles["system"]]
        if normalize_name(value) in _ENGLISH:
            unit = "in" if kind == "position" else "lbf"
            return unit, (
                f"field {self.header[self.roles['system']]!r} = {value!r} (English units: "
                "inches and pounds-force)"
            )
        return None, ""


def read_scada(
    o: Opts, holder: list[str], column_keys: dict[str, str]
) -> list[Raw | CardError]:
    """Read a SCADA export; ``holder`` holds the text and is emptied.

    Each row is read on its own: a row's problem is a :class:`CardError` in place of its
    card(s), and the other rows are still read.
    """
    rows = meaningful(holder.pop())
    first = next(rows, None)
    if first is None:
        raise o.error("no data rows")
    hline, htext = first
    header = _split_pipe(htext)
    roles: dict[str, int] = {}
    units: dict[str, str | None] = {}
    for k, name in enumerate(header):
        role, unit = field_role(name)
        if role is not None and role not in roles:
            roles[role], units[role] = k, unit
    # Caller overrides by header name (position/load are the surface lists).
    for key, spec in (o.columns or {}).items():
        target = {"position": "sp", "load": "sl", "card": "card", "well": "well", "spm": "spm",
                  "period": "period", "t": None, "closure": None}[column_keys[key]]  # fmt: skip
        if target is None:
            raise o.error(f"columns[{key!r}] does not apply to SCADA exports", field="columns")
        if spec is None:
            roles.pop(target, None)
            continue
        idx = (
            spec
            if isinstance(spec, int)
            else next((k for k, h in enumerate(header) if h.lower() == spec.strip().lower()), None)
        )
        if idx is None or not 0 <= idx < len(header):
            raise o.error(f"no field {spec!r} in the header", line=hline, field=f"columns[{key!r}]")
        roles[target], units[target] = idx, interpret_name(header[idx])[2]
    want = {"surface": ("sp", "sl"), "downhole": ("dp", "dl"), "both": ("sp", "sl", "dp", "dl")}
    for role in want[o.scada_cards]:
        if role not in roles:
            raise o.error(
                f"no {_LABELS[role]!r} field in the header ({', '.join(map(repr, header))})",
                line=hline,
                field=_LABELS[role],
            )
    period_factor = 1.0
    if "period" in roles:
        period_factor = time_factor(
            o, units.get("period"), line=hline, field=header[roles["period"]]
        )
    list_cols = {roles[x] for x in ("sp", "sl", "dp", "dl") if x in roles}
    stated = {
        r: file_unit(o, "position" if r in ("sp", "dp") else "load", units.get(r), line=hline,
                     field=header[roles[r]])
        for r in ("sp", "sl", "dp", "dl") if r in roles
    }  # fmt: skip
    clues = _UnitClues(header, roles, units)

    def parse_list(value: str, line: int, name: str) -> np.ndarray:
        if not value.strip():
            raise o.error("empty list of values", line=line, field=name)
        return numbers(o, value, line=line, field=name)

    suffixes = {"surface": ("",), "downhole": ("/downhole",),
                "both": ("", "/downhole")}[o.scada_cards]  # fmt: skip

    def row_cards(
        fields: list[str], lineno: int, base_id: str, well: str | None
    ) -> list[Raw | CardError]:
        """The card(s) of one row (a CardError for the first problem)."""
        meta: dict[str, Any] = {}
        for k, (name, value) in enumerate(zip(header, fields, strict=True)):
            if k not in list_cols:
                meta[name] = scalar(value) if value else None
        cards: list[Raw | CardError] = []
        notes: list[str] = []
        spm = period = None
        rate_where = ""
        if "spm" in roles and fields[roles["spm"]]:
            name = header[roles["spm"]]
            value = num(o, fields[roles["spm"]], line=lineno, field=name)
            spm = rate(o, value, line=lineno, field=name, what="SPM")
            rate_where = f"field {name!r}"
        if "period" in roles and fields[roles["period"]]:
            name = header[roles["period"]]
            value = num(o, fields[roles["period"]], line=lineno, field=name)
            with np.errstate(over="ignore"):
                value = float(value) * period_factor
            period = rate(o, value, line=lineno, field=name, what="stroke period")
            if spm is None:
                rate_where = f"field {name!r}"
            else:
                if abs(60.0 / spm - period) > 0.01 * period:
                    notes.append(
                        f"{header[roles['spm']]!r} ({fmt(spm)}, i.e. {fmt(60 / spm)} s) and "
                        f"{name!r} ({fmt(period)} s) disagree; SPM used"
                    )
                period = None  # SPM wins; the period stays in metadata
        kinds = {"surface": [("sp", "sl", "")], "downhole": [("dp", "dl", "/downhole")],
                 "both": [("sp", "sl", ""), ("dp", "dl", "/downhole")]}[o.scada_cards]  # fmt: skip
        for pr, lr, suffix in kinds:
            try:
                pname, lname = header[roles[pr]], header[roles[lr]]
                pos = parse_list(fields[roles[pr]], lineno, pname)
                load = parse_list(fields[roles[lr]], lineno, lname)
                card_notes = list(notes)
                pos_unit, pos_where = stated[pr], f"field name {pname!r}"
                load_unit, load_where = stated[lr], f"field name {lname!r}"
                if pos_unit is None and o.position_unit is None:
                    if pr == "sp":
                        pos_unit, pos_where = clues.position(o, fields, lineno, pos, card_notes)
                    else:
                        pos_unit, pos_where = clues.system(fields, "position")
                if load_unit is None and o.load_unit is None:
                    if lr == "sl":
                        load_unit, load_where = clues.load(o, fields, lineno, load, card_notes)
                    else:
                        load_unit, load_where = clues.system(fields, "load")
                raw = Raw(
                    position=pos,
                    load=load,
                    card_id=base_id + suffix,
                    source=f"{o.name}, line {lineno}",
                    line=lineno,
                    lines=None,
                    pos_field=pname,
                    load_field=lname,
                    pos_unit=pos_unit,
                    pos_unit_where=pos_where,
                    load_unit=load_unit,
                    load_unit_where=load_where,
                    well_id=well,
                    spm=spm,
                    period=period,
                    rate_where=rate_where,
                    notes=card_notes,
                    metadata={**meta, "card_type": "surface" if pr == "sp" else "downhole"},
                )
                if o.scada_cards == "surface" and "dp" in roles and "dl" in roles:
                    dpn, dln = header[roles["dp"]], header[roles["dl"]]
                    if fields[roles["dp"]] or fields[roles["dl"]]:
                        dp, dl = fields[roles["dp"]], fields[roles["dl"]]
                        raw.metadata["downhole_position"] = parse_list(dp, lineno, dpn)
                        raw.metadata["downhole_load"] = parse_list(dl, lineno, dln)
                        raw.notes.append(
                            "downhole card kept unchecked in metadata['downhole_position'] and "
                            "metadata['downhole_load'] (read with scada_cards='both' to check it)"
                        )
                cards.append(raw)
            except CardError as exc:  # this card only (both: the other is kept)
                cards.append(exc.for_card(base_id + suffix, well))
        return cards

    out: list[Raw | CardError] = []
    seen: dict[str, int] = {}
    for r, (lineno, text_row) in enumerate(rows):
        fields = _split_pipe(text_row)

        def field(role: str, fields: list[str] = fields) -> str:
            k = roles.get(role)
            return fields[k] if k is not None and k < len(fields) else ""

        well = field("well") or None
        stamp = field("stamp")
        if field("card"):
            base_id = field("card")
        elif well and stamp:
            base_id = f"{well}@{stamp}"
        else:
            base_id = well or stamp or f"row {r}"
        seen[base_id] = seen.get(base_id, 0) + 1
        if seen[base_id] > 1:
            base_id = f"{base_id} ({seen[base_id]})"  # keep ids unique within the file
        if len(fields) != len(header):
            problem = o.error(
                f"expected {len(header)} '|'-separated fields (as in the header), found "
                f"{len(fields)}",
                line=lineno,
            )
            out.extend(problem.for_card(base_id + sfx, well) for sfx in suffixes)
            continue
        try:
            out.extend(row_cards(fields, lineno, base_id, well))
        except CardError as exc:  # a broken row spoils its own card(s) only
            out.extend(exc.for_card(base_id + sfx, well) for sfx in suffixes)
    if not out:
        raise o.error("header but no card rows", line=hline)
    return out
