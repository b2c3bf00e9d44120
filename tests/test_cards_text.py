"""Text-level behaviour of the card readers: encodings, display-safe messages, numbers."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid.cards import Card, CardError, parse_cards, printable, read_card, read_cards


def table(n: int = 30) -> str:
    th = 2 * np.pi * np.arange(n) / n
    pos = 50 * (1 - np.cos(th))
    load = 8000 + 2000 * np.tanh(4 * np.sin(th))
    return "position_in,load_lbf\n" + "".join(
        f"{x:.4f},{f:.2f}\n" for x, f in zip(pos, load, strict=True)
    )


# --------------------------------------------------------------------------- printable
@pytest.mark.parametrize(
    ("raw", "shown"),
    [
        ("WX-1A", "WX-1A"),
        ("café Ø", "café Ø"),
        ("a\x1b[31mred", "a\\x1b[31mred"),
        ("two\nlines\r", "two\\nlines\\r"),
        ("tab\there", "tab\\there"),
        ("zero\u200bwidth", "zero\\u200bwidth"),
        ("bell\x07", "bell\\x07"),
    ],
)
def test_printable(raw, shown):
    assert printable(raw) == shown
    assert printable(raw).isprintable()


def test_printable_accepts_any_object():
    assert printable(12) == "12"


def test_card_error_message_is_printable_but_path_is_kept():
    err = CardError("card 'x\x1b[2J': bad", path="dir/f\x07.csv", line=3)
    assert str(err) == "dir/f\\x07.csv, line 3: card 'x\\x1b[2J': bad"
    assert err.path == "dir/f\x07.csv"  # raw, for programs


def test_control_characters_in_card_ids_are_kept_raw_and_shown_escaped(tmp_path):
    bad_id = "W\x1b[31m-1"
    body = table().splitlines()
    rows = ["card_id," + body[0]] + [f"{bad_id},{r}" for r in body[1:]]
    p = tmp_path / "ids.csv"
    p.write_text("\n".join(rows))
    (card,) = read_cards(p)
    assert card.card_id == bad_id  # the raw id is data
    assert all(n.isprintable() for n in card.notes)
    assert all(w.isprintable() for w in card.warnings)
    p.write_text("\n".join([*rows, f"{bad_id},1,nan"]))
    with pytest.raises(CardError) as info:
        read_cards(p)
    assert "\x1b" not in str(info.value) and "\\x1b[31m" in str(info.value)


# --------------------------------------------------------------------------- encodings
@pytest.mark.parametrize(
    ("encoding", "expected_note"),
    [
        ("utf-16", "UTF-16 (little-endian), detected from its byte-order mark"),
        ("utf-16-le", "UTF-16 (little-endian), detected from its pattern of zero bytes"),
        ("utf-16-be", "UTF-16 (big-endian), detected from its pattern of zero bytes"),
        ("utf-32", "UTF-32 (little-endian), detected from its byte-order mark"),
        ("utf-32-le", "UTF-32 (little-endian), detected from its pattern of zero bytes"),
        ("utf-32-be", "UTF-32 (big-endian), detected from its pattern of zero bytes"),
    ],
)
def test_wide_encodings_are_detected(tmp_path, encoding, expected_note):
    p = tmp_path / "wide.csv"
    p.write_bytes(table().encode(encoding))
    card = read_card(p)
    assert card.n == 30 and card.position_unit == "in"
    assert any(expected_note in n for n in card.notes), card.notes


def test_utf16_big_endian_with_bom(tmp_path):
    p = tmp_path / "be.csv"
    p.write_bytes(b"\xfe\xff" + table().encode("utf-16-be"))
    assert any("UTF-16 (big-endian)" in n for n in read_card(p).notes)


def test_encoding_option_wins_over_detection(tmp_path):
    p = tmp_path / "w.csv"
    p.write_bytes(table().encode("utf-16-le"))
    card = read_card(p, encoding="utf-16-le")
    assert "decoded as utf-16-le (encoding given by the caller)" in card.notes
    # Latin-1 decodes anything: the caller's choice is obeyed, and the NULs then show.
    with pytest.raises(CardError, match="binary content") as info:
        read_card(p, encoding="latin-1")
    assert str(p) in str(info.value)
    text = table().replace("position_in", "pösition_in")
    q = tmp_path / "cp.csv"
    q.write_bytes(text.encode("cp1252"))
    assert read_card(q, encoding="cp1252", columns={"position": 0, "load": 1}).n == 30


def test_undecodable_file_names_file_encoding_and_offset(tmp_path):
    p = tmp_path / "odd.csv"
    data = table().encode("utf-16")
    p.write_bytes(data[:-1])  # an odd number of bytes: the last code unit is cut
    with pytest.raises(CardError) as info:
        read_cards(p)
    msg = str(info.value)
    assert str(p) in msg and "UTF-16" in msg and f"byte offset {len(data) - 2}" in msg
    with pytest.raises(CardError, match=r"cannot decode the file as 'ascii'.*byte offset 4"):
        parse_cards(b"posi\xe9tion", name="a.csv", encoding="ascii")
    with pytest.raises(CardError, match="unknown encoding 'klingon'"):
        parse_cards(b"x", name="a.csv", encoding="klingon")
    with pytest.raises(CardError, match="not a text encoding"):
        parse_cards(b"x", name="a.csv", encoding="base64")


def test_binary_content_still_refused_with_offset():
    data = b"position,load\n" + bytes(range(256)) * 4
    with pytest.raises(CardError, match=r"binary content \(NUL byte at byte offset 14\)"):
        parse_cards(data, name="b.bin")


# --------------------------------------------------------------------------- numbers
def test_complex_tokens_are_refused_clearly(tmp_path):
    text = table().replace("\n0.0000,", "\n0.0000+1j,", 1)
    with pytest.raises(CardError, match=r"complex number '0.0000\+1j'") as info:
        parse_cards(text, name="c.csv")
    assert info.value.line == 2 and "c.csv" in str(info.value)


def test_card_refuses_complex_arrays():
    with pytest.raises(CardError, match="complex"):
        Card(position=np.array([1.0, 2.0]) + 1j, load=[1.0, 2.0])
    with pytest.raises(CardError, match="complex"):
        Card(position=[1.0, 2.0], load=[1.0, complex(2, 1)])


def test_card_warnings_field():
    card = Card(position=[0.0, 1.0], load=[1.0, 2.0], warnings=("look",))
    assert card.warnings == ("look",)
    assert card.replace(note="x").warnings == ("look",)
    assert Card(position=[0.0, 1.0], load=[1.0, 2.0]).warnings == ()
