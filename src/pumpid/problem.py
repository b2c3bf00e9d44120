"""The identification problem: data, model structure and options -> residuals.

A :class:`Problem` holds everything a solver needs and nothing of how it solves: the model
class, the validated time grid, load and measured displacement, and the choices of observed
output, initial state, integrator, residual form, scale factor and position offset. It maps a
vector of free values to residuals and their exact Jacobian (for the default method) or to
batches of model outputs (for the paper's finite-difference method).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .models import Model
from .simulate import (
    Grid,
    InitialState,
    Integrator,
    _initial_state_vector,
    _spectral_applies,
    check_signal,
    make_grid,
    observed,
    observed_blocks,
)

__all__ = ["MIN_SAMPLES", "SPECTRAL_RANGE", "Problem", "build_problem"]

MIN_SAMPLES = 10
Residual = Literal["linear", "log"]
#: Parameters within this log-distance (a factor 1000) of their natural scales are simulated
#: in the frequency domain; beyond it (the far end of the search window, boundary probes),
#: by the state scan, which keeps full precision there (see pumpid.simulate.observed).
SPECTRAL_RANGE = math.log(1e3)


@dataclass(frozen=True)
class Problem:
    """A fully specified identification problem (see :func:`build_problem`)."""

    model_cls: type[Model]
    grid: Grid
    load: NDArray[np.float64]
    data: NDArray[np.float64]
    observe: str
    initial_state: InitialState
    integrator: Integrator
    residual: Residual
    period: float | None
    #: Fixed scale C (for the log residual, C = exp(D)); None when fitted.
    scale_fixed: float | None
    #: Fixed additive offset; None when fitted.
    offset_fixed: float | None
    #: True when C was requested free but fixed to 1 because of the scale symmetry.
    gauge_fixed: bool
    #: Model parameters held at given values: (index, value) pairs.
    fixed: tuple[tuple[int, float], ...] = ()

    # ------------------------------------------------------------------ layout
    @property
    def n_params(self) -> int:
        """Number of model parameters."""
        return len(self.model_cls.param_names())

    @functools.cached_property
    def free_idx(self) -> NDArray[np.intp]:
        """Indices of the model parameters that are fitted (not fixed)."""
        held = {i for i, _ in self.fixed}
        idx = np.array([i for i in range(self.n_params) if i not in held], dtype=np.intp)
        idx.flags.writeable = False  # cached: shared by every caller
        return idx

    @property
    def n_free(self) -> int:
        """Number of fitted model parameters."""
        return int(self.free_idx.size)

    def full_theta(self, free: ArrayLike) -> NDArray[np.float64]:
        """All model parameters from the fitted ones (fixed ones filled in)."""
        free_arr = np.asarray(free, dtype=float)
        theta = np.empty((*free_arr.shape[:-1], self.n_params))
        theta[..., self.free_idx] = free_arr
        for i, value in self.fixed:
            theta[..., i] = value
        return theta

    @property
    def free_names(self) -> tuple[str, ...]:
        """Names of the free values, in solver order."""
        all_names = self.model_cls.param_names()
        names = [all_names[i] for i in self.free_idx]
        if self.scale_fixed is None:
            names.append("D" if self.residual == "log" else "C")
        if self.offset_fixed is None:
            names.append("offset")
        return tuple(names)

    @property
    def out_index(self) -> int:
        """Index of the observed state."""
        return self.model_cls.output_index(self.observe)

    def reference_scales(self) -> NDArray[np.float64]:
        """Natural size of each parameter from the data, by its unit (read-only array).

        Stiffness ~ C * (load range) / (displacement range), time ~ period / (2 pi), masses
        and dampers accordingly. Used to keep the optimizer inside a wide but finite window,
        so that a parameter the data drive to 0 or infinity stops at a recognisable edge
        instead of at values where the matrix exponential loses precision.
        """
        return self._reference_scales

    @functools.cached_property
    def _reference_scales(self) -> NDArray[np.float64]:
        scale = self.scale_fixed if self.scale_fixed is not None else 1.0
        load_span = float(np.ptp(self.load)) or float(np.max(np.abs(self.load))) or 1.0
        out_span = float(np.ptp(self.data)) / scale
        span = float(self.grid.t[-1] - self.grid.t[0])
        if self.period is not None:
            span = self.period
        base = {"{load}": load_span, "{position}": out_span, "s": span / (2 * math.pi)}
        ref = np.array([_unit_size(info.unit, base) for info in self.model_cls.param_info()])
        ref.flags.writeable = False  # cached: shared by every caller
        return ref

    def split(self, x: ArrayLike) -> tuple[NDArray[np.float64], float, float]:
        """Free vector (physical values) -> (theta, C, offset)."""
        xv = np.asarray(x, dtype=float)
        p = self.n_free
        theta = self.full_theta(xv[:p])
        i = p
        if self.scale_fixed is None:
            s = float(xv[i])
            scale = math.exp(s) if self.residual == "log" else s
            i += 1
        else:
            scale = self.scale_fixed
        offset = float(xv[i]) if self.offset_fixed is None else self.offset_fixed
        return theta, scale, offset

    def join(self, theta: ArrayLike, scale: float, offset: float) -> NDArray[np.float64]:
        """(theta, C, offset) -> free vector (physical values; D = ln C for log residual)."""
        parts = list(np.asarray(theta, dtype=float)[self.free_idx])
        if self.scale_fixed is None:
            parts.append(math.log(scale) if self.residual == "log" else scale)
        if self.offset_fixed is None:
            parts.append(offset)
        return np.array(parts, dtype=float)

    # ------------------------------------------------------------------ evaluation
    def far_from_scale(self, theta: ArrayLike) -> NDArray[np.bool_]:
        """Parameter sets (..., p) with a parameter beyond ``SPECTRAL_RANGE`` of its natural
        scale: they are simulated by the state scan, whose accuracy does not depend on it."""
        th = np.asarray(theta, dtype=float)
        # log(theta / ref) within +-SPECTRAL_RANGE, without logarithms: theta between
        # ref / 1000 and ref * 1000 (a non-positive or NaN entry is "far").
        low, high = self._spectral_band
        return ~np.all((th >= low) & (th <= high), axis=-1)

    @functools.cached_property
    def _spectral_band(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        ref = self.reference_scales()
        factor = math.exp(SPECTRAL_RANGE)
        return ref / factor, ref * factor

    def outputs(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Unscaled model output for one (p,) or a batch (K, p) of parameter vectors."""
        th = np.asarray(theta, dtype=float)
        far = self.far_from_scale(th)

        def run(part: NDArray[np.float64], scan: bool) -> NDArray[np.float64]:
            return observed(self.model_cls, part, self.grid, self.load, [self.out_index],
                            initial_state=self.initial_state, integrator=self.integrator,
                            sensitivities=False, period=self.period, scan=scan)[..., 0]

        if th.ndim == 1 or not far.any() or far.all():
            return run(th, bool(np.any(far)))
        y = np.empty((*th.shape[:-1], self.grid.n))
        y[~far] = run(th[~far], False)
        y[far] = run(th[far], True)
        return y

    def output_and_sensitivities(
        self, theta: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Unscaled output y (N,) and exact dy/dtheta (N, p_free) for the fitted parameters."""
        if self._spectral and not self.far_from_scale(theta):
            # The fitters' hot path: straight to the frequency-domain engine (dy is a
            # transposed view of its contiguous (p_free, N) rows).
            out = observed_blocks(self.model_cls, np.asarray(theta, dtype=float), self.grid,
                                  self.load, np.array([self.out_index]), self.free_idx,
                                  initial_state=self.initial_state,
                                  integrator=self.integrator)
            return out[0, 0], out[1:, 0].T
        n = self.model_cls.n_states()
        k = self.out_index
        rows = [k] + [n * (i + 1) + k for i in self.free_idx]
        y = observed(self.model_cls, theta, self.grid, self.load, rows,
                     initial_state=self.initial_state, integrator=self.integrator,
                     sensitivities=True, period=self.period, scan=True)
        return y[:, 0], y[:, 1:]

    @functools.cached_property
    def _spectral(self) -> bool:
        return _spectral_applies(self.grid, self.model_cls, self.initial_state, self.period)

    def predict(self, theta: ArrayLike, scale: float, offset: float) -> NDArray[np.float64]:
        """Fitted displacement C y + offset (position units)."""
        return scale * self.outputs(theta) + offset

    def residual_vector(
        self, y: NDArray[np.float64], scale: float, offset: float
    ) -> NDArray[np.float64]:
        """Residual for a given unscaled output: linear C y + b - data, or ln C + ln y - ln data."""
        if self.residual == "log":
            with np.errstate(divide="ignore", invalid="ignore"):
                return math.log(scale) + np.log(y) - np.log(self.data)
        return scale * y + offset - self.data


def _unit_size(unit: str, base: dict[str, float]) -> float:
    """Size of a unit template such as ``{load}*s^2/{position}`` from base sizes.

    Unknown factors (dimensionless numbers, other units) count as 1.
    """
    size = 1.0
    for k, side in enumerate(unit.split("/", 1)):
        sign = 1 if k == 0 else -1
        for token in side.replace("(", "").replace(")", "").split("*"):
            name, _, power = token.strip().partition("^")
            if name in base:
                try:
                    exp = float(power) if power else 1.0
                except ValueError:
                    exp = 1.0
                size *= base[name] ** (sign * exp)
    return size


def _is_zero_state(initial_state: InitialState, model_cls: type[Model]) -> bool:
    """True when the initial state scales with the parameters like the response does."""
    x0 = _initial_state_vector(model_cls, initial_state)
    return x0 is None or not np.any(x0)


def build_problem(
    model_cls: type[Model],
    t: ArrayLike,
    load: ArrayLike,
    displacement: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
    residual: Residual = "linear",
    scale: float | str = 1.0,
    offset: bool | float = False,
    period: float | None = None,
    fixed: dict[str, float] | None = None,
    warnings: list[str] | None = None,
) -> Problem:
    """Validate the data and options and build a :class:`Problem`.

    Raises
    ------
    ValueError
        With a message naming the problem: non-finite values, mismatched lengths,
        non-increasing time, too few samples, a constant load (from a load-driven initial
        state), non-positive data with the log residual, unknown options.
    """
    grid = make_grid(t, min_samples=1)
    if grid.n < MIN_SAMPLES:
        raise ValueError(f"t: {grid.n} samples; a fit needs at least {MIN_SAMPLES}")
    f = check_signal("load", load, grid.n)
    d = check_signal("displacement", displacement, grid.n)
    if integrator not in ("exact", "euler"):
        raise ValueError(f"integrator must be 'exact' or 'euler', got {integrator!r}")
    if residual not in ("linear", "log"):
        raise ValueError(f"residual must be 'linear' or 'log', got {residual!r}")
    obs = model_cls.default_output if observe is None else observe
    model_cls.output_index(obs)
    x0 = _initial_state_vector(model_cls, initial_state)

    spread = float(np.ptp(f))
    if x0 is None and spread <= 1e-12 * max(1.0, float(np.max(np.abs(f)))):
        raise ValueError(
            f"load: constant ({f[0]:g}) over the whole record; with initial_state="
            f"{initial_state!r} such a record carries no information on the dynamics. "
            "Give a varying load, or the initial state (numbers) to fit a free response"
        )
    if np.ptp(d) == 0.0:
        raise ValueError(f"displacement: constant ({d[0]:g}); nothing to fit")

    if residual == "log":
        if np.any(d <= 0):
            raise ValueError(
                "displacement: the log residual needs positive data; "
                f"{int(np.sum(d <= 0))} sample(s) are <= 0"
            )
        if offset is not False and offset != 0:
            raise ValueError("offset: not available with the log residual")

    if isinstance(scale, str):
        if scale != "free":
            raise ValueError(f"scale must be a positive number or 'free', got {scale!r}")
        scale_fixed: float | None = None
    else:
        scale_fixed = float(scale)
        if not math.isfinite(scale_fixed) or scale_fixed <= 0:
            raise ValueError(f"scale: must be positive and finite, got {scale!r}")

    names = model_cls.param_names()
    fixed_pairs: list[tuple[int, float]] = []
    for name, value in (fixed or {}).items():
        if name not in names:
            raise ValueError(f"fixed: {name!r} is not a parameter of {model_cls.__name__} {names}")
        v = float(value)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"fixed: {name} = {value!r} must be positive and finite")
        fixed_pairs.append((names.index(name), v))
    if len(fixed_pairs) == len(names):
        raise ValueError("fixed: every model parameter is fixed; nothing left to fit")

    gauge_fixed = False
    # A fixed model parameter already breaks the scale symmetry (it is a gauge itself).
    if not fixed_pairs and scale_fixed is None and model_cls.scale_symmetric and _is_zero_state(
        initial_state, model_cls
    ):
        # MODEL-NOTES section 2: (lambda * theta, lambda * C) gives the same C y(t) from a
        # load-driven state, so the five-parameter problem has a ridge. Fix the gauge C = 1.
        gauge_fixed = True
        scale_fixed = 1.0
        names = ", ".join(model_cls.param_names())
        if warnings is not None:
            warnings.append(
                f"scale symmetry: C and the overall scale of {names} are not separately "
                f"identifiable from initial_state={initial_state!r} (multiplying all of them "
                "by any lambda > 0 gives the same fitted curve); only the ratios "
                f"{names} / C are determined. Parameters are reported on the gauge C = 1."
            )

    if offset is True:
        offset_fixed: float | None = None
    elif offset is False:
        offset_fixed = 0.0
    else:
        offset_fixed = float(offset)
        if not math.isfinite(offset_fixed):
            raise ValueError("offset: must be finite")

    return Problem(
        model_cls=model_cls,
        grid=grid,
        load=f,
        data=d,
        observe=obs,
        initial_state=(
            initial_state if isinstance(initial_state, str) else tuple(
                np.asarray(x0, dtype=float).tolist()
            )
        ),
        integrator=integrator,
        residual=residual,
        period=period,
        scale_fixed=scale_fixed,
        offset_fixed=offset_fixed,
        gauge_fixed=gauge_fixed,
        fixed=tuple(sorted(fixed_pairs)),
    )


def initial_state_label(initial_state: InitialState | Sequence[float]) -> str | list[float]:
    """A JSON-friendly description of the initial state."""
    if isinstance(initial_state, str):
        return initial_state
    return [float(v) for v in np.asarray(initial_state, dtype=float).ravel()]
