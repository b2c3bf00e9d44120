"""Recognising the position and load columns of headerless tables.

Synthetic cards of many shapes (seeded and hypothesis-drawn), in both column orders, with and
without an angle or index column, through the detector and through the readers; and inputs
where no honest decision exists, which must be refused.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pumpid.cards import (
    ROLE_CONFIDENCE_MIN,
    CardError,
    ColumnRoles,
    detect_column_roles,
    parse_cards,
)


def synthetic_card(rng: np.random.Generator, n: int | None = None):
    """A made-up polished-rod card: kinematic position, fluid load picked up and released."""
    n = int(rng.integers(30, 400)) if n is None else n
    th = 2 * np.pi * np.arange(n) / n + rng.uniform(-0.2, 0.2)
    stroke = 10 ** rng.uniform(-0.5, 2.3)
    pos = stroke * (0.5 * (1 - np.cos(th)) + 0.5 * rng.uniform(0, 0.15) * np.sin(2 * th))
    pos -= pos.min() - rng.uniform(-0.02, 0.05) * stroke
    phase = (th / (2 * np.pi)) % 1.0
    up, down = rng.uniform(0.02, 0.15), rng.uniform(0.45, 0.75)
    pickup = 0.5 * (1 + np.tanh((phase - up) / rng.uniform(0.01, 0.05)))
    release = 0.5 * (1 + np.tanh((phase - down) / rng.uniform(0.01, 0.08)))
    rods = 10 ** rng.uniform(0, 4.5)
    fluid = rods * rng.uniform(0.2, 1.0)
    ripple = (
        rng.uniform(0, 0.15)
        * fluid
        * np.sin(2 * np.pi * rng.integers(2, 9) * phase + rng.uniform(0, 6))
    )
    load = rods + fluid * pickup * (1 - release) + ripple
    pos = pos + rng.uniform(0, 0.003) * stroke * rng.standard_normal(n)
    load = load + rng.uniform(0, 0.02) * fluid * rng.standard_normal(n)
    return pos, load


def arrange(pos, load, swap: bool, extra: str | None, rng: np.random.Generator):
    """Columns in the requested order; where position and load ended up."""
    cols = [load, pos] if swap else [pos, load]
    if extra == "angle":
        cols.insert(0, np.arange(pos.size) * 365.0 / pos.size)
    elif extra == "index":
        cols.insert(int(rng.integers(0, 3)), np.arange(pos.size, dtype=float))
    p = next(k for k, c in enumerate(cols) if c is pos)
    q = next(k for k, c in enumerate(cols) if c is load)
    return cols, p, q


@pytest.mark.parametrize("swap", [False, True])
@pytest.mark.parametrize("extra", [None, "angle", "index"])
def test_seeded_synthetic_cards_both_orders(swap, extra):
    rng = np.random.default_rng(7 + 3 * swap + hash(extra) % 5)
    confident = 0
    for _ in range(150):
        pos, load = synthetic_card(rng)
        cols, p, q = arrange(pos, load, swap, extra, rng)
        roles = detect_column_roles(cols)
        if roles.confidence >= ROLE_CONFIDENCE_MIN:
            confident += 1
            # Never wrong when it is sure.
            assert (roles.position, roles.load) == (p, q), roles
        if extra is not None:
            assert "monotone" in roles.other[next(k for k in range(3) if k not in (p, q))]
    assert confident >= 145  # a few near-elliptical cards may be refused, not misread


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans(), st.sampled_from([None, "angle", "index"]))
def test_hypothesis_cards_never_misread_confidently(seed, swap, extra):
    rng = np.random.default_rng(seed)
    pos, load = synthetic_card(rng)
    cols, p, q = arrange(pos, load, swap, extra, rng)
    roles = detect_column_roles(np.column_stack(cols))
    assert 0.0 <= roles.confidence <= 1.0
    if roles.confidence >= ROLE_CONFIDENCE_MIN:
        assert (roles.position, roles.load) == (p, q)


def test_multi_stroke_record_and_extra_columns():
    rng = np.random.default_rng(11)
    pos, load = synthetic_card(rng, n=120)
    pos, load = np.tile(pos, 4), np.tile(load, 4)
    spm = np.full(pos.size, 8.5)  # constant: neither role
    flag = (np.arange(pos.size) % 120 == 119).astype(float)  # two values: a flag
    noise = rng.standard_normal(pos.size)  # no structure: not a load
    roles = detect_column_roles([spm, load, noise, flag, pos])
    assert (roles.position, roles.load) == (4, 1)
    assert roles.confidence >= 0.95
    assert roles.other[0] == "constant" and "flag" in roles.other[3]
    assert "not chosen" in roles.other[2]


def test_magnitudes_and_scale_do_not_matter():
    rng = np.random.default_rng(3)
    pos, load = synthetic_card(rng, n=100)
    base = detect_column_roles([load, pos])
    for scale in (1e-300, 1e-6, 1e6, 1e300):
        roles = detect_column_roles([load * scale, pos / scale])
        assert (roles.position, roles.load) == (1, 0)
        assert roles.confidence == pytest.approx(base.confidence, rel=1e-6)


AMBIGUOUS = {
    "ellipse": lambda th, rng: (1 - np.cos(th), np.sin(th)),
    "two positions": lambda th, rng: (1 - np.cos(th), 1 - np.cos(th + 1.0)),
    "white noise": lambda th, rng: (rng.standard_normal(th.size), rng.standard_normal(th.size)),
    "random walks": lambda th, rng: (
        np.cumsum(rng.standard_normal(th.size)),
        np.cumsum(rng.standard_normal(th.size)),
    ),
}


@pytest.mark.parametrize("kind", sorted(AMBIGUOUS))
def test_ambiguous_pairs_get_low_confidence(kind):
    rng = np.random.default_rng(5)
    for n in (30, 80, 250):
        th = 2 * np.pi * np.arange(n) / n
        a, b = AMBIGUOUS[kind](th, rng)
        assert detect_column_roles([a, b]).confidence < ROLE_CONFIDENCE_MIN
        assert detect_column_roles([b * 1e3, a]).confidence < ROLE_CONFIDENCE_MIN


@pytest.mark.parametrize(
    ("cols", "fragment"),
    [
        ([np.arange(50.0), np.arange(50.0) * 2], r"0 column\(s\) could be position or load"),
        ([np.ones(50), np.sin(np.arange(50.0))], r"1 column\(s\)"),
        ([np.r_[np.ones(25), np.zeros(25)], np.sin(np.arange(50.0))], "distinct values"),
        ([np.arange(5.0), np.arange(5.0)], "too few"),
        ([np.full(30, np.nan), np.arange(30.0)], "too few"),
    ],
)
def test_impossible_inputs_raise(cols, fragment):
    with pytest.raises(CardError, match=fragment):
        detect_column_roles(cols)


def test_result_record():
    rng = np.random.default_rng(2)
    pos, load = synthetic_card(rng, n=90)
    roles = detect_column_roles([np.arange(90.0), pos, load])
    assert isinstance(roles, ColumnRoles)
    meta = roles.to_metadata()
    assert meta["position"] == 1 and meta["load"] == 2
    assert meta["words"] in ("high", "very high") and "shape" in meta["method"]
    assert meta["other"] == {0: "monotone (angle, index or time)"}


# --------------------------------------------------------------------------- through readers
def text_table(cols, sep=","):
    rows = zip(*(np.asarray(c, dtype=float).tolist() for c in cols), strict=True)
    return "\n".join(sep.join(repr(v) for v in row) for row in rows) + "\n"


@pytest.mark.parametrize("sep", [",", "\t", " ", ";"])
@pytest.mark.parametrize("swap", [False, True])
@pytest.mark.parametrize("angle", [False, True])
def test_readers_detect_roles_of_headerless_tables(sep, swap, angle):
    rng = np.random.default_rng(100 + 2 * swap + angle)
    pos, load = synthetic_card(rng, n=72)
    cols, p, q = arrange(pos, load, swap, "angle" if angle else None, rng)
    (card,) = parse_cards(text_table(cols, sep), name="h.txt", drop_closing_point=False)
    np.testing.assert_array_equal(card.position, pos)
    np.testing.assert_array_equal(card.load, load)
    roles = card.metadata["column_roles"]
    assert (roles["position"], roles["load"]) == (p, q)
    assert any(f"column {p} read as position and column {q} as load" in n for n in card.notes)
    if angle:
        assert card.metadata["column_0"].shape == (72,)  # kept, aligned with the samples


def test_readers_refuse_ambiguous_tables_naming_file_and_columns_option():
    th = 2 * np.pi * np.arange(60) / 60
    text = text_table([1 - np.cos(th), np.sin(th)])
    with pytest.raises(CardError) as info:
        parse_cards(text, name="ellipse.txt")
    msg = str(info.value)
    assert msg.startswith("ellipse.txt: ") and "cannot be told with confidence" in msg
    assert "columns={'position': " in msg and "--columns position=" in msg
    rng = np.random.default_rng(0)
    noise = text_table([rng.standard_normal(60), rng.standard_normal(60)])
    with pytest.raises(CardError, match="cannot be told with confidence"):
        parse_cards(noise, name="noise.txt")
    with pytest.raises(CardError, match=r"cannot be recognised: 0 column\(s\)"):
        parse_cards(text_table([np.arange(40.0), np.arange(40.0) ** 2]), name="mono.txt")


def test_explicit_columns_always_win():
    rng = np.random.default_rng(4)
    pos, load = synthetic_card(rng, n=60)
    text = text_table([pos, load])
    (card,) = parse_cards(text, name="x.txt", columns={"position": 1, "load": 0})
    np.testing.assert_array_equal(card.position, load)  # obeyed, though it looks wrong
    assert card.metadata["column_roles"]["method"] == "given by the caller (columns=)"
    assert any("look swapped" in w for w in card.warnings)
    th = 2 * np.pi * np.arange(60) / 60
    (card,) = parse_cards(
        text_table([1 - np.cos(th), np.sin(th)]), name="e.txt", columns={"position": 0, "load": 1}
    )
    assert card.metadata["column_roles"]["confidence"] == 1.0


def test_given_time_column_and_detected_roles():
    rng = np.random.default_rng(8)
    pos, load = synthetic_card(rng, n=64)
    t = np.arange(64) * 0.125
    (card,) = parse_cards(text_table([load, t, pos]), name="t.txt", columns={"t": 1})
    assert card.time_source == "file" and card.dt == pytest.approx(0.125)
    np.testing.assert_array_equal(card.position, pos)
    assert card.metadata["column_roles"]["other"] == {1: "given role 't'"}


def test_short_headerless_table_reports_its_length_not_the_roles():
    rng = np.random.default_rng(1)
    pos, load = synthetic_card(rng, n=12)
    with pytest.raises(CardError, match="only 12 samples"):
        parse_cards(text_table([pos, load]), name="s.txt")


@pytest.mark.parametrize(
    "values", [[[1.0, 2.0], [1.0]], [["a", "b"], [1.0, 2.0]], np.arange(10.0), [object()]]
)
def test_bad_input_to_the_detector(values):
    with pytest.raises(CardError):
        detect_column_roles(values)
