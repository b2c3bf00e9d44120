"""Property-based tests of the card readers.

Whatever bytes they are given, the readers either return valid cards or raise CardError with
a message; never another exception. Round trips through CSV and JSON keep values exactly.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pumpid.cards import (
    FORMATS,
    Card,
    CardError,
    convert_load,
    convert_position,
    parse_cards,
    split_strokes,
    strokes_seen,
)

DATA = Path(__file__).parent / "data" / "cards"
FIXTURES = {p.name: p.read_bytes() for p in sorted(DATA.iterdir()) if p.is_file()}

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def check_outcome(data: bytes | str, **options) -> list[Card] | None:
    """Read and assert the only outcomes are valid cards or a CardError with a message."""
    try:
        cards = parse_cards(data, name="fuzz.dat", **options)
    except CardError as exc:
        assert str(exc).strip(), "CardError without a message"
        assert exc.reason.strip()
        return None
    assert isinstance(cards, list) and cards
    for card in cards:
        assert isinstance(card, Card)
        assert card.n >= options.get("min_samples", 20)
        assert card.position.shape == card.load.shape == (card.n,)
        assert np.all(np.isfinite(card.position)) and np.all(np.isfinite(card.load))
        assert card.load.max() > card.load.min()
        if card.t is not None:
            assert card.t.shape == (card.n,) and np.all(np.diff(card.t) > 0)
        assert card.notes and all(isinstance(n, str) and n for n in card.notes)
    return cards


@FAST
@given(st.binary(max_size=2000))
def test_arbitrary_bytes(data):
    check_outcome(data)


@FAST
@given(
    st.text(alphabet=st.sampled_from(list('0123456789.,;|:\t\n -+eE@#[]{}"nainf?')), max_size=600)
)
def test_arbitrary_text_from_card_characters(text):
    check_outcome(text)


@settings(max_examples=40, deadline=None)
@given(st.binary(max_size=400), st.sampled_from([*FORMATS, "tsv", "sktime"]))
def test_arbitrary_bytes_forced_format(data, fmt):
    check_outcome(data, format=fmt)


def _mutate(data: bytes, ops: list[tuple[int, int, int, bytes]]) -> bytes:
    out = bytearray(data)
    for kind, a, b, payload in ops:
        if not out:
            out.extend(payload)
            continue
        i, j = sorted((a % len(out), b % len(out)))
        if kind == 0:  # delete a slice
            del out[i : j + 1]
        elif kind == 1:  # insert bytes
            out[i:i] = payload
        elif kind == 2:  # overwrite one byte
            out[i] = payload[0] if payload else 0x20
        elif kind == 3:  # duplicate a slice (e.g. a line)
            out[j:j] = out[i:j]
        elif kind == 4:  # truncate
            del out[j:]
        else:  # swap two bytes
            out[i], out[j] = out[j], out[i]
    return bytes(out)


_interesting = st.sampled_from(
    [b"nan", b"inf", b"-", b",", b";", b"|", b":", b"\n", b"\t", b"?", b"1e999", b"\x00",
     b"\xff", b"[", b"{", b"\"", b"@data\n", b"E-03", b"0", b"9", b".", b" ", b"true", b"null"]
)  # fmt: skip
_ops = st.lists(
    st.tuples(
        st.integers(0, 5),
        st.integers(0, 10_000),
        st.integers(0, 10_000),
        st.one_of(_interesting, st.binary(min_size=1, max_size=8)),
    ),
    min_size=1,
    max_size=4,
)


@settings(max_examples=120, deadline=None)
@given(st.sampled_from(sorted(FIXTURES)), _ops, st.booleans())
def test_mutated_fixtures(name, ops, force):
    data = _mutate(FIXTURES[name], ops)
    fmt = None
    if force:
        fmt = {".csv": "csv", ".tsv": "tsv", ".json": "json", ".dat": "whitespace",
               ".ts": "ts", ".txt": "scada"}[Path(name).suffix]  # fmt: skip
    check_outcome(data, format=fmt)


def test_unmutated_fixtures_read():
    for name, data in FIXTURES.items():
        assert check_outcome(data), name


finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@st.composite
def card_arrays(draw):
    n = draw(st.integers(20, 60))
    pos = draw(st.lists(finite, min_size=n, max_size=n))
    load = draw(st.lists(finite, min_size=n, max_size=n))
    # Constant signals are rejected by design; make sure these are not constant.
    pos[0], pos[1] = -1.5, 2.5
    load[0], load[1] = 100.0, 250.0
    # Nor padding: a run of one point at the end is dropped by design.
    pos[-2] = 1.25 if pos[-1] != 1.25 else -1.25
    return np.array(pos), np.array(load)


@settings(max_examples=40, deadline=None)
@given(card_arrays(), st.sampled_from([",", ";", "\t", " "]))
def test_table_round_trip_is_exact(arrays, sep):
    pos, load = arrays
    header = f"position_in{sep}load_lbf" if sep != " " else "position load"
    lines = [header] + [
        f"{x!r}{sep}{f!r}" for x, f in zip(pos.tolist(), load.tolist(), strict=True)
    ]
    cards = parse_cards("\n".join(lines), name="rt.txt", drop_closing_point=False)
    assert len(cards) == 1
    np.testing.assert_array_equal(cards[0].position, pos)
    np.testing.assert_array_equal(cards[0].load, load)


@settings(max_examples=40, deadline=None)
@given(card_arrays(), st.floats(0.5, 30.0))
def test_json_round_trip_and_time_rule(arrays, spm):
    pos, load = arrays
    doc = json.dumps({"position": pos.tolist(), "load": load.tolist(), "spm": spm})
    (card,) = parse_cards(doc, name="rt.json", drop_closing_point=False)
    np.testing.assert_array_equal(card.position, pos)
    period = 60.0 / spm
    assert card.time_source == "spm"
    rises, per_stroke = strokes_seen(pos)
    if rises < 2:  # one stroke: its samples span the period
        np.testing.assert_allclose(card.t, np.arange(card.n) * period / card.n, rtol=1e-12)
        assert card.periodic and not any("several strokes" in w for w in card.warnings)
    else:  # several: each stroke's samples span it
        np.testing.assert_allclose(card.t, np.arange(card.n) * period / per_stroke, rtol=1e-12)
        assert not card.periodic and any("several strokes" in w for w in card.warnings)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(finite, min_size=1, max_size=10),
    st.sampled_from(["in", "ft", "m", "mm", "cm"]),
    st.sampled_from(["in", "ft", "m", "mm", "cm"]),
    st.sampled_from(["lbf", "klbf", "N", "kN", "kgf", "daN"]),
    st.sampled_from(["lbf", "klbf", "N", "kN", "kgf", "daN"]),
)
def test_unit_round_trips(values, p1, p2, l1, l2):
    x = np.array(values)
    np.testing.assert_allclose(
        convert_position(convert_position(x, p1, p2), p2, p1), x, rtol=1e-12, atol=1e-9
    )
    np.testing.assert_allclose(
        convert_load(convert_load(x, l1, l2), l2, l1), x, rtol=1e-12, atol=1e-9
    )


@settings(max_examples=30, deadline=None)
@given(
    st.integers(2, 6),
    st.integers(30, 80),
    st.floats(0.0, 2 * np.pi),
    st.floats(0.0, 0.01),
    st.integers(0, 2**16),
)
def test_split_strokes_counts_full_strokes(k, n, phase, noise, seed):
    rng = np.random.default_rng(seed)
    i = np.arange(k * n + 1)
    th = 2 * np.pi * i / n + phase
    pos = 1 - np.cos(th) + noise * rng.standard_normal(i.size)
    load = 5 + np.sin(th)
    card = Card(position=pos, load=load, t=i * 0.05, time_source="file", card_id="r")
    strokes = split_strokes(card)
    # Between k and k-1 complete strokes fit in k periods, depending on where the record starts.
    assert k - 1 <= len(strokes) <= k
    for s in strokes:
        assert abs(s.n - n) <= max(2, n // 10)
        assert s.periodic and s.card_id.startswith("r#")
