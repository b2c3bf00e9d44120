"""Card files for the command-line tests, made by the project's generator."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

import pumpid
from pumpid.pump.synthetic import synthetic_card

SRC = Path(pumpid.__file__).resolve().parents[1]
TRUE = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)


def write_cards(path: Path, ids: Sequence[str], *, n_samples: int = 60, spm: float = 8.0,
                seed: int = 0) -> Path:
    """A CSV of synthetic cards (crank-rocker motion, Kelvin load, 0.2 % noise), one per id.

    Columns ``card_id, spm, position_in, load_lbf``; no time column (time from the SPM).
    """
    rng = np.random.default_rng(seed)
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["card_id", "spm", "position_in", "load_lbf"])
        for card_id in ids:
            card = synthetic_card(TRUE, spm=spm, n_samples=n_samples, stroke=100.0,
                                  observe="u", noise=0.002, seed=rng)
            for x, f in zip(card.position, card.load, strict=True):
                writer.writerow([card_id, f"{spm:g}", f"{x:.5f}", f"{f:.3f}"])
    return path


@pytest.fixture
def two_cards(tmp_path: Path) -> Path:
    """Two ordinary cards, W-1 and W-2."""
    return write_cards(tmp_path / "two.csv", ["W-1", "W-2"])


def run_cli(args: Sequence[str], *, cwd: Path | None = None,
            timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """``python -m pumpid.cli ARGS`` in a child process (this checkout's code)."""
    return subprocess.run([sys.executable, "-m", "pumpid.cli", *args], cwd=cwd,
                          env=cli_env(), capture_output=True, text=True, timeout=timeout,
                          check=False)


def cli_env() -> dict[str, str]:
    """The environment of a child ``pumpid`` process: this checkout first, Agg plots."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["MPLBACKEND"] = "Agg"
    env.pop("PUMPID_DEBUG", None)
    return env
