"""Hostile input through the command line: every case of issue 16, and generated ones.

Whatever the file, the options or the output path, ``pumpid`` ends with a documented exit
code and at most a line or two on stderr: never a traceback (exit 1 means a bug), never a
raw control character on the terminal, never a numpy warning.
"""

from __future__ import annotations

import codecs
import io
import json
import re
import sys
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pumpid.cli import main

from .conftest import write_cards

U = ["--observe", "u"]
DOCUMENTED = {0, 2, 3, 4, 5, 6}


def _check(captured: pytest.CaptureResult[str], code: int, allowed: set[int] = DOCUMENTED):
    text = captured.out + captured.err
    assert code in allowed, (code, captured.err[-2000:])
    assert "Traceback" not in text and "internal error" not in text, captured.err[-2000:]
    assert "\x1b" not in text, "a control character reached the terminal"
    assert "Warning:" not in captured.err, captured.err
    assert "np.float64(" not in text


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two short cards: the base every mutation starts from."""
    return write_cards(tmp_path_factory.mktemp("hostile") / "small.csv", ["S-1", "S-2"],
                       n_samples=30)


# --------------------------------------------------------------------------- listed cases
@pytest.mark.parametrize("option", [
    ["--spm", "1e300"], ["--spm", "1e-300"], ["--spm", "1e150"], ["--spm", "nan"],
    ["--spm", "inf"], ["--spm", "-8"], ["--spm", "0"], ["--period", "0"],
    ["--period", "1e308"], ["--spm", "8", "--period", "3"], ["--scale", "-1"],
    ["--scale", "nan"], ["--scale", "abc"], ["--x0", "k0=nan,m=1,c1=1,k1=1"],
    ["--x0", "k0=1"], ["--initial-state", "nan,1,2"], ["--initial-state", "sideways"],
    ["--columns", "position"], ["--columns", "bogus=1"], ["--observe", "x\x1b[2J"],
    ["--card", "\x1b[31mnone"], ["--format", "xml"], ["--position-unit", "furlong"],
    ["--encoding", "no-such-codec"], ["--predict", "nothing-of-that-name"],
])
def test_bad_options_are_exit_2_with_one_line(small: Path, option: list[str], capsys) -> None:
    code = main(["fit", str(small), *U, *option])
    captured = capsys.readouterr()
    _check(captured, code, {2})
    assert captured.out == ""
    assert captured.err.startswith("pumpid: error: ") and captured.err.count("\n") == 1


def test_a_stroke_of_a_week_at_a_scale_of_1e300_is_no_internal_error(small: Path,
                                                                     capsys) -> None:
    # Found by the generated cases: the mass ran past ln m = 709 and the diagnostics' scan
    # along it overflowed ("internal error (OverflowError: math range error)").
    code = main(["fit", str(small), "--spm", "1e-05", "--model", "kelvin", "--scale",
                 "1e300", "--brief"])
    _check(capsys.readouterr(), code)


def test_spm_of_a_file_beyond_reason_fails_its_card_only(tmp_path: Path, capsys) -> None:
    path = write_cards(tmp_path / "c.csv", ["A", "B"], n_samples=30)
    lines = path.read_text().splitlines()
    lines = [ln.replace(",8,", ",1e300,", 1) if ln.startswith("A,") else ln for ln in lines]
    path.write_text("\n".join(lines) + "\n")
    code = main(["fit", str(path), *U, "--brief"])
    captured = capsys.readouterr()
    rows = [ln.split("\t") for ln in captured.out.splitlines() if not ln.startswith("#")]
    assert rows[0][0] == "A" and rows[0][1] in ("failed", "invalid-input")
    assert rows[1][0] == "B" and rows[1][1] in ("converged", "boundary")
    assert code == 3
    assert "Traceback" not in captured.err


@pytest.mark.parametrize("value", ["1e308", "-1e308", "1e-300", "5e-324"])
def test_extreme_sample_values(small: Path, tmp_path: Path, value: str, capsys) -> None:
    lines = small.read_text().splitlines()
    parts = lines[5].split(",")
    parts[3] = value
    lines[5] = ",".join(parts)
    path = tmp_path / "extreme.csv"
    path.write_text("\n".join(lines) + "\n")
    code = main(["fit", str(path), *U, "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    _check(captured, code)
    assert "S-2  " in captured.out  # the other card is there whatever happened to S-1


def test_loads_near_the_smallest_float_are_read_and_named(small: Path, tmp_path: Path,
                                                          capsys) -> None:
    lines = small.read_text().splitlines()
    out = [lines[0]]
    for line in lines[1:]:
        p = line.split(",")
        p[3] = repr(float(p[3]) * 1e-300)
        out.append(",".join(p))
    path = tmp_path / "tiny.csv"
    path.write_text("\n".join(out) + "\n")
    code = main(["fit", str(path), *U])
    captured = capsys.readouterr()
    _check(captured, code)
    for line in (captured.out + captured.err).splitlines():
        if re.search(r"(?<!time )\bconstant\b", line):  # "the load is constant" and kin
            assert "tiny.csv" in line, line


def test_spm_nan_in_a_file_is_named(small: Path, tmp_path: Path, capsys) -> None:
    lines = small.read_text().splitlines()
    lines = [lines[0]] + [ln.replace(",8,", ",nan,", 1) for ln in lines[1:]]
    path = tmp_path / "spm_nan.csv"
    path.write_text("\n".join(lines) + "\n")
    code = main(["fit", str(path)])
    captured = capsys.readouterr()
    _check(captured, code, {2})
    assert "spm_nan.csv, line 2, field 'spm'" in captured.err and "NaN" in captured.err
    assert "nan then nan" not in captured.err


@pytest.mark.parametrize("view", [[], ["--brief"], ["--verbose"], ["--json"]])
def test_escape_codes_in_card_ids_never_reach_the_terminal(tmp_path: Path, view: list[str],
                                                           capsys) -> None:
    path = write_cards(tmp_path / "ansi.csv", ["\x1b[31mRED\x1b[0m", "\x1b]0;title\x07x"],
                       n_samples=30)
    code = main(["fit", str(path), *U, *view])
    captured = capsys.readouterr()
    _check(captured, code)
    if view == ["--json"]:
        ids = [c["card"]["id"] for c in json.loads(captured.out)["cards"]]
        assert ids == ["\x1b[31mRED\x1b[0m", "\x1b]0;title\x07x"]  # kept exact in JSON
    else:
        assert "\\x1b[31mRED\\x1b[0m" in captured.out


def test_numpy_warnings_do_not_leak(tmp_path: Path, capsys) -> None:
    """A load spike of 1e308 makes numpy warn (overflow) inside the fit: counted, not shown;
    --verbose says how many were raised."""
    path = write_cards(tmp_path / "spike.csv", ["A"], n_samples=30)
    lines = path.read_text().splitlines()
    parts = lines[4].split(",")
    parts[3] = "1e308"
    lines[4] = ",".join(parts)
    path.write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings(record=True) as escaped:
        warnings.simplefilter("always")
        code = main(["fit", str(path), *U, "--verbose"])
    assert not escaped, [str(w.message) for w in escaped]
    captured = capsys.readouterr()
    _check(captured, code)
    assert "RuntimeWarning" not in captured.err


def test_utf16_file_is_read_and_encoding_can_be_given(small: Path, tmp_path: Path,
                                                      capsys) -> None:
    text = small.read_text()
    utf16 = tmp_path / "utf16.csv"
    utf16.write_bytes(codecs.BOM_UTF16_LE + text.encode("utf-16-le"))
    code = main(["fit", str(utf16), *U, "--brief"])
    captured = capsys.readouterr()
    _check(captured, code)
    assert code in (0, 3) and "S-1\t" in captured.out
    latin = tmp_path / "latin.csv"
    latin.write_bytes(text.replace("S-1", "S-\xe91").encode("latin-1"))
    code = main(["fit", str(latin), *U, "--brief", "--encoding", "latin-1"])
    captured = capsys.readouterr()
    _check(captured, code)
    assert "S-\xe91\t" in captured.out


def test_simulate_non_utf8_file_is_named(tmp_path: Path, capsys) -> None:
    path = tmp_path / "latin.csv"
    path.write_bytes(b"t,load\n0,1\n1,\xff2\n")
    code = main(["simulate", str(path), "-p", "k0=1,m=1,c1=1,k1=1"])
    captured = capsys.readouterr()
    _check(captured, code, {2})
    assert "latin.csv: not utf-8 text (byte 0xff" in captured.err and "--encoding" in captured.err


def test_flow_message_prints_plain_numbers(tmp_path: Path, capsys) -> None:
    rows = ["t,dp,q"] + [f"{min(0.1 * i, 0.5):.2f},{2e5},{1e-6 * i}" for i in range(20)]
    path = tmp_path / "back.csv"
    path.write_text("\n".join(rows) + "\n")
    code = main(["flow", "fit", str(path)])
    captured = capsys.readouterr()
    _check(captured, code, {2})
    assert "time must be strictly increasing: 0.5 s follows 0.5 s" in captured.err


class _ClosedPipe(io.StringIO):
    """Standard output whose reader has gone (``pumpid ... | head -1``)."""

    def write(self, text: str) -> int:
        raise BrokenPipeError(32, "Broken pipe")

    def fileno(self) -> int:
        raise io.UnsupportedOperation("no file descriptor")


def test_closed_output_pipe_is_quiet(small: Path, monkeypatch, capsys) -> None:
    """Exit 141 and nothing on stderr when the reader of standard output has gone."""
    monkeypatch.setattr(sys, "stdout", _ClosedPipe())
    code = main(["fit", str(small), *U, "--brief"])
    assert code == 141
    assert capsys.readouterr().err == ""


# --------------------------------------------------------------------------- generated
TOKENS = ["nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e400", "1e-320", "0", "", " ",
          "abc", "1,5", "0x10", "\x00", "\x1b[31m", "１２", "∞", "--", "1e", ".", "+-1",
          '"', "\r", "9" * 400]


@st.composite
def mutated(draw: st.DrawFn, base: str) -> bytes:
    lines = base.splitlines()
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["cell", "drop", "dup", "swap", "id", "header", "cut",
                                     "bytes"]))
        if kind == "cell" and len(lines) > 1:
            i = draw(st.integers(1, len(lines) - 1))
            cells = lines[i].split(",")
            j = draw(st.integers(0, len(cells) - 1))
            cells[j] = draw(st.sampled_from(TOKENS) | st.text(max_size=8))
            lines[i] = ",".join(cells)
        elif kind == "drop" and len(lines) > 1:
            del lines[draw(st.integers(0, len(lines) - 1))]
        elif kind == "dup" and lines:
            i = draw(st.integers(0, len(lines) - 1))
            lines.insert(i, lines[i])
        elif kind == "swap" and len(lines) > 2:
            i, j = draw(st.integers(1, len(lines) - 1)), draw(st.integers(1, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "id" and len(lines) > 1:
            new = draw(st.sampled_from(["..", ".", "a/b", "", "\x1b[2J", "S-1", "é"]))
            i = draw(st.integers(1, len(lines) - 1))
            lines[i] = new + lines[i][lines[i].index(","):] if "," in lines[i] else new
        elif kind == "header" and lines:
            lines[0] = draw(st.sampled_from(["a,b,c,d", "card_id,spm,position_m,load_kN",
                                             "card_id,spm,load_lbf,position_in", "", "#"]))
        elif kind == "cut":
            text = "\n".join(lines)
            lines = text[: draw(st.integers(0, len(text)))].splitlines()
    data = "\n".join(lines).encode("utf-8", "surrogatepass")
    if draw(st.booleans()):
        return data
    pos = draw(st.integers(0, len(data)))
    return data[:pos] + draw(st.binary(max_size=16)) + data[pos:]


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_mutated_card_files_never_give_a_traceback(small: Path, tmp_path: Path, data,
                                                   capsys) -> None:
    content = data.draw(mutated(small.read_text()))
    path = tmp_path / "mutated.csv"
    path.write_bytes(content)
    view = data.draw(st.sampled_from([["--brief"], ["--json"], []]))
    code = main(["fit", str(path), *U, *view])
    captured = capsys.readouterr()
    _check(captured, code)
    if view == ["--json"] and code in (0, 3):
        doc = json.loads(captured.out)
        assert all({"status", "reason", "card"} <= set(c) for c in doc["cards"])


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(spm=st.none() | st.floats(allow_nan=True, allow_infinity=True),
       period=st.none() | st.floats(min_value=-1e300, max_value=1e300),
       model=st.sampled_from(["kelvin", "maxwell", "msd", "first-order"]),
       scale=st.none() | st.sampled_from(["free", "1", "0.5", "1e300", "1e-300"]),
       state=st.none() | st.sampled_from(["rest", "periodic", "equilibrium", "0,0,0", "1e300"]),
       offset=st.sampled_from(["auto", "yes", "no"]))
def test_generated_options_never_give_a_traceback(small: Path, spm, period, model, scale,
                                                  state, offset, capsys) -> None:
    argv = ["fit", str(small), "--model", model, "--offset", offset, "--brief"]
    for name, value in (("--spm", spm), ("--period", period), ("--scale", scale),
                        ("--initial-state", state)):
        if value is not None:
            argv.append(f"{name}={value}")  # "=": a value such as -1e+30 is not an option
    code = main(argv)
    _check(capsys.readouterr(), code)


def test_option_syntax_errors_return_2(small: Path, capsys) -> None:
    assert main(["fit", str(small), "--period", "-1e+30"]) == 2
    assert main(["fit"]) == 2
    assert main(["no-such-command"]) == 2
    captured = capsys.readouterr()
    assert "usage: pumpid" in captured.err and "Traceback" not in captured.err
