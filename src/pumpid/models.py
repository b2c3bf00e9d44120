"""Linear lumped models of the paper, in physical state-space form.

Every model is a frozen dataclass whose fields are its parameters. A model maps a measured
input (the load ``F(t)``) to displacement-like states through

    x'(t) = A(theta) x(t) + B(theta) F(t),        y(t) = x[observe](t)

and knows the parameter derivatives dA/dtheta and dB/dtheta exactly. The state variables are
physical (displacements, velocities, internal forces), so no derivative of the measured load is
ever needed and any physical state can be observed (MODEL-NOTES section 1).

The matrices are produced by class methods that take a *batch* of parameter vectors
(``theta`` of shape ``(..., p)``) so that the batch fitter and the single fit share one source
of truth.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MODELS",
    "FirstOrder",
    "Kelvin",
    "MassSpringDamper",
    "Maxwell",
    "Model",
    "ParamInfo",
    "model_class",
]


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
class Model:
    """Base class of the linear lumped models.

    Subclasses declare their parameters as dataclass fields with :func:`param` and implement
    :meth:`_system`, which returns A, B and their derivatives for a batch of parameter vectors.
    """

    #: Names of the state variables, in order.
    states: ClassVar[tuple[str, ...]] = ()
    #: States that may be observed, with a plain description.
    outputs: ClassVar[Mapping[str, str]] = {}
    #: The default observed state (the paper's choice).
    default_output: ClassVar[str] = ""
    #: True when scaling every parameter by lambda scales the zero-state response by 1/lambda,
    #: so that with a free output scale C only ratios are identifiable (MODEL-NOTES section 2).
    scale_symmetric: ClassVar[bool] = False
    #: Short name used by the CLI and in results.
    key: ClassVar[str] = ""
    #: One-line description.
    title: ClassVar[str] = ""
    #: Unit of the model's input: the first-order model of eq. (23) is driven by a rate.
    input_unit: ClassVar[str] = "{load}"

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
    def values(self) -> NDArray[np.float64]:
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
    def _system(
        cls, theta: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Batched state-space matrices.

        Parameters
        ----------
        theta : ndarray, shape (..., p)
            Parameter vectors in canonical order.

        Returns
        -------
        A : ndarray, shape (..., n, n)
        B : ndarray, shape (..., n)
        dA : ndarray, shape (..., p, n, n)
            dA[..., i] = dA/dtheta_i.
        dB : ndarray, shape (..., p, n)
        """
        raise NotImplementedError

    @classmethod
    def system_batch(
        cls, theta: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """A, B, dA/dtheta, dB/dtheta for a batch of parameter vectors ``theta`` (..., p)."""
        th = np.asarray(theta, dtype=float)
        if th.shape[-1:] != (len(cls.param_names()),):
            raise ValueError(
                f"{cls.__name__}: expected parameter vectors of length {len(cls.param_names())}"
            )
        return cls._system(th)

    #: True when the model passes its input through a static map g(theta, F) before the
    #: linear dynamics (a Hammerstein model); see :meth:`input_map`.
    transforms_input: ClassVar[bool] = False

    @classmethod
    def input_map(
        cls, theta: NDArray[np.float64], load: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Static input map g(theta, F) and its parameter derivatives.

        Parameters
        ----------
        theta : ndarray, shape (..., p)
        load : ndarray, shape (..., N)

        Returns
        -------
        g : ndarray, shape (..., N)
            The input seen by the linear dynamics (the load itself by default).
        dg : ndarray, shape (..., p, N) or None
            dg/dtheta_i; None when g does not depend on the parameters.
        """
        return load, None

    def matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """State matrix A (n, n) and input vector B (n,) of ``x' = A x + B F``."""
        a, b, _, _ = self._system(self.values)
        return a, b

    def matrix_derivatives(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exact derivatives dA/dtheta (p, n, n) and dB/dtheta (p, n), canonical order."""
        _, _, da, db = self._system(self.values)
        return da, db

    def transfer_function(self, s: ArrayLike, observe: str | None = None) -> NDArray[np.complex128]:
        """Evaluate the transfer function from load to the observed state at complex ``s``."""
        a, b = self.matrices()
        k = self.output_index(observe)
        s_arr = np.atleast_1d(np.asarray(s, dtype=complex))
        eye = np.eye(a.shape[0])
        out = np.array([np.linalg.solve(si * eye - a, b)[k] for si in s_arr.ravel()])
        return out.reshape(s_arr.shape)

    def static_gain(self, observe: str | None = None) -> float:
        """Static displacement of the observed state per unit constant load."""
        a, b = self.matrices()
        return float(-np.linalg.solve(a, b)[self.output_index(observe)])

    def describe(self, load_unit: str = "N", position_unit: str = "m") -> str:
        """One line per parameter: name = value unit."""
        return "\n".join(
            f"{p.name} = {getattr(self, p.name):.6g} {p.unit_for(load_unit, position_unit)}"
            for p in self.param_info()
        )


@functools.cache
def _param_info(cls: type[Model]) -> tuple[ParamInfo, ...]:
    # Dataclass introspection is slow and runs inside every solver iteration; a model
    # class's parameters never change, so compute them once per class.
    return tuple(
        ParamInfo(f.name, f.metadata["unit"], f.metadata["doc"], f.metadata["lower"],
                  f.metadata["upper"])
        for f in dataclasses.fields(cls)
        if "unit" in f.metadata
    )


def _zeros(theta: NDArray[np.float64], n: int) -> tuple[NDArray[np.float64], ...]:
    batch = theta.shape[:-1]
    p = theta.shape[-1]
    return (
        np.zeros((*batch, n, n)),
        np.zeros((*batch, n)),
        np.zeros((*batch, p, n, n)),
        np.zeros((*batch, p, n)),
    )


@dataclass(frozen=True)
class FirstOrder(Model):
    """First-order relaxation, eq. (23): ``u' = f - u / tau``.

    The static gain is ``tau``: a constant input ``f`` settles at ``u = tau f``.
    """

    tau: float = param("s", "relaxation time")

    states: ClassVar[tuple[str, ...]] = ("u",)
    outputs: ClassVar[Mapping[str, str]] = {"u": "the relaxing quantity"}
    default_output: ClassVar[str] = "u"
    key: ClassVar[str] = "first-order"
    title: ClassVar[str] = "first-order relaxation u' = f - u/tau (paper eq. 23)"
    input_unit: ClassVar[str] = "{position}/s"

    @classmethod
    def _system(cls, theta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        a, b, da, db = _zeros(theta, 1)
        tau = theta[..., 0]
        a[..., 0, 0] = -1.0 / tau
        b[..., 0] = 1.0
        da[..., 0, 0, 0] = 1.0 / tau**2
        return a, b, da, db


@dataclass(frozen=True)
class MassSpringDamper(Model):
    """Mass-spring-dashpot, eq. (28): ``m u'' + c u' + k u = f``.

    States: displacement ``u`` and velocity ``v``.
    """

    m: float = param("{load}*s^2/{position}", "mass")
    c: float = param("{load}*s/{position}", "damping")
    k: float = param("{load}/{position}", "stiffness")

    states: ClassVar[tuple[str, ...]] = ("u", "v")
    outputs: ClassVar[Mapping[str, str]] = {"u": "displacement of the mass"}
    default_output: ClassVar[str] = "u"
    scale_symmetric: ClassVar[bool] = True
    key: ClassVar[str] = "msd"
    title: ClassVar[str] = "mass-spring-dashpot m u'' + c u' + k u = f (paper eq. 28)"

    @classmethod
    def _system(cls, theta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        a, b, da, db = _zeros(theta, 2)
        m, c, k = theta[..., 0], theta[..., 1], theta[..., 2]
        a[..., 0, 1] = 1.0
        a[..., 1, 0] = -k / m
        a[..., 1, 1] = -c / m
        b[..., 1] = 1.0 / m
        # d/dm
        da[..., 0, 1, 0] = k / m**2
        da[..., 0, 1, 1] = c / m**2
        db[..., 0, 1] = -1.0 / m**2
        # d/dc, d/dk
        da[..., 1, 1, 1] = -1.0 / m
        da[..., 2, 1, 0] = -1.0 / m
        return a, b, da, db


@dataclass(frozen=True)
class Kelvin(Model):
    """Mass on a spring k0 in series with a Kelvin element (k1 parallel c1), eqs. (8)-(9).

    States: mass displacement ``u``, its velocity ``v`` and the Kelvin element's
    displacement ``u2``::

        m v'   = F - k0 (u - u2)
        c1 u2' = k0 (u - u2) - k1 u2

    The paper fits ``u2`` (default); physically the polished rod moves with the mass, ``u``.
    """

    k0: float = param("{load}/{position}", "series spring stiffness")
    m: float = param("{load}*s^2/{position}", "lumped mass")
    c1: float = param("{load}*s/{position}", "Kelvin dashpot")
    k1: float = param("{load}/{position}", "Kelvin spring stiffness")

    states: ClassVar[tuple[str, ...]] = ("u", "v", "u2")
    outputs: ClassVar[Mapping[str, str]] = {
        "u2": "displacement of the Kelvin element (the paper's fitted output)",
        "u": "displacement of the mass",
    }
    default_output: ClassVar[str] = "u2"
    scale_symmetric: ClassVar[bool] = True
    key: ClassVar[str] = "kelvin"
    title: ClassVar[str] = "mass + spring k0 in series with Kelvin element k1 || c1 (eqs. 8-9)"

    @classmethod
    def _system(cls, theta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        a, b, da, db = _zeros(theta, 3)
        k0, m, c1, k1 = (theta[..., i] for i in range(4))
        a[..., 0, 1] = 1.0
        a[..., 1, 0] = -k0 / m
        a[..., 1, 2] = k0 / m
        a[..., 2, 0] = k0 / c1
        a[..., 2, 2] = -(k0 + k1) / c1
        b[..., 1] = 1.0 / m
        # d/dk0
        da[..., 0, 1, 0] = -1.0 / m
        da[..., 0, 1, 2] = 1.0 / m
        da[..., 0, 2, 0] = 1.0 / c1
        da[..., 0, 2, 2] = -1.0 / c1
        # d/dm
        da[..., 1, 1, 0] = k0 / m**2
        da[..., 1, 1, 2] = -k0 / m**2
        db[..., 1, 1] = -1.0 / m**2
        # d/dc1
        da[..., 2, 2, 0] = -k0 / c1**2
        da[..., 2, 2, 2] = (k0 + k1) / c1**2
        # d/dk1
        da[..., 3, 2, 2] = -1.0 / c1
        return a, b, da, db


@dataclass(frozen=True)
class Maxwell(Model):
    """Mass on a spring k0 in parallel with a Maxwell arm (k1 in series with c1), eqs. (11)-(12).

    States: mass displacement ``u``, velocity ``v`` and the Maxwell arm's force ``F0``::

        m v' = F - k0 u - F0
        F0'  = k1 (v - F0 / c1)

    Only the load itself drives the system: the paper's form (eq. 13) needs dF/dt, this one
    does not.
    """

    k0: float = param("{load}/{position}", "parallel spring stiffness")
    m: float = param("{load}*s^2/{position}", "lumped mass")
    c1: float = param("{load}*s/{position}", "Maxwell dashpot")
    k1: float = param("{load}/{position}", "Maxwell spring stiffness")

    states: ClassVar[tuple[str, ...]] = ("u", "v", "F0")
    outputs: ClassVar[Mapping[str, str]] = {"u": "displacement of the mass"}
    default_output: ClassVar[str] = "u"
    scale_symmetric: ClassVar[bool] = True
    key: ClassVar[str] = "maxwell"
    title: ClassVar[str] = "mass + spring k0 in parallel with Maxwell arm k1 -- c1 (eqs. 11-12)"

    @classmethod
    def _system(cls, theta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        a, b, da, db = _zeros(theta, 3)
        k0, m, c1, k1 = (theta[..., i] for i in range(4))
        a[..., 0, 1] = 1.0
        a[..., 1, 0] = -k0 / m
        a[..., 1, 2] = -1.0 / m
        a[..., 2, 1] = k1
        a[..., 2, 2] = -k1 / c1
        b[..., 1] = 1.0 / m
        # d/dk0
        da[..., 0, 1, 0] = -1.0 / m
        # d/dm
        da[..., 1, 1, 0] = k0 / m**2
        da[..., 1, 1, 2] = 1.0 / m**2
        db[..., 1, 1] = -1.0 / m**2
        # d/dc1
        da[..., 2, 2, 2] = k1 / c1**2
        # d/dk1
        da[..., 3, 2, 1] = 1.0
        da[..., 3, 2, 2] = -1.0 / c1
        return a, b, da, db


MODELS: dict[str, type[Model]] = {
    cls.key: cls for cls in (FirstOrder, MassSpringDamper, Kelvin, Maxwell)
}


def model_class(name: str | type[Model] | Model) -> type[Model]:
    """Resolve a model name (``"kelvin"``, ``"maxwell"``, ``"msd"``, ``"first-order"``)."""
    if isinstance(name, Model):
        return type(name)
    if isinstance(name, type) and issubclass(name, Model):
        return name
    key = str(name).strip().lower().replace("_", "-")
    aliases = {"firstorder": "first-order", "first": "first-order",
               "massspringdamper": "msd", "mass-spring-damper": "msd"}
    key = aliases.get(key, key)
    if key not in MODELS:
        raise ValueError(f"unknown model {name!r}; choose one of {sorted(MODELS)}")
    return MODELS[key]
