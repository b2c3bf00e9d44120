"""The models: linear lumped systems in physical state-space form, one file per family.

Every model is a frozen dataclass whose fields are its parameters (units and bounds in the
field metadata) and which carries its own knowledge: state equations as monomial terms,
equation-error forms for the automatic start, a shape grid and its limits
(:mod:`pumpid.models.base`).
"""

from __future__ import annotations

from .base import EquationError, Limit, Model, ParamInfo, Term, param, term
from .first_order import FirstOrder
from .kelvin import Kelvin
from .maxwell import Maxwell
from .msd import MassSpringDamper
from .own import OwnModel, Parameter

__all__ = [
    "MODELS",
    "EquationError",
    "FirstOrder",
    "Kelvin",
    "Limit",
    "MassSpringDamper",
    "Maxwell",
    "Model",
    "OwnModel",
    "ParamInfo",
    "Parameter",
    "Term",
    "model_class",
    "param",
    "term",
]

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
