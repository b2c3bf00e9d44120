"""pumpid fit hands each card over as soon as it is fitted: a closed pipe (``| head``) ends
the run after at most one more card, and an interrupt keeps every finished card, printed
and indexed. The fits are counted through the API, so nothing here depends on timing."""

from __future__ import annotations

import csv
import io
import sys
from pathlib import Path
from typing import Any

import pytest

import pumpid.pump.runner as runner
from pumpid.cli import main
from tests.cli.conftest import write_cards

N_CARDS = 12


class _Counted:
    """``pumpid.fit`` as ``pumpid fit`` calls it, counting the cards it fits; a
    KeyboardInterrupt (as Ctrl-C raises it) once ``stop_at`` cards have been fitted, when
    given."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, stop_at: int | None = None) -> None:
        self.fitted = 0
        self.stop_at = stop_at
        plain = runner.fit

        def fit(model: Any, data: Any, *args: Any, **kwargs: Any) -> Any:
            self._starting()
            out = plain(model, data, *args, **kwargs)
            self.fitted += len(data) if isinstance(data, list) else 1
            return out

        monkeypatch.setattr(runner, "fit", fit)

    def _starting(self) -> None:
        if self.stop_at is not None and self.fitted >= self.stop_at:
            raise KeyboardInterrupt


class _ClosingPipe(io.StringIO):
    """Standard output that a reader closes after ``lines`` lines (``| head -n LINES``)."""

    def __init__(self, lines: int) -> None:
        super().__init__()
        self.lines = lines

    def write(self, text: str) -> int:
        if self.getvalue().count("\n") >= self.lines:
            raise BrokenPipeError(32, "Broken pipe")
        return super().write(text)


@pytest.fixture
def many(tmp_path: Path) -> Path:
    return write_cards(tmp_path / "many.csv", [f"W-{i}" for i in range(N_CARDS)])


@pytest.mark.parametrize("method", ["lm", "newton-fd"])
def test_head_ends_the_run_after_at_most_one_more_card(many: Path, monkeypatch,
                                                       method: str) -> None:
    counted = _Counted(monkeypatch)
    pipe = _ClosingPipe(lines=3)  # the two '#' lines and the first card's
    monkeypatch.setattr(sys, "stdout", pipe)
    code = main(["fit", str(many), "--brief", "--model", "msd", "--method", method])
    monkeypatch.undo()
    assert code == 141
    assert pipe.getvalue().splitlines()[2].startswith("W-0\t")
    assert counted.fitted <= 2  # the printed card and the one whose line found no reader


def test_interrupt_keeps_every_finished_card(many: Path, tmp_path: Path, monkeypatch,
                                            capsys) -> None:
    counted = _Counted(monkeypatch, stop_at=3)
    out = tmp_path / "out"
    code = main(["fit", str(many), "--brief", "--model", "msd", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 130
    assert counted.fitted == 3
    printed = [line.split("\t")[0] for line in captured.out.splitlines()
               if not line.startswith("#")]
    assert printed == ["W-0", "W-1", "W-2"]
    assert "interrupted (Ctrl-C) after 3 cards" in captured.err
    with (out / "results.csv").open(encoding="utf-8") as fh:
        indexed = [row["card_id"] for row in csv.DictReader(fh)]
    assert indexed == printed
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == printed
