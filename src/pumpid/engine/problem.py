"""The identification problem with a card axis: data, model structure and options.

A :class:`Problem` holds everything the engine needs and nothing of how it solves: the model
class, the observed output, the integrator, the residual form, the output scale and position
offset (fixed or fitted), held parameters, and the cards -- each with its own time vector,
load, measured displacement, initial state and period. A single fit is a problem with one
card; a field is a problem with thousands. The cards' samples are stored concatenated, so the
compiled kernel reaches any card by its bounds.

Cards that fail validation do not stop a problem with several cards: they are kept with
``valid[i] = False`` and the reason in words (the batch reports them as failed rows); a
problem built for a single fit raises :class:`ValueError` naming the problem instead.
"""

from __future__ import annotations

import datetime
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..models import Model
from . import kernel, spectrum

__all__ = [
    "MIN_SAMPLES",
    "WINDOW",
    "CardData",
    "InitialState",
    "Problem",
    "build_problem",
    "check_signal",
    "initial_state_label",
    "initial_state_vector",
    "make_time",
]

Array = NDArray[np.float64]
InitialState = str | Sequence[float] | Mapping[str, float] | NDArray[np.float64]
Integrator = Literal["exact", "euler"]
Residual = Literal["linear", "log"]

#: Fewest samples a fit accepts.
MIN_SAMPLES = 10
#: The search window of the log-parameters: each parameter's natural scale times or
#: divided by 1e6. A parameter that runs to the window's edge is a boundary (0 or infinity).
WINDOW = math.log(1e6)
#: Keeps exp() of the log-scale finite during wild trial steps.
LOG_MAX = 700.0
INITIAL_MODES = {"rest": kernel.REST, "equilibrium": kernel.EQUILIBRIUM,
                 "periodic": kernel.PERIODIC}
_UNIFORM_RTOL = 1e-9


def check_signal(name: str, values: ArrayLike, n: int | None = None) -> Array:
    """Return ``values`` as a finite 1-D float array or raise ValueError naming the problem."""
    if np.iscomplexobj(values):
        raise ValueError(f"{name}: complex values are not accepted (give real numbers)")
    if _holds_dates(values):  # float() would give epoch counts (ns), not seconds
        raise ValueError(
            f"{name}: dates, times or durations are not numbers; give seconds, e.g. "
            "(t - t[0]) / np.timedelta64(1, 's') or Series.dt.total_seconds()")
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: not an array of numbers ({exc})") from None
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        kind = "NaN" if np.isnan(arr[i]) else "inf"
        raise ValueError(
            f"{name}: {int(bad.sum())} non-finite value(s); first is {kind} at index {i}"
        )
    if n is not None and arr.size != n:
        raise ValueError(f"{name}: length {arr.size} does not match the time vector's length {n}")
    return arr


def _holds_dates(values: ArrayLike) -> bool:
    """True for datetime64/timedelta64 arrays and sequences of datetime-like objects."""
    dtype = getattr(values, "dtype", None)
    if isinstance(dtype, np.dtype):
        if dtype.kind in "mM":
            return True
        if dtype.kind != "O":
            return False
    elif dtype is not None:  # pandas extension dtypes (tz-aware datetimes, periods)
        return str(getattr(dtype, "kind", "")) in ("m", "M") or "date" in str(dtype).lower()
    try:
        probe = values if isinstance(values, np.ndarray) else list(values)  # type: ignore[arg-type]
    except TypeError:
        return False
    first = probe[0] if len(probe) else None
    return isinstance(first, datetime.date | datetime.timedelta | np.datetime64 | np.timedelta64)


def make_time(t: ArrayLike, min_samples: int = 2) -> tuple[Array, bool]:
    """Validate a time vector (finite, 1-D, strictly increasing); return it and uniformity."""
    tt = check_signal("t", t)
    if tt.size < min_samples:
        raise ValueError(f"t: {tt.size} samples; at least {min_samples} are needed")
    with np.errstate(over="ignore", invalid="ignore"):
        steps = np.diff(tt)
    if not np.all(np.isfinite(steps)):
        raise ValueError("t: the time steps overflow (times beyond the float range)")
    if (steps <= 0).any():
        i = int(np.flatnonzero(steps <= 0)[0])
        raise ValueError(f"t: time must be strictly increasing; t[{i + 1}] = "
                         f"{float(tt[i + 1])!r} s follows t[{i}] = {float(tt[i])!r} s")
    mean = (tt[-1] - tt[0]) / max(tt.size - 1, 1)
    # Times far from zero hold their steps to their float spacing only (3e-9 of a 0.02 s
    # step at 777600 s): judged against 1e-9 alone, such a card was simulated step by step.
    spacing = 4.0 * np.finfo(float).eps * max(abs(float(tt[0])), abs(float(tt[-1])))
    uniform = bool(np.all(np.abs(steps - mean) <= _UNIFORM_RTOL * mean + spacing))
    return tt, uniform


def initial_state_vector(model: type[Model], initial_state: InitialState) -> Array | None:
    """A given initial state as an array, or None for the named modes."""
    if isinstance(initial_state, str):
        if initial_state not in INITIAL_MODES:
            raise ValueError(
                f"initial_state: unknown mode {initial_state!r}; use one of "
                f"{tuple(INITIAL_MODES)} or give the state {model.states} as numbers"
            )
        return None
    n = model.n_states()
    if isinstance(initial_state, Mapping):
        unknown = set(initial_state) - set(model.states)
        if unknown:
            raise ValueError(
                f"initial_state: {sorted(unknown)} are not states of {model.__name__} "
                f"{model.states}"
            )
        x0 = np.zeros(n)
        for name, value in initial_state.items():
            x0[model.states.index(name)] = float(value)
    else:
        x0 = np.asarray(initial_state, dtype=float).ravel()
        if x0.size != n:
            raise ValueError(
                f"initial_state: {model.__name__} has {n} states {model.states}, "
                f"got {x0.size} values"
            )
    if not np.all(np.isfinite(x0)):
        raise ValueError("initial_state: values must be finite")
    return x0


def initial_state_label(initial_state: InitialState) -> str | list[float]:
    """A JSON-friendly description of the initial state."""
    if isinstance(initial_state, str):
        return initial_state
    if isinstance(initial_state, Mapping):
        return {str(k): float(v) for k, v in initial_state.items()}  # type: ignore[return-value]
    return [float(v) for v in np.asarray(initial_state, dtype=float).ravel()]


@dataclass(frozen=True)
class CardData:
    """One card's samples and its initial-state choice (before validation).

    Attributes
    ----------
    t : array_like
        Time, s, strictly increasing.
    load : array_like
        The input (the polished-rod load of a card).
    data : array_like
        The measured output, in the observed state's terms (a card's displacement).
    initial_state : {"rest", "equilibrium", "periodic"}, default "rest"
        How the record starts.
    period : float, optional
        The stroke period, s, for ``initial_state="periodic"`` (default: the record's span).
    """

    t: ArrayLike
    load: ArrayLike
    data: ArrayLike
    initial_state: InitialState = "rest"
    period: float | None = None


@dataclass(frozen=True)
class Problem:
    """A fully specified identification problem over one or many cards.

    Build it with :func:`build_problem`. Arrays are read-only; ``t``, ``load`` and ``data``
    hold every card's samples one after the other, card ``i`` in
    ``bounds[i]:bounds[i + 1]``.
    """

    model: type[Model]
    observe: str
    integrator: Integrator
    residual: Residual
    #: Fixed scale C (for the log residual, C = exp(D)); None when fitted.
    scale_fixed: float | None
    #: Fixed additive offset; None when fitted.
    offset_fixed: float | None
    #: True when C was requested free but fixed to 1 because of the scale symmetry.
    gauge_fixed: bool
    #: Model parameters held at given values: (index, value) pairs.
    fixed: tuple[tuple[int, float], ...]
    t: Array
    load: Array
    data: Array
    bounds: NDArray[np.int64]
    mode: NDArray[np.int64]
    x0: Array
    period: Array
    uniform: NDArray[np.bool_]
    #: Each card's initial state as the user gave it (for reports).
    initial_states: tuple[Any, ...]
    valid: NDArray[np.bool_]
    #: Why a card is not valid ("" for valid cards).
    invalid: tuple[str, ...]
    #: The constant taken off each card's load before it drives the model (0 for most
    #: cards; see :func:`load_shift`). The solver's offset coordinate is then the offset of
    #: that centred response; :meth:`true_offset` converts it back.
    load_shift: Array | None = None

    # ------------------------------------------------------------------ layout
    @property
    def n_cards(self) -> int:
        """Number of cards."""
        return int(self.mode.size)

    @property
    def n_params(self) -> int:
        """Number of model parameters."""
        return len(self.model.param_names())

    @functools.cached_property
    def free_idx(self) -> NDArray[np.int64]:
        """Indices of the fitted model parameters."""
        held = {i for i, _ in self.fixed}
        idx = np.array([i for i in range(self.n_params) if i not in held], dtype=np.int64)
        idx.flags.writeable = False
        return idx

    @property
    def n_free(self) -> int:
        """Number of fitted model parameters."""
        return int(self.free_idx.size)

    @property
    def q(self) -> int:
        """Number of solver coordinates (free parameters, C, offset)."""
        return self.n_free + (self.scale_fixed is None) + (self.offset_fixed is None)

    @property
    def free_names(self) -> tuple[str, ...]:
        """Names of the fitted values, in solver order."""
        names = [self.model.param_names()[i] for i in self.free_idx]
        if self.scale_fixed is None:
            names.append("D" if self.residual == "log" else "C")
        if self.offset_fixed is None:
            names.append("offset")
        return tuple(names)

    @property
    def out_index(self) -> int:
        """Index of the observed state."""
        return self.model.output_index(self.observe)

    def card(self, i: int) -> tuple[Array, Array, Array]:
        """Time, load and data of card ``i``."""
        a, b = int(self.bounds[i]), int(self.bounds[i + 1])
        return self.t[a:b], self.load[a:b], self.data[a:b]

    def n_samples(self, i: int) -> int:
        """Number of samples of card ``i``."""
        return int(self.bounds[i + 1] - self.bounds[i])

    def full_theta(self, free: ArrayLike) -> Array:
        """All model parameters (..., p) from the fitted ones (..., n_free)."""
        arr = np.asarray(free, dtype=float)
        theta = np.empty((*arr.shape[:-1], self.n_params))
        theta[..., self.free_idx] = arr
        for i, value in self.fixed:
            theta[..., i] = value
        return theta

    def harmonic(self, k: int) -> bool:
        """Whether the harmonic cost (:mod:`pumpid.engine.spectrum`) applies to card ``k``:
        one uniformly sampled period closed by one more step, a model of at most three
        states without an input map, the linear residual."""
        return (self.one_period(k) and self.model.input_map is None
                and self.residual != "log" and self.model.n_states() <= spectrum.MAX_STATES)

    def one_period(self, k: int) -> bool:
        """Whether card ``k`` is one uniformly sampled period closed by one more step
        (period ``N h``): its samples are then one period of a discrete Fourier series."""
        if not (self.valid[k] and self.mode[k] == kernel.PERIODIC and self.uniform[k]):
            return False
        t = self.card(k)[0]
        if t.size < 3:
            return False
        period = float(self.period[k])
        return abs(period - t.size * float(t[1] - t[0])) <= 1e-9 * period

    # ------------------------------------------------------------------ load shift
    @functools.cached_property
    def engine_load(self) -> Array:
        """The load that drives the model in the engine: each card's less its shift."""
        if self.load_shift is None or not np.any(self.load_shift):
            return self.load
        out = self.load - np.repeat(self.load_shift, np.diff(self.bounds))
        out.flags.writeable = False
        return out

    def shift_of(self, k: int) -> float:
        """The constant taken off card k's load (0 when none)."""
        return 0.0 if self.load_shift is None else float(self.load_shift[k])

    def offset_gap(self, k: int, theta: ArrayLike, scale: ArrayLike) -> Array:
        """C x static gain x shift: what the solver's offset exceeds the true offset by.

        For parameter rows ``theta`` (..., p) and scales C (...); 0 for a card without shift.
        """
        th = np.asarray(theta, dtype=float)
        shift = self.shift_of(k)
        if shift == 0.0:
            return np.zeros(th.shape[:-1])
        gain = self.model.static_gains(th, self.observe)
        return np.asarray(scale, dtype=float) * gain * shift

    # ------------------------------------------------------------------ kernel arrays
    @functools.cached_property
    def arrays(self) -> tuple[Any, Any, Any]:
        """(data, model, settings) tuples in the compiled drivers' layout."""
        period = np.where(np.isfinite(self.period), self.period, 0.0)
        data = (self.t, self.engine_load, self.data, self.bounds, self.mode, self.x0, period,
                self.uniform)
        integrator = kernel.EULER if self.integrator == "euler" else kernel.EXACT
        model = (self.model.code(), self.model.n_states(), self.model.input_code(),
                 self.out_index, integrator)
        lz_base = np.zeros(self.n_params)
        for i, value in self.fixed:
            lz_base[i] = math.log(value)
        settings = (
            np.asarray(self.free_idx, dtype=np.int64), lz_base, self.residual == "log",
            self.scale_fixed is None, 1.0 if self.scale_fixed is None else self.scale_fixed,
            self.offset_fixed is None, 0.0 if self.offset_fixed is None else self.offset_fixed,
        )
        return data, model, settings

    # ------------------------------------------------------------------ scales
    @functools.cached_property
    def reference(self) -> Array:
        """Natural size of each parameter per card (K, p), from the data, by its unit.

        Stiffness ~ C (load range) / (displacement range), time ~ period / (2 pi), masses
        and dampers accordingly. The solver keeps each log-parameter within ``WINDOW`` of
        it, so that a parameter the data drive to 0 or infinity stops at a recognisable edge
        instead of where the matrix exponential loses precision.
        """
        scale = self.scale_fixed if self.scale_fixed is not None else 1.0
        out = np.ones((self.n_cards, self.n_params))
        infos = self.model.param_info()
        for i in range(self.n_cards):
            if not self.valid[i]:
                continue
            t, f, d = self.card(i)
            load_span = float(np.ptp(f)) or float(np.max(np.abs(f))) or 1.0
            out_span = float(np.ptp(d)) / scale or 1.0
            span = float(t[-1] - t[0])
            if math.isfinite(self.period[i]):
                span = float(self.period[i])
            base = {"{load}": load_span, "{position}": out_span, "s": span / (2 * math.pi)}
            out[i] = [_unit_size(info.unit, base) for info in infos]
        out.flags.writeable = False
        return out

    def window(self, cards: NDArray[np.int64], z0: Array) -> tuple[Array, Array]:
        """Solver bounds (m, q) for items starting at z0 (m, q) on the given cards.

        Log-parameters within ``WINDOW`` of their natural scale (widened to contain the
        start by a factor e), ln C within +-LOG_MAX, the offset free.
        """
        m = z0.shape[0]
        p = self.n_free
        ref = np.log(self.reference[cards][:, self.free_idx])
        lo = np.full((m, self.q), -math.inf)
        hi = np.full((m, self.q), math.inf)
        lo[:, :p] = np.minimum(ref - WINDOW, z0[:, :p] - 1.0)
        hi[:, :p] = np.maximum(ref + WINDOW, z0[:, :p] + 1.0)
        if self.scale_fixed is None:
            lo[:, p] = -LOG_MAX
            hi[:, p] = LOG_MAX
        return lo, hi

    def with_model(self, model: type[Model], observe: str, scale: float | str) -> Problem:
        """The same cards with another model (a reduced model at a limit)."""
        cards = [CardData(*self.card(i), initial_state=self.initial_states[i],
                          period=None if not math.isfinite(self.period[i]) else
                          float(self.period[i])) for i in range(self.n_cards)]
        return build_problem(
            model, cards, observe=observe, integrator=self.integrator,
            residual=self.residual, scale=scale,
            offset=True if self.offset_fixed is None else self.offset_fixed, strict=False,
            invalid=self.invalid)


def _unit_size(unit: str, base: dict[str, float]) -> float:
    """Size of a unit template such as ``{load}*s^2/{position}`` from base sizes."""
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


#: Durations of a record the engine accepts (s). Far wider than any physical record; beyond
#: them the start's natural scales (powers of the stroke frequency) leave floating point.
TIME_SPAN = (1e-120, 1e120)


def load_shift(t: Array, f: Array, period: float) -> float:
    """The load's mean over one period of the periodic, piecewise-linear load.

    Why the engine takes it off: a periodic steady state's mean level is the static gain
    times the load's mean, and with a fitted position offset that level is absorbed by the
    offset. Fitted as given, a card whose model runs toward a vanishing static stiffness
    (Kelvin k1 -> 0) needs an offset growing like 1/k1 in step with it: a curved valley
    the solver crawls along for hundreds of evaluations. Driven by the load less its mean,
    the model's periodic response does not move with the static gain and the solver's
    offset stays put; the reported offset is converted back exactly (linearity).
    """
    closing = t[0] + period - t[-1]
    area = float(np.sum(np.diff(t) * (f[1:] + f[:-1]))) + closing * (f[-1] + f[0])
    return 0.5 * area / period


def _check_magnitudes(model: type[Model], t: Array, f: Array, d: Array) -> None:
    """Refuse data whose magnitudes put a parameter's natural size outside the float range
    (subnormal positions such as 1e-319, say): nothing could be computed from them."""
    base = {"{load}": float(np.ptp(f)) or float(np.max(np.abs(f))) or 1.0,
            "{position}": float(np.ptp(d)) or 1.0, "s": float(t[-1] - t[0]) / (2 * math.pi)}
    tiny = float(np.finfo(float).tiny)
    for info in model.param_info():
        try:
            size = _unit_size(info.unit, base)
        except (OverflowError, ZeroDivisionError):
            size = math.inf
        if not tiny <= size < math.inf:
            raise ValueError(
                f"displacement and load: their ranges ({base['{position}']:.3g} and "
                f"{base['{load}']:.3g}) put parameter {info.name}'s natural size outside "
                "the floating-point range; rescale the data (change its units)")


def _validate_card(
    model: type[Model], card: CardData, residual: str, offset: bool | float
) -> tuple[Array, Array, Array, int, Array, float, bool]:
    """One card's arrays, mode, given state, period and uniformity; ValueError naming the
    problem otherwise."""
    # The fit's own minimum for every short record, an empty one included (it was told
    # "at least 1 are needed").
    size = check_signal("t", card.t).size
    if size < MIN_SAMPLES:
        raise ValueError(f"t: {size} samples; a fit needs at least {MIN_SAMPLES}")
    t, uniform = make_time(card.t, min_samples=1)
    span = float(t[-1] - t[0])
    if not TIME_SPAN[0] <= span <= TIME_SPAN[1]:
        raise ValueError(f"t: the record lasts {span:.3g} s; a fit needs a duration between "
                         f"{TIME_SPAN[0]:g} and {TIME_SPAN[1]:g} s (is the time in seconds?)")
    f = check_signal("load", card.load, t.size)
    d = check_signal("displacement", card.data, t.size)
    x0 = initial_state_vector(model, card.initial_state)
    mode = kernel.GIVEN if x0 is not None else INITIAL_MODES[str(card.initial_state)]
    peak_f = float(np.max(np.abs(f)))
    spread = float(np.ptp(f))
    if x0 is None and not spread > 1e-12 * peak_f:
        what = "zero" if peak_f == 0 else f"constant ({f[0]:g})"
        raise ValueError(
            f"load: {what} over the whole record; with initial_state="
            f"{card.initial_state!r} such a record carries no information on the dynamics. "
            "Give a varying load, or the initial state (numbers) to fit a free response"
        )
    peak_d = float(np.max(np.abs(d)))
    if not np.ptp(d) > 1e-12 * peak_d:
        raise ValueError(f"displacement: constant ({d[0]:g}); nothing to fit")
    _check_magnitudes(model, t, f, d)
    with np.errstate(over="ignore"):
        squares = float(np.sum((d - d.mean()) ** 2))
    if not math.isfinite(squares):
        raise ValueError(
            f"displacement: values up to {peak_d:g} overflow the sum of squares; rescale the "
            "data (change its unit)")
    info = np.finfo(float)
    if squares < float(info.tiny) / float(info.eps):
        # Squares in the subnormal range hold too few digits to tell one cost from the next:
        # positions of 1e-160 gave "failed" beside R^2 0.9994, 1e-200 an R^2 "not defined".
        raise ValueError(
            f"displacement: its spread ({float(np.ptp(d)):g}) is so small that its squares "
            "underflow the floating-point range; rescale the data (change its unit)")
    if residual == "log":
        if np.any(d <= 0):
            raise ValueError(
                "displacement: the log residual needs positive data; "
                f"{int(np.sum(d <= 0))} sample(s) are <= 0"
            )
        if offset is not False and offset != 0:
            raise ValueError("offset: not available with the log residual")
        if mode == kernel.REST:
            raise ValueError(
                "residual='log' from rest: the model's output starts at exactly zero, whose "
                "logarithm is not finite; start from equilibrium, a periodic state or a given "
                "(non-zero) state, or use the linear residual")
    period = math.nan
    if mode == kernel.PERIODIC:
        span = float(t[-1] - t[0])
        if card.period is None:
            if not uniform:
                raise ValueError(
                    "initial_state='periodic' on a non-uniform grid needs period= (the stroke "
                    "period in s): the closing step cannot be inferred")
            period = span + span / (t.size - 1)
        else:
            period = float(card.period)
            if not (math.isfinite(period) and period > span):
                raise ValueError(
                    f"period = {period:g} s must exceed the record's span {span:g} s (the "
                    "samples cover one period, without a repeated closing point)")
    x0_arr = np.zeros(model.n_states()) if x0 is None else x0
    return t, f, d, mode, x0_arr, period, uniform


def build_problem(
    model: type[Model],
    cards: Sequence[CardData],
    *,
    observe: str | None = None,
    integrator: str = "exact",
    residual: str = "linear",
    scale: float | str = 1.0,
    offset: bool | float = False,
    fixed: Mapping[str, float] | None = None,
    strict: bool = True,
    warnings: list[str] | None = None,
    invalid: Sequence[str] | None = None,
) -> Problem:
    """Validate the options and the cards and build a :class:`Problem`.

    Parameters
    ----------
    model : Model class
    cards : sequence of CardData
        Each card's time (s, strictly increasing), load, measured displacement, initial state
        and period.
    observe, integrator, residual, scale, offset, fixed
        As for :func:`pumpid.fit`.
    strict : bool
        Raise ValueError for the first invalid card (a single fit); otherwise mark invalid
        cards and go on (a batch).
    warnings : list, optional
        Receives the option-level warnings (the gauge fixed by the scale symmetry).
    invalid : sequence of str, optional
        Reasons already known for cards that must stay invalid ("" for the others).

    Raises
    ------
    ValueError
        For bad options, and (``strict``) bad cards, with a message naming the problem.
    """
    if not (isinstance(model, type) and issubclass(model, Model)):
        raise TypeError(f"model must be a model class, got {model!r}")
    if integrator not in ("exact", "euler"):
        raise ValueError(f"integrator must be 'exact' or 'euler', got {integrator!r}")
    if residual not in ("linear", "log"):
        raise ValueError(f"residual must be 'linear' or 'log', got {residual!r}")
    obs = model.default_output if observe is None else observe
    model.output_index(obs)
    if isinstance(scale, str):
        if scale != "free":
            raise ValueError(f"scale must be a positive number or 'free', got {scale!r}")
        scale_fixed: float | None = None
    else:
        try:
            scale_fixed = float(scale)
        except (TypeError, ValueError):
            raise ValueError(f"scale must be a positive number or 'free', got {scale!r}") \
                from None
        if not math.isfinite(scale_fixed) or scale_fixed <= 0:
            raise ValueError(f"scale: must be positive and finite, got {scale!r}")
    if offset is True:
        offset_fixed: float | None = None
    elif offset is False:
        offset_fixed = 0.0
    else:
        try:
            offset_fixed = float(offset)
        except (TypeError, ValueError):
            raise ValueError(f"offset must be True, False or a number, got {offset!r}") \
                from None
        if not math.isfinite(offset_fixed):
            raise ValueError("offset: must be finite")
    names = model.param_names()
    fixed_pairs: list[tuple[int, float]] = []
    for name, value in (fixed or {}).items():
        if name not in names:
            raise ValueError(f"fixed: {name!r} is not a parameter of {model.__name__} {names}")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"fixed: {name} = {value!r} must be a number") from None
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"fixed: {name} = {value!r} must be positive and finite")
        fixed_pairs.append((names.index(name), v))
    if len(fixed_pairs) == len(names):
        raise ValueError("fixed: every model parameter is fixed; nothing left to fit")
    if not cards:
        raise ValueError("no cards to fit")

    n = model.n_states()
    k = len(cards)
    ts, fs, ds = [], [], []
    mode = np.zeros(k, dtype=np.int64)
    x0 = np.zeros((k, n))
    period = np.full(k, math.nan)
    uniform = np.ones(k, dtype=bool)
    valid = np.ones(k, dtype=bool)
    reasons = list(invalid) if invalid is not None else [""] * k
    labels: list[Any] = []
    for i, card in enumerate(cards):
        labels.append(initial_state_label(card.initial_state)
                      if not isinstance(card.initial_state, str) else card.initial_state)
        try:
            if reasons[i]:
                raise ValueError(reasons[i])
            t, f, d, mode[i], x0[i], period[i], uniform[i] = _validate_card(
                model, card, residual, offset)
        except ValueError as exc:
            if strict:
                raise
            valid[i] = False
            reasons[i] = str(exc)
            t = f = d = np.zeros(0)
        ts.append(t)
        fs.append(f)
        ds.append(d)
    bounds = np.zeros(k + 1, dtype=np.int64)
    bounds[1:] = np.cumsum([a.size for a in ts])
    shifts = np.zeros(k)
    if offset is True and residual == "linear" and model.input_map is None:
        for i in range(k):
            if valid[i] and mode[i] == kernel.PERIODIC:
                shifts[i] = load_shift(ts[i], fs[i], float(period[i]))

    gauge_fixed = False
    states = [c.initial_state for c in cards]
    zero_state = all(mode[i] != kernel.GIVEN or not np.any(x0[i]) for i in range(k)
                     if valid[i])
    if (not fixed_pairs and scale_fixed is None and model.scale_symmetric and zero_state):
        # Scaling every parameter and C by the same lambda gives the same curve from a
        # load-driven state: fix the gauge C = 1.
        gauge_fixed = True
        scale_fixed = 1.0
        if warnings is not None:
            pnames = ", ".join(names)
            label = states[0] if len(set(map(str, states))) == 1 else "the cards' states"
            warnings.append(
                f"scale symmetry: C and the overall scale of {pnames} are not separately "
                f"identifiable from initial_state={label!r} (multiplying all of them by any "
                f"lambda > 0 gives the same fitted curve); only the ratios {pnames} / C are "
                "determined. Parameters are reported on the gauge C = 1."
            )

    def frozen(a: np.ndarray) -> np.ndarray:
        a.flags.writeable = False
        return a

    return Problem(
        model=model, observe=obs, integrator=integrator,  # type: ignore[arg-type]
        residual=residual, scale_fixed=scale_fixed,  # type: ignore[arg-type]
        offset_fixed=offset_fixed, gauge_fixed=gauge_fixed, fixed=tuple(sorted(fixed_pairs)),
        t=frozen(np.concatenate(ts) if ts else np.zeros(0)),
        load=frozen(np.concatenate(fs) if fs else np.zeros(0)),
        data=frozen(np.concatenate(ds) if ds else np.zeros(0)),
        bounds=frozen(bounds), mode=frozen(mode), x0=frozen(x0), period=frozen(period),
        uniform=frozen(uniform), initial_states=tuple(labels), valid=frozen(valid),
        invalid=tuple(reasons), load_shift=frozen(shifts),
    )
