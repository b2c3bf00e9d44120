"""Flow records and the flow main job: read a transient record, fit a first-order surrogate.

A flow record is a time series of the pressure drop across a delivery system and the volume
flow rate through it, from CFD or a test rig. The job is the paper's second application:
replace the CFD by a first-order ODE with a time constant and a gain (:mod:`pumpid.surrogates`)
identified from the record with the same machinery as the cards.

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
from typing import Any, Literal

import numpy as np
import scipy.optimize
import scipy.stats
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from .cards import CardError
from .models import Model
from .pipeflow import Pipe, PowerLawFluid, power_law_time_scale, simulate_pipe_flow
from .result import FitResult, Units
from .simulate import simulate, simulate_sensitivities
from .surrogates import (
    FirstOrderLag,
    PowerLawLag,
    ShearThinningLag,
    reference_pressure,
    simulate_shear_thinning,
    surrogate_class,
)

__all__ = [
    "FLOW_UNITS",
    "MIN_SAMPLES",
    "PRESSURE_UNITS",
    "FlowRecord",
    "StepStudy",
    "convert_flow",
    "convert_pressure",
    "fit_flow",
    "fit_flow_records",
    "flow_figures",
    "flow_record",
    "normalize_flow_unit",
    "normalize_pressure_unit",
    "plot_flow_fit",
    "plot_tau_vs_step",
    "read_flow_record",
    "simulate_flow_record",
    "simulate_surrogate",
    "step_response_study",
    "write_flow_outputs",
    "write_study_outputs",
]

FloatArray = NDArray[np.float64]
Direction = Literal["dp->q", "q->dp"]
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
        """True when the flow rate starts at zero (to 1e-6 of its largest value)."""
        return bool(abs(self.q[0]) <= 1e-6 * float(np.max(np.abs(self.q))))

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


def _split_header(cell: str) -> tuple[str, str | None]:
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
    header = [_split_header(c) for c in rows[0]]
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
                "...}} or --" + role.replace("_", "-") + "-col)",
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
            f"time must be strictly increasing: {t[k + 1]!r} s follows {t[k]!r} s",
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


# --------------------------------------------------------------------------- fitting
def _orient(record: FlowRecord, direction: str) -> tuple[FloatArray, FloatArray, Units]:
    """(input, output, units) for a direction."""
    if direction == "dp->q":
        return record.dp, record.q, Units(load=record.dp_unit, position=record.q_unit)
    if direction == "q->dp":
        return record.q, record.dp, Units(load=record.q_unit, position=record.dp_unit)
    raise ValueError(f"direction must be 'dp->q' or 'q->dp', got {direction!r}")


def _initial_state(u: FloatArray, y: FloatArray, requested: Any) -> tuple[Any, str]:
    """The initial state for a fit and a sentence saying which and why."""
    at_rest = abs(y[0]) <= 1e-6 * float(np.max(np.abs(y)))
    if requested in (None, "auto"):
        if at_rest:
            state: Any = "rest"
            why = "rest (the output starts at zero)"
        else:
            state = "equilibrium"
            why = ("equilibrium (the output starts away from zero: steady state under the "
                   "first input sample is assumed)")
    else:
        state = requested
        why = f"{requested} (as requested)"
    if state == "rest" and np.ptp(u) == 0.0:
        # A step from rest at t[0]: the zero state given as a number, because a *named* rest
        # state with a constant input is refused by pumpid.fit as uninformative.
        state = (0.0,)
        why = "rest (a step from rest at the first sample)"
    return state, why


def _equation_error_start(t: FloatArray, u: FloatArray, y: FloatArray) -> tuple[float, float]:
    """(tau, gain) of a first-order lag by linear least squares on the integrated ODE.

    ``y(t) - y(t0) = (gain/tau) int u - (1/tau) int y``: no derivative of noisy data needed.
    """
    dt = np.diff(t)
    iu = np.concatenate([[0.0], np.cumsum(0.5 * dt * (u[1:] + u[:-1]))])
    iy = np.concatenate([[0.0], np.cumsum(0.5 * dt * (y[1:] + y[:-1]))])
    mat = np.column_stack([iu, -iy])
    coef, *_ = np.linalg.lstsq(mat, y - y[0], rcond=None)
    c_u, c_y = (float(c) for c in coef)
    span = float(t[-1] - t[0])
    if c_y > 0 and math.isfinite(c_u / c_y) and c_u / c_y > 0:
        return min(max(1.0 / c_y, 1e-6 * span), 1e3 * span), c_u / c_y
    top = float(np.max(np.abs(u))) or 1.0
    return span / 5.0, max(float(np.max(np.abs(y))) / top, 1e-300)


def _bind_reference(cls: type[Model], dp_ref: float | None, u: FloatArray) -> type[Model]:
    if issubclass(cls, PowerLawLag | ShearThinningLag):
        ref = reference_pressure(u) if dp_ref is None else float(dp_ref)
        return cls.at_reference(ref)  # type: ignore[attr-defined,no-any-return]
    return cls


def _start_model(cls: type[Model], t: FloatArray, u: FloatArray, y: FloatArray,
                 x0: Mapping[str, float] | None, fixed: Mapping[str, float] | None) -> Model:
    tau0, gain0 = _equation_error_start(t, u, y)
    values = {"tau": tau0, "gain": gain0}
    if "n" in cls.param_names():
        values["n"] = 1.0
        if issubclass(cls, PowerLawLag | ShearThinningLag):
            # The linear estimate is a mean conductance; the reference one is at dp_ref.
            values["gain"] = gain0
    values.update(dict(x0 or {}))
    values.update(dict(fixed or {}))
    return cls(**{k: values[k] for k in cls.param_names()})


def fit_flow(
    record: FlowRecord,
    model: str | type[Model] | Model = "first-order",
    *,
    direction: Direction = "dp->q",
    method: str = "lm",
    initial_state: Any = "auto",
    dp_ref: float | None = None,
    fixed: Mapping[str, float] | None = None,
    x0: Mapping[str, float] | None = None,
    **fit_options: Any,
) -> FitResult:
    """Fit a first-order surrogate to a flow record (the flow main job).

    Parameters
    ----------
    record : FlowRecord
    model : {"first-order", "power-law", "shear-thinning"} or a surrogate class/instance
        ``first-order``: :class:`~pumpid.surrogates.FirstOrderLag` (tau, gain);
        ``power-law``: :class:`~pumpid.surrogates.PowerLawLag` (tau, gain, n);
        ``shear-thinning``: :class:`~pumpid.surrogates.ShearThinningLag` (tau, gain, n), whose
        time constant follows the flow level. An instance is the starting guess.
    direction : {"dp->q", "q->dp"}
        Pressure drop in and flow rate out (default), or the reverse (first-order only).
    method : {"lm", "newton-fd"}
        As :func:`pumpid.fit`. ``shear-thinning`` supports ``lm`` only.
    initial_state : "auto", "rest", "equilibrium" or numbers
        ``auto``: rest when the output starts at zero (a start-up), else the steady state
        under the first input sample; the choice is stated in ``extra["flow"]``.
    dp_ref : float, optional
        Pressure reference of the power-law models (default: max |dp|, 3 digits).
    fixed : mapping, optional
        Parameters held fixed, e.g. ``{"n": 0.4}`` (``n`` cannot be identified from a
        record with a single pressure-drop level).
    x0 : mapping, optional
        Starting values (default: a linear equation-error estimate, n = 1).
    **fit_options
        Passed to :func:`pumpid.fit` (tol, max_nfev, eps0, ...).

    Returns
    -------
    FitResult
        Parameters with units (``tau`` in s, ``gain`` in output per input unit), R^2, RMSE,
        standard errors and 95 % intervals (``extra["stderr"]``, ``extra["ci95"]``),
        warnings, and ``extra["flow"]`` with the record's source, notes, direction, initial
        state and the pressure reference.
    """
    if isinstance(model, Model):
        cls: type[Model] = type(model)
        start: Model | None = model
    else:
        cls, start = surrogate_class(model), None
    u, y, units = _orient(record, direction)
    if direction == "q->dp" and cls is not FirstOrderLag:
        raise ValueError(
            f"direction 'q->dp' is available for the first-order model only; the power-law "
            f"surrogates take the pressure drop as input (got {cls.__name__})")
    if start is None:
        cls = _bind_reference(cls, dp_ref, u)
    state, why = _initial_state(u, y, initial_state)
    warnings: list[str] = []
    if "n" in cls.param_names() and not (fixed and "n" in fixed):
        levels = _distinct_levels(u)
        if levels < 2:
            warnings.append(
                "the pressure drop visits a single level: the flow index n is not identifiable "
                "from this record (any n fits equally); fix it (fixed={'n': ...}, --fix n=...) "
                "or fit records at several pressure drops")
    if start is None:
        start = _start_model(cls, record.t, u, y, x0, fixed)
    if getattr(cls, "nonlinear", False):
        if method != "lm":
            raise ValueError(f"{cls.__name__} is fitted with method 'lm' only (its simulation "
                             "is a nonlinear ODE, not pumpid's linear simulator)")
        res = _fit_nonlinear(start, [record], [state], fixed=fixed, units=units,
                             tol=fit_options.get("tol", 1e-10),
                             max_nfev=fit_options.get("max_nfev"))
    else:
        from .fit import fit

        res = fit(start, record.t, u, y, method=method,  # type: ignore[arg-type]
                  initial_state=state, units=units, fixed=dict(fixed) if fixed else None,
                  **fit_options)
    res.warnings[:0] = warnings
    _add_uncertainty(res)
    res.extra["flow"] = {
        "source": record.source, "direction": direction,
        "input": "pressure drop" if direction == "dp->q" else "flow rate",
        "output": "flow rate" if direction == "dp->q" else "pressure drop",
        "initial_state": why, "notes": list(record.notes),
        "dp_ref": getattr(cls, "dp_ref", None) if "n" in cls.param_names() else None,
    }
    return res


def _distinct_levels(u: FloatArray, rel: float = 0.05) -> int:
    """Number of pressure-drop levels held for at least 10 % of the record (5 % apart)."""
    mag = np.abs(u)
    top = float(mag.max()) or 1.0
    bins = np.round(mag / (rel * top))
    _, counts = np.unique(bins[mag > rel * top], return_counts=True)
    return int(np.sum(counts >= max(2, 0.1 * u.size)))


def _add_uncertainty(res: FitResult) -> None:
    """Standard errors, 95 % intervals and correlations from the Jacobian (if not present).

    ``cov = s^2 (J^T J)^-1`` with ``s^2 = SSR / (N - p)``: the usual linearized estimate that
    treats the residuals as independent noise. For CFD records the residual is model error,
    not noise, so these numbers measure how sharply the data fix the parameters, not a
    statistical confidence.
    """
    if res.jacobian is None or res.model is None or "stderr" in res.extra:
        return
    jac = np.asarray(res.jacobian, dtype=float)
    names = list(res.free)
    if jac.ndim != 2 or jac.shape[1] != len(names) or not np.all(np.isfinite(jac)):
        return
    n_obs, p = jac.shape
    dof = max(n_obs - p, 1)
    s2 = float(np.sum(res.residuals**2)) / dof
    values = np.array([res.params.get(nm, res.scale if nm == "C" else res.offset)
                       for nm in names], dtype=float)
    # Scale columns to relative changes so the conditioning reflects identifiability, not
    # units (a gain of 1e-11 m^3/s/Pa next to a time constant of 1 s).
    scale = np.where(values != 0, np.abs(values), 1.0)
    js = jac * scale
    _u, sv, vt = np.linalg.svd(js, full_matrices=False)
    if sv[0] == 0:
        return
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    keep = sv > 1e-12 * sv[0]
    inv_sv2 = np.zeros_like(sv)
    inv_sv2[keep] = 1.0 / sv[keep] ** 2
    cov_s = (vt.T * inv_sv2) @ vt * s2
    cov = cov_s * np.outer(scale, scale)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    tq = float(scipy.stats.t.ppf(0.975, dof))
    res.extra["stderr"] = {nm: float(s) for nm, s in zip(names, se, strict=True)}
    res.extra["ci95"] = {nm: [float(v - tq * s), float(v + tq * s)]
                         for nm, v, s in zip(names, values, se, strict=True)}
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    res.extra["correlation"] = {a: {b: float(corr[i, j]) for j, b in enumerate(names)}
                                for i, a in enumerate(names)}
    if not math.isfinite(cond) or cond > 1e8:
        res.extra["identifiability"] = [
            f"the Jacobian is near-singular (relative condition number {cond:.3g}): some "
            "combination of the parameters is not determined by this record"]
        res.warnings.append(res.extra["identifiability"][0])


# --------------------------------------------------------------------------- joint fits
def _simulate_any(
    model_cls: type[Model], theta: FloatArray, t: FloatArray, u: FloatArray, state: Any,
    sens: bool,
) -> Any:
    """Output (and sensitivities) of any surrogate for one record."""
    if getattr(model_cls, "nonlinear", False):
        init = state
        if isinstance(state, tuple | list):
            init = float(state[0])
        return simulate_shear_thinning(theta, t, u, dp_ref=model_cls.dp_ref,  # type: ignore
                                       initial_state=init, sensitivities=sens)
    model = model_cls.from_values(theta)
    if sens:
        return simulate_sensitivities(model, t, u, initial_state=state)
    return simulate(model, t, u, initial_state=state)


def _fit_nonlinear(
    start: Model, records: Sequence[FlowRecord], states: Sequence[Any], *,
    fixed: Mapping[str, float] | None, units: Units, tol: float = 1e-10,
    max_nfev: int | None = None, direction: str = "dp->q",
    weights: Sequence[float] | None = None,
) -> FitResult:
    """Least squares over one or several records (dp -> q) with exact sensitivities.

    Levenberg-Marquardt (scipy.optimize.least_squares) on log-parameters, like pumpid.fit's
    default method; used for the nonlinear ShearThinningLag and for joint fits of any
    surrogate over several records (one parameter set for all of them).
    """
    cls = type(start)
    names = cls.param_names()
    fixed = dict(fixed or {})
    free = [i for i, nm in enumerate(names) if nm not in fixed]
    theta0 = start.values.copy()
    for nm, v in fixed.items():
        theta0[names.index(nm)] = float(v)
    pairs = [_orient(r, direction)[:2] for r in records]
    data = np.concatenate([y for _, y in pairs])
    w = np.concatenate([np.full(r.n, 1.0 if weights is None else float(wk))
                        for r, wk in zip(records, weights or [1.0] * len(records),
                                         strict=True)])
    penalty = 1e3 * (float(np.ptp(w * data)) + 1.0)
    history: list[dict[str, float]] = []
    counter = {"nfev": 0, "best": math.inf}

    def theta_of(z: FloatArray) -> FloatArray:
        th = theta0.copy()
        th[free] = np.exp(np.clip(z, -700.0, 700.0))
        return th

    def outputs(th: FloatArray, sens: bool) -> Any:
        ys, dys = [], []
        for rec, (u, _), st in zip(records, pairs, states, strict=True):
            out = _simulate_any(cls, th, rec.t, u, st, sens)
            if sens:
                ys.append(out[0])
                dys.append(out[1])
            else:
                ys.append(out)
        if sens:
            return np.concatenate(ys), np.vstack(dys)
        return np.concatenate(ys)

    def fun(z: FloatArray) -> FloatArray:
        counter["nfev"] += 1
        th = theta_of(z)
        try:
            with np.errstate(all="ignore"):
                r = w * (outputs(th, False) - data)
        except (RuntimeError, ValueError, FloatingPointError):
            return np.full(data.size, penalty)
        if not np.all(np.isfinite(r)):
            return np.full(data.size, penalty)
        cost = 0.5 * float(r @ r)
        if cost < counter["best"]:
            counter["best"] = cost
            row = {"iteration": float(len(history))}
            row.update(zip(names, th.tolist(), strict=True))
            row["cost"] = cost
            history.append(row)
        return r

    def jac(z: FloatArray) -> FloatArray:
        th = theta_of(z)
        try:
            with np.errstate(all="ignore"):
                _, dy = outputs(th, True)
        except (RuntimeError, ValueError, FloatingPointError):
            return np.zeros((data.size, len(free)))
        jm = w[:, None] * dy[:, free] * th[free]
        return jm if np.all(np.isfinite(jm)) else np.zeros_like(jm)

    ok, reason, njev = True, "", 0
    try:
        sol = scipy.optimize.least_squares(fun, np.log(theta0[free]), jac=jac, method="lm",
                                           xtol=tol, ftol=tol, gtol=tol, max_nfev=max_nfev)
        theta = theta_of(sol.x)
        ok = bool(sol.status > 0)
        reason = {0: "stopped: the maximum number of function evaluations was reached",
                  1: f"converged: the gradient fell below gtol = {tol:g}",
                  2: f"converged: the relative cost reduction fell below ftol = {tol:g}",
                  3: f"converged: the relative step fell below xtol = {tol:g}",
                  4: f"converged: cost reduction and step both below tolerance {tol:g}",
                  }.get(sol.status, str(sol.message))
        njev = int(sol.njev or 0)
    except (ValueError, np.linalg.LinAlgError) as exc:
        theta, ok, reason = theta0, False, f"solver error: {exc}"
    model: Model | None = cls.from_values(theta)
    try:
        fitted, dy = outputs(theta, True)
    except (RuntimeError, ValueError):
        fitted, dy, ok, model = np.full_like(data, np.nan), None, False, None
        reason += "; the fitted model cannot be simulated"
    if fitted is not None and np.all(fitted == penalty):
        ok = False
    res = fitted - data
    finite = bool(np.all(np.isfinite(res)))
    sst = float(np.sum((data - data.mean()) ** 2))
    rmse = float(np.sqrt(np.mean(res**2))) if finite else math.nan
    r2 = 1.0 - float(res @ res) / sst if finite and sst > 0 else math.nan
    # Records placed end to end on one time axis (display only; each starts from its own
    # initial state).
    t_all, u_all, shift = [], [], 0.0
    for rec, (u, _) in zip(records, pairs, strict=True):
        t_all.append(rec.t - rec.t[0] + shift)
        u_all.append(u)
        step = float(rec.t[-1] - rec.t[0])
        shift += step + step / max(rec.n - 1, 1)
    state_label = states[0] if len(set(map(str, states))) == 1 else "per record"
    if isinstance(state_label, tuple):
        state_label = list(state_label)
    return FitResult(
        model=model, params=dict(zip(names, theta.tolist(), strict=True)), scale=1.0,
        offset=0.0, converged=ok and finite, reason=reason, iterations=njev,
        nfev=counter["nfev"], history=history, rmse=rmse, r2=r2, warnings=[], method="lm",
        integrator="solve_ivp (LSODA)" if getattr(cls, "nonlinear", False) else "exact",
        residual="linear", observe="q", initial_state=state_label, units=units,
        free=tuple(names[i] for i in free), cost=0.5 * float(res @ res) if finite else math.nan,
        t=np.concatenate(t_all), load=np.concatenate(u_all), data=data, fitted=fitted,
        jacobian=None if dy is None else dy[:, free],
        extra={"model_name": cls.__name__},
        status="converged" if ok and finite else "failed",
    )


def fit_flow_records(
    records: Sequence[FlowRecord],
    model: str | type[Model] | Model = "shear-thinning",
    *,
    initial_state: Any = "auto",
    dp_ref: float | None = None,
    fixed: Mapping[str, float] | None = None,
    x0: Mapping[str, float] | None = None,
    tol: float = 1e-10,
    max_nfev: int | None = None,
) -> FitResult:
    """One parameter set for several records (pressure drop in, flow rate out).

    Used to test whether a surrogate describes start-ups at several step sizes at once. The
    result's arrays hold the records end to end; ``extra["records"]`` gives each record's
    R^2 and RMSE.
    """
    if not records:
        raise ValueError("no records to fit")
    if isinstance(model, Model):
        start: Model = model
        cls: type[Model] = type(model)
    else:
        cls = surrogate_class(model)
        all_dp = np.concatenate([r.dp for r in records])
        cls = _bind_reference(cls, dp_ref, all_dp)
        longest = max(records, key=lambda r: float(np.ptp(r.dp)) + float(np.max(np.abs(r.dp))))
        start = _start_model(cls, longest.t, longest.dp, longest.q, x0, fixed)
        if "n" in cls.param_names() and len(records) > 1 and not (fixed and "n" in fixed):
            start = _two_level_start(cls, records, start)
    states = [_initial_state(r.dp, r.q, initial_state)[0] for r in records]
    units = records[0].units
    # Each record counts equally whatever its flow level (q ~ dp^(1/n) spans decades across
    # steps): residuals are taken relative to the record's largest flow rate.
    weights = [1.0 / float(np.max(np.abs(r.q))) for r in records]
    res = _fit_nonlinear(start, records, states, fixed=fixed, units=units, tol=tol,
                         max_nfev=max_nfev, weights=weights)
    _add_uncertainty(res)
    per = []
    i = 0
    for rec in records:
        sl = slice(i, i + rec.n)
        err = res.fitted[sl] - rec.q
        sst = float(np.sum((rec.q - rec.q.mean()) ** 2))
        per.append({"source": rec.source, "dp_max": float(np.max(np.abs(rec.dp))),
                    "rmse": float(np.sqrt(np.mean(err**2))),
                    "r2": 1.0 - float(err @ err) / sst if sst > 0 else math.nan})
        i += rec.n
    res.extra["records"] = per
    res.extra["flow"] = {"direction": "dp->q", "input": "pressure drop",
                         "output": "flow rate", "n_records": len(records),
                         "dp_ref": getattr(cls, "dp_ref", None)}
    return res


def _two_level_start(cls: type[Model], records: Sequence[FlowRecord], start: Model) -> Model:
    """Start n from the steady levels of the records: q_end ~ dp^(1/n) (log-log slope)."""
    dps = np.array([abs(float(r.dp[-1])) for r in records])
    qs = np.array([abs(float(r.q[-1])) for r in records])
    ok = (dps > 0) & (qs > 0)
    if ok.sum() >= 2 and np.ptp(np.log(dps[ok])) > 0:
        slope = float(np.polyfit(np.log(dps[ok]), np.log(qs[ok]), 1)[0])
        if slope > 0.2:
            ref = cls.dp_ref  # type: ignore[attr-defined]
            top = int(np.argmax(dps))
            gain = qs[top] / ref * (ref / dps[top]) ** slope
            return start.replace(n=min(max(1.0 / slope, 0.1), 3.0), gain=gain)
    return start


# --------------------------------------------------------------------------- simulation
def simulate_surrogate(
    model: Model, t: ArrayLike, u: ArrayLike, *, initial_state: Any = "rest"
) -> FloatArray:
    """Output of any flow surrogate (linear, Hammerstein or ShearThinningLag) for an input."""
    tt = np.asarray(t, dtype=float)
    uu = np.asarray(u, dtype=float)
    return np.asarray(_simulate_any(type(model), model.values, tt, uu, initial_state, False))


def simulate_flow_record(
    t: ArrayLike,
    dp: ArrayLike | float,
    *,
    fluid: PowerLawFluid,
    pipe: Pipe,
    source: str | None = None,
    **options: Any,
) -> FlowRecord:
    """A reference record from the pipe-flow simulator (:func:`pumpid.pipeflow.simulate_pipe_flow`).

    Parameters
    ----------
    t : array_like
        Output times (s).
    dp : float or array_like
        A constant pressure drop (a step from rest at ``t[0]``) or samples aligned with ``t``
        (piecewise linear, as the surrogates see them).
    fluid, pipe : PowerLawFluid, Pipe
    **options
        Passed to ``simulate_pipe_flow`` (``n_radial``, ``rtol``, ...).
    """
    tt = np.asarray(t, dtype=float)
    dd = np.broadcast_to(np.asarray(dp, dtype=float), tt.shape).astype(float)
    res = simulate_pipe_flow(tt, dd, fluid=fluid, pipe=pipe, **options)
    desc = source or (f"pipe-flow simulation: K = {fluid.K:g} Pa s^n, n = {fluid.n:g}, "
                      f"rho = {fluid.rho:g} kg/m^3, R = {pipe.radius:g} m, "
                      f"L = {pipe.length:g} m")
    return FlowRecord(t=tt.copy(), dp=dd.copy(), q=np.asarray(res.q, dtype=float), source=desc,
                      notes=("simulated with pumpid.pipeflow (laminar power-law pipe flow "
                             "from rest)",))


# --------------------------------------------------------------------------- step study
@dataclass
class StepStudy:
    """Fitted time constants against the size of a pressure-drop step (see
    :func:`step_response_study`).

    Attributes
    ----------
    fluid, pipe : PowerLawFluid, Pipe
    steps : ndarray
        Step sizes (Pa).
    records : list of FlowRecord
        The reference start-ups.
    linear : list of FitResult
        FirstOrderLag fitted to each record separately.
    joint : dict of str to FitResult
        ``power-law`` and ``shear-thinning`` surrogates fitted to all records at once.
    apparent_tau : dict of str to ndarray
        For each joint surrogate, the time constant a FirstOrderLag fit gives on that
        surrogate's own response to each step (so it compares directly with ``tau_linear``).
    """

    fluid: PowerLawFluid
    pipe: Pipe
    steps: FloatArray
    records: list[FlowRecord]
    linear: list[FitResult]
    joint: dict[str, FitResult]
    apparent_tau: dict[str, FloatArray]
    window: str

    @property
    def tau_linear(self) -> FloatArray:
        """FirstOrderLag time constant fitted to each reference record (s)."""
        return np.array([r.params["tau"] for r in self.linear])

    @property
    def gain_linear(self) -> FloatArray:
        """FirstOrderLag gain fitted to each reference record ((m^3/s)/Pa)."""
        return np.array([r.params["gain"] for r in self.linear])

    @property
    def predicted_exponent(self) -> float:
        """Self-similarity: tau ~ dp^((1 - n)/n)."""
        return (1.0 - self.fluid.n) / self.fluid.n

    def exponent(self, taus: ArrayLike | None = None) -> float:
        """Log-log slope of a time constant against the step (least squares)."""
        y = self.tau_linear if taus is None else np.asarray(taus, dtype=float)
        if self.steps.size < 2:
            return math.nan
        return float(np.polyfit(np.log(self.steps), np.log(y), 1)[0])

    def joint_r2(self, key: str) -> FloatArray:
        """Per-record R^2 of a joint (one parameter set) surrogate."""
        return np.array([p["r2"] for p in self.joint[key].extra["records"]])

    def rows(self) -> list[dict[str, float]]:
        """One row per step: step, time scale, linear fit and the joint surrogates."""
        out = []
        for i, step in enumerate(self.steps):
            row = {"dp": float(step),
                   "time_scale": power_law_time_scale(float(step), self.fluid, self.pipe),
                   "tau_linear": float(self.tau_linear[i]),
                   "gain_linear": float(self.gain_linear[i]),
                   "r2_linear": float(self.linear[i].r2)}
            for key in self.joint:
                row[f"tau_{key}"] = float(self.apparent_tau[key][i])
                row[f"r2_{key}"] = float(self.joint_r2(key)[i])
            out.append(row)
        return out

    def table(self) -> str:
        """The study as aligned text with units."""
        rows = self.rows()
        keys = list(rows[0])
        units = {"dp": "Pa", "time_scale": "s", "gain_linear": "(m^3/s)/Pa"}
        head = [f"{k} [{units.get(k, 's' if k.startswith('tau') else '-')}]" for k in keys]
        cells = [head] + [[f"{r[k]:.6g}" for k in keys] for r in rows]
        widths = [max(len(c[i]) for c in cells) for i in range(len(keys))]
        lines = ["  ".join(c.rjust(w) for c, w in zip(line, widths, strict=True))
                 for line in cells]
        lines.append("")
        lines.append(f"log-log slope of tau_linear vs dp: {self.exponent():.4f} (self-similarity "
                     f"predicts (1-n)/n = {self.predicted_exponent:.4f})")
        for key, res in self.joint.items():
            p = res.params
            lines.append(
                f"{res.model_name} (one parameter set for all steps, dp_ref = "
                f"{res.extra['flow']['dp_ref']:g} Pa): tau = {p['tau']:.6g} s, gain = "
                f"{p['gain']:.6g} (m^3/s)/Pa, n = {p['n']:.6g}; R^2 = {res.r2:.6f} overall, "
                f"min per step {np.min(self.joint_r2(key)):.6f}; apparent tau slope "
                f"{self.exponent(self.apparent_tau[key]):.4f}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "fluid": {"K": self.fluid.K, "n": self.fluid.n, "rho": self.fluid.rho},
            "pipe": {"radius": self.pipe.radius, "length": self.pipe.length},
            "window": self.window,
            "rows": self.rows(),
            "exponent_linear": self.exponent(),
            "exponent_predicted": self.predicted_exponent,
            "joint": {k: {"model": r.model_name, "params": r.params, "r2": r.r2,
                          "rmse": r.rmse, "dp_ref": r.extra["flow"]["dp_ref"],
                          "r2_per_step": self.joint_r2(k).tolist(),
                          "exponent_apparent_tau": self.exponent(self.apparent_tau[k])}
                      for k, r in self.joint.items()},
        }


def step_response_study(
    fluid: PowerLawFluid,
    pipe: Pipe,
    steps: ArrayLike,
    *,
    window: Literal["common", "scaled"] = "common",
    periods: float = 6.0,
    samples: int = 301,
    n_radial: int = 120,
    joint: Sequence[str] = ("power-law", "shear-thinning"),
) -> StepStudy:
    """Start-up flows for several pressure-drop steps, fitted with each surrogate.

    Parameters
    ----------
    fluid, pipe : PowerLawFluid, Pipe
    steps : array_like
        Step sizes in Pa (positive).
    window : {"common", "scaled"}
        ``common``: every record covers ``periods`` time scales of the *largest* step with
        ``samples`` uniform samples (one record length for all, as on a test rig);
        ``scaled``: each record covers ``periods`` of its own time scale
        (:func:`pumpid.pipeflow.power_law_time_scale`), so the records are exact rescalings
        of one another when the fluid is self-similar.
    periods : float
        Record length in time scales.
    samples : int
        Samples per record (t = 0 included).
    n_radial : int
        Radial cells of the reference simulator (120 keeps the flow rate within ~3e-5).
    joint : sequence of str
        Surrogates fitted with one parameter set to all records.

    Returns
    -------
    StepStudy
    """
    st = np.sort(np.asarray(steps, dtype=float).ravel())
    if st.size < 2 or np.any(st <= 0):
        raise ValueError("steps: give at least two positive pressure-drop steps")
    scales = np.array([power_law_time_scale(float(a), fluid, pipe) for a in st])
    records = []
    for a, scale in zip(st, scales, strict=True):
        t_end = periods * (scales.max() if window == "common" else scale)
        t = np.linspace(0.0, t_end, int(samples))
        records.append(simulate_flow_record(
            t, a, fluid=fluid, pipe=pipe, n_radial=n_radial,
            source=f"pipe-flow start-up, dp = {a:g} Pa"))
    linear = [fit_flow(r, "first-order") for r in records]
    joint_fits: dict[str, FitResult] = {}
    apparent: dict[str, FloatArray] = {}
    for key in joint:
        res = fit_flow_records(records, key)
        joint_fits[key] = res
        taus = []
        for rec in records:
            y = simulate_surrogate(res.model, rec.t, rec.dp, initial_state="rest") \
                if res.model is not None else np.full(rec.n, np.nan)
            if not np.all(np.isfinite(y)):
                taus.append(math.nan)
                continue
            own = replace(rec, q=y, source=f"{res.model_name} response")
            taus.append(fit_flow(own, "first-order").params["tau"])
        apparent[key] = np.array(taus)
    return StepStudy(fluid, pipe, st, records, linear, joint_fits, apparent, window)


# --------------------------------------------------------------------------- figures
def _new_figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _names(result: FitResult) -> tuple[str, str]:
    """(input name, output name) of a flow fit."""
    info = result.extra.get("flow", {})
    return info.get("input", "pressure drop"), info.get("output", "flow rate")


def plot_flow_fit(result: FitResult) -> Figure:
    """Measured and fitted output over time, with the input below it.

    Returns
    -------
    Figure
        Two axes sharing time: output (flow rate for dp -> q) measured and fitted, and the
        input (pressure drop), each labelled with its unit.
    """
    u = result.units
    inp, outp = _names(result)
    fig = _new_figure(8.0, 6.0)
    ax, axi = fig.subplots(2, 1, sharex=True, height_ratios=[2.2, 1.0])
    ax.plot(result.t, result.data, color="0.35", linewidth=2.4, alpha=0.75,
            label="measured / reference")
    if np.any(np.isfinite(result.fitted)):
        ax.plot(result.t, result.fitted, color="tab:red", linewidth=1.3,
                label=f"fitted {result.model_name}")
    ax.set_ylabel(f"{outp} [{u.position}]")
    ax.set_title(f"{result.model_name}: {inp} -> {outp}, R² = {result.r2:.6g}")
    ax.legend(loc="best")
    axi.plot(result.t, result.load, color="tab:blue", linewidth=1.2)
    axi.set_ylabel(f"{inp} [{u.load}]")
    axi.set_xlabel("time [s]")
    for a in (ax, axi):
        a.grid(True, alpha=0.3)
    return fig


def plot_flow_characteristic(result: FitResult) -> Figure:
    """Output against input: the measured trajectory, the fitted one and the steady map."""
    u = result.units
    inp, outp = _names(result)
    fig = _new_figure(6.8, 5.2)
    ax = fig.add_subplot()
    ax.plot(result.load, result.data, ".", color="0.35", markersize=3,
            label="measured / reference")
    if np.any(np.isfinite(result.fitted)):
        ax.plot(result.load, result.fitted, ".", color="tab:red", markersize=2,
                label=f"fitted {result.model_name}")
    if result.model is not None and np.ptp(result.load) > 0:
        grid = np.linspace(min(0.0, result.load.min()), result.load.max(), 200)
        steady = getattr(result.model, "steady_flow", None)
        level = steady(grid) if steady is not None else result.params["gain"] * grid
        ax.plot(grid, level, "--", color="tab:green", label="fitted steady state")
    ax.set_xlabel(f"{inp} [{u.load}]")
    ax.set_ylabel(f"{outp} [{u.position}]")
    ax.set_title(f"{result.model_name}: {outp} against {inp}")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return fig


def flow_figures(result: FitResult) -> dict[str, Figure]:
    """The standard figures of a flow fit: time series, characteristic, residuals, history."""
    from .plots import plot_history, plot_residuals

    return {"flow": plot_flow_fit(result), "characteristic": plot_flow_characteristic(result),
            "residuals": plot_residuals(result), "history": plot_history(result)}


def plot_tau_vs_step(study: StepStudy) -> Figure:
    """Time constant against the pressure-drop step, log-log, with per-step R^2.

    The markers are FirstOrderLag fits to each reference start-up (what a linear surrogate
    reports at each step); the lines are the apparent time constants of the surrogates fitted
    with ONE parameter set to all steps; the dashed line is the self-similar slope
    (1 - n)/n through the middle point.
    """
    fig = _new_figure(8.5, 7.0)
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2.0, 1.0])
    st = study.steps
    ax.loglog(st, study.tau_linear, "o", color="black", markersize=7,
              label="linear first-order fit to each reference start-up")
    styles = {"power-law": ("tab:blue", "s-"), "shear-thinning": ("tab:red", "^-")}
    for key, res in study.joint.items():
        color, mk = styles.get(key, ("tab:green", "d-"))
        ax.loglog(st, study.apparent_tau[key], mk, color=color, linewidth=1.3,
                  label=f"{res.model_name}, one parameter set (apparent tau)")
    mid = len(st) // 2
    guide = study.tau_linear[mid] * (st / st[mid]) ** study.predicted_exponent
    ax.loglog(st, guide, "--", color="0.5",
              label=f"self-similar slope (1-n)/n = {study.predicted_exponent:.3g}")
    ax.set_ylabel("time constant tau [s]")
    ax.set_title(f"Start-up of a power-law fluid (n = {study.fluid.n:g}): time constant vs "
                 f"pressure-drop step")
    ax.legend(loc="best", fontsize=8.5)
    one_minus = 1.0 - np.array([r.r2 for r in study.linear])
    ax2.semilogy(st, np.maximum(one_minus, 1e-16), "o", color="black",
                 label="linear, fitted per step")
    for key, res in study.joint.items():
        color, mk = styles.get(key, ("tab:green", "d-"))
        ax2.semilogy(st, np.maximum(1.0 - study.joint_r2(key), 1e-16), mk, color=color,
                     label=f"{res.model_name}, one set")
    ax2.set_xscale("log")
    ax2.set_xlabel("pressure-drop step dp [Pa]")
    ax2.set_ylabel("1 - R² [-]")
    ax2.legend(loc="best", fontsize=8.5)
    for a in (ax, ax2):
        a.grid(True, which="both", alpha=0.3)
    return fig


# --------------------------------------------------------------------------- outputs
def _title(result: FitResult) -> str:
    inp, outp = _names(result)
    return f"pumpid flow fit: {result.model_name}, {inp} in, {outp} out"


def _flow_notes(result: FitResult, notes: str | Sequence[str] | None) -> list[str]:
    out = [notes] if isinstance(notes, str) else [str(n) for n in notes or ()]
    info = result.extra.get("flow", {})
    if info.get("source"):
        out.append(f"record: {info['source']}")
    out += [str(n) for n in info.get("notes", []) if str(n) not in out]
    if info.get("initial_state"):
        out.append(f"initial state: {info['initial_state']}")
    if info.get("dp_ref"):
        out.append(f"pressure reference of the power-law map: dp_ref = {info['dp_ref']:g} Pa "
                   "(gain = steady q/dp there)")
    out.append("report wording: 'load' is the model input and 'position' the model output "
               f"({info.get('input', 'pressure drop')} and {info.get('output', 'flow rate')}); "
               "the scale C and offset are fixed (1 and 0)")
    return out


def write_flow_outputs(
    result: FitResult,
    out_dir: str | os.PathLike[str],
    *,
    notes: str | Sequence[str] | None = None,
    title: str | None = None,
    extra_figures: Mapping[str, Figure] | None = None,
    extra_sections: Mapping[str, Any] | None = None,
) -> dict[str, Path]:
    """Write the figures (PNG), ``result.json`` and ``report.html`` of a flow fit.

    The files are those of :func:`pumpid.report.write_outputs`, with figures labelled for
    pressure drop and flow rate (``flow.png``, ``characteristic.png``, ``residuals.png``,
    ``history.png``) instead of the card figures.
    """
    from .report import write_outputs

    figs = {**flow_figures(result), **dict(extra_figures or {})}
    return write_outputs(result, out_dir, title=title or _title(result), figures=figs,
                         notes=_flow_notes(result, notes), extra_sections=extra_sections)


def write_study_outputs(study: StepStudy, out_dir: str | os.PathLike[str]) -> dict[str, Path]:
    """Write the step study: ``tau_vs_step.png``, ``study.csv``, ``study.json`` and a report.

    The report is the standard one for the shear-thinning surrogate fitted to all steps at
    once, with the time-constant figure and the table added.
    """
    import json

    from .result import _jsonable

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path] = {}
    rows = study.rows()
    csv_path = out / "study.csv"
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    paths["csv"] = csv_path
    json_path = out / "study.json"
    json_path.write_text(json.dumps(_jsonable(study.to_dict()), indent=2) + "\n",
                         encoding="utf-8")
    paths["study_json"] = json_path
    key = "shear-thinning" if "shear-thinning" in study.joint else next(iter(study.joint))
    res = study.joint[key]
    linear_ok = abs(study.exponent() - study.predicted_exponent)
    verdict = [
        f"The linear first-order surrogate fitted step by step gives time constants that grow "
        f"with the step like dp^{study.exponent():.3f} (self-similarity predicts "
        f"dp^{study.predicted_exponent:.3f}, difference {linear_ok:.3f}): one linear model "
        "cannot describe all steps.",
    ]
    for k, r in study.joint.items():
        verdict.append(
            f"{r.model_name} with one parameter set for all steps: apparent time constant "
            f"~ dp^{study.exponent(study.apparent_tau[k]):.3f}, R^2 per step "
            f"{np.min(study.joint_r2(k)):.5f} ... {np.max(study.joint_r2(k)):.5f}"
            + (" -- it captures the step-size dependence." if abs(
                study.exponent(study.apparent_tau[k]) - study.predicted_exponent) < 0.1
               else " -- it does NOT capture the step-size dependence (its time constant does "
                    "not depend on the step)."))
    paths.update(write_flow_outputs(
        res, out, title=f"pumpid flow study: time constant vs pressure-drop step "
                        f"(n = {study.fluid.n:g})",
        notes=[f"{len(study.records)} reference start-ups from rest (pumpid.pipeflow), "
               f"window '{study.window}'; the time-series figures show them end to end on one "
               "axis, each starting from rest", *verdict],
        extra_figures={"tau_vs_step": plot_tau_vs_step(study)},
        extra_sections={"Time constant against step size": study.table(),
                        "Conclusion": "\n".join(verdict)},
    ))
    return paths
