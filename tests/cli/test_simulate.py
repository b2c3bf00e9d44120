"""pumpid simulate refuses options and records whose simulation is not finite: exit 2 with
the reason, and no output file (never a file of NaN or inf with exit 0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pumpid.cli import main

PARAMS = "k0=4,m=1,c1=0.2,k1=4"


def _record(path: Path, t: np.ndarray, load: np.ndarray) -> Path:
    rows = "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, load, strict=True))
    path.write_text("t,load\n" + rows)
    return path


@pytest.fixture
def record(tmp_path: Path) -> Path:
    t = np.arange(50) * 0.1
    return _record(tmp_path / "load.csv", t, 100.0 * np.sin(0.3 * np.arange(50)))


@pytest.mark.parametrize("scale", ["nan", "inf", "-inf", "0", "-1"])
def test_scale_that_is_not_a_positive_number_is_refused(record: Path, tmp_path: Path,
                                                        capsys, scale: str) -> None:
    out = tmp_path / "sim.csv"
    code = main(["simulate", str(record), "-p", PARAMS, f"--scale={scale}", "-o", str(out)])
    assert code == 2
    assert "output scale must be a positive finite number" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(("params", "scale"), [
    (PARAMS, "1e308"),  # a displacement of 1e308 times the load's: overflows
    ("k0=1e308,m=1,c1=0.2,k1=4", "1"),
    ("k0=1e308,m=1,c1=0.2,k1=4", "1e308"),
    ("k0=4,m=1e-320,c1=0.2,k1=4", "1"),
])
def test_non_finite_simulation_writes_nothing(record: Path, tmp_path: Path, capsys,
                                              params: str, scale: str) -> None:
    out = tmp_path / "sim.csv"
    code = main(["simulate", str(record), "-p", params, "--scale", scale, "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "load.csv: the simulated displacement is not a finite number" in err
    assert "nothing was written" in err
    assert not out.exists()


def test_time_steps_too_small_to_divide_by(tmp_path: Path, capsys) -> None:
    rec = _record(tmp_path / "tiny.csv", np.arange(50) * 5e-320, np.sin(np.arange(50.0)))
    code = main(["simulate", str(rec), "-p", PARAMS])
    captured = capsys.readouterr()
    assert code == 2
    assert "tiny.csv: the simulated displacement is not a finite number" in captured.err
    assert "nan" not in captured.out.lower() and "inf" not in captured.out.lower()
