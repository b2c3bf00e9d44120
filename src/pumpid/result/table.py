"""The results table: one owner of its columns, their types and its rows.

Every table of fits -- ``pumpid batch``'s Parquet folder, ``FitBatch.to_frame()``, the index
``pumpid fit --out`` writes -- has these columns, in this order:

* the card's identity (:data:`IDENTITY`): well, card id, time, source, and for a batch run
  the input file, the card's place in the run, its partition and the card it repeats;
* the fit (:data:`FIT`): model, observed output, status, reason, warnings, R^2, RMSE, cost,
  samples, evaluations, units;
* per parameter ``p_NAME``, ``p_NAME_se`` (the error shown: the robust one where the
  residuals are serially correlated or too few to test), ``p_NAME_se_hac``, ``p_NAME_se_white``,
  ``p_NAME_determined`` (the fit calls it determined), ``p_NAME_unit``; then ``scale``,
  ``offset`` and ``offset_se`` (in ``position_unit``);
* per derived quantity ``d_NAME``, ``d_NAME_se`` (shown), ``d_NAME_se_hac``,
  ``d_NAME_se_white``, ``d_NAME_determined``, ``d_NAME_well_property``, ``d_NAME_unit``.

A row is built here only (:func:`fit_row`, :func:`unfitted_row`, :func:`identity_of`), and
checked against the columns (:func:`check_row`): a key the table does not own is an error,
where Arrow would drop it without a word.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..models import Model
from .parts import CardInfo

if TYPE_CHECKING:
    import pandas
    import pyarrow

__all__ = ["FIT", "IDENTITY", "check_row", "columns", "fit_row", "identity_of",
           "results_schema", "rows_frame", "unfitted_row"]

#: The card's identity: the first columns of every row.
IDENTITY: tuple[tuple[str, str], ...] = (
    ("well_id", "string"), ("card_id", "string"), ("time", "timestamp"),
    ("source", "string"), ("file", "string"), ("item", "int"), ("partition", "int"),
    ("duplicate_of", "string"))
#: The fit's own columns, after the identity.
FIT: tuple[tuple[str, str], ...] = (
    ("model", "string"), ("observe", "string"), ("status", "string"), ("reason", "string"),
    ("warnings", "string"), ("r2", "float"), ("r2_fundamental", "float"),
    ("r2_beyond", "float"), ("rmse", "float"), ("cost", "float"),
    ("n_samples", "int"), ("nfev", "int"), ("position_unit", "string"),
    ("load_unit", "string"))
_PARAM = (("", "float"), ("_se", "float"), ("_se_hac", "float"), ("_se_white", "float"),
          ("_determined", "bool"), ("_unit", "string"))
_DERIVED = (("", "float"), ("_se", "float"), ("_se_hac", "float"), ("_se_white", "float"),
            ("_determined", "bool"), ("_well_property", "bool"), ("_unit", "string"))


def columns(models: type[Model] | Sequence[type[Model]] | Iterable[Any] = ()
            ) -> list[tuple[str, str]]:
    """The table's columns and their kinds (``string``, ``float``, ``int``, ``bool``,
    ``timestamp``) for one model class or several (every class's parameter and derived
    columns, each once, in the order first met).

    A class may also be an own model (anything with ``param_names()``).
    """
    classes = list(models) if isinstance(models, Iterable) and not isinstance(
        models, type) else [models]
    params = list(dict.fromkeys(n for cls in classes for n in cls.param_names()))
    derived = list(dict.fromkeys(
        i.name for cls in classes for i in getattr(cls, "derived_info", tuple)()))
    cols = [*IDENTITY, *FIT]
    cols += [(f"p_{n}{suffix}", kind) for n in params for suffix, kind in _PARAM]
    cols += [("scale", "float"), ("offset", "float"), ("offset_se", "float")]
    cols += [(f"d_{n}{suffix}", kind) for n in derived for suffix, kind in _DERIVED]
    return cols


def results_schema(models: type[Model] | Sequence[type[Model]]) -> pyarrow.Schema:
    """The Arrow schema of :func:`columns` (every part of a run has it, so a partition
    whose cards all failed to read still has every column, all null)."""
    import pyarrow as pa

    kinds = {"string": pa.string(), "float": pa.float64(), "int": pa.int64(),
             "bool": pa.bool_(), "timestamp": pa.timestamp("ns", tz="UTC")}
    return pa.schema([(name, kinds[kind]) for name, kind in columns(models)])


def identity_of(card: CardInfo | None, **batch: Any) -> dict[str, Any]:
    """The identity columns of a card (the one place a card's identity joins a row);
    ``batch`` gives the run's own (``file``, ``item``, ``partition``, ``duplicate_of``)."""
    row = {"well_id": card.well if card else None, "card_id": card.id if card else None,
           "time": card.time if card else None, "source": card.source if card else None}
    unknown = sorted(set(batch) - {name for name, _ in IDENTITY})
    if unknown:
        raise ValueError(f"identity_of: {unknown} are not identity columns")
    row.update(batch)
    return row


def fit_row(result: Any) -> dict[str, Any]:
    """A fit's row: its card's identity, the fit's columns, its parameters (with the errors
    shown, robust and white) and its derived quantities.

    ``result`` is a :class:`~pumpid.result.FitResult` (not named in the annotation: the
    result imports this module to make its own row, and the two must not import each
    other).
    """
    row = identity_of(result.card)
    row.update({
        "model": result.model_name, "observe": result.observe, "status": result.status.key,
        "reason": result.reason, "warnings": " | ".join(result.warnings),
        "r2": result.r2, "r2_fundamental": result.r2_fundamental,
        "r2_beyond": result.r2_beyond, "rmse": result.rmse, "cost": result.cost,
        "n_samples": int(result.t.size), "nfev": result.nfev,
        "position_unit": result.units.position, "load_unit": result.units.load})
    se, se_hac, se_white = result.stderr, result.stderr_hac, result.stderr_white
    units = result.param_units()
    known = set(result.determined.get("parameters", ()))
    for name, value in result.params.items():
        row[f"p_{name}"] = value
        row[f"p_{name}_se"] = float(se.get(name, math.nan))
        row[f"p_{name}_se_hac"] = float(se_hac.get(name, math.nan))
        row[f"p_{name}_se_white"] = float(se_white.get(name, math.nan))
        row[f"p_{name}_determined"] = name in known
        row[f"p_{name}_unit"] = units.get(name)
    row["scale"] = result.scale
    row["offset"] = result.offset
    row["offset_se"] = float(se.get("offset", math.nan))
    for name, d in result.derived.items():
        row.update({f"d_{name}": d.value, f"d_{name}_se": d.stderr,
                    f"d_{name}_se_hac": d.stderr_hac, f"d_{name}_se_white": d.stderr_white,
                    f"d_{name}_determined": d.determined,
                    f"d_{name}_well_property": d.well_property, f"d_{name}_unit": d.unit})
    return row


def unfitted_row(card: CardInfo | None, *, model: str, observe: str | None, status: str,
                 reason: str, **values: Any) -> dict[str, Any]:
    """The row of a card that has no fit (``invalid-input``, or ``failed`` with the error);
    ``values`` adds other columns the caller knows (``n_samples``, units, batch columns)."""
    row = identity_of(card)
    row.update(model=model, observe=observe, status=status, reason=reason, warnings="")
    row.update(values)
    return row


def check_row(row: Mapping[str, Any], names: Iterable[str]) -> None:
    """ValueError for a key of ``row`` that is not one of the table's column ``names``."""
    known = set(names)
    stray = sorted(k for k in row if k not in known)
    if stray:
        raise ValueError(f"results table: row key(s) {stray} are not columns of the table "
                         "(pumpid.result.table.columns)")


def rows_frame(rows: Sequence[Mapping[str, Any]],
               models: type[Model] | Sequence[type[Model]]) -> pandas.DataFrame:
    """The rows as a DataFrame with every column of the table, in order (checked)."""
    import pandas as pd

    names = [name for name, _ in columns(models)]
    for row in rows:
        check_row(row, names)
    return pd.DataFrame([{n: row.get(n) for n in names} for row in rows], columns=names)
