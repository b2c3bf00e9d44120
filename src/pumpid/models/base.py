"""What every model is: a frozen dataclass of parameters and the knowledge that goes with it.

A model maps a measured input (the load ``F(t)``) to displacement-like states through

    x'(t) = A(theta) x(t) + B(theta) g(F(t)),        y(t) = x[observe](t)

with physical states (displacements, velocities, internal forces), so no derivative of the
measured load is ever needed and any physical state can be observed. ``g`` is the identity
except for models that declare an input map (a static power law, for the flow surrogates).

Each entry of ``A`` and ``B`` is declared as a sum of monomials in the parameters
(:func:`term`): ``-(k0 + k1) / c1`` is ``term(-1, k0=1, c1=-1), term(-1, k1=1, c1=-1)``. That
one declaration gives the matrices, their exact derivatives (the derivative of a monomial
along ``ln theta_j`` is ``e_j`` times the monomial) and the compiled kernel's input
(:meth:`Model.code`), so adding a model is one file with its terms and its knowledge:

* ``equation_error``: per observed output, the linear equation-error form used by the
  automatic start (regressors and the closed-form map back to parameters);
* :meth:`Model.shape_grid`: dimensionless parameter shapes spanning plausible dynamics;
* ``limits``: the limits a parameter can run to (0 or infinity), in words, and the reduced
  model the data then want with the maps between the two parameter sets.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DerivedInfo",
    "EquationError",
    "Limit",
    "Model",
    "ParamInfo",
    "Term",
    "evaluate_terms",
    "param",
    "term",
]

Array = NDArray[np.float64]


def param(unit: str, doc: str, lower: float = 0.0, upper: float = math.inf) -> Any:
    """Declare a model parameter field (positive by default).

    ``unit`` is a template over the user's units: ``{load}``, ``{position}`` and ``s``.
    """
    return field(metadata={"unit": unit, "doc": doc, "lower": lower, "upper": upper})


@dataclass(frozen=True)
class ParamInfo:
    """Static description of one model parameter."""

    name: str
    unit: str
    doc: str
    lower: float
    upper: float

    def unit_for(self, load: str, position: str) -> str:
        """Return the unit with the user's load and position units filled in."""
        return self.unit.format(load=load, position=position)


@dataclass(frozen=True)
class Term:
    """A monomial ``coef * prod(theta[name] ** power)``."""

    coef: float
    powers: tuple[tuple[str, float], ...] = ()

    def value(self, values: Mapping[str, float]) -> float:
        """The monomial at the given parameter values."""
        out = self.coef
        for name, power in self.powers:
            out *= values[name] ** power
        return out


def term(coef: float, **powers: float) -> Term:
    """A monomial: ``term(-1, k0=1, m=-1)`` is ``-k0 / m``."""
    return Term(float(coef), tuple((k, float(v)) for k, v in powers.items()))


def evaluate_terms(terms: tuple[Term, ...], values: Mapping[str, float]) -> float:
    """A sum of monomials at the given parameter values."""
    return float(sum(t.value(values) for t in terms))


@dataclass(frozen=True)
class EquationError:
    """The linear equation-error form of a model for one observed output.

    ``target = sum_j coef_j * regressor_j`` where the regressors are derivatives of the
    displacement (orders ``y_orders``) and of the load (``f_orders``), filtered alike;
    ``target`` names the left-hand side (``("f", 0)``: the load itself; ``("y", 1)``: the
    displacement's rate). ``to_theta`` maps coefficient rows (K, c) back to parameter rows
    (K, p), NaN where a row has no physical solution.
    """

    target: tuple[str, int]
    y_orders: tuple[int, ...]
    f_orders: tuple[int, ...]
    to_theta: Callable[[Array], Array]

    @property
    def order(self) -> int:
        """Highest derivative order (the state-variable filter's order)."""
        return max((*self.y_orders, *self.f_orders, self.target[1]))

    @property
    def n_coef(self) -> int:
        """Number of coefficients."""
        return len(self.y_orders) + len(self.f_orders)


@dataclass(frozen=True)
class Limit:
    """A parameter running to 0 or infinity: what it means and, when known, the reduced model.

    ``to_reduced`` gives each reduced parameter as a sum of monomials of the full ones, and
    ``gain`` the factor by which the reduced model's output must be scaled to match the full
    model's near the limit (a massless MSD is a first-order lag with gain 1/c).
    ``from_reduced`` maps a reduced solution back to a full-model point next to the limit
    (to restart a full fit that the reduced model beats). ``observe`` is the reduced model's
    observed output; ``companions`` the other limits the reduced model takes at once, by the
    full model's observed output, named with it: a massless Kelvin model is a first-order
    lag at u2, but at u the series spring adds the load's own share ``F / k0``, which no lag
    has, so there the lag is the limit m -> 0 with k0 -> infinity (it was printed as the
    limit m -> 0 alone). The tests that accept a limit are unchanged by them.
    """

    param: str
    direction: str  # "infinity" or "zero"
    description: str
    reduced: str | None = None
    observe: str | None = None
    to_reduced: Mapping[str, tuple[Term, ...]] = field(default_factory=dict)
    gain: tuple[Term, ...] = (Term(1.0),)
    from_reduced: Mapping[str, tuple[Term, ...]] = field(default_factory=dict)
    companions: Mapping[str, tuple[tuple[str, str], ...]] = field(default_factory=dict)

    def with_limits(self, observe: str) -> tuple[tuple[str, str], ...]:
        """The (parameter, direction) limits the reduced model takes with this one when the
        full model observes ``observe``."""
        return tuple(self.companions.get(observe, ()))

    def named(self, observe: str) -> str:
        """The limit in words, its companions included (``m -> 0 with k0 -> inf``)."""
        head = self.description.split(":")[0]
        extra = [f"{p} -> {'inf' if d == 'infinity' else '0'}"
                 for p, d in self.with_limits(observe)]
        return " with ".join([head, *extra])

    def reduced_start(self, params: Mapping[str, float]) -> tuple[dict[str, float], float]:
        """The reduced model's parameters and output gain at a full-model point."""
        start = {k: evaluate_terms(v, params) for k, v in self.to_reduced.items()}
        return start, evaluate_terms(self.gain, params)

    def full_point(self, reduced: Mapping[str, float]) -> dict[str, float] | None:
        """A full-model point next to the limit from the reduced model's parameters."""
        if not self.from_reduced:
            return None
        return {k: evaluate_terms(v, reduced) for k, v in self.from_reduced.items()}


@dataclass(frozen=True)
class DerivedInfo:
    """A quantity computed from a model's parameters: name, unit template, meaning."""

    name: str
    unit: str
    meaning: str

    def unit_for(self, load: str, position: str) -> str:
        """The unit in the data's units; a compound one bracketed inside a quotient (a flow
        fit's static stiffness read "Pa/m^3/s" for Pa/(m^3/s))."""
        def filled(unit: str) -> str:
            return f"({unit})" if "/" in unit and self.unit not in ("{load}", "{position}") \
                else unit
        return self.unit.replace("{load}", filled(load)).replace("{position}", filled(position))


#: The quantities of :meth:`Model.derived_values`, by the number of states.
_TIME_CONSTANT = DerivedInfo("time_constant", "s", "time constant of the real pole (-1/pole)")
# "Of the oscillating pair" beside a damping ratio of 1.4 contradicted itself: past critical
# damping the pair is two real poles, and |pole| is their geometric mean.
_NATURAL = DerivedInfo("natural_frequency", "Hz",
                       "natural frequency of the pair of poles (|pole| / 2 pi; with a damping "
                       "ratio above 1 the pair is two real poles and this is their geometric "
                       "mean, nothing oscillates)")
_DAMPING = DerivedInfo("damping_ratio", "1",
                       "damping ratio of that pair (-Re pole / |pole|; above 1: two real "
                       "poles, overdamped)")
_STATIC = DerivedInfo("static_stiffness", "{load}/{position}",
                      "load per unit displacement of the observed output at equilibrium "
                      "(1 / (C x static gain))")
_EXTRA_POLE = DerivedInfo("time_constant", "s",
                          "time constant of the real pole outside the oscillating pair "
                          "(creep or relaxation)")


def _pair_and_rest(lam: NDArray[np.complex128]) -> tuple[list[complex], list[complex]]:
    """The oscillating pair of poles and the others.

    A complex pair when there is one; with only real poles, the two that sit closest together
    on a log scale (the pair that became real as damping grew), the isolated one apart.
    """
    lam = np.asarray(lam)
    cplx = [i for i in range(lam.size) if lam[i].imag > 0]
    if cplx:
        i = max(cplx, key=lambda j: lam[j].imag)
        j = int(np.argmin(np.abs(lam - np.conj(lam[i]))))
        rest = [complex(lam[k]) for k in range(lam.size) if k not in (i, j)]
        return [complex(lam[i]), complex(lam[j])], rest
    if lam.size == 2:
        return [complex(x) for x in lam], []
    logs = np.log(np.abs(lam.real) + 1e-300)
    best = (math.inf, 0, 1)
    for a in range(lam.size):
        for b in range(a + 1, lam.size):
            gap = abs(logs[a] - logs[b])
            if gap < best[0]:
                best = (gap, a, b)
    _, a, b = best
    return ([complex(lam[a]), complex(lam[b])],
            [complex(lam[k]) for k in range(lam.size) if k not in (a, b)])


def polished_roots(coefficients: ArrayLike) -> NDArray[np.complex128]:
    """Roots (m, n) of polynomials (m, n + 1), highest power first, each refined by
    Newton's method on the polynomial itself.

    Why by hand: the companion matrix's eigenvalues (what ``np.roots`` returns) have an
    absolute error of about the rounding unit times the largest root, so a creep pole 1e-15
    times the fastest one comes out wrong in its first digits; a few Newton steps on the
    coefficients, where the small root's terms are not lost, restore its relative accuracy.
    Stacked, so that the derived quantities' many parameter rows cost one eigenvalue call.
    """
    c = np.atleast_2d(np.asarray(coefficients, dtype=float))
    m, n = c.shape[0], c.shape[1] - 1
    companion = np.zeros((m, n, n))
    with np.errstate(all="ignore"):
        companion[:, 0, :] = -c[:, 1:] / c[:, :1]
    companion[:, np.arange(1, n), np.arange(n - 1)] = 1.0
    ok = np.all(np.isfinite(companion), axis=(1, 2))
    roots = np.full((m, n), np.nan, dtype=complex)
    if ok.any():
        roots[ok] = np.linalg.eigvals(companion[ok])

    def horner(r: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], ...]:
        value = np.broadcast_to(c[:, :1], r.shape).astype(complex)
        slope = np.zeros_like(value)
        for j in range(1, n + 1):
            slope = slope * r + value
            value = value * r + c[:, j:j + 1]
        return value, slope

    with np.errstate(all="ignore"):
        value, slope = horner(roots)
        for _ in range(4):
            trial = roots - value / slope
            trial_value, trial_slope = horner(trial)
            better = np.isfinite(trial) & (np.abs(trial_value) < np.abs(value))
            roots = np.where(better, trial, roots)
            value = np.where(better, trial_value, value)
            slope = np.where(better, trial_slope, slope)
    return roots


def _pole_quantities(lam: NDArray[np.complex128]) -> dict[str, float]:
    """Natural frequency (Hz), damping ratio and other time constant (s) from the poles."""
    values: dict[str, float] = {}
    if lam.size == 1:
        values["time_constant"] = -1.0 / lam[0].real if lam[0].real < 0 else math.nan
        return values
    pair, rest = _pair_and_rest(lam)
    wn2 = (pair[0] * pair[1]).real
    if wn2 > 0:
        wn = math.sqrt(wn2)
        values["natural_frequency"] = wn / (2 * math.pi)
        values["damping_ratio"] = -(pair[0] + pair[1]).real / (2 * wn)
    if rest and rest[0].real < 0:
        values["time_constant"] = -1.0 / rest[0].real
    return values


@dataclass(frozen=True)
class Model:
    """Base class of the linear lumped models.

    Subclasses declare their parameters as dataclass fields with :func:`param`, their state
    equations as terms (``a_terms``, ``b_terms``), and their knowledge (``equation_error``,
    :meth:`shape_grid`, ``limits``).
    """

    #: Names of the state variables, in order.
    states: ClassVar[tuple[str, ...]] = ()
    #: States that may be observed, with a plain description.
    outputs: ClassVar[Mapping[str, str]] = {}
    #: The default observed state.
    default_output: ClassVar[str] = ""
    #: True when scaling every parameter by lambda scales the zero-state response by 1/lambda,
    #: so that with a free output scale C only ratios are identifiable.
    scale_symmetric: ClassVar[bool] = False
    #: Short name used by the CLI and in results.
    key: ClassVar[str] = ""
    #: One-line description.
    title: ClassVar[str] = ""
    #: Unit of the model's input: the first-order model of eq. (23) is driven by a rate.
    input_unit: ClassVar[str] = "{load}"
    #: Unit of the output scale C when the model is driven by the card's load: 1 where the
    #: parameters carry the units, else what turns the model's output into a position. It
    #: is given beside a reduced model's C.
    scale_unit: ClassVar[str] = "1"
    #: Entries of A: {(row, col): terms}; of B: {row: terms}.
    a_terms: ClassVar[Mapping[tuple[int, int], tuple[Term, ...]]] = {}
    b_terms: ClassVar[Mapping[int, tuple[Term, ...]]] = {}
    #: A static input map applied to the load before the linear dynamics: None, or
    #: ("power-law", parameter name) for g = ref sign(F) |F/ref|^(1/n) (see ``input_reference``).
    input_map: ClassVar[tuple[str, str] | None] = None
    #: The reference of the power-law input map (in the input's unit).
    input_reference: ClassVar[float] = 1.0
    #: Not a linear state-space model (simulated and fitted by its own evaluator).
    nonlinear: ClassVar[bool] = False
    #: Equation-error forms per observed output (automatic start).
    equation_error: ClassVar[Mapping[str, EquationError]] = {}
    #: Known limits of the parameters.
    limits: ClassVar[tuple[Limit, ...]] = ()
    #: The parameter that sets the model's resonance (its inertia), or None. Where the
    #: resonance lies far above the stroke's frequency, the cost along it is flat and
    #: rippled, and the main job scans along it for a lower dip.
    resonance: ClassVar[str | None] = None

    def __post_init__(self) -> None:
        for info in self.param_info():
            value = getattr(self, info.name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ValueError(
                    f"{type(self).__name__}: parameter {info.name} must be a number, got {value!r}"
                ) from None
            if not math.isfinite(value):
                raise ValueError(f"{type(self).__name__}: parameter {info.name} is {value}")
            if not (info.lower < value < info.upper):
                raise ValueError(
                    f"{type(self).__name__}: parameter {info.name} = {value:g} is outside "
                    f"its bounds ({info.lower:g}, {info.upper:g}); physical parameters must "
                    "be strictly positive"
                )
            object.__setattr__(self, info.name, value)

    # ------------------------------------------------------------------ parameters
    @classmethod
    def param_info(cls) -> tuple[ParamInfo, ...]:
        """Describe the parameters (name, unit template, description, bounds)."""
        return _param_info(cls)

    @classmethod
    def param_names(cls) -> tuple[str, ...]:
        """Parameter names in the model's canonical order."""
        return tuple(p.name for p in _param_info(cls))

    @property
    def values(self) -> Array:
        """Parameter values as an array in canonical order."""
        return np.array([getattr(self, n) for n in self.param_names()], dtype=float)

    def as_dict(self) -> dict[str, float]:
        """Parameters as a ``{name: value}`` dictionary."""
        return {n: getattr(self, n) for n in self.param_names()}

    @classmethod
    def from_values(cls, values: ArrayLike) -> Model:
        """Build a model from an array of parameter values in canonical order."""
        arr = np.asarray(values, dtype=float).ravel()
        names = cls.param_names()
        if arr.size != len(names):
            raise ValueError(
                f"{cls.__name__} takes {len(names)} parameters {names}, got {arr.size}"
            )
        return cls(**dict(zip(names, arr.tolist(), strict=True)))

    def replace(self, **changes: float) -> Model:
        """Return a copy with some parameters changed."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def n_states(cls) -> int:
        """Number of state variables."""
        return len(cls.states)

    @classmethod
    def output_index(cls, observe: str | None) -> int:
        """Index of the observed state; ``None`` selects the default output."""
        name = cls.default_output if observe is None else observe
        if name not in cls.outputs:
            raise ValueError(
                f"{cls.__name__} cannot observe {name!r}; choose one of {sorted(cls.outputs)}"
            )
        return cls.states.index(name)

    # ------------------------------------------------------------------ matrices
    @classmethod
    def code(cls) -> tuple[Any, ...]:
        """The compiled kernel's form of the state equations (cached per class).

        ``(a_pos (Ta, 2), a_coef (Ta,), a_exp (Ta, p), b_pos (Tb,), b_coef (Tb,),
        b_exp (Tb, p))``: the position, coefficient and exponent row of every term.
        """
        return _code(cls)

    @classmethod
    def input_code(cls) -> Array:
        """The input map for the kernel: (kind, parameter index, reference)."""
        if cls.input_map is None:
            return np.zeros(3)
        kind, name = cls.input_map
        if kind != "power-law":
            raise ValueError(f"{cls.__name__}: unknown input map {kind!r}")
        return np.array([1.0, float(cls.param_names().index(name)), float(cls.input_reference)])

    @classmethod
    def system_batch(cls, theta: ArrayLike) -> tuple[Array, Array, Array, Array]:
        """A (..., n, n), B (..., n), dA/dtheta (..., p, n, n), dB/dtheta (..., p, n)."""
        return cls._system(theta, True)

    @classmethod
    def _system(cls, theta: ArrayLike, derivatives: bool) -> tuple[Array, Array, Array, Array]:
        # The derivatives' arrays stay zero unless asked for: an offset's gap costs the
        # static gain several times a fit and needs none.
        th = np.asarray(theta, dtype=float)
        p = len(cls.param_names())
        if th.shape[-1:] != (p,):
            raise ValueError(f"{cls.__name__}: expected parameter vectors of length {p}")
        a_pos, a_coef, a_exp, b_pos, b_coef, b_exp = cls.code()
        n = cls.n_states()
        batch = th.shape[:-1]
        a = np.zeros((*batch, n, n))
        b = np.zeros((*batch, n))
        da = np.zeros((*batch, p, n, n))
        db = np.zeros((*batch, p, n))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            for (r, c), coef, exp in zip(a_pos, a_coef, a_exp, strict=True):
                val = coef * np.prod(th**exp, axis=-1)
                a[..., r, c] += val
                for j in np.flatnonzero(exp) if derivatives else ():
                    da[..., j, r, c] += exp[j] * val / th[..., j]
            for r, coef, exp in zip(b_pos, b_coef, b_exp, strict=True):
                val = coef * np.prod(th**exp, axis=-1)
                b[..., r] += val
                for j in np.flatnonzero(exp) if derivatives else ():
                    db[..., j, r] += exp[j] * val / th[..., j]
        return a, b, da, db

    def matrices(self) -> tuple[Array, Array]:
        """State matrix A (n, n) and input vector B (n,) of ``x' = A x + B g(F)``."""
        a, b, _, _ = self._system(self.values, False)
        return a, b

    def matrix_derivatives(self) -> tuple[Array, Array]:
        """Exact derivatives dA/dtheta (p, n, n) and dB/dtheta (p, n), canonical order."""
        _, _, da, db = self.system_batch(self.values)
        return da, db

    def transfer_function(self, s: ArrayLike, observe: str | None = None) -> NDArray[np.complex128]:
        """Evaluate the transfer function from the (mapped) input to the observed state."""
        a, b = self.matrices()
        k = self.output_index(observe)
        s_arr = np.atleast_1d(np.asarray(s, dtype=complex))
        eye = np.eye(a.shape[0])
        out = np.array([np.linalg.solve(si * eye - a, b)[k] for si in s_arr.ravel()])
        return out.reshape(s_arr.shape)

    def static_gain(self, observe: str | None = None) -> float:
        """Static displacement of the observed state per unit constant input."""
        return float(self.static_gains(self.values, observe))

    @classmethod
    def static_gains(cls, theta: ArrayLike, observe: str | None = None) -> Array:
        """:meth:`static_gain` for parameter vectors ``theta`` (..., p); NaN where there is
        no equilibrium (a singular state matrix)."""
        a, b, _, _ = cls._system(theta, False)
        k = cls.output_index(observe)
        with np.errstate(all="ignore"):
            try:
                return -np.linalg.solve(a, b[..., None])[..., k, 0]
            except np.linalg.LinAlgError:
                # One singular matrix fails the stacked solve: the rows one at a time.
                flat_a, flat_b = a.reshape(-1, *a.shape[-2:]), b.reshape(-1, b.shape[-1])
                out = np.full(flat_b.shape[0], math.nan)
                for i in range(out.size):
                    with contextlib.suppress(np.linalg.LinAlgError):
                        out[i] = -np.linalg.solve(flat_a[i], flat_b[i])[k]
                return out.reshape(b.shape[:-1])

    def poles(self) -> NDArray[np.complex128]:
        """The poles (1/s; A's eigenvalues, :meth:`pole_sets`), sorted by decreasing real
        part."""
        lam = self.pole_sets(self.values[None])[0]
        return lam[np.argsort(-lam.real)]

    @classmethod
    def characteristic(cls, theta: Array) -> Array | None:
        """Coefficients (m, n + 1), highest power first, of a polynomial whose roots are the
        poles at parameter rows ``theta`` (m, p), written from the parameters directly; None:
        the poles are A's eigenvalues. A model overrides it where forming A loses a
        parameter to rounding (a sum such as k0 + k1 with k1 1e-15 of k0)."""
        return None

    @classmethod
    def pole_sets(cls, theta: Array) -> NDArray[np.complex128]:
        """The poles (m, n) at parameter rows ``theta`` (m, p)."""
        coefficients = cls.characteristic(theta)
        if coefficients is None:
            return np.linalg.eigvals(cls._system(theta, False)[0])
        return polished_roots(coefficients)

    @classmethod
    def derived_info(cls) -> tuple[DerivedInfo, ...]:
        """The quantities :meth:`derived_values` gives, in order.

        Physical combinations a card determines even where single parameters are not: from
        the poles, an oscillating pair's natural frequency and damping ratio and any other
        real pole's time constant; from the static gain, the stiffness seen at the observed
        output (for load-driven models).
        """
        n = cls.n_states()
        out: list[DerivedInfo] = []
        if n == 1:
            out.append(_TIME_CONSTANT)
        else:
            out += [_NATURAL, _DAMPING]
            if n == 3:
                out.append(_EXTRA_POLE)
        if cls.input_unit == "{load}":
            out.append(_STATIC)
        return tuple(out)

    @classmethod
    def derived_values(cls, theta: ArrayLike, observe: str | None = None,
                       scale: ArrayLike = 1.0) -> Array:
        """The values of :meth:`derived_info` at parameters ``theta`` (canonical order).

        ``theta`` is one parameter vector (p,) or a stack of them (m, p), with ``scale`` a
        number or one per vector; the result is (k,) or (m, k). NaN where a quantity does
        not exist there (for example no equilibrium).
        """
        th = np.asarray(theta, dtype=float)
        single = th.ndim == 1
        th = np.atleast_2d(th)
        m = th.shape[0]
        scales = np.broadcast_to(np.asarray(scale, dtype=float), (m,))
        a, b, _, _ = cls._system(th, False)
        infos = cls.derived_info()
        names = [info.name for info in infos]
        out = np.full((m, len(infos)), math.nan)
        ok = np.all(np.isfinite(a), axis=(1, 2)) & np.all(np.isfinite(b), axis=1)
        rows = np.flatnonzero(ok)
        if rows.size:
            # One stacked eigenvalue and solve call for all vectors (the derivatives of the
            # quantities take 2p + 2 of them per fit).
            lams = cls.pole_sets(th[rows])
            gains = cls.static_gains(th[rows], observe)
            for j, i in enumerate(rows):
                values = _pole_quantities(lams[j])
                gain = float(gains[j])
                if gain != 0 and math.isfinite(gain):
                    values["static_stiffness"] = 1.0 / (float(scales[i]) * gain)
                out[i] = [values.get(name, math.nan) for name in names]
        return out[0] if single else out

    def describe(self, load_unit: str = "N", position_unit: str = "m") -> str:
        """One line per parameter: name = value unit."""
        return "\n".join(
            f"{p.name} = {getattr(self, p.name):.6g} {p.unit_for(load_unit, position_unit)}"
            for p in self.param_info()
        )

    # ------------------------------------------------------------------ knowledge
    @classmethod
    def shape_grid(cls, w0: float, dense: bool = False) -> Array:
        """Parameter shapes (S, p) at unit stiffness spanning plausible dynamics.

        ``w0`` is the record's fundamental angular frequency (rad/s). ``dense`` asks for the
        wide search's grid (many more shapes, into the limits). The default spans every
        parameter's natural size a decade (dense: three decades) either way; models override
        it with shapes from their physics.
        """
        import itertools

        if dense:
            factors: tuple[float, ...] = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3)
        else:
            factors = (0.1, 1.0, 10.0) if len(cls.param_names()) <= 4 else (0.3, 3.0)
        base = np.array([_unit_size(p.unit, w0) for p in cls.param_info()])
        return np.array([base * np.array(c) for c in itertools.product(
            factors, repeat=base.size)])

    @classmethod
    def scale_unit_for(cls, load: str, position: str) -> str:
        """:attr:`scale_unit` in the data's units (``"1"`` where C is a number)."""
        return cls.scale_unit.format(load=load, position=position)

    @classmethod
    def limit(cls, name: str, direction: str) -> Limit:
        """The known limit of a parameter (a generic description when none is declared)."""
        for lim in cls.limits:
            if lim.param == name and lim.direction == direction:
                return lim
        arrow = "inf" if direction == "infinity" else "0"
        return Limit(name, direction, f"{name} -> {arrow}")


def _unit_size(unit: str, w0: float) -> float:
    """Size of a unit template at unit load and position and time scale 1/w0."""
    size = 1.0
    for k, side in enumerate(unit.split("/", 1)):
        sign = 1 if k == 0 else -1
        for token in side.replace("(", "").replace(")", "").split("*"):
            name, _, power = token.strip().partition("^")
            if name == "s":
                size *= (1.0 / w0) ** (sign * (float(power) if power else 1.0))
    return size


@functools.cache
def _param_info(cls: type[Model]) -> tuple[ParamInfo, ...]:
    # Dataclass introspection is slow; a model class's parameters never change.
    return tuple(
        ParamInfo(f.name, f.metadata["unit"], f.metadata["doc"], f.metadata["lower"],
                  f.metadata["upper"])
        for f in dataclasses.fields(cls)
        if "unit" in f.metadata
    )


@functools.cache
def _code(cls: type[Model]) -> tuple[Any, ...]:
    names = cls.param_names()
    p = len(names)

    def rows(terms: list[tuple[Any, Term]]) -> tuple[Array, Array]:
        coef = np.array([t.coef for _pos, t in terms], dtype=float)
        exp = np.zeros((len(terms), p))
        for k, (_pos, t) in enumerate(terms):
            for name, power in t.powers:
                if name not in names:
                    raise ValueError(f"{cls.__name__}: term uses unknown parameter {name!r}")
                exp[k, names.index(name)] += power
        return coef, exp

    a_list = [(pos, t) for pos, ts in cls.a_terms.items() for t in ts]
    b_list = [(pos, t) for pos, ts in cls.b_terms.items() for t in ts]
    a_pos = np.array([pos for pos, _t in a_list], dtype=np.int64).reshape(-1, 2)
    b_pos = np.array([pos for pos, _t in b_list], dtype=np.int64)
    a_coef, a_exp = rows(a_list)
    b_coef, b_exp = rows(b_list)
    out = (a_pos, a_coef, a_exp, b_pos, b_coef, b_exp)
    for arr in out:
        arr.flags.writeable = False
    return out
