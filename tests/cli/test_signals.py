"""Real signals on a running ``pumpid fit``: Ctrl-C keeps the results so far, exit 130;
kill -9 leaves no partial file under a final name."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pumpid.report.output import MANIFEST

from .conftest import cli_env, run_cli, write_cards

PNG_END = b"IEND\xaeB`\x82"
CARD_FILES = ("result.json", "report.html", "card.png", "displacement.png", "residuals.png")

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")


@pytest.fixture(scope="module")
def many_cards(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Enough cards that writing their reports takes far longer than the test waits."""
    folder = tmp_path_factory.mktemp("signals")
    return write_cards(folder / "many.csv", [f"C{i:03d}" for i in range(150)], n_samples=50)


def _start(args: list[str]) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "pumpid.cli", *args], env=cli_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _assert_complete(folder: Path) -> None:
    """A card folder is whole: every file there, each one complete."""
    names = {p.name for p in folder.iterdir()}
    assert set(CARD_FILES) <= names, (folder, names)
    json.loads((folder / "result.json").read_text(encoding="utf-8"))
    assert (folder / "report.html").read_text(encoding="utf-8").endswith("</html>\n")
    for png in folder.glob("*.png"):
        data = png.read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and data.endswith(PNG_END), png


def _visible(out: Path) -> list[Path]:
    return [p for p in out.iterdir() if not p.name.startswith(".")]


def test_ctrl_c_exits_130_with_one_line_and_keeps_the_results(many_cards: Path,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = _start(["fit", str(many_cards), "--observe", "u", "--brief", "--out", str(out)])
    assert proc.stdout is not None
    seen = []
    deadline = time.monotonic() + 300
    while len(seen) < 3 and time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        if not line.startswith("#"):
            seen.append(line)
    assert len(seen) == 3, "the run printed no cards"
    proc.send_signal(signal.SIGINT)
    rest, err = proc.communicate(timeout=300)
    assert proc.returncode == 130
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pumpid: interrupted (Ctrl-C) after ")
    done = int(lines[0].split(" after ")[1].split()[0])
    cards = seen + [ln for ln in rest.splitlines() if ln and not ln.startswith("#")]
    assert len(cards) == done >= 3
    assert rest.splitlines()[-1].endswith("(interrupted)")
    index = (out / "results.csv").read_text(encoding="utf-8").splitlines()
    assert len(index) == done + 1
    folders = [p for p in _visible(out) if p.is_dir()]
    assert len(folders) == done
    for folder in folders:
        _assert_complete(folder)
    assert not [p for p in out.iterdir() if p.name.startswith(".pumpid-")]


def test_kill_9_leaves_no_partial_file(many_cards: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    for delay in (0.0, 0.7):
        proc = _start(["fit", str(many_cards), "--observe", "u", "--brief", "--out", str(out)])
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and not (
                out.is_dir() and any(p.is_dir() for p in _visible(out))):
            time.sleep(0.05)
        time.sleep(delay)
        proc.kill()  # SIGKILL: no handler, no clean-up
        proc.communicate(timeout=60)
        assert proc.returncode == -signal.SIGKILL
        visible = _visible(out)
        assert visible, "no card was written before the kill"
        for entry in visible:
            # Only whole card folders under final names; the index appears only at the end.
            assert entry.is_dir(), entry
            _assert_complete(entry)
    # The next run into the folder removes what the killed runs left (hidden staging).
    small = write_cards(tmp_path / "small.csv", ["S1", "S2"], n_samples=40)
    done = run_cli(["fit", str(small), "--observe", "u", "--brief", "--out", str(out)])
    assert done.returncode == 0, done.stderr
    hidden = [p.name for p in out.iterdir() if p.name.startswith(".") and p.name != MANIFEST]
    assert hidden == []
    for name in ("S1", "S2"):
        _assert_complete(out / name)
