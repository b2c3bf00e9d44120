"""Fleet analysis: many wells' fit results over time; which wells changed, when and how.

``changes``
    :func:`detect_changes` (persistent shifts per well and quantity) and
    :func:`summarise_wells` (one row per well).
``report``
    :func:`write_fleet_report`: one self-contained HTML page, its PNGs and CSV tables.
``dataset``
    :func:`read_parquet_cards` and :func:`iter_parquet_cards`: cards stored in the Parquet
    long layout (one row per sample).
``batch``, ``inputs``, ``engines``, ``store``, ``progress``
    :func:`run_batch` (``pumpid batch``): every card of files and folders fitted into one
    results folder, partition by partition, on the local cores or on Dask, resumable;
    :func:`read_results` reads it back.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "BatchSummary",
    "FitSpec",
    "ReadOptions",
    "detect_changes",
    "iter_parquet_cards",
    "read_parquet_cards",
    "read_results",
    "run_batch",
    "summarise_wells",
    "write_fleet_report",
]

# pandas, pyarrow and matplotlib load with the modules that need them, on first use of a
# name: ``pumpid fit`` and ``import pumpid`` do not pay for the fleet.
_WHERE = {
    "BatchSummary": "batch", "FitSpec": "batch", "run_batch": "batch",
    "detect_changes": "changes", "summarise_wells": "changes",
    "iter_parquet_cards": "dataset", "read_parquet_cards": "dataset",
    "ReadOptions": "inputs", "write_fleet_report": "report", "read_results": "store",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        module = importlib.import_module(f".{_WHERE[name]}", __name__)
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
