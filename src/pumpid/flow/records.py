"""Flow records: a transient pressure drop and flow rate, read and checked.

A flow record is a time series of the pressure drop across a delivery system and the volume
flow rate through it, from CFD or a test rig (the paper's second application); the flow main
job (:mod:`pumpid.flow.fit`) fits a first-order surrogate to it.

Conventions
-----------
* Values are converted to SI on reading -- pressure drop in Pa, flow rate in m^3/s, time in
  s -- from the units the caller names (``dp_unit=``, ``q_unit=``, ``t_unit=``), else from a
  unit in the column header (``dp [kPa]``, ``q (L/min)``), else the SI default is assumed;
  every conversion and assumption is recorded in ``FlowRecord.notes``.
* Inlet and outlet pressures (``p_in``, ``p_out``) instead of a pressure drop give
  ``dp = p_in - p_out`` (noted).
* Nothing is repaired: unreadable files, missing columns, unparsable numbers, NaN/inf, fewer
  than 10 samples, time not strictly increasing, a constant flow rate, a constant pressure
  drop (except a step from rest, see below) and unknown units raise
  :class:`pumpid.cards.CardError` naming the file, line and field.
* A record whose pressure drop is constant from its first sample and whose flow starts at
  zero is a start-up from rest by a step at ``t[0]`` (the usual CFD set-up); it is accepted and
  noted, and fitted from the zero state.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cards import CardError
from ..result import Units

__all__ = [
    "FLOW_UNITS",
    "MIN_SAMPLES",
    "PRESSURE_UNITS",
    "FlowRecord",
    "convert_flow",
    "convert_pressure",
    "flow_record",
    "normalize_flow_unit",
    "normalize_pressure_unit",
    "read_flow_record",
    "seconds_per",
    "split_header",
    "starts_near_zero",
]

FloatArray = NDArray[np.float64]
MIN_SAMPLES = 10

# --------------------------------------------------------------------------- units
_PSI_PA = 6894.757293168361  # 1 lbf/in^2 = 4.4482216152605 N / 0.0254^2 m^2, exact
_US_GALLON_M3 = 3.785411784e-3  # exact by definition (231 in^3)

#: Pressure units and their size in Pa.
PRESSURE_UNITS: Mapping[str, float] = MappingProxyType({
    "Pa": 1.0, "hPa": 100.0, "kPa": 1e3, "MPa": 1e6, "mbar": 100.0, "bar": 1e5,
    "psi": _PSI_PA, "atm": 101325.0,
})
#: Flow-rate units and their size in m^3/s.
FLOW_UNITS: Mapping[str, float] = MappingProxyType({
    "m^3/s": 1.0, "m^3/h": 1.0 / 3600.0, "L/s": 1e-3, "L/min": 1e-3 / 60.0, "mL/s": 1e-6,
    "mL/min": 1e-6 / 60.0, "gpm": _US_GALLON_M3 / 60.0,
})
_TIME_UNITS: Mapping[str, float] = MappingProxyType(
    {"s": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0}
)
_PRESSURE_ALIASES = {
    "pa": "Pa", "pascal": "Pa", "pascals": "Pa", "n/m^2": "Pa", "n/m2": "Pa",
    "hpa": "hPa", "kpa": "kPa", "mpa": "MPa", "mbar": "mbar", "bar": "bar",
    "psi": "psi", "psid": "psi", "lbf/in^2": "psi", "atm": "atm",
}  # fmt: skip
_FLOW_ALIASES = {
    "m^3/s": "m^3/s", "m3/s": "m^3/s", "m³/s": "m^3/s", "cms": "m^3/s",
    "m^3/h": "m^3/h", "m3/h": "m^3/h", "m³/h": "m^3/h", "m^3/hr": "m^3/h", "m3/hr": "m^3/h",
    "l/s": "L/s", "lps": "L/s", "l/min": "L/min", "lpm": "L/min",
    "ml/s": "mL/s", "cm^3/s": "mL/s", "cm3/s": "mL/s", "cc/s": "mL/s",
    "ml/min": "mL/min", "cm^3/min": "mL/min", "cm3/min": "mL/min", "ccm": "mL/min",
    "gpm": "gpm", "gal/min": "gpm", "usgpm": "gpm",
}  # fmt: skip
_TIME_ALIASES = {"s": "s", "sec": "s", "second": "s", "seconds": "s", "ms": "ms",
                 "min": "min", "minute": "min", "minutes": "min", "h": "h", "hr": "h",
                 "hour": "h", "hours": "h"}


def _normalize(unit: str, aliases: Mapping[str, str], known: Mapping[str, float], kind: str,
               field_name: str, path: str | None = None) -> str:
    if not isinstance(unit, str):
        raise CardError(f"{kind} unit must be a string, got {unit!r}", path=path,
                        field=field_name)
    key = unit.strip().lower().replace(" ", "")
    if key in aliases:
        return aliases[key]
    raise CardError(f"unknown {kind} unit {unit!r}; known units: {', '.join(known)}",
                    path=path, field=field_name)


def normalize_pressure_unit(unit: str, *, field_name: str = "dp_unit") -> str:
    """Canonical name (a key of :data:`PRESSURE_UNITS`) of a pressure unit spelling."""
    return _normalize(unit, _PRESSURE_ALIASES, PRESSURE_UNITS, "pressure", field_name)


def seconds_per(unit: str, *, field_name: str = "t_unit", path: str | None = None) -> float:
    """Seconds in one of a time unit's spelling (``ms``: 1e-3); CardError for an unknown
    one."""
    return _TIME_UNITS[_normalize(unit, _TIME_ALIASES, _TIME_UNITS, "time", field_name, path)]


def normalize_flow_unit(unit: str, *, field_name: str = "q_unit") -> str:
    """Canonical name (a key of :data:`FLOW_UNITS`) of a flow-rate unit spelling."""
    return _normalize(unit, _FLOW_ALIASES, FLOW_UNITS, "flow-rate", field_name)


def convert_pressure(values: ArrayLike, from_unit: str, to_unit: str = "Pa") -> FloatArray:
    """Convert pressures between units (exact factors)."""
    a = PRESSURE_UNITS[normalize_pressure_unit(from_unit)]
    b = PRESSURE_UNITS[normalize_pressure_unit(to_unit)]
    return np.asarray(values, dtype=float) * (a / b)


def convert_flow(values: ArrayLike, from_unit: str, to_unit: str = "m^3/s") -> FloatArray:
    """Convert volume flow rates between units (exact factors; gpm is the US gallon)."""
    a = FLOW_UNITS[normalize_flow_unit(from_unit)]
    b = FLOW_UNITS[normalize_flow_unit(to_unit)]
    return np.asarray(values, dtype=float) * (a / b)


# --------------------------------------------------------------------------- record
#: A record starts at rest when its first value is within this many noise scales of zero.
_REST_NOISE = 3.0
#: ... and within this share of its largest value (a record starting at a low equilibrium
#: after which the flow rises thirtyfold is not at rest).
_REST_SHARE = 0.02


def starts_near_zero(y: ArrayLike) -> bool:
    """Whether a record's output starts at zero: within 1e-6 of its largest value, or
    within its noise (three robust scales of its sample-to-sample differences) and 2 % of
    its largest value.

    A noise-free test (1e-6 of the largest value) called a start-up from rest with 0.1 %
    noise a record that "does not start from rest" and refused it, or fitted it from an
    equilibrium (R^2 0.0003).
    """
    arr = np.asarray(y, dtype=float)
    peak = float(np.max(np.abs(arr)))
    first = abs(float(arr[0]))
    if first <= 1e-6 * peak:
        return True
    if arr.size < 3:
        return False
    # The differences' median absolute value over 0.6745 is sqrt(2) noise scales for white
    # noise; on a smooth record it overstates the noise, and the 2 % share bounds that.
    noise = float(np.median(np.abs(np.diff(arr)))) / (0.6745 * math.sqrt(2.0))
    return first <= min(_REST_NOISE * noise, _REST_SHARE * peak)


@dataclass(frozen=True)
class FlowRecord:
    """A transient pressure-drop / flow-rate record.

    Attributes
    ----------
    t : ndarray
        Time in s, strictly increasing.
    dp : ndarray
        Pressure drop (inlet minus outlet) in ``dp_unit``.
    q : ndarray
        Volume flow rate in ``q_unit``.
    dp_unit, q_unit : str
        Units of ``dp`` and ``q`` (``Pa`` and ``m^3/s`` after reading).
    source : str
        Where the record came from (file name, or a description).
    notes : tuple of str
        Everything done to the data while reading, in plain language.
    """

    t: FloatArray
    dp: FloatArray
    q: FloatArray
    dp_unit: str = "Pa"
    q_unit: str = "m^3/s"
    source: str = ""
    notes: tuple[str, ...] = field(default=())

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def units(self) -> Units:
        """Units for a dp -> q fit (input = "load", output = "position")."""
        return Units(load=self.dp_unit, position=self.q_unit)

    @property
    def starts_at_rest(self) -> bool:
        """True when the flow rate starts at zero, within its noise (:func:`starts_near_zero`)."""
        return starts_near_zero(self.q)

    @property
    def step_from_rest(self) -> bool:
        """True for a start-up record: constant pressure drop from t[0] and the flow at rest."""
        return bool(np.ptp(self.dp) == 0.0 and self.dp[0] != 0.0 and self.starts_at_rest)

    def to_units(self, dp_unit: str = "Pa", q_unit: str = "m^3/s") -> FlowRecord:
        """The record converted to other units (noted)."""
        du, qu = normalize_pressure_unit(dp_unit), normalize_flow_unit(q_unit)
        notes = list(self.notes)
        dp, q = self.dp, self.q
        if du != self.dp_unit:
            dp = convert_pressure(dp, self.dp_unit, du)
            notes.append(f"pressure drop converted from {self.dp_unit} to {du}")
        if qu != self.q_unit:
            q = convert_flow(q, self.q_unit, qu)
            notes.append(f"flow rate converted from {self.q_unit} to {qu}")
        return replace(self, dp=dp, q=q, dp_unit=du, q_unit=qu, notes=tuple(notes))

    def to_csv(self, path: str | os.PathLike[str] | None = None) -> str:
        """Write ``t, dp, q`` (header with units in brackets) to ``path``; return the text."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["t [s]", f"dp [{self.dp_unit}]", f"q [{self.q_unit}]"])
        for row in zip(self.t, self.dp, self.q, strict=True):
            writer.writerow([repr(float(v)) for v in row])
        text = buf.getvalue()
        if path is not None:
            Path(path).write_text(text, encoding="utf-8")
        return text


_HEADER_UNIT = re.compile(r"^\s*(?P<name>.*?)\s*(?:\[(?P<u1>[^\]]*)\]|\((?P<u2>[^)]*)\))\s*$")


def split_header(cell: str) -> tuple[str, str | None]:
    """``"dp [kPa]"`` -> ("dp", "kPa"); ``"dp"`` -> ("dp", None)."""
    m = _HEADER_UNIT.match(cell)
    if m:
        return m.group("name").strip(), (m.group("u1") or m.group("u2") or "").strip() or None
    return cell.strip(), None


_ROLES = ("t", "dp", "q", "p_in", "p_out")
_DEFAULT_NAMES = {"t": ("t", "time"), "dp": ("dp", "pressure_drop", "delta_p"),
                  "q": ("q", "flow", "flow_rate"), "p_in": ("p_in", "pin", "p_inlet"),
                  "p_out": ("p_out", "pout", "p_outlet")}


def read_flow_record(
    path: str | os.PathLike[str],
    *,
    columns: Mapping[str, str] | None = None,
    dp_unit: str | None = None,
    q_unit: str | None = None,
    t_unit: str | None = None,
    delimiter: str | None = None,
    min_samples: int = MIN_SAMPLES,
) -> FlowRecord:
    """Read and check a transient flow record from a delimited text file with a header.

    Parameters
    ----------
    path : path-like
        CSV (comma, semicolon or tab separated, detected) with a header row. Lines starting
        with ``#`` and blank lines are skipped.
    columns : mapping, optional
        Column names by role: ``t``, ``dp``, ``q`` (default names ``t``, ``dp``, ``q``,
        case-insensitive, a unit in brackets allowed), or ``p_in`` and ``p_out`` instead of
        ``dp``.
    dp_unit, q_unit, t_unit : str, optional
        Units of the file's columns (they win over units in the header). Pressure: Pa, hPa,
        kPa, MPa, mbar, bar, psi, atm; flow rate: m^3/s, m^3/h, L/s, L/min, mL/s, mL/min, gpm;
        time: s, ms, min, h. Default: the header's, else Pa, m^3/s and s (noted).
    delimiter : str, optional
        Force the field separator.
    min_samples : int
        Fewest samples accepted (10: fewer cannot constrain a fit with diagnostics).

    Returns
    -------
    FlowRecord
        In Pa, m^3/s and s; ``notes`` say what was converted or assumed.

    Raises
    ------
    CardError
        A ``ValueError`` naming the file, line and field of the problem.
    """
    where = os.fspath(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise CardError("no such file", path=where) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CardError(f"cannot read the file ({exc})", path=where) from None
    lines = [(i, line) for i, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise CardError("the file holds no header and no data", path=where)
    sep = delimiter or _sniff([line for _, line in lines[:5]])
    rows = list(csv.reader([line for _, line in lines], delimiter=sep))
    header_line = lines[0][0]
    header = [split_header(c) for c in rows[0]]
    names = [h[0] for h in header]
    lookup = {name.lower(): j for j, name in enumerate(names)}

    notes: list[str] = []
    wanted = {k.strip().lower(): v for k, v in dict(columns or {}).items()}
    unknown = set(wanted) - set(_ROLES)
    if unknown:
        raise CardError(f"unknown column role(s) {sorted(unknown)}; roles are {list(_ROLES)}",
                        path=where, field="columns")

    def find(role: str, required: bool) -> int | None:
        if role in wanted:
            j = lookup.get(str(wanted[role]).strip().lower())
            if j is None:
                raise CardError(f"no column {wanted[role]!r} (for {role}); columns are {names}",
                                path=where, line=header_line, field=str(wanted[role]))
            return j
        for cand in _DEFAULT_NAMES[role]:
            if cand in lookup:
                return lookup[cand]
        if required:
            raise CardError(
                f"no {role} column; columns are {names} (name it with columns={{'{role}': "
                "...} or --" + role.replace("_", "-") + "-col)",
                path=where, line=header_line, field=role)
        return None

    j_t = find("t", True)
    j_q = find("q", True)
    use_pressures = "dp" not in wanted and ("p_in" in wanted or "p_out" in wanted)
    j_dp = None if use_pressures else find("dp", False)
    j_pin = j_pout = None
    if j_dp is None:
        j_pin, j_pout = find("p_in", False), find("p_out", False)
        if j_pin is None or j_pout is None:
            raise CardError(
                f"no pressure-drop column (dp) and no inlet/outlet pressure pair (p_in, p_out); "
                f"columns are {names}", path=where, line=header_line, field="dp")
    assert j_t is not None and j_q is not None

    data_rows = rows[1:]
    data_lines = [i for i, _ in lines[1:]]
    width = len(names)

    def column(j: int) -> FloatArray:
        out = np.empty(len(data_rows))
        for k, (lineno, row) in enumerate(zip(data_lines, data_rows, strict=True)):
            if len(row) != width:
                raise CardError(f"{len(row)} fields where the header has {width}", path=where,
                                line=lineno)
            cell = row[j].strip()
            if not cell:
                raise CardError("empty value", path=where, line=lineno, field=names[j])
            try:
                value = float(cell)
            except ValueError:
                raise CardError(f"not a number: {cell!r}", path=where, line=lineno,
                                field=names[j]) from None
            if not math.isfinite(value):
                raise CardError(f"{cell!r} is not a finite number", path=where, line=lineno,
                                field=names[j])
            out[k] = value
        return out

    def unit_of(j: int, given: str | None, kind: str) -> tuple[str, str]:
        """(unit spelling, how it was chosen)."""
        header_unit = header[j][1]
        if given is not None:
            if header_unit is not None and header_unit.strip() != given.strip():
                notes.append(f"column {names[j]!r} says {header_unit!r}; the given unit "
                             f"{given!r} was used")
            return given, "given"
        if header_unit is not None:
            return header_unit, "header"
        return {"pressure": "Pa", "flow": "m^3/s", "time": "s"}[kind], "assumed"

    t_spelling, t_how = unit_of(j_t, t_unit, "time")
    t_u = _normalize(t_spelling, _TIME_ALIASES, _TIME_UNITS, "time", names[j_t], where)
    t = column(j_t) * _TIME_UNITS[t_u]
    if t_u != "s":
        notes.append(f"time converted from {t_u} to s")

    if j_dp is not None:
        p_spelling, p_how = unit_of(j_dp, dp_unit, "pressure")
        p_u = _normalize(p_spelling, _PRESSURE_ALIASES, PRESSURE_UNITS, "pressure",
                         names[j_dp], where)
        dp = column(j_dp) * PRESSURE_UNITS[p_u]
        dp_src = f"column {names[j_dp]!r}"
    else:
        assert j_pin is not None and j_pout is not None
        p_spelling, p_how = unit_of(j_pin, dp_unit, "pressure")
        p_u = _normalize(p_spelling, _PRESSURE_ALIASES, PRESSURE_UNITS, "pressure",
                         names[j_pin], where)
        out_spelling, _ = unit_of(j_pout, dp_unit or p_spelling, "pressure")
        p_out_u = _normalize(out_spelling, _PRESSURE_ALIASES, PRESSURE_UNITS, "pressure",
                             names[j_pout], where)
        dp = (column(j_pin) * PRESSURE_UNITS[p_u] - column(j_pout) * PRESSURE_UNITS[p_out_u])
        dp_src = f"inlet minus outlet pressure ({names[j_pin]!r} - {names[j_pout]!r})"
        notes.append(f"pressure drop dp = {names[j_pin]} - {names[j_pout]} (inlet minus "
                     "outlet pressure)")
    if p_how == "assumed":
        notes.append("pressure unit not given: Pa assumed")
    if p_u != "Pa":
        notes.append(f"pressure drop converted from {p_u} to Pa (x {PRESSURE_UNITS[p_u]:.10g})")

    q_spelling, q_how = unit_of(j_q, q_unit, "flow")
    q_u = _normalize(q_spelling, _FLOW_ALIASES, FLOW_UNITS, "flow-rate", names[j_q], where)
    q = column(j_q) * FLOW_UNITS[q_u]
    if q_how == "assumed":
        notes.append("flow-rate unit not given: m^3/s assumed")
    if q_u != "m^3/s":
        notes.append(f"flow rate converted from {q_u} to m^3/s (x {FLOW_UNITS[q_u]:.10g})")
    if t_how == "assumed" and t_u == "s":
        pass  # seconds are the documented default; no note needed

    if t.size < min_samples:
        raise CardError(f"{t.size} samples; at least {min_samples} are needed", path=where,
                        field=names[j_t])
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise CardError(
            f"time must be strictly increasing: {float(t[k + 1]):.10g} s follows "
            f"{float(t[k]):.10g} s",
            path=where, line=data_lines[k + 1], field=names[j_t])
    if np.ptp(q) == 0.0:
        raise CardError(f"the flow rate is constant ({q[0]:g} m^3/s): nothing to fit",
                        path=where, field=names[j_q])
    record = FlowRecord(t=t, dp=dp, q=q, dp_unit="Pa", q_unit="m^3/s", source=where,
                        notes=tuple(notes))
    if np.ptp(dp) == 0.0:
        if not record.step_from_rest:
            raise CardError(
                f"the pressure drop ({dp_src}) is constant ({dp[0]:g} Pa) and the flow does "
                "not start from rest: such a record carries no information on the dynamics",
                path=where, field="dp")
        notes.append(f"pressure drop constant ({dp[0]:g} Pa) from t = {t[0]:g} s with the "
                     "flow at rest: read as a step from rest at the first sample")
        record = replace(record, notes=tuple(notes))
    return record


def _sniff(lines: Sequence[str]) -> str:
    """Comma unless another separator splits every sampled line more consistently."""
    best, best_score = ",", -1
    for sep in (",", ";", "\t", "|"):
        counts = {line.count(sep) for line in lines}
        if len(counts) == 1 and (n := counts.pop()) > 0 and n > best_score:
            best, best_score = sep, n
    return best


def flow_record(
    t: ArrayLike, dp: ArrayLike, q: ArrayLike, *, source: str = "arrays",
    notes: Iterable[str] = (),
) -> FlowRecord:
    """A record from arrays in SI units (checked like a file)."""
    tt, dd, qq = (np.asarray(a, dtype=float).ravel() for a in (t, dp, q))
    if not (tt.size == dd.size == qq.size):
        raise CardError(f"t, dp and q have {tt.size}, {dd.size}, {qq.size} samples",
                        path=source)
    for name, arr in (("t", tt), ("dp", dd), ("q", qq)):
        if not np.all(np.isfinite(arr)):
            raise CardError("non-finite value", path=source, field=name)
    if tt.size < MIN_SAMPLES:
        raise CardError(f"{tt.size} samples; at least {MIN_SAMPLES} are needed", path=source)
    if np.any(np.diff(tt) <= 0):
        raise CardError("time must be strictly increasing", path=source, field="t")
    return FlowRecord(tt, dd, qq, source=source, notes=tuple(notes))


