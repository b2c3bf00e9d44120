"""Hostile input through the readers.

Whatever a file holds (random bytes, broken versions of the made-up fixtures, extreme
numbers, NaN and infinity, mixed encodings, very long lines, empty columns, duplicate
headers), :func:`read_cards` either returns cards whose arrays are finite and of matching
lengths, or raises :class:`CardError` whose message names the file. Nothing else escapes,
not even a numpy ``RuntimeWarning``, and every message, note and warning is printable.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pumpid.cards import Card, CardError, read_cards

DATA = Path(__file__).parent / "data" / "cards"
FIXTURES = {p.name: p.read_bytes() for p in sorted(DATA.iterdir()) if p.is_file()}
NAME = "hostile-input"  # every message must name the file: look for this

QUICK = settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("hostile")


def check(folder: Path, data: bytes, suffix: str = ".csv", **options) -> list[Card] | None:
    """Write ``data`` to a file, read it and check the only allowed outcomes."""
    path = folder / f"{NAME}{suffix}"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a leaked RuntimeWarning fails the test
        try:
            cards = read_cards(path, **options)
        except CardError as exc:
            msg = str(exc)
            assert NAME in msg, msg
            assert msg.isprintable(), msg
            return None
    assert cards
    for card in cards:
        assert isinstance(card, Card)
        assert card.position.shape == card.load.shape == (card.n,)
        assert card.n >= options.get("min_samples", 20)
        assert np.all(np.isfinite(card.position)) and np.all(np.isfinite(card.load))
        if card.t is not None:
            assert card.t.shape == (card.n,) and np.all(np.isfinite(card.t))
            assert np.all(np.diff(card.t) > 0)
        for text in (*card.notes, *card.warnings):
            assert isinstance(text, str) and text.isprintable(), text
    return cards


# --------------------------------------------------------------------------- tokens
EXTREME = [
    "1e308", "-1e308", "1.7976931348623157e308", "1e309", "-1e309", "1e-308", "-1e-308",
    "5e-324", "2.2e-308", "4.9e-324", "-0.0", "0", "0.0", "+0", "9" * 40, "-" + "9" * 400,
    "1" + "0" * 5000, "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1.0D+308", "1D-320",
    "1+2j", "(3-4j)", "2j", "1_000", "0x10", "1e", ".", "-", "", " ", "١٢٣", "１２", "1,5",
    "\x1b[31m5\x1b[0m", "\u200b7", "'8'", '"9"', "1e308,1e308", "?",
]  # fmt: skip
numbers = st.one_of(
    st.sampled_from(EXTREME),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(min_value=-1e4, max_value=1e4).map(lambda x: f"{x:.6g}"),
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
)
words = st.sampled_from(
    ["position", "load", "t", "time (ms)", "card_id", "well", "spm", "period", "position_in",
     "load_lbf", "Position [m]", "Load (kN)", "is_closure_point", "", "x", "position",
     "load (furlong)", "t_s", "\x1b[2J", "名前", "a\tb"]
)  # fmt: skip
ENCODINGS = ["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "utf-32", "latin-1"]


SCALES = [1e-300, 1e-6, 1.0, 1e6, 1e300]
GOOD_HEADERS = [
    ["position_in", "load_lbf"],
    ["t_s", "position", "load"],
    ["card_id", "position", "load", "spm"],
    ["load (kN)", "Position [m]", "is_closure_point"],
    ["position", "position", "load"],  # a duplicated name
    ["position", "", "load", ""],  # empty names
]


@st.composite
def delimited(draw) -> bytes:
    """A card-like table with hostile cells here and there, any encoding and line ending."""
    sep = draw(st.sampled_from([",", ";", "\t", "|", " "]))
    header = draw(st.one_of(st.sampled_from(GOOD_HEADERS), st.lists(words, min_size=1, max_size=5)))
    with_header = draw(st.booleans())
    ncols = len(header)
    nrows = draw(st.integers(0, 60))
    sp, sl = draw(st.sampled_from(SCALES)), draw(st.sampled_from(SCALES))
    th = 2 * np.pi * np.arange(nrows) / max(nrows, 1)
    pos = (sp * 50 * (1 - np.cos(th))).tolist()
    load = (sl * (8000 + 2000 * np.tanh(4 * np.sin(th)))).tolist()
    hostile_rate = draw(st.sampled_from([0, 0, 20, 5]))
    lines = [sep.join(h.replace(sep, "_") for h in header)] if with_header else []
    for i in range(nrows):
        row = []
        for name in header:
            if "load" in name.lower():
                row.append(repr(load[i]))
            elif "card" in name:
                row.append("C1")
            elif name.startswith("t"):
                row.append(repr(0.1 * i))
            elif name in ("spm", "is_closure_point"):
                row.append("7" if name == "spm" else "0")
            else:
                row.append(repr(pos[i]))
        if hostile_rate and draw(st.integers(0, hostile_rate)) == 0:
            row[draw(st.integers(0, ncols - 1))] = draw(numbers)
        if hostile_rate and draw(st.integers(0, 4 * hostile_rate)) == 0:
            row = row[:-1]
        lines.append(sep.join(row))
    text = draw(st.sampled_from(["\n", "\r\n", "\r"])).join(lines)
    encoding = draw(st.sampled_from(ENCODINGS))
    try:
        data = text.encode(encoding)
    except UnicodeEncodeError:
        data = text.encode("utf-8")
    if draw(st.integers(0, 5)) == 0:  # mixed encodings: a second part in another one
        data += draw(st.sampled_from(["7,8\n", "é,ü\n"])).encode(draw(st.sampled_from(ENCODINGS)))
    return data


@st.composite
def scada(draw) -> bytes:
    n = draw(st.integers(0, 30))
    cells = draw(st.lists(numbers, min_size=n, max_size=n))
    good = [repr(float(50 * (1 - np.cos(2 * np.pi * i / max(n, 1))))) for i in range(n)]
    loads = [c if draw(st.booleans()) else g for c, g in zip(cells, good, strict=True)]
    header = "Well|SPM|Stroke Length (in)|Peak Load (lbf)|Surface Positions|Surface Loads"
    spm = draw(numbers)
    row = f"W\x07|{spm}|{draw(numbers)}|{draw(numbers)}|{','.join(good)}|{','.join(loads)}"
    return (header + "\n" + row + "\n").encode("utf-8")


@st.composite
def json_doc(draw) -> bytes:
    n = draw(st.integers(0, 30))
    values = st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(min_value=-(10**400), max_value=10**400),
        st.sampled_from([None, True, "1", [], {}]),
    )
    pos = [float(i) for i in range(n)]
    if n and draw(st.booleans()):
        pos[draw(st.integers(0, n - 1))] = draw(values)
    load = [float(5 + (i % 3)) for i in range(n)]
    doc = {"card_id": draw(words), "position": pos, "load": load, "spm": draw(values)}
    text = json.dumps(doc, allow_nan=True, default=str)
    return text.encode("utf-8")


# --------------------------------------------------------------------------- properties
@QUICK
@given(st.binary(max_size=3000))
def test_random_bytes(folder, data):
    check(folder, data)


@QUICK
@given(st.sampled_from(sorted(FIXTURES)), st.integers(0, 10_000), st.booleans())
def test_truncated_fixtures(folder, name, cut, from_start):
    data = FIXTURES[name]
    k = cut % (len(data) + 1)
    check(folder, data[k:] if from_start else data[:k], Path(name).suffix)


_inserts = st.one_of(
    st.sampled_from([t.encode("utf-8") for t in EXTREME]),
    st.sampled_from([b"\x00", b"\xff\xfe", b"\xfe\xff", b"\xef\xbb\xbf", b"\r", b"\x1b[2J",
                     "é".encode("utf-16"), b"|", b",", b";", b"\n\n", b"@data\n", b"{"]),
    st.binary(min_size=1, max_size=6),
)  # fmt: skip


@QUICK
@given(
    st.sampled_from(sorted(FIXTURES)),
    st.lists(st.tuples(st.integers(0, 10_000), _inserts, st.booleans()), min_size=1, max_size=4),
)
def test_mutated_fixtures(folder, name, edits):
    data = bytearray(FIXTURES[name])
    for at, payload, replace in edits:
        i = at % (len(data) + 1)
        if replace:
            data[i : i + len(payload)] = payload
        else:
            data[i:i] = payload
    check(folder, bytes(data), Path(name).suffix)


@QUICK
@given(delimited())
def test_hostile_tables(folder, data):
    check(folder, data)
    check(folder, data, min_samples=2)


@QUICK
@given(scada(), st.sampled_from(["surface", "both"]))
def test_hostile_scada_rows(folder, data, which):
    check(folder, data, ".txt", min_samples=2, scada_cards="surface")
    check(folder, data, ".txt", min_samples=2, format="scada", scada_cards=which)


@QUICK
@given(json_doc())
def test_hostile_json(folder, data):
    check(folder, data, ".json", min_samples=2)


@settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(10_000, 200_000), st.sampled_from(["token", "columns", "list"]))
def test_very_long_lines(folder, size, kind):
    if kind == "token":
        data = b"position,load\n" + b"1" * size + b",2\n"
    elif kind == "columns":
        data = (",".join(["1"] * (size // 2)) + "\n").encode() * 3
    else:
        values = ",".join(["1.5"] * (size // 4))
        data = f"Well|Surface Positions|Surface Loads\nW|{values}|{values}\n".encode()
    check(folder, data)
    check(folder, b'position,load\n"' + b"x" * size + b'",1\n')


@pytest.mark.parametrize(
    "text",
    [
        "position,position,load\n" + "".join(f"{i % 9},{i % 5},{i % 7}\n" for i in range(30)),
        "position,,load,\n" + "".join(f"{i % 9},,{i % 7},\n" for i in range(30)),
        ",,\n" * 30,
        "load,load\n" + "1,2\n" * 30,
        "\n".join(["1e308 1e308"] * 30),
        "\n".join(["5e-324 -0.0"] * 30),
        "\n".join(f"{(-1) ** i * 1.7e308!r},{i}" for i in range(30)),
    ],
)
def test_duplicate_headers_empty_columns_and_extremes(folder, text):
    check(folder, text.encode())
    check(folder, text.encode("utf-16"), min_samples=2)


def test_a_padded_card_is_read_without_its_padding(tmp_path) -> None:
    # A card whose last fifth repeats (0, 0) (39 of the public oilfield set's cards) was
    # fitted as a fifth of the stroke, its period spread over every sample.
    import numpy as np

    import pumpid
    from pumpid.cards import read_cards

    x = np.linspace(0.0, 2 * np.pi, 200, endpoint=False)
    pos, load = np.r_[30 - 30 * np.cos(x), np.zeros(50)], np.r_[5 + 2 * np.sin(x), np.zeros(50)]

    def written(name: str, n: int) -> object:
        path = tmp_path / name
        path.write_text("position_in,load_klbf\n" + "".join(
            f"{a:.6f},{b:.6f}\n" for a, b in zip(pos[:n], load[:n], strict=True)),
            encoding="utf-8")
        return path

    (card,) = read_cards(written("padded.csv", 250), spm=6)
    (plain,) = read_cards(written("plain.csv", 200), spm=6)
    assert card.n == 200 and not card.warnings
    assert any("padding dropped: the last 50 of 250 samples repeated one point (position 0 "
               "in, load 0 klbf) (lines 202-251)" in n for n in card.notes)
    np.testing.assert_array_equal(card.position, plain.position)
    np.testing.assert_allclose(card.t, plain.t)  # the stroke's 10 s over its 200 samples
    assert pumpid.fit(pumpid.Kelvin, card).cost == pumpid.fit(pumpid.Kelvin, plain).cost
    # A card that is mostly padding is refused, saying why it is short.
    from pumpid.cards import CardError

    pos, load = pos[185:], load[185:]
    with pytest.raises(CardError, match="only 15 samples after 50 samples of padding were "
                                        "dropped, at least 20 needed"):
        read_cards(written("short.csv", 65), spm=6)
    pos, load = np.r_[30 - 30 * np.cos(x), np.zeros(50)], np.r_[5 + 2 * np.sin(x), np.zeros(50)]
    # Two samples of one point are no padding (a stroke's turn-around can hold a point).
    (card,) = read_cards(written("held.csv", 202), spm=6)
    assert card.n == 202 and not any("padding" in w for w in (*card.notes, *card.warnings))
    # Five rows of (0, 0) (under 5 % of the card: a fit of R^2 0.65, no word), and thirty
    # at the start (warned about as a frozen sensor, and fitted: a fluid load twice the
    # true one), are dropped too: the card jumps to them.
    (card,) = read_cards(written("short.csv", 205), spm=6)
    assert card.n == 200 and any("the last 5 of 205 samples" in n for n in card.notes)
    pos, load = np.r_[np.zeros(30), pos[:200]], np.r_[np.zeros(30), load[:200]]
    (card,) = read_cards(written("lead.csv", 230), spm=6)
    assert card.n == 200 and not card.warnings
    assert any("padding dropped: the first 30 of 230 samples repeated one point (position 0 "
               "in, load 0 klbf) (lines 2-31)" in n for n in card.notes)
    np.testing.assert_array_equal(card.position, plain.position)


def test_a_record_of_strokes_without_time_is_not_read_as_one_stroke(tmp_path) -> None:
    # Three strokes without a time column, given 6 SPM, were read as one stroke of 10 s:
    # periodic, the motion three times too fast, without a word.
    import numpy as np

    from pumpid.cards import read_cards, split_strokes, strokes_seen

    x = np.linspace(0.0, 2 * np.pi, 100, endpoint=False)
    one_pos, one_load = 30 - 30 * np.cos(x), 5 + 2 * np.sin(x) + 0.5 * np.sin(2 * x)
    noise = np.random.default_rng(0).normal(0.0, 0.05, 300)

    def written(name: str, pos: np.ndarray, load: np.ndarray) -> object:
        path = tmp_path / name
        path.write_text("position_in,load_klbf\n" + "".join(
            f"{a:.6f},{b:.6f}\n" for a, b in zip(pos, load, strict=True)), encoding="utf-8")
        return path

    (card,) = read_cards(written("three.csv", np.tile(one_pos, 3) + noise,
                                 np.tile(one_load, 3)), spm=6)
    assert not card.periodic and card.period == 10.0
    np.testing.assert_allclose(np.diff(card.t), 0.1)  # 10 s over each stroke's 100 samples
    assert any("holds several strokes, not one: its position rises through mid-stroke 3 "
               "times, one every 100 samples" in w for w in card.warnings)
    strokes = split_strokes(card)
    assert len(strokes) == 3 and all(abs(s.period - 10.0) < 0.2 for s in strokes)
    # The API's own rebuild says the same.
    again = card.replace(t=None, time_source="none", periodic=False, warnings=()).with_spm(6)
    assert not again.periodic and any("several strokes" in w for w in again.warnings)
    # One stroke is one stroke wherever it starts (here mid-upstroke), and the public
    # cards' strokes are each seen as one (tests/test_cards_realdata.py reads them all).
    for shift in (0, 25, 50, 75):
        (one,) = read_cards(written("one.csv", np.roll(one_pos, shift), np.roll(one_load, shift)),
                            spm=6)
        assert one.periodic and not one.warnings and strokes_seen(one.position)[0] <= 1


def test_a_frozen_stretch_is_warned_about() -> None:
    # 15 samples of one point mid-stroke (a frozen transmitter) were fitted without a word.
    import numpy as np

    from pumpid.cards import parse_cards

    x = np.linspace(0.0, 2 * np.pi, 200, endpoint=False)
    pos, load = 30 - 30 * np.cos(x), 5 + 2 * np.sin(x)
    pos[80:95], load[80:95] = pos[80], load[80]

    def read(p: np.ndarray, f: np.ndarray) -> object:
        return parse_cards("position_in,load_klbf\n" + "".join(
            f"{a:.6f},{b:.6f}\n" for a, b in zip(p, f, strict=True)), spm=6)[0]

    card = read(pos, load)
    assert card.n == 200
    assert any("its samples 80-94 (counted from 0, 15 of 200) repeat one point (position "
               "54.27 in, load 6.176 klbf): a frozen sensor or a stopped unit?" in w
               for w in card.warnings)
    # Below 5 % of the card (a turn-around held for a few samples) it is no warning.
    pos, load = 30 - 30 * np.cos(x), 5 + 2 * np.sin(x)
    pos[80:88], load[80:88] = pos[80], load[80]
    assert not any("repeat one point" in w for w in read(pos, load).warnings)


def test_a_stroke_no_pumping_unit_has_is_warned_about() -> None:
    # A time column in milliseconds named plainly "time" gave a stroke of 4 hours and a
    # displacement a thousand times too small, without a word.
    import numpy as np

    from pumpid.cards import parse_cards

    x = np.linspace(0.0, 2 * np.pi, 143, endpoint=False)
    pos, load = 2 - 2 * np.cos(x), 20 + 5 * np.sin(x)
    t = np.arange(143) * 15.0 / 143 * 1000

    def table(time_name: str) -> str:
        return f"{time_name},position_m,load_kN\n" + "".join(
            f"{a:.3f},{b:.5f},{c:.4f}\n" for a, b, c in zip(t, pos, load, strict=True))

    (card,) = parse_cards(table("time"))
    assert any("its stroke lasts 1.5e+04 s (0.004 strokes/min) by its time column 'time': "
               "no pumping unit runs at that speed (0.5-40 strokes/min); a time in "
               "milliseconds read as seconds?" in w for w in card.warnings)
    (card,) = parse_cards(table("time_ms"))  # its unit named: 15 s, no warning
    assert abs(card.period - 15.0) < 1e-6 and not card.warnings
    plain = "position_m,load_kN\n" + "".join(
        f"{b:.5f},{c:.4f}\n" for b, c in zip(pos, load, strict=True))
    (card,) = parse_cards(plain, spm=0.1)
    assert any("by the stroke rate (given by the caller)" in w and "check the stroke rate" in w
               for w in card.warnings)
    assert not parse_cards(plain, spm=6)[0].warnings


def test_a_loggers_jitter_is_still_one_stroke(tmp_path) -> None:
    # Timestamps with 5 % jitter made the same stroke a record fitted from rest (another
    # status, c1 30.5 -> 6259) with nothing said why.
    import numpy as np

    from pumpid.cards import parse_cards

    x = np.linspace(0.0, 2 * np.pi, 93, endpoint=False)
    pos, load = 30 - 30 * np.cos(x), 5000 + 2000 * np.sin(x) + 300 * np.sin(2 * x)
    t = np.arange(93) * 0.075 + np.random.default_rng(0).uniform(-0.05, 0.05, 93) * 0.075

    def card(times: np.ndarray, keep: slice = slice(None)) -> object:
        return parse_cards("t_s,position_in,load_lbf\n" + "".join(
            f"{a:.6f},{b:.5f},{c:.3f}\n"
            for a, b, c in zip(times[keep], pos[keep], load[keep], strict=True)))[0]

    jittered = card(t)
    assert jittered.periodic and jittered.period == pytest.approx(93 * 0.075, rel=2e-3)
    assert "s apart on average, each step within" in jittered.notes[-1]
    # Given the uniform times its logger meant (the downhole solvers refused the card).
    assert jittered.dt == pytest.approx(jittered.period / 93)
    assert "taken as uniform, t_i = t_0 + i*dt" in jittered.notes[-1]
    # A gap (a sample missing: one step of two) is no jitter: a record, as before.
    gap = card(np.arange(93) * 0.075, np.r_[0:40, 41:93])
    assert not gap.periodic


def test_a_record_of_strokes_no_pumping_unit_has_is_warned_about_too() -> None:
    # Three strokes with a time column in milliseconds named "time": strokes of 10,000 s,
    # and no word (the check ran on single strokes only).
    import numpy as np

    from pumpid.cards import parse_cards

    x = np.linspace(0.0, 6 * np.pi, 300, endpoint=False)
    pos, load = 2 - 2 * np.cos(x), 20 + 5 * np.sin(x)
    t = np.arange(300) * 10.0 / 100 * 1000
    (card,) = parse_cards("time,position_m,load_kN\n" + "".join(
        f"{a:.3f},{b:.5f},{c:.4f}\n" for a, b, c in zip(t, pos, load, strict=True)))
    assert not card.periodic
    assert any("its stroke lasts 1e+04 s (0.006 strokes/min) by its time column 'time'" in w
               for w in card.warnings), card.warnings
