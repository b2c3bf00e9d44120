"""A flow record floating point cannot fit is refused before any linear algebra, in the
record's words: its file and quantity (pressure drop, flow rate), never LAPACK's lines nor
the engine's "load"/"displacement"."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pumpid.cli import main
from pumpid.flow import fit_flow
from pumpid.flow.records import FlowRecord

T = np.linspace(0.0, 1.0, 101)
Q = 1e-4 * (1.0 - np.exp(-T / 0.1))


def _record(path: Path, dp: np.ndarray, q: np.ndarray) -> Path:
    rows = "".join(f"{float(a)!r},{float(b)!r},{float(c)!r}\n" for a, b, c in zip(T, dp, q,
                                                                                strict=True))
    path.write_text("t [s],dp [Pa],q [m^3/s]\n" + rows)
    return path


@pytest.mark.parametrize(("dp", "q", "quantity", "unit_option"), [
    # a pressure drop whose time integral overflows: LAPACK's "illegal value" before
    (np.where(np.arange(101) > 50, 1e308, 1e-300), Q, "pressure drop dp [Pa]", "--dp-unit"),
    # a flow rate whose squares overflow: "displacement" before
    (np.full(101, 2e5), 1e300 * Q, "flow rate q [m^3/s]", "--q-unit"),
])
def test_huge_magnitudes_are_refused_naming_file_and_quantity(
        tmp_path: Path, capfd, dp: np.ndarray, q: np.ndarray, quantity: str,
        unit_option: str) -> None:
    path = _record(tmp_path / "huge.csv", dp, q)
    code = main(["flow", "fit", str(path)])
    err = capfd.readouterr().err
    assert code == 2
    assert "DLASCL" not in err and "SVD did not converge" not in err
    assert "displacement" not in err and "load" not in err
    assert f"huge.csv: {quantity}: values up to" in err and unit_option in err
    assert err.count("\n") == 1  # one line


def test_engine_refusals_use_the_flow_quantities() -> None:
    # A record made in code (no reader's checks): a constant pressure drop from an
    # equilibrium carries nothing to fit, and the engine says so of its "load".
    record = FlowRecord(t=T, dp=np.full(101, 2e5), q=1e-5 + Q, source="rig-7")
    with pytest.raises(ValueError, match=r"^rig-7: pressure drop dp \[Pa\]: constant") as info:
        fit_flow(record)
    assert "load" not in str(info.value) and "displacement" not in str(info.value)
