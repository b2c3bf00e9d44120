"""Every card of a multi-card file is read on its own: a broken card never costs the others.

A property test writes several valid cards in every layout, breaks one value (or the
length of one list) inside one card, and checks that every other card reads exactly as
from the intact file, while the broken card is an error naming the file, its line (where
the layout has lines), the field and the card.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pumpid.cards import CardError, parse_cards, parse_cards_and_errors, read_cards_and_errors


@dataclass
class Source:
    ids: list[str]
    pos: list[list[str]]  # numbers as written, one list per card
    load: list[list[str]]


def cards_of(n_cards: int, n: int, seed: int) -> Source:
    rng = np.random.default_rng(seed)
    th = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    ids, pos, load = [], [], []
    for k in range(n_cards):
        stroke = rng.uniform(40, 120)
        p = stroke / 2 * (1 - np.cos(th))
        ld = rng.uniform(4000, 9000) + rng.uniform(1000, 3000) * np.sin(th + 0.3)
        ids.append(f"C{k}")
        pos.append([f"{v:.4f}" for v in p])
        load.append([f"{v:.3f}" for v in ld])
    return Source(ids, pos, load)


# --------------------------------------------------------------------------- layouts
# Each writer returns (text, file name, 1-based line of (card k, sample i) or None).
def _rows(src: Source, sep: str, header: str) -> tuple[str, dict[tuple[int, int], int]]:
    lines = [header]
    where = {}
    for k, cid in enumerate(src.ids):
        for i, (p, ld) in enumerate(zip(src.pos[k], src.load[k], strict=True)):
            lines.append(sep.join((cid, p, ld)))
            where[(k, i)] = len(lines)
    return "\n".join(lines) + "\n", where


def table(sep: str, name: str):
    def write(src: Source) -> tuple[str, str, dict[tuple[int, int], int] | None]:
        head = sep.join(("card_id", "position_in", "load_lbf")) if sep != " " else \
            "card_id position_in load_lbf"
        text, where = _rows(src, sep, head)
        return text, name, where

    return write


def scada(src: Source) -> tuple[str, str, dict[tuple[int, int], int] | None]:
    lines = ["Well|Card ID|Surface Positions (in)|Surface Loads (lbf)|Downhole Positions|"
             "Downhole Loads"]
    where = {}
    for k, cid in enumerate(src.ids):
        p, ld = ",".join(src.pos[k]), ",".join(src.load[k])
        lines.append(f"W1|{cid}|{p}|{ld}|{p}|{ld}")
        for i in range(len(src.pos[k])):
            where[(k, i)] = len(lines)
    return "\n".join(lines) + "\n", "export.txt", where


def as_json(src: Source) -> tuple[str, str, dict[tuple[int, int], int] | None]:
    # Numbers written as text here, so that a mutation can put any token in their place.
    cards = [f'{{"card_id": "{cid}", "position": [{", ".join(src.pos[k])}], '
             f'"load": [{", ".join(src.load[k])}]}}' for k, cid in enumerate(src.ids)]
    return '{"units": {"position": "in", "load": "lbf"}, "cards": [\n' + ",\n".join(cards) \
        + "\n]}\n", "cards.json", None


def ts(src: Source) -> tuple[str, str, dict[tuple[int, int], int] | None]:
    lines = ["@problemName cards", "@univariate false", "@dimensions 2", "@data"]
    where = {}
    for k in range(len(src.ids)):
        lines.append(f"{','.join(src.pos[k])}:{','.join(src.load[k])}")
        for i in range(len(src.pos[k])):
            where[(k, i)] = len(lines)
    return "\n".join(lines) + "\n", "cards.ts", where


LAYOUTS = {
    "csv": table(",", "cards.csv"),
    "tsv": table("\t", "cards.tsv"),
    "semicolon": table(";", "cards.csv"),
    "pipe table": table("|", "cards.csv"),
    "whitespace": table(" ", "cards.txt"),
    "scada": scada,
    "json": as_json,
    "ts": ts,
}

# Tokens that break a card in every layout (JSON: NaN/Infinity are literals there).
BAD = {"nan": "NaN", "inf": "Infinity", "text": "abc", "two dots": "1.2.3"}


def ids_of(src_ids: list[str], layout: str) -> list[str]:
    return [f"cards[{k}]" for k in range(len(src_ids))] if layout == "ts" else src_ids


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    layout=st.sampled_from(sorted(LAYOUTS)),
    n_cards=st.integers(2, 4),
    n=st.integers(20, 32),
    seed=st.integers(0, 10_000),
    data=st.data(),
)
def test_a_broken_card_costs_only_itself(layout, n_cards, n, seed, data):
    src = cards_of(n_cards, n, seed)
    text, name, where = LAYOUTS[layout](src)
    intact = parse_cards(text, name=name)
    assert [c.card_id for c in intact] == ids_of(src.ids, layout)

    k = data.draw(st.integers(0, n_cards - 1), label="broken card")
    i = data.draw(st.integers(0, n - 1), label="sample")
    kind = data.draw(st.sampled_from([*BAD, "extra value"] if layout in ("scada", "json", "ts")
                                     else [*BAD]), label="mutation")
    which = data.draw(st.sampled_from(["pos", "load"]), label="list")
    target = getattr(src, which)[k]
    if kind == "extra value":  # positions and loads of different lengths
        target.insert(i, target[i])
    else:
        token = BAD[kind]
        # JSON: NaN/Infinity are literals, nan/inf/abc/1.2.3 bare tokens (not JSON at all)
        lower = layout != "json" or data.draw(st.booleans(), label="bare token")
        target[i] = token.lower() if lower and kind in ("nan", "inf") else token
    broken_text, _, _ = LAYOUTS[layout](src)

    read = parse_cards_and_errors(broken_text, name=name)
    expected_ids = ids_of(src.ids, layout)
    assert [c.card_id for c in read.cards] == [c for j, c in enumerate(expected_ids) if j != k]
    for card in read.cards:
        before = intact[expected_ids.index(card.card_id)]
        np.testing.assert_array_equal(card.position, before.position)
        np.testing.assert_array_equal(card.load, before.load)
        # (the once-per-file unknown-unit note goes to the file's first good card)
        assert [n for n in card.notes if "not stated" not in n] == \
            [n for n in before.notes if "not stated" not in n]
        assert (card.position_unit, card.load_unit) == (before.position_unit, before.load_unit)
    (error,) = read.errors
    assert error.card_id == expected_ids[k]
    assert error.path == name and error.field
    if where is not None:
        assert error.line == where[(k, i)]
    assert [type(x).__name__ for x in read.items].index("CardError") == k  # in file order
    # read_cards keeps its contract: the first problem is raised.
    with pytest.raises(CardError):
        parse_cards(broken_text, name=name)


def test_a_bad_value_in_an_unused_field_refuses_its_card_only():
    src = cards_of(3, 24, 1)
    text, name, _ = scada(src)
    lines = text.splitlines()
    fields = lines[2].split("|")
    fields[4] = fields[4].replace(",", ",x,", 1)  # Downhole Positions of C1
    lines[2] = "|".join(fields)
    read = parse_cards_and_errors("\n".join(lines), name=name)
    assert [c.card_id for c in read.cards] == ["C0", "C2"]
    (error,) = read.errors
    assert (error.card_id, error.well_id, error.line) == ("C1", "W1", 3)
    assert error.field == "Downhole Positions[1]"
    # the caller's well wins on a refused card as on the others
    read = parse_cards_and_errors("\n".join(lines), name=name, well_id="W9")
    assert {c.well_id for c in read.cards} == {read.errors[0].well_id} == {"W9"}


def test_a_ragged_row_and_separate_blocks_refuse_their_cards_only():
    src = cards_of(3, 24, 2)
    text, name, where = table(",", "c.csv")(src)
    lines = text.splitlines()
    lines[where[(0, 5)] - 1] = "C0,1.0"  # one field missing
    read = parse_cards_and_errors("\n".join(lines), name=name)
    assert [c.card_id for c in read.cards] == ["C1", "C2"]
    assert read.errors[0].line == where[(0, 5)] and read.errors[0].card_id == "C0"
    # C1's last row moved below C2: C1 is in two blocks; C0 and C2 are still read.
    lines = text.splitlines()
    moved = lines.pop(where[(1, 23)] - 1)
    lines.append(moved)
    read = parse_cards_and_errors("\n".join(lines), name=name)
    assert [c.card_id for c in read.cards] == ["C0", "C2"]
    assert "two separate blocks" in read.errors[0].reason and read.errors[0].card_id == "C1"


def test_whole_file_problems_are_still_raised(tmp_path):
    with pytest.raises(CardError, match="no position"):
        parse_cards_and_errors("card_id,a,b\nx,1,2\n", name="h.csv")
    with pytest.raises(CardError, match="invalid JSON: nested deeper"):
        parse_cards_and_errors("[" * 100_000 + "]" * 100_000, name="deep.json")
    with pytest.raises(CardError, match=r"line 1: invalid JSON: Expecting ',' delimiter"):
        parse_cards_and_errors('[{"a": 1]', name="s.json")  # structure, not a value
    with pytest.raises(CardError, match="property name"):
        parse_cards_and_errors('[{"card_id": "A", position: [1, 2]}]', name="k.json")
    with pytest.raises(CardError, match="line 2, field 'site': unparsable value 'nowhere'"):
        parse_cards_and_errors('{"cards": [],\n "site": nowhere}', name="t.json")


def test_a_bare_unparsable_json_value_costs_its_card_only():
    src = cards_of(3, 24, 5)
    src.pos[1][4] = "nan"
    text, name, _ = as_json(src)
    text = text.replace('"card_id": "C2", ', '"card_id": "C2", "operator": J. Doe, ')
    read = parse_cards_and_errors(text, name=name)
    assert [c.card_id for c in read.cards] == ["C0"]
    assert [(e.card_id, e.line, e.field, e.reason) for e in read.errors] == [
        ("C1", 3, "cards[1].position[4]", "unparsable value 'nan'"),
        ("C2", 4, "cards[2].operator", "unparsable value 'J. Doe'")]


def test_a_lone_surrogate_id_is_escaped_with_a_note(tmp_path):
    src = cards_of(2, 24, 3)
    doc = [{"card_id": cid, "position": [float(v) for v in src.pos[k]],
            "load": [float(v) for v in src.load[k]]} for k, cid in enumerate(["A\ud800", "B"])]
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))  # ensure_ascii: the file holds the escape \ud800
    cards = read_cards_and_errors(path).cards
    assert cards[0].card_id == "A\\ud800"
    cards[0].card_id.encode("utf-8")  # valid text for every writer
    assert any("lone surrogate" in n for n in cards[0].notes)


def test_non_regular_files_are_refused_not_read(tmp_path):
    import os

    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(CardError, match="named pipe"):  # would block forever if opened
        read_cards_and_errors(fifo)
    with pytest.raises(CardError, match="character device"):
        read_cards_and_errors("/dev/null")


def test_no_time_is_said_in_words():
    src = cards_of(1, 24, 4)
    text, name, _ = table(",", "c.csv")(src)
    (card,) = parse_cards(text, name=name)
    assert not any("t is None" in n for n in card.notes)
    assert any("no time axis" in n and "--spm" in n for n in card.notes)


def test_strict_reader_says_the_rest_of_the_file_is_fine():
    src = cards_of(3, 30, seed=7)
    src.load[1][5] = "nan"
    text, _ = _rows(src, ",", "card_id,position_in,load_lbf")
    with pytest.raises(CardError) as info:
        parse_cards(text, name="export.csv")
    message = str(info.value)
    assert "export.csv" in message and "line 37" in message
    assert "2 cards of this file passed their checks" in message
    assert "parse_cards_and_errors keeps them" in message
    assert info.value.card_id == "C1"


def test_strict_reader_of_one_broken_card_gives_its_error_alone():
    src = cards_of(1, 30, seed=8)
    src.load[0][3] = "nan"
    text, _ = _rows(src, ",", "card_id,position_in,load_lbf")
    with pytest.raises(CardError) as info:
        parse_cards(text, name="one.csv")
    assert "passed their checks" not in str(info.value)
