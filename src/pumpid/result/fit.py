"""The result of one identification, :class:`FitResult`, and its text report."""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..models import Model
from .boundaries import BoundaryInfo
from .derived import Derived
from .parts import CardInfo, StartInfo, Status, Units, jsonable
from .text import error_table, fmt, fmt_error, model_choice_text, squared
from .uncertainty import Uncertainty

if TYPE_CHECKING:
    from ..engine.problem import Problem

__all__ = ["FitResult", "beyond_text", "derived_text", "diagnostics_text", "format_report",
           "fundamental_better"]

Array = NDArray[np.float64]


def fundamental_better(result: FitResult) -> bool:
    """Whether the stroke's fundamental alone fits the card better than the model (by more
    than rounding of the share): every output then says so instead of a share of 0 %."""
    return result.r2_beyond < -1e-3


def beyond_text(result: FitResult, short: bool = False) -> str:
    """What R^2 means beside the stroke's fundamental, for a fit quality line ("" off a
    periodic card); ``short`` in the few words of a card's one-line summary."""
    beyond = result.r2_beyond
    if not math.isfinite(beyond):
        return ""
    alone = fmt(result.r2_fundamental, 6)
    share = f"{100 * max(beyond, 0.0):.1f} %"
    if result.determined.get("signal_beyond_fundamental") is False:
        # Nothing beyond the fundamental above the noise level: "explains 0.0 % of the rest"
        # blamed the model for what no model can explain, and "the rest is noise" stood
        # beside "the residuals are not white noise" on field cards.
        return (f" (fundamental alone {alone}: the rest at the noise level)" if short else
                f" (the stroke's fundamental alone: {alone}; what it leaves is at the noise "
                "level)")
    if short:
        return (f" (fundamental alone {alone}: "
                + ("better than this fit)" if fundamental_better(result)
                   else f"explains {share} of the rest)"))
    if fundamental_better(result):
        return f" (the stroke's fundamental alone: {alone}, better than this fit)"
    return (f" (the stroke's fundamental alone: {alone}; the model explains {share} of what "
            "it leaves)")


def _frozen(a: Any) -> Any:
    if isinstance(a, np.ndarray):
        a = a.view()
        a.flags.writeable = False
    return a


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
    model_name, method, integrator, residual, observe : str
        The model's name, the solver, the simulation scheme, the residual (``linear`` or
        ``log``) and the observed output.
    initial_state : str or tuple of float
        The record's initial state (``rest``, ``equilibrium``, ``periodic`` or the values).
    units : Units
        The load and position units of the data.
    free : tuple of str
        The fitted values (parameters, ``C`` or ``D``, ``offset``), in the covariance's order.
    t, load, data, fitted : ndarray
        The record's time (s), input, measured output and the fitted output (read-only).
    jacobian : ndarray or None
        The residual's sensitivities at the answer, by the free values (read-only).
    determined : mapping
        What the data determine: ``parameters``, ``derived`` and ``boundary`` name lists.
    derived : mapping of str to Derived
        Derived quantities (natural frequency, damping ratio, static stiffness, ...) with
        their errors and whether they are a property of the well.
    gauge : str or None
        The gauge fixed for a scale symmetry, in words.
    r2_fundamental : float
        R^2 of the stroke's fundamental alone on a periodic card (NaN elsewhere).
    application : mapping
        Application-specific facts (the joint fit's, the flow record's), read-only.
    problem, options : Problem or None, mapping
        What the fit solved and with which options, for refits (profiles, predictions).

    Notes
    -----
    Computed views are properties (``stderr``, ``ci95``, ``stderr_white``, ``ci95_white``,
    ``stderr_hac``, ``ci95_hac``, ``correlation``, ``covariance``, ``whiteness``,
    ``residuals``, ``r2_beyond``, ``scale_name``; ``extra``, everything beyond the core
    fields as the JSON has it, read-only); the dicts are fresh copies, so changing one
    changes nothing in the result. Those that take the data's units into words
    are methods (``param_units()``, ``scale_unit()``, ``free_values()``), as are the
    outputs (``to_dict()``, ``to_json()``, ``to_row()``, ``report()``).
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
    #: R^2 of the stroke's fundamental alone (the position's mean and first harmonic) on a
    #: periodic card; NaN where the record is not one uniformly sampled period.
    r2_fundamental: float = math.nan
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
    def r2_beyond(self) -> float:
        """The share of what the stroke's fundamental leaves of the position that the model
        explains: ``1 - SSR / SSR_fundamental`` (NaN off a periodic card). Near 0, the fit
        reproduces the imposed motion's fundamental alone, which any load gives."""
        left = 1.0 - self.r2_fundamental
        if not (math.isfinite(left) and left > 0.0 and math.isfinite(self.r2)):
            return math.nan
        return 1.0 - (1.0 - self.r2) / left

    @property
    def residuals(self) -> Array:
        """Fitted minus measured displacement (position units)."""
        return self.fitted - self.data

    @property
    def stderr(self) -> dict[str, float]:
        """Standard error of every fitted value (empty when not computed): the error that
        holds for these residuals, robust to their serial correlation where their lag-1
        autocorrelation exceeds what independent noise leaves in a fit's residuals by a
        one-sided 5 % test, or where the card is too short for that test to tell
        (:attr:`errors_shown`; :attr:`stderr_white` assumes white noise)."""
        return dict(self.uncertainty.stderr) if self.uncertainty else {}

    @property
    def ci95(self) -> dict[str, Any]:
        """95 % confidence interval (low, high) of every fitted value."""
        return dict(self.uncertainty.ci95) if self.uncertainty else {}

    @property
    def errors_shown(self) -> str:
        """Which errors :attr:`stderr` and :attr:`ci95` are: ``"robust"`` (the residuals
        are serially correlated, or too few to test: the autocorrelation-robust ones) or
        ``"white"``."""
        return str(getattr(self.uncertainty, "shown", "white"))

    @property
    def serial_test(self) -> dict[str, Any]:
        """The residuals' serial test behind :attr:`errors_shown` (its lag-1
        autocorrelation, null mean and sd, ``found``: it finds them correlated, ``weak``:
        too few samples for it to tell), or {} where the large-sample test decided."""
        hac = self.uncertainty.hac if self.uncertainty is not None else None
        return dict((hac or {}).get("serial_test") or {})

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

    def scale_unit(self) -> str:
        """Unit of the output scale C in the data's units (``-`` where it is a number)."""
        if not isinstance(self.model, Model):
            return "-"
        unit = self.model.scale_unit_for(self.units.load, self.units.position)
        return "-" if unit == "1" else unit

    def cost_unit(self, mark: str = "^2") -> str:
        """Unit of the cost (half the sum of squared residuals): the position's squared for
        the linear residual, ``-`` for the log one; ``mark`` writes the square."""
        return squared(self.units.position, mark) if self.residual == "linear" else "-"

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
        """One flat row of the results table (:mod:`pumpid.result.table` owns its columns:
        the card's identity, the fit, ``p_NAME`` with its errors, ``scale``, ``offset``,
        ``d_NAME`` with its errors, whether determined and its unit)."""
        from .table import fit_row

        return fit_row(self)

    def with_parts(self, **changes: Any) -> FitResult:
        """A copy with some parts replaced (e.g. ``card=CardInfo(...)``)."""
        return replace(self, **changes)

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
            "rmse": self.rmse, "r2": self.r2, "r2_fundamental": self.r2_fundamental,
            "r2_beyond_fundamental": self.r2_beyond, "n_samples": int(self.t.size),
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
        # Every column with its unit (a flow fit's --history printed bare numbers).
        units = {**self.param_units(), "C": self.scale_unit(), "D": "-", "epsilon": "-",
                 "offset": self.units.position, "iteration": "",
                 "cost": self.cost_unit()}
        rows = [[str(k) for k in keys], [f"[{units[k]}]" if units.get(k) else "" for k in keys]]
        for row in self.history:
            rows.append([str(int(row[k])) if k == "iteration" else fmt(row.get(k), 12)
                         for k in keys])
        widths = [max(len(r[i]) for r in rows) for i in range(len(keys))]
        return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True))
                         for r in rows)

    def report(self, history: bool = False) -> str:
        """A readable report: parameters with units, fit quality, convergence, warnings."""
        return format_report(self, history=history)

    def __str__(self) -> str:
        return self.report()


def _why_robust(result: FitResult) -> str:
    """Why the robust errors are shown: the whiteness warning where it was given, else the
    eager 5 % test's figures (the warning asks for 99.5 %, so it can be absent)."""
    if not (result.whiteness or {}).get("white", True):
        return "see the warning below"
    test = result.serial_test
    if not test:
        lag1 = (result.whiteness or {}).get("lag1_autocorrelation", math.nan)
        return (f"the residuals' lag-1 autocorrelation {lag1:.2f} fails a one-sided 5 % "
                "test of independence")
    said = (f"the residuals' lag-1 autocorrelation {test['lag1']:.2f} is {test['z']:.1f} "
            "standard deviations above its value for independent noise")
    if test.get("found", True) or not test.get("weak"):
        return said + ": a one-sided 5 % test"
    # A short card: the test could not have found the correlation that matters.
    return (said + f", a one-sided 5 % test passes it, but {result.t.size} samples are "
            "too few for that test to tell: residuals of noise correlated "
            f"{test['alternative_rho']:g} from one sample to the next would stand only "
            f"{test['power_z']:.1f} standard deviations above it on average")


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
                         f"spread; {_why_robust(result)}):")
            lines += error_table(result.free, values, units, unc.stderr, unc.ci95)
            lines.append("  assuming independent noise ("
                         + ("too narrow for these residuals"
                            if result.serial_test.get("found", True)
                            else "not testable on so few samples")
                         + ": stderr_white, ci95_white):")
            lines += error_table(result.free, values, units, result.stderr_white,
                                  result.ci95_white)
        else:
            lines += error_table(result.free, values, units, unc.stderr, unc.ci95)
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
        lines.append(f"  {d.name:<18}  {fmt(d.value, 6):<12}  {fmt_error(d.stderr):<11}  "
                     f"{fmt_error(d.stderr_white):<11}  {verdict:<10}  {d.unit}")
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
    limited = set(result.determined.get("boundary", []) or [])

    def errors_and_flag(name: str) -> str:
        # The same marks as the short output and the HTML: an offset the data do not fix
        # read "(fitted)" here alone.
        se = stderr.get(name)
        se_white = white.get(name)
        white_txt = (f"; independent-noise +/- {fmt_error(se_white, 3)}"
                     if se_white is not None and math.isfinite(se_white) else "")
        what = "robust " if robust else ""
        se_txt = f"  ({what}+/- {fmt_error(se, 3)}{white_txt})" if se is not None else ""
        flag = ("  (fixed)" if name not in result.free else "  (at a limit)" if name in limited
                else "  (not determined)" if name in loose else "")
        return se_txt + flag

    for name, value in result.params.items():
        lines.append(f"  {name:<15}  {fmt(value, 10):<15}  {units.get(name, '')}"
                     f"{errors_and_flag(name)}")
    scale_state = "fitted" if "C" in result.free or "D" in result.free else "fixed"
    if result.problem is not None or scale_state == "fitted":
        # A lumped model's output scale; a model with its own simulator has none.
        lines.append(f"  {'C (scale)':<15}  {fmt(result.scale, 10):<15}  "
                     f"{result.scale_unit()} ({scale_state})")
    if result.residual == "log" and result.scale > 0:
        lines.append(f"  {'D = ln C':<15}  {fmt(math.log(result.scale), 10):<15}  -")
    if "offset" in result.free or result.offset != 0.0:
        lines.append(f"  {'offset':<15}  {fmt(result.offset, 10):<15}  "
                     f"{result.units.position}{errors_and_flag('offset')}")
    lines += ["", f"  fit quality: RMSE = {fmt(result.rmse, 6)} {result.units.position}, "
              f"R^2 = {fmt(result.r2, 8)}{beyond_text(result)}"]
    lines += derived_text(result)
    diag = diagnostics_text(result)
    if diag:
        lines += ["", diag]
    reduced = result.boundary.reduced if result.boundary else None
    if reduced:
        lines.append("")
        named = reduced.limit or "the limit the data want"
        lines.append(f"  reduced model ({reduced.model}, {named}):")
        for name, value in reduced.params.items():
            lines.append(f"  {name:<15}  {fmt(value, 10):<15}  {reduced.units.get(name, '')}")
        lines.append(f"  {'C (scale)':<15}  {fmt(reduced.scale, 10):<15}  "
                     f"{reduced.units.get('C', '-')}")
        lines.append(f"  fit quality: RMSE = {fmt(reduced.rmse, 6)} {result.units.position}, "
                     f"R^2 = {fmt(reduced.r2, 8)}")
    if result.warnings:
        lines += ["", "  warnings:"]
        lines += [f"  - {w}" for w in result.warnings]
    choice = result.application.get("model_choice")
    if choice:
        lines += ["", *("  " + ln for ln in model_choice_text(choice).splitlines())]
    if history:
        lines += ["", "  history:", result.history_table()]
    return "\n".join(lines)
