"""Fleet analysis: many wells' fit results over time; which wells changed, when and how.

``changes``
    :func:`detect_changes` (persistent shifts per well and quantity) and
    :func:`summarise_wells` (one row per well).
``report``
    :func:`write_fleet_report`: one self-contained HTML page, its PNGs and CSV tables.
``dataset``
    :func:`read_parquet_cards` and :func:`iter_parquet_cards`: cards stored in the Parquet
    long layout (one row per sample).
"""

from .changes import detect_changes, summarise_wells
from .dataset import iter_parquet_cards, read_parquet_cards
from .report import write_fleet_report

__all__ = [
    "detect_changes",
    "iter_parquet_cards",
    "read_parquet_cards",
    "summarise_wells",
    "write_fleet_report",
]
