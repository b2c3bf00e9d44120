"""The one result type returned by every fit."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .models import Model

__all__ = ["FitResult", "Units"]


@dataclass(frozen=True)
class Units:
    """Units of the data a fit was made on (time is always seconds)."""

    load: str = "N"
    position: str = "m"
    time: str = "s"

    def to_dict(self) -> dict[str, str]:
        """As a plain dictionary."""
        return {"load": self.load, "position": self.position, "time": self.time}


def _fmt(value: float | None, digits: int = 6) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return f"{value:.{digits}g}"


def _jsonable(value: Any) -> Any:
    """Turn numpy scalars/arrays and non-finite floats into JSON-safe values."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@dataclass
class FitResult:
    """Outcome of one identification.

    Attributes
    ----------
    model : Model or None
        The fitted model (None when the fit failed before producing finite parameters).
    params : dict
        Fitted parameter values by name (on the stated gauge when one was fixed).
    scale : float
        The output scale factor C (1 when fixed at its default).
    offset : float
        The fitted (or fixed) additive position offset, in position units.
    converged : bool
        True when the solver met its convergence test at a finite, physical point.
    reason : str
        Why the solver stopped, in words.
    iterations : int
        Accepted iterations.
    nfev : int
        Model simulations used (the paper's method counts every finite-difference run).
    history : list of dict
        One row per iteration: iteration number, parameters, scale, cost and step size.
    rmse, r2 : float
        Root-mean-square error (position units) and coefficient of determination of the
        fitted displacement against the data.
    warnings : list of str
        Plain-language caveats (gauge fixed, parameter at a bound, ...).
    """

    model: Model | None
    params: dict[str, float]
    scale: float
    offset: float
    converged: bool
    reason: str
    iterations: int
    nfev: int
    history: list[dict[str, float]]
    rmse: float
    r2: float
    warnings: list[str]
    method: str
    integrator: str
    residual: str
    observe: str
    initial_state: Any
    units: Units
    free: tuple[str, ...]
    cost: float
    t: NDArray[np.float64] = field(repr=False)
    load: NDArray[np.float64] = field(repr=False)
    data: NDArray[np.float64] = field(repr=False)
    fitted: NDArray[np.float64] = field(repr=False)
    jacobian: NDArray[np.float64] | None = field(default=None, repr=False)
    extra: dict[str, Any] = field(default_factory=dict, repr=False)
    #: "converged", "boundary" (a parameter ran to 0 or infinity) or "failed".
    status: str = "converged"
    #: What a refit needs (the problem and the fit options), for profiles; not serialised.
    context: dict[str, Any] = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------------ derived
    @property
    def model_name(self) -> str:
        """Class name of the fitted model."""
        return self.extra.get("model_name", type(self.model).__name__ if self.model else "?")

    @property
    def residuals(self) -> NDArray[np.float64]:
        """Fitted minus measured displacement (position units)."""
        return self.fitted - self.data

    @property
    def stderr(self) -> dict[str, float]:
        """Standard error of every fitted value (empty when not computed)."""
        return dict(self.extra.get("stderr", {}))

    @property
    def ci95(self) -> dict[str, list[float]]:
        """95 % confidence interval [low, high] of every fitted value."""
        return dict(self.extra.get("ci95", {}))

    @property
    def stderr_hac(self) -> dict[str, float]:
        """Standard errors robust to serially correlated residuals (HAC).

        Empty when the diagnostics have not run; NaN entries when the fit has no finite
        solution with a Jacobian to compute them from.
        """
        return dict(self.extra.get("stderr_hac", {}))

    @property
    def ci95_hac(self) -> dict[str, list[float]]:
        """95 % intervals from :attr:`stderr_hac` (same form as :attr:`ci95`)."""
        return dict(self.extra.get("ci95_hac", {}))

    @property
    def correlation(self) -> dict[str, Any]:
        """Correlation matrix of the fitted values: ``{"names": [...], "matrix": [[...]]}``."""
        return dict(self.extra.get("correlation", {}))

    @property
    def identifiability(self) -> list[str]:
        """Plain-language identifiability findings (empty when all parameters are determined)."""
        return list(self.extra.get("identifiability", []))

    @property
    def scale_name(self) -> str:
        """``C`` for the linear residual, ``D = ln C`` for the log residual."""
        return "D" if self.residual == "log" else "C"

    def param_units(self) -> dict[str, str]:
        """Unit of every parameter in the data's units."""
        if self.model is None:
            return {}
        return {
            p.name: p.unit_for(self.units.load, self.units.position)
            for p in self.model.param_info()
        }

    def profile(self, name: str, *, n_points: int = 21, span: float | None = None,
                level: float = 0.95) -> Any:
        """Profile likelihood of one fitted value (refits with it fixed on a grid).

        Returns a :class:`pumpid.profile.Profile` with the interval (one-sided when the
        parameter is at a boundary) and ``plot()``.
        """
        from .profile import profile

        return profile(self, name, n_points=n_points, span=span, level=level)

    # ------------------------------------------------------------------ output
    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary (no arrays of samples)."""
        out: dict[str, Any] = {
            "model": self.model_name,
            "method": self.method,
            "integrator": self.integrator,
            "residual": self.residual,
            "observe": self.observe,
            "initial_state": self.initial_state,
            "params": dict(self.params),
            "units": {**self.units.to_dict(), "params": self.param_units()},
            "scale": self.scale,
            "offset": self.offset,
            "free": list(self.free),
            "converged": self.converged,
            "status": self.status,
            "reason": self.reason,
            "iterations": self.iterations,
            "nfev": self.nfev,
            "cost": self.cost,
            "rmse": self.rmse,
            "r2": self.r2,
            "n_samples": int(self.t.size),
            "warnings": list(self.warnings),
        }
        if self.residual == "log":
            out["D"] = math.log(self.scale) if self.scale > 0 else None
        for key, value in self.extra.items():
            if key != "model_name":
                out[key] = value
        return _jsonable(out)

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
            rows.append([
                str(int(row[k])) if k == "iteration" else _fmt(row.get(k), 12) for k in keys
            ])
        widths = [max(len(r[i]) for r in rows) for i in range(len(keys))]
        return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True))
                         for r in rows)

    def report(self, history: bool = False) -> str:
        """A readable report: parameters with units, fit quality, convergence, warnings."""
        units = self.param_units()
        lines = [
            f"pumpid fit: {self.model_name} model, method {self.method}, "
            f"integrator {self.integrator}, {self.residual} residual",
            f"  data: {self.t.size} samples over {self.t[-1] - self.t[0]:.6g} s; observed "
            f"output {self.observe}; initial state {self.initial_state}",
            f"  status: {self.status}"
            f"{'' if self.converged else ' (not an ordinary converged answer)'} -- {self.reason}",
            f"  iterations: {self.iterations}, model simulations: {self.nfev}",
            "",
            "  parameter        value            unit",
        ]
        stderr = self.extra.get("stderr", {})
        # Residuals that fail the whiteness check make the ordinary +/- too small: the
        # serial-correlation-robust one stands beside it.
        check = (self.extra.get("uncertainty") or {}).get("whiteness")
        robust = self.extra.get("stderr_hac", {}) if check and not check.get("white") else {}
        for name, value in self.params.items():
            se = stderr.get(name)
            se_hac = robust.get(name)
            hac_txt = (f"; robust +/- {_fmt(se_hac, 3)}"
                       if se_hac is not None and math.isfinite(se_hac) else "")
            se_txt = f"  (+/- {_fmt(se, 3)}{hac_txt})" if se is not None else ""
            lines.append(f"  {name:<15}  {_fmt(value, 10):<15}  {units.get(name, '')}{se_txt}")
        scale_state = "fitted" if "C" in self.free or "D" in self.free else "fixed"
        lines.append(f"  {'C (scale)':<15}  {_fmt(self.scale, 10):<15}  - ({scale_state})")
        if self.residual == "log" and self.scale > 0:
            lines.append(f"  {'D = ln C':<15}  {_fmt(math.log(self.scale), 10):<15}  -")
        if "offset" in self.free or self.offset != 0.0:
            off_state = "fitted" if "offset" in self.free else "fixed"
            lines.append(
                f"  {'offset':<15}  {_fmt(self.offset, 10):<15}  {self.units.position} "
                f"({off_state})"
            )
        lines += [
            "",
            f"  fit quality: RMSE = {_fmt(self.rmse, 6)} {self.units.position}, "
            f"R^2 = {_fmt(self.r2, 8)}",
        ]
        from .diagnostics import diagnostics_text

        diag = diagnostics_text(self)
        if diag:
            lines += ["", diag]
        reduced = self.extra.get("reduced")
        if reduced:
            lines.append("")
            lines.append(f"  reduced model ({reduced['model']}, the limit the data want):")
            for name, value in reduced["params"].items():
                unit = reduced.get("units", {}).get(name, "")
                lines.append(f"  {name:<15}  {_fmt(value, 10):<15}  {unit}")
            lines.append(f"  {'C (scale)':<15}  {_fmt(reduced['scale'], 10):<15}  -")
            lines.append(
                f"  fit quality: RMSE = {_fmt(reduced['rmse'], 6)} {self.units.position}, "
                f"R^2 = {_fmt(reduced['r2'], 8)}"
            )
        if self.warnings:
            lines.append("")
            lines.append("  warnings:")
            lines += [f"  - {w}" for w in self.warnings]
        if history:
            lines += ["", "  history:", self.history_table()]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.report()
