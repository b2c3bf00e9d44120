"""The one result type, built once: parameters, uncertainty, diagnostics, status, report.

:class:`FitResult` is immutable. Its typed parts are :class:`~pumpid.inference.uncertainty.
Uncertainty` (standard errors, intervals, what they assume), :class:`BoundaryInfo` (parameters
that ran to 0 or infinity and the reduced model fitted there), :class:`StartInfo` (how the
start was found) and :class:`CardInfo` (where the data came from); ``status`` is a
:class:`Status` member with its message. A prediction is its own object
(:class:`Prediction`), never written into the fit it was made with.

:class:`FitBatch` holds the fits of many cards as arrays (one entry per card) and builds a
card's :class:`FitResult` on request.
"""

from __future__ import annotations

import enum
import functools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .inference.boundaries import BoundaryInfo, Limiting, ReducedFit
from .inference.derived import Derived
from .inference.uncertainty import Uncertainty
from .models import Model

if TYPE_CHECKING:
    from .engine.problem import Problem
    from .inference.profile import Profile

__all__ = [
    "BoundaryInfo",
    "CardInfo",
    "Derived",
    "FitBatch",
    "FitResult",
    "Limiting",
    "Prediction",
    "ReducedFit",
    "StartInfo",
    "Status",
    "Units",
    "model_choice_text",
]

Array = NDArray[np.float64]


class Status(enum.StrEnum):
    """What a fit's answer is, with its meaning in words.

    A member is its name as a string (``Status.CONVERGED == "converged"``), the name JSON,
    tables and exit codes use.
    """

    CONVERGED = ("converged", "the solver met a convergence test at an interior optimum")
    BOUNDARY = ("boundary", "a parameter ran to 0 or infinity: the data want a limiting "
                "model, whose parameters are reported beside the full model's")
    UNDETERMINED = ("undetermined", "the solver found its optimum, but the data determine "
                    "none of the model's parameters (each ran to a limit, is structurally free "
                    "or has an error over 100 % of its value): the numbers are one point of a "
                    "wide set of models that fit as well; only derived quantities marked "
                    "determined, if any, say something")
    POOR_FIT = ("poor-fit", "the solver found its optimum, but the model explains less of "
                "the data than the quality threshold asks (R^2 below min_r2): the numbers "
                "describe a model that does not reproduce this record")
    FAILED = ("failed", "no converged solution: the solver stopped without meeting a "
              "convergence test, or the model could not be simulated")
    INVALID_INPUT = ("invalid-input", "the card could not be read or validated")

    def __new__(cls, key: str, meaning: str) -> Status:
        obj = str.__new__(cls, key)
        obj._value_ = key
        obj.meaning = meaning  # type: ignore[attr-defined]
        return obj

    @property
    def key(self) -> str:
        """The status' name."""
        return str(self.value)

    def __str__(self) -> str:
        return str(self.value)

    @classmethod
    def parse(cls, text: str) -> Status:
        """The member named ``text``."""
        try:
            return cls(text)
        except ValueError:
            raise ValueError(f"unknown status {text!r}; one of {[m.value for m in cls]}") \
                from None


@dataclass(frozen=True)
class Units:
    """Units of the data a fit was made on (time is always seconds)."""

    load: str = "N"
    position: str = "m"
    time: str = "s"

    def to_dict(self) -> dict[str, str]:
        """As a plain dictionary."""
        return {"load": self.load, "position": self.position, "time": self.time}


@dataclass(frozen=True)
class CardInfo:
    """Where a fit's data came from and everything done to them."""

    id: str | None = None
    well: str | None = None
    source: str | None = None
    time_source: str | None = None
    spm: float | None = None
    period: float | None = None
    notes: tuple[str, ...] = ()
    #: When the card was recorded (ISO 8601), where the file says.
    time: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {"id": self.id, "well": self.well, "time": self.time, "source": self.source,
                "time_source": self.time_source, "spm": self.spm, "period": self.period,
                "notes": list(self.notes)}


@dataclass(frozen=True)
class StartInfo:
    """How the starting point was found."""

    note: str
    candidates: int = 0
    polished: int = 0


def _fmt(value: float | None, digits: int = 6) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return f"{value:.{digits}g}"


def jsonable(value: Any) -> Any:
    """Turn numpy values, mappings, tuples and non-finite floats into JSON-safe values."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, enum.Enum):
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _frozen(a: Any) -> Any:
    if isinstance(a, np.ndarray):
        a = a.view()
        a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Prediction:
    """A fitted model's prediction of another record (the paper's Fig. 9)."""

    card: str | None
    t: Array
    load: Array
    measured: Array
    predicted: Array
    rmse: float
    r2: float

    def to_dict(self) -> dict[str, Any]:
        """The scores (no arrays)."""
        return {"card": self.card, "rmse": self.rmse, "r2": self.r2}

    def __getitem__(self, key: str) -> Any:
        # Dictionary-style access to the fields (``pred["r2"]``).
        return getattr(self, key)


@dataclass(frozen=True, eq=False)
class FitResult:
    """Outcome of one identification (immutable).

    Attributes
    ----------
    model : Model or None
        The fitted model (None when the fit produced no finite parameters).
    status : Status
        ``converged``, ``boundary`` (a parameter ran to 0 or infinity), ``undetermined``
        (no parameter determined), ``poor-fit`` or ``failed``.
    reason : str
        Why the solver stopped, in words, and what the boundary analysis found.
    params : mapping
        Fitted parameter values by name (on the stated gauge when one was fixed).
    scale, offset : float
        The output scale factor C and the additive position offset (position units).
    iterations, nfev : int
        Accepted iterations and model evaluations.
    history : tuple of mappings
        One row per accepted iterate: iteration, parameters, scale, offset, cost.
    rmse, r2, cost : float
        Root-mean-square error (position units), coefficient of determination, and
        0.5 * sum of squared residuals of the minimized residual.
    warnings : tuple of str
        Plain-language caveats.
    uncertainty : Uncertainty or None
        Standard errors and intervals (None when the fit has no usable solution).
    identifiability : tuple of str
        What the data cannot determine, in words (empty when everything is determined).
    boundary : BoundaryInfo or None
        Parameters at a bound and the reduced model fitted there.
    start : StartInfo or None
        How the start was found (None for a user's guess taken as it was).
    card : CardInfo or None
        Where the data came from (card fits).
    """

    model: Model | None
    model_name: str
    status: Status
    reason: str
    params: Mapping[str, float]
    scale: float
    offset: float
    iterations: int
    nfev: int
    history: tuple[Mapping[str, float], ...]
    rmse: float
    r2: float
    cost: float
    warnings: tuple[str, ...]
    method: str
    integrator: str
    residual: str
    observe: str
    initial_state: Any
    units: Units
    free: tuple[str, ...]
    t: Array = field(repr=False)
    load: Array = field(repr=False)
    data: Array = field(repr=False)
    fitted: Array = field(repr=False)
    jacobian: Array | None = field(default=None, repr=False)
    uncertainty: Uncertainty | None = field(default=None, repr=False)
    identifiability: tuple[str, ...] = ()
    determined: Mapping[str, Any] = field(default_factory=dict, repr=False)
    derived: Mapping[str, Derived] = field(default_factory=dict, repr=False)
    boundary: BoundaryInfo | None = None
    start: StartInfo | None = None
    card: CardInfo | None = None
    gauge: str | None = None
    #: Application-specific facts (e.g. the flow record's), read-only.
    application: Mapping[str, Any] = field(default_factory=dict, repr=False)
    #: The problem and options behind the fit, for refits (profiles, predictions).
    problem: Problem | None = field(default=None, repr=False, compare=False)
    options: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("t", "load", "data", "fitted", "jacobian"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))
        object.__setattr__(self, "derived", MappingProxyType(dict(self.derived)))

    # ------------------------------------------------------------------ derived
    @property
    def converged(self) -> bool:
        """True for an ordinary converged answer (status ``converged``)."""
        return self.status is Status.CONVERGED

    @property
    def residuals(self) -> Array:
        """Fitted minus measured displacement (position units)."""
        return self.fitted - self.data

    @property
    def stderr(self) -> dict[str, float]:
        """Standard error of every fitted value (empty when not computed): the error that
        holds for these residuals, robust to their serial correlation where they fail the
        whiteness check (:attr:`errors_shown`; :attr:`stderr_white` assumes white noise)."""
        return dict(self.uncertainty.stderr) if self.uncertainty else {}

    @property
    def ci95(self) -> dict[str, Any]:
        """95 % confidence interval (low, high) of every fitted value."""
        return dict(self.uncertainty.ci95) if self.uncertainty else {}

    @property
    def errors_shown(self) -> str:
        """Which errors :attr:`stderr` and :attr:`ci95` are: ``"robust"`` (the residuals
        are serially correlated: the autocorrelation-robust ones) or ``"white"``."""
        return str(getattr(self.uncertainty, "shown", "white"))

    @property
    def stderr_white(self) -> dict[str, float]:
        """Standard errors that assume independent (white) noise, whatever is shown."""
        unc = self.uncertainty
        if unc is None:
            return {}
        return dict(getattr(unc, "stderr_white", None) or unc.stderr)

    @property
    def ci95_white(self) -> dict[str, Any]:
        """95 % intervals from :attr:`stderr_white`."""
        unc = self.uncertainty
        if unc is None:
            return {}
        return dict(getattr(unc, "ci95_white", None) or unc.ci95)

    @property
    def stderr_hac(self) -> dict[str, float]:
        """Standard errors robust to serially correlated residuals (HAC)."""
        if self.uncertainty is None:
            return dict.fromkeys(self.free, math.nan) if self.model is None else {}
        return dict(self.uncertainty.stderr_hac)

    @property
    def ci95_hac(self) -> dict[str, Any]:
        """95 % intervals from :attr:`stderr_hac`."""
        return dict(self.uncertainty.ci95_hac) if self.uncertainty else {}

    @property
    def correlation(self) -> dict[str, Any]:
        """Correlation matrix of the fitted values: ``{"names": [...], "matrix": [[...]]}``."""
        if self.uncertainty is None:
            return {}
        return {"names": list(self.uncertainty.names),
                "matrix": self.uncertainty.correlation.tolist()}

    @property
    def covariance(self) -> dict[str, Any]:
        """Covariance matrix of the fitted values (same layout as :attr:`correlation`)."""
        if self.uncertainty is None:
            return {}
        return {"names": list(self.uncertainty.names),
                "matrix": self.uncertainty.covariance.tolist()}

    @property
    def whiteness(self) -> Mapping[str, Any] | None:
        """The residuals' whiteness check (None for an exact fit or no solution)."""
        return self.uncertainty.whiteness if self.uncertainty else None

    @property
    def scale_name(self) -> str:
        """``C`` for the linear residual, ``D = ln C`` for the log residual."""
        return "D" if self.residual == "log" else "C"

    def param_units(self) -> dict[str, str]:
        """Unit of every parameter in the data's units."""
        if self.model is None:
            return {}
        return {p.name: p.unit_for(self.units.load, self.units.position)
                for p in self.model.param_info()}

    def free_values(self) -> dict[str, float]:
        """The fitted values by name (parameters, C or D, offset)."""
        out: dict[str, float] = {}
        for name in self.free:
            if name == "C":
                out[name] = self.scale
            elif name == "D":
                out[name] = math.log(self.scale) if self.scale > 0 else math.nan
            elif name == "offset":
                out[name] = self.offset
            else:
                out[name] = self.params[name]
        return out

    @functools.cached_property
    def extra(self) -> Mapping[str, Any]:
        """Everything beyond the core fields, as the JSON has it (read-only)."""
        out: dict[str, Any] = {"model_name": self.model_name, "gauge": self.gauge}
        if self.start is not None:
            out["start"] = self.start.note
        if self.boundary is not None:
            out["boundaries"] = [{"name": b.name, "direction": b.direction,
                                  "limit": b.limit} for b in self.boundary.limits]
            if self.boundary.reduced is not None:
                out["reduced"] = self.boundary.reduced.to_dict()
        unc = self.uncertainty
        if unc is not None:
            out.update({
                "sigma2": unc.sigma2, "uncertainty": unc.to_dict(),
                "covariance": self.covariance, "correlation": self.correlation,
                "stderr": dict(unc.stderr),
                "ci95": {k: list(v) if v else None for k, v in unc.ci95.items()},
                "stderr_hac": dict(unc.stderr_hac),
                "ci95_hac": {k: list(v) if v else None for k, v in unc.ci95_hac.items()},
                "stderr_white": self.stderr_white,
                "ci95_white": {k: list(v) if v else None for k, v in self.ci95_white.items()},
                "errors_shown": self.errors_shown,
            })
        else:
            out.update({"stderr": {}, "ci95": {}, "stderr_hac": {}, "ci95_hac": {},
                        "stderr_white": {}, "ci95_white": {}, "errors_shown": "white",
                        "correlation": {}, "covariance": {}, "sigma2": math.nan,
                        "uncertainty": {"note": "not computed: the fit has no finite solution "
                                                "with a Jacobian, or no more samples than "
                                                "fitted values"}})
        out["identifiability"] = list(self.identifiability)
        out["determined"] = dict(self.determined)
        out["derived"] = {name: d.to_dict() for name, d in self.derived.items()}
        if self.card is not None:
            out["card"] = self.card.to_dict()
        out.update(self.application)
        return MappingProxyType(out)

    def to_row(self) -> dict[str, Any]:
        """One flat row for a results table (the fleet's layout).

        Keys: ``well_id``, ``card_id``, ``time``, ``source``, ``model``, ``observe``,
        ``status``, ``reason``, ``warnings`` (joined by " | "), ``r2``, ``rmse``, ``cost``,
        ``n_samples``, ``nfev``, ``position_unit``, ``load_unit``; per parameter
        ``p_NAME``, ``p_NAME_se`` (the error shown: robust where the residuals are serially
        correlated), ``p_NAME_se_hac``, ``p_NAME_se_white``; ``scale`` and ``offset``; per
        derived quantity ``d_NAME``, ``d_NAME_se`` (shown), ``d_NAME_se_hac``,
        ``d_NAME_se_white``, ``d_NAME_determined``, ``d_NAME_well_property`` (False when the
        card's imposed motion, not the well, sets it), ``d_NAME_unit``. Standard errors are
        NaN where not computed.
        """
        card = self.card
        row: dict[str, Any] = {
            "well_id": card.well if card else None,
            "card_id": card.id if card else None,
            "time": card.time if card else None,
            "source": card.source if card else None,
            "model": self.model_name, "observe": self.observe, "status": self.status.key,
            "reason": self.reason, "warnings": " | ".join(self.warnings),
            "r2": self.r2, "rmse": self.rmse, "cost": self.cost,
            "n_samples": int(self.t.size), "nfev": self.nfev,
            "position_unit": self.units.position, "load_unit": self.units.load,
        }
        se = self.stderr
        se_hac = self.stderr_hac
        se_white = self.stderr_white
        for name, value in self.params.items():
            row[f"p_{name}"] = value
            row[f"p_{name}_se"] = float(se.get(name, math.nan))
            row[f"p_{name}_se_hac"] = float(se_hac.get(name, math.nan))
            row[f"p_{name}_se_white"] = float(se_white.get(name, math.nan))
        row["scale"] = self.scale
        row["offset"] = self.offset
        for name, d in self.derived.items():
            row[f"d_{name}"] = d.value
            row[f"d_{name}_se"] = d.stderr
            row[f"d_{name}_se_hac"] = d.stderr_hac
            row[f"d_{name}_se_white"] = d.stderr_white
            row[f"d_{name}_determined"] = d.determined
            row[f"d_{name}_well_property"] = d.well_property
            row[f"d_{name}_unit"] = d.unit
        return row

    def with_parts(self, **changes: Any) -> FitResult:
        """A copy with some parts replaced (e.g. ``card=CardInfo(...)``)."""
        return replace(self, **changes)

    def profile(self, name: str, *, n_points: int = 21, span: float | None = None,
                level: float = 0.95) -> Profile:
        """Profile likelihood of one fitted value (refits with it fixed on a grid).

        Returns a :class:`pumpid.inference.profile.Profile` with the interval (one-sided when
        the parameter is at a boundary) and ``plot()``.
        """
        from .inference.profile import profile

        return profile(self, name, n_points=n_points, span=span, level=level)

    # ------------------------------------------------------------------ output
    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary (no arrays of samples)."""
        out: dict[str, Any] = {
            "model": self.model_name, "method": self.method, "integrator": self.integrator,
            "residual": self.residual, "observe": self.observe,
            "initial_state": self.initial_state, "params": dict(self.params),
            "units": {**self.units.to_dict(), "params": self.param_units()},
            "scale": self.scale, "offset": self.offset, "free": list(self.free),
            "converged": self.converged, "status": self.status.key, "reason": self.reason,
            "iterations": self.iterations, "nfev": self.nfev, "cost": self.cost,
            "rmse": self.rmse, "r2": self.r2, "n_samples": int(self.t.size),
            "warnings": list(self.warnings),
        }
        if self.residual == "log":
            out["D"] = math.log(self.scale) if self.scale > 0 else None
        for key, value in self.extra.items():
            if key != "model_name":
                out[key] = value
        return jsonable(out)

    def to_json(self, **kwargs: Any) -> str:
        """The result as a JSON string."""
        return json.dumps(self.to_dict(), **kwargs)

    def history_table(self) -> str:
        """The per-iteration history as aligned text."""
        if not self.history:
            return "(no iterations recorded)"
        keys = list(self.history[0].keys())
        rows = [[str(k) for k in keys]]
        for row in self.history:
            rows.append([str(int(row[k])) if k == "iteration" else _fmt(row.get(k), 12)
                         for k in keys])
        widths = [max(len(r[i]) for r in rows) for i in range(len(keys))]
        return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True))
                         for r in rows)

    def report(self, history: bool = False) -> str:
        """A readable report: parameters with units, fit quality, convergence, warnings."""
        return format_report(self, history=history)

    def __str__(self) -> str:
        return self.report()


# --------------------------------------------------------------------------- text report
def _error_table(names: Sequence[str], values: Mapping[str, float], units: Mapping[str, str],
                 stderr: Mapping[str, Any], ci95: Mapping[str, Any]) -> list[str]:
    lines = [f"  {'value':<15}  {'std. error':<12}  {'rel.':<8}  {'95 % interval':<30}  unit"]
    for name in names:
        se = stderr.get(name)
        se = math.nan if se is None else float(se)
        v = values[name]
        rel = abs(se / v) if v and math.isfinite(se) else math.nan
        ci = ci95.get(name)
        ci_txt = f"[{ci[0]:.6g}, {ci[1]:.6g}]" if ci else "none"
        rel_txt = f"{100 * rel:.3g} %" if math.isfinite(rel) else "n/a"
        se_txt = f"{se:.4g}" if math.isfinite(se) else "n/a"
        lines.append(f"  {name:<15}  {se_txt:<12}  {rel_txt:<8}  {ci_txt:<30}  "
                     f"{units.get(name, '')}")
    return lines


def diagnostics_text(result: FitResult) -> str:
    """The diagnostics as report lines (uncertainty table, correlations, findings)."""
    lines: list[str] = []
    unc = result.uncertainty
    if unc is not None:
        lines.append(f"  uncertainty: residual variance sigma^2 = {unc.sigma2:.4g} "
                     f"{unc.sigma2_unit}, {unc.dof} degrees of freedom")
        lines.append(f"  ({unc.assumptions})")
        values = result.free_values()
        units = {**result.param_units(), "C": "-", "D": "-", "offset": result.units.position}
        if result.errors_shown == "robust" and unc.hac:
            m = unc.hac["bandwidth"]
            lines.append("  robust to the residuals' serial correlation (shown; HAC: "
                         f"prewhitened Bartlett kernel, bandwidth {m} "
                         f"sample{'s' if m != 1 else ''}, widened by "
                         f"{float(unc.hac.get('factor', 1.0)):.3g} for the estimate's own "
                         "spread; see the warning below):")
            lines += _error_table(result.free, values, units, unc.stderr, unc.ci95)
            lines.append("  assuming independent noise (too narrow for these residuals: "
                         "stderr_white, ci95_white):")
            lines += _error_table(result.free, values, units, result.stderr_white,
                                  result.ci95_white)
        else:
            lines += _error_table(result.free, values, units, unc.stderr, unc.ci95)
        for note in unc.notes:
            lines.append(f"  note: {note}")
        lines.append("  correlation:")
        cn = list(unc.names)
        lines.append("  " + " " * 8 + "".join(f"{n:>8}" for n in cn))
        for n, row in zip(cn, unc.correlation.tolist(), strict=True):
            lines.append(f"  {n:<8}" + "".join(
                f"{x:>8.3f}" if x is not None and math.isfinite(x) else f"{'n/a':>8}"
                for x in row))
    elif result.model is None and not result.identifiability:
        return ""
    findings = result.identifiability
    lines.append("  identifiability:" if findings else
                 "  identifiability: every fitted value is determined by the data")
    lines += [f"  - {f}" for f in findings]
    return "\n".join(lines)


def derived_text(result: FitResult) -> list[str]:
    """The derived quantities as report lines (empty when there are none)."""
    if not result.derived:
        return []
    shown = "robust" if result.errors_shown == "robust" else "std. error"
    lines = ["", "  derived quantities (what the data determine in physical terms):",
             f"  {'quantity':<18}  {'value':<12}  {shown:<11}  {'white':<11}  "
             f"{'determined':<10}  unit"]
    notes = []
    for d in result.derived.values():
        verdict = "yes" if d.determined else "no"
        if not d.well_property:
            verdict += " (*)"
            notes.append(f"  (*) {d.name}: not a property of the well: {d.note}")
        lines.append(f"  {d.name:<18}  {_fmt(d.value, 6):<12}  {_fmt(d.stderr, 4):<11}  "
                     f"{_fmt(d.stderr_white, 4):<11}  {verdict:<10}  {d.unit}")
    return lines + notes


def format_report(result: FitResult, history: bool = False) -> str:
    """The text report of :meth:`FitResult.report`."""
    units = result.param_units()
    span = float(result.t[-1] - result.t[0]) if result.t.size else 0.0
    lines = [
        f"pumpid fit: {result.model_name} model, method {result.method}, "
        f"integrator {result.integrator}, {result.residual} residual",
        f"  data: {result.t.size} samples over {span:.6g} s; observed "
        f"output {result.observe}; initial state {result.initial_state}",
        f"  status: {result.status.key}"
        f"{'' if result.converged else ' (not an ordinary converged answer)'} -- "
        f"{result.reason}",
        f"  iterations: {result.iterations}, model simulations: {result.nfev}",
        "",
        "  parameter        value            unit",
    ]
    unc = result.uncertainty
    stderr = dict(unc.stderr) if unc else {}
    robust = result.errors_shown == "robust"
    white = result.stderr_white if robust else {}
    loose = set(result.determined.get("not_determined", []) or [])
    for name, value in result.params.items():
        se = stderr.get(name)
        se_white = white.get(name)
        white_txt = (f"; independent-noise +/- {_fmt(se_white, 3)}"
                     if se_white is not None and math.isfinite(se_white) else "")
        what = "robust " if robust else ""
        se_txt = f"  ({what}+/- {_fmt(se, 3)}{white_txt})" if se is not None else ""
        flag = "  (not determined)" if name in loose else ""
        lines.append(f"  {name:<15}  {_fmt(value, 10):<15}  {units.get(name, '')}{se_txt}"
                     f"{flag}")
    scale_state = "fitted" if "C" in result.free or "D" in result.free else "fixed"
    lines.append(f"  {'C (scale)':<15}  {_fmt(result.scale, 10):<15}  - ({scale_state})")
    if result.residual == "log" and result.scale > 0:
        lines.append(f"  {'D = ln C':<15}  {_fmt(math.log(result.scale), 10):<15}  -")
    if "offset" in result.free or result.offset != 0.0:
        off_state = "fitted" if "offset" in result.free else "fixed"
        lines.append(f"  {'offset':<15}  {_fmt(result.offset, 10):<15}  "
                     f"{result.units.position} ({off_state})")
    lines += ["", f"  fit quality: RMSE = {_fmt(result.rmse, 6)} {result.units.position}, "
              f"R^2 = {_fmt(result.r2, 8)}"]
    lines += derived_text(result)
    diag = diagnostics_text(result)
    if diag:
        lines += ["", diag]
    reduced = result.boundary.reduced if result.boundary else None
    if reduced:
        lines.append("")
        lines.append(f"  reduced model ({reduced.model}, the limit the data want):")
        for name, value in reduced.params.items():
            lines.append(f"  {name:<15}  {_fmt(value, 10):<15}  {reduced.units.get(name, '')}")
        lines.append(f"  {'C (scale)':<15}  {_fmt(reduced.scale, 10):<15}  -")
        lines.append(f"  fit quality: RMSE = {_fmt(reduced.rmse, 6)} {result.units.position}, "
                     f"R^2 = {_fmt(reduced.r2, 8)}")
    if result.warnings:
        lines += ["", "  warnings:"]
        lines += [f"  - {w}" for w in result.warnings]
    choice = result.application.get("model_choice")
    if choice:
        lines += ["", *("  " + ln for ln in model_choice_text(choice).splitlines())]
    if history:
        lines += ["", "  history:", result.history_table()]
    return "\n".join(lines)


# --------------------------------------------------------------------------- many cards
@dataclass(frozen=True, eq=False)
class FitBatch:
    """The fits of many cards: arrays with one entry per card, and each card's full result.

    Attributes
    ----------
    model_name : str
        The fitted model class.
    param_names : tuple of str
        Parameter names in canonical order.
    params : mapping of str -> ndarray
        Fitted parameters by name (NaN for failed cards).
    scale, offset, rmse, r2, cost : ndarray
        Per card.
    status : tuple of Status
        Per card (``invalid-input`` for a card that failed validation).
    iterations, nfev : ndarray
        Per card.
    """

    model_name: str
    param_names: tuple[str, ...]
    results: tuple[FitResult | None, ...]
    invalid: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.results)

    def __getitem__(self, i: int) -> FitResult:
        return self.result(i)

    def result(self, i: int) -> FitResult:
        """Card ``i``'s full result; ValueError for a card that failed validation."""
        res = self.results[i]
        if res is None:
            raise ValueError(f"card {i} is not valid: {self.invalid[i]}")
        return res

    def _column(self, get: Any, default: float = math.nan) -> Array:
        return np.array([get(r) if r is not None else default for r in self.results],
                        dtype=float)

    @functools.cached_property
    def params(self) -> Mapping[str, Array]:
        """Fitted parameters by name, one entry per card."""
        return MappingProxyType({n: self._column(lambda r, n=n: r.params.get(n, math.nan))
                                 for n in self.param_names})

    @property
    def theta(self) -> Array:
        """Fitted parameters (cards, p) in canonical order."""
        return np.column_stack([self.params[n] for n in self.param_names])

    @functools.cached_property
    def status(self) -> tuple[Status, ...]:
        """Each card's status."""
        return tuple(r.status if r is not None else Status.INVALID_INPUT
                     for r in self.results)

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Cards with status ``converged``."""
        return np.array([s is Status.CONVERGED for s in self.status])

    @property
    def scale(self) -> Array:
        """Output scale C per card."""
        return self._column(lambda r: r.scale)

    @property
    def offset(self) -> Array:
        """Position offset per card."""
        return self._column(lambda r: r.offset)

    @property
    def rmse(self) -> Array:
        """RMSE per card (position units)."""
        return self._column(lambda r: r.rmse)

    @property
    def r2(self) -> Array:
        """R^2 per card."""
        return self._column(lambda r: r.r2)

    @property
    def cost(self) -> Array:
        """0.5 * sum of squared residuals per card."""
        return self._column(lambda r: r.cost)

    @property
    def iterations(self) -> NDArray[np.int64]:
        """Accepted iterations per card."""
        return self._column(lambda r: r.iterations, 0).astype(np.int64)

    @property
    def nfev(self) -> NDArray[np.int64]:
        """Model evaluations per card."""
        return self._column(lambda r: r.nfev, 0).astype(np.int64)

    def to_records(self) -> list[dict[str, Any]]:
        """One flat dictionary per card (parameters as top-level keys)."""
        out = []
        for i, r in enumerate(self.results):
            row: dict[str, Any] = {"card": i, "model": self.model_name,
                                   "status": self.status[i].key}
            if r is None:
                row["reason"] = self.invalid[i]
                row.update(dict.fromkeys(self.param_names, math.nan))
            else:
                row.update(dict(r.params))
                row.update({"scale": r.scale, "offset": r.offset, "reason": r.reason,
                            "iterations": r.iterations, "nfev": r.nfev, "rmse": r.rmse,
                            "r2": r.r2, "cost": r.cost})
            out.append(row)
        return out

    def summary(self) -> str:
        """One line: cards per status and the median R^2."""
        counts = ", ".join(f"{s.key} {sum(1 for x in self.status if x is s)}" for s in Status
                           if any(x is s for x in self.status))
        r2 = self.r2
        med = float(np.nanmedian(r2)) if np.any(np.isfinite(r2)) else math.nan
        return f"{self.model_name}: {len(self)} cards ({counts}); median R^2 = {med:.6g}"


def model_choice_text(choice: Mapping[str, Any]) -> str:
    """A model choice's ranking (``application["model_choice"]``) as text."""
    crit = str(choice["criterion"]).upper()
    data = choice.get("n_eff_data", choice["n_eff"])
    data = choice["n_eff"] if data is None or not math.isfinite(data) else float(data)
    used = (f"n_eff = {data:.1f}" if abs(data - choice["n_eff"]) < 0.05 else
            f"n_eff = {data:.1f}, counted as {choice['n_eff']:.1f} by the criteria, their "
            f"smallest usable size")
    lines = [f"Model choice by {crit} on the effective sample size (n = {choice['n']}, "
             f"residual lag-1 autocorrelation {choice['rho']:.3f}, {used}); chosen: "
             f"{choice['chosen']}",
             f"  {'structure':<18}{'k':>3}{'R^2':>11}{'BIC':>12}{'AICc':>12}"
             f"{'delta':>9}{'weight':>8}  status"]
    for c in choice["candidates"]:
        lines.append(f"  {c['name']:<18}{c['k']:>3}{c['r2']:>11.6f}{c['bic']:>12.2f}"
                     f"{c['aicc']:>12.2f}{c['delta']:>9.2f}{c['weight']:>8.3f}  {c['status']}")
    for t in choice["nested_tests"]:
        lines.append(f"  likelihood ratio {t['big']} against {t['small']} ({t['limit']}): "
                     f"statistic {t['statistic']:.3g} on {t['dof']} dof, p = "
                     f"{t['p_value']:.3g}")
    return "\n".join(lines)
