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

from .batch import BatchSummary, FitSpec, run_batch
from .changes import detect_changes, summarise_wells
from .dataset import iter_parquet_cards, read_parquet_cards
from .inputs import ReadOptions
from .report import write_fleet_report
from .store import read_results

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
