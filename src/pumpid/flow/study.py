"""The step study: time constants against the size of a pressure-drop step.

For a power-law fluid the start-up is self-similar: a larger pressure step responds *slower*
for n < 1 (time constant ~ dp^((1-n)/n)). A linear first-order surrogate fitted per step needs
a different time constant per step; :func:`step_response_study` shows it, and how the
power-law and shear-thinning surrogates fare with one parameter set for all steps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..result import FitResult
from .fit import fit_flow, fit_flow_records, simulate_flow_record, simulate_surrogate
from .pipeflow import Pipe, PipeNumerics, PowerLawFluid, power_law_time_scale
from .records import FlowRecord

__all__ = ["StepStudy", "step_response_study"]

FloatArray = NDArray[np.float64]


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
        return np.array([p["r2"] for p in self.joint[key].application["records"]])

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
                f"{res.application['flow']['dp_ref']:g} Pa): tau = {p['tau']:.6g} s, gain = "
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
                          "rmse": r.rmse, "dp_ref": r.application["flow"]["dp_ref"],
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
        (:func:`pumpid.flow.pipeflow.power_law_time_scale`), so the records are exact rescalings
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
            t, a, fluid=fluid, pipe=pipe, numerics=PipeNumerics(n_radial=n_radial),
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


