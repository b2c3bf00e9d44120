"""A 2,000-card field and its uninterrupted batch run, shared by the fleet tests."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from pumpid.fleet import FitSpec, read_results, run_batch

from .fields import make_field

#: Cards per partition of the shared runs (100 partitions: resume has much to skip).
PARTS = 20


@pytest.fixture(scope="session")
def field(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame]:
    """25 wells x 80 cards in four layouts (one multi-well SCADA export), 5 % broken."""
    folder = tmp_path_factory.mktemp("field")
    return folder, make_field(folder)


@pytest.fixture(scope="session")
def local_run(field: tuple[Path, pd.DataFrame],
              tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object, pd.DataFrame]:
    """The field fitted with the mass-spring-damper model on the local engine.

    The batch machinery (reading, partitions, ids, writing, resume) does not depend on the
    model; MSD fits these cards about three times faster than Kelvin, which keeps the
    2,000-card tests to seconds. Kelvin runs on a smaller field in test_batch.py.
    """
    folder, _ = field
    out = tmp_path_factory.mktemp("runs") / "local"
    summary = run_batch([str(folder)], out, fit=FitSpec("msd"), partition_size=PARTS)
    return out, summary, read_results(out)
