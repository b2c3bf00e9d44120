"""Reader behaviour added with the hardening of the card readers.

Units stated by a controller export's summary fields, plausibility warnings, scale-free
checks, a card's rows in separate blocks, NaN stroke rates, and no numpy warnings leaking.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from pumpid.cards import Card, CardError, parse_cards, read_card, read_cards, split_strokes

DATA = Path(__file__).parent / "data" / "cards"


def stroke(n: int = 40, length: float = 100.0, base: float = 8000.0, fluid: float = 2000.0):
    th = 2 * np.pi * np.arange(n) / n
    return length / 2 * (1 - np.cos(th)), base + fluid * np.tanh(4 * np.sin(th))


def table(pos, load, header="position,load", prefix=None) -> str:
    rows = [header]
    for i, (x, f) in enumerate(zip(pos.tolist(), load.tolist(), strict=True)):
        rows.append(("" if prefix is None else f"{prefix(i)},") + f"{x!r},{f!r}")
    return "\n".join(rows) + "\n"


# --------------------------------------------------------------------------- SCADA units
class TestControllerUnits:
    def test_units_from_summary_fields_checked_on_each_row(self):
        cards = read_cards(DATA / "controller_header_units.txt")
        assert [(c.position_unit, c.load_unit) for c in cards] == [
            ("in", "lbf"),
            ("in", "lbf"),
            (None, "lbf"),  # its stroke-length field (120) is not its stroke (64)
        ]
        first = cards[0]
        assert any(
            "position unit in taken from field 'Stroke Length (in)'" in n
            and "is the stroke of the row's positions" in n
            for n in first.notes
        )
        assert any("load unit lbf taken from field 'Peak Load (lbf)'" in n for n in first.notes)
        third = cards[2]
        assert any("'Stroke Length (in)' (120) is not the stroke" in n for n in third.notes)
        assert third.metadata["Fillage (%)"] == 89

    def test_unit_system_field(self):
        cards = read_cards(DATA / "controller_unit_system.txt")
        assert all((c.position_unit, c.load_unit) == ("in", "lbf") for c in cards)
        assert any("field 'Units' = 'English'" in n for n in cards[0].notes)

    def test_caller_units_win_over_inference(self):
        cards = read_cards(DATA / "controller_header_units.txt", position_unit="m")
        assert all(c.position_unit == "m" for c in cards)
        assert not any("Stroke Length" in n for c in cards for n in c.notes)

    def test_units_in_list_field_names_still_win(self):
        card = read_cards(DATA / "controller_export.txt")[0]
        assert any("taken from field name 'Surface Positions (in)'" in n for n in card.notes)

    def test_unknown_units_said_once_per_file(self, tmp_path):
        pos, load = stroke(24)
        lists = f"{','.join(map(repr, pos.tolist()))}|{','.join(map(repr, load.tolist()))}"
        text = "Well|Date|SPM|Surface Positions|Surface Loads\n" + "".join(
            f"W{k}|2020-01-0{k + 1}|7.0|{lists}\n" for k in range(4)
        )
        cards = parse_cards(text, name="x.txt")
        said = [[n for n in c.notes if "not stated" in n] for c in cards]
        assert [len(n) for n in said] == [1, 0, 0, 0]  # one note, on the first card only
        # ... naming both units and how to give them, once.
        assert "position and load units" in said[0][0]
        assert "--position-unit, --load-unit" in said[0][0]
        assert "position_unit= and load_unit=" in said[0][0]
        assert all(c.position_unit is None and c.load_unit is None for c in cards)

    def test_summary_field_unit_that_is_not_a_length_is_ignored(self, tmp_path):
        pos, load = stroke(24)
        text = (
            "Well|Stroke Length (%)|Peak Load (bar)|Surface Positions|Surface Loads\n"
            f"W|100|10000|{','.join(map(repr, pos.tolist()))}|"
            f"{','.join(map(repr, load.tolist()))}\n"
        )
        (card,) = parse_cards(text, name="y.txt")
        assert card.position_unit is None and card.load_unit is None


# --------------------------------------------------------------------------- warnings
class TestPlausibility:
    def read(self, pos, load, header="position,load", **opts) -> Card:
        (card,) = parse_cards(table(pos, load, header), name="w.csv", **opts)
        return card

    def test_ordinary_cards_have_no_warnings(self):
        pos, load = stroke()
        assert self.read(pos, load, "position_in,load_lbf").warnings == ()
        assert self.read(pos * 0.0254, load * 4.448e-3, "position_m,load_kN").warnings == ()
        assert self.read(pos, load).warnings == ()  # units unknown, values plausible

    @pytest.mark.parametrize(
        ("scale_pos", "scale_load", "header", "fragment"),
        [
            (1000.0, 1.0, "position_in,load_lbf", "stroke length 1e+05 in (2540 m)"),
            (1e-5, 1.0, "position_in,load_lbf", "stroke length 0.001 in (2.54e-05 m)"),
            (1.0, 100.0, "position_in,load_lbf", "load reaches 9.999e+05 lbf"),
            (1.0, 1e-4, "position_in,load_lbf", "load never exceeds 0.9999 lbf"),
            (1.0, 1000.0, "position_m,load_kN", "stroke length 100 m"),
            (1e6, 1.0, "position,load", "stroke length 1e+08 (position unit unknown)"),
            (1e-5, 1.0, "position,load", "stroke length 0.001 (position unit unknown)"),
            (1.0, 1e3, "position,load", "load reaches 9.999e+06 (load unit unknown)"),
        ],
    )
    def test_implausible_magnitudes_warn_naming_card_value_and_unit(
        self, scale_pos, scale_load, header, fragment
    ):
        pos, load = stroke()
        card = self.read(pos * scale_pos, load * scale_load, header)
        assert any(fragment in w for w in card.warnings), card.warnings
        assert all(w.startswith("card 'w': ") for w in card.warnings)
        assert not any(fragment in n for n in card.notes)  # warnings are not notes

    def test_position_far_from_zero(self):
        pos, load = stroke()
        card = self.read(pos + 3000.0, load, "position_in,load_lbf")
        assert any("positions reach 3100 in" in w for w in card.warnings)

    def test_tiny_load_swing(self):
        pos, _ = stroke()
        load = 10000.0 + 5.0 * np.sin(np.linspace(0, 2 * np.pi, pos.size, endpoint=False))
        card = self.read(pos, load, "position_in,load_lbf")
        assert any(
            "load varies by only 10 lbf around a mean of 1e+04 lbf" in w for w in card.warnings
        )

    def test_swapped_columns_in_a_header_file(self):
        pos, load = stroke(60)
        card = self.read(load, pos, "position_lbf,load_in", position_unit="in", load_unit="lbf")
        assert any("look swapped" in w and "'load_in' has the shape" in w for w in card.warnings)

    def test_warnings_survive_transformations(self):
        pos, load = stroke()
        card = self.read(pos * 1e4, load, "position_in,load_lbf")
        assert card.warnings and card.with_spm(7.0).warnings == card.warnings
        assert split_strokes(card)[0].warnings == card.warnings


# --------------------------------------------------------------------------- scale-free
class TestScaleFree:
    @pytest.mark.parametrize("scale", [1e-300, 1e-150, 1.0, 1e150, 1e300])
    def test_any_scale_reads_and_splits(self, scale):
        pos, load = stroke(48)
        rec_pos, rec_load = np.tile(pos, 4), np.tile(load, 4)
        t = np.arange(rec_pos.size) * 0.1
        text = "t,position,load\n" + "".join(
            f"{a!r},{b!r},{c!r}\n"
            for a, b, c in zip(
                t.tolist(), (rec_pos * scale).tolist(), (rec_load * scale).tolist(), strict=True
            )
        )
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            (card,) = parse_cards(text, name="s.csv")
            strokes = split_strokes(card)
        assert card.n == rec_pos.size
        assert 3 <= len(strokes) <= 4 and all(abs(s.n - 48) <= 2 for s in strokes)

    def test_constant_and_rounding_only_signals_name_file_and_card(self):
        pos, _ = stroke()
        flat = np.full(pos.size, 1e-296)
        with pytest.raises(CardError, match=r"^c\.csv, field 'load': card 'c': constant load"):
            parse_cards(table(pos, flat), name="c.csv")
        wiggle = 1e-296 * (1 + 1e-15 * np.sin(np.arange(pos.size)))
        with pytest.raises(CardError, match=r"card 'c': load is constant to 12 significant"):
            parse_cards(table(pos, wiggle), name="c.csv")
        real = 1e-296 * (8 + 2 * np.sin(np.arange(pos.size)))  # tiny, but it varies
        (card,) = parse_cards(table(pos, real), name="c.csv")
        assert any("load never exceeds" in w for w in card.warnings)

    def test_split_strokes_errors_name_the_card_source(self):
        card = Card(position=np.ones(30), load=np.arange(30.0), card_id="k", source="f.csv, x")
        with pytest.raises(CardError, match=r"^f\.csv, x, field 'position': card 'k': constant"):
            split_strokes(card)

    def test_extreme_values_raise_no_numpy_warnings(self):
        pos, load = stroke()
        cases = [
            table(pos * 1.7e306, load * 1e304),
            table(np.where(np.arange(pos.size) % 2, 1.7e308, -1.7e308), load),
            table(pos * 5e-324 * 1e3, load * 5e-324 * 1e3),
            "t (h),position,load\n"
            + "".join(f"{1e306 * (i + 1)!r},{i},{i % 3}\n" for i in range(30)),
        ]
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            for text in cases:
                try:
                    cards = parse_cards(text, name="x.csv")
                except CardError as exc:
                    assert "x.csv" in str(exc)
                else:
                    for card in cards:
                        assert np.all(np.isfinite(card.position))
                        try:
                            split_strokes(card)
                        except CardError as exc:
                            assert "x.csv" in str(exc)


# --------------------------------------------------------------------------- blocks, rates
def test_card_rows_in_separate_blocks_are_refused_with_both_blocks():
    pos, load = stroke(30)

    def ids(i: int) -> str:
        return "A" if i < 10 or i >= 20 else "B"

    text = table(pos, load, "card,position,load", prefix=ids)
    with pytest.raises(CardError) as info:
        parse_cards(text, name="blocks.csv", min_samples=5)
    msg = str(info.value)
    assert "card 'A' has rows in two separate blocks, lines 2-11 and lines 22-31" in msg
    assert msg.startswith("blocks.csv, line 22") and "must be contiguous" in msg


def test_interleaved_rows_are_refused_too():
    pos, load = stroke(30)
    text = table(pos, load, "well,position,load", prefix=lambda i: f"W{i % 2}")
    with pytest.raises(
        CardError, match=r"card 'W0' has rows in two separate blocks, lines 2-2 and"
    ):
        parse_cards(text, name="w.csv", min_samples=5)


def test_contiguous_cards_still_read():
    cards = read_cards(DATA / "two_cards_closure.csv")
    assert [c.card_id for c in cards] == ["WX-1A", "WX-1B"]
    assert not any("contiguous" in n for c in cards for n in c.notes)


@pytest.mark.parametrize(
    ("value", "fragment"),
    [("nan", "spm is not a number (NaN)"), ("inf", "spm must be a positive finite number")],
)
def test_non_finite_spm_named_with_its_line(value, fragment):
    pos, load = stroke(25)
    text = table(pos, load, "spm,position,load", prefix=lambda i: value if i == 3 else "7")
    with pytest.raises(CardError) as info:
        parse_cards(text, name="r.csv")
    assert fragment in str(info.value) and info.value.line == 5
    assert str(info.value).startswith("r.csv, line 5, field 'spm': ")
    text = table(pos, load, "spm,position,load", prefix=lambda i: value)
    with pytest.raises(CardError, match=r"line 2, field 'spm'"):
        parse_cards(text, name="r.csv")


def test_nan_spm_in_scada_export():
    pos, load = stroke(24)
    text = (
        "Well|SPM|Surface Positions|Surface Loads\n"
        f"W|nan|{','.join(map(repr, pos.tolist()))}|{','.join(map(repr, load.tolist()))}\n"
    )
    with pytest.raises(CardError, match=r"^s\.txt, line 2, field 'SPM': SPM is not a number"):
        parse_cards(text, name="s.txt")


def test_fixtures_read_as_before():
    card = read_card(DATA / "stroke_with_time.csv")
    assert card.metadata["column_roles"] == {
        "position": 1, "load": 2, "confidence": 1.0, "words": "certain", "method": "header names",
    }  # fmt: skip
    assert card.warnings == ()


def test_a_column_named_like_the_readers_record_does_not_replace_it():
    pos, load = stroke(30)
    text = table(pos, load, "column_roles,position,load", prefix=lambda i: str(i))
    (card,) = parse_cards(text, name="c.csv")
    assert card.metadata["column_roles"]["method"] == "header names"
    assert card.metadata["column_roles (column)"].shape == (30,)


class TestInMemoryOptions:
    """parse_cards takes exactly read_cards' keywords, checked: no list to drift."""

    def test_same_cards_as_the_file_reader(self, tmp_path: Path) -> None:
        pos, load = stroke()
        text = table(pos, load)
        f = tmp_path / "c.csv"
        f.write_text(text)
        opts = {"spm": 6.0, "well_id": "W1", "min_samples": 10}
        (a,) = read_cards(f, **opts)
        (b,) = parse_cards(text, name=str(f), **opts)
        np.testing.assert_array_equal(a.t, b.t)
        np.testing.assert_array_equal(a.load, b.load)
        assert (a.well_id, a.spm) == (b.well_id, b.spm) == ("W1", 6.0)

    @pytest.mark.parametrize("fn", ["parse_cards", "parse_cards_and_errors"])
    def test_unknown_keyword_is_named_with_the_known_ones(self, fn: str) -> None:
        import pumpid.cards as cards

        pos, load = stroke()
        with pytest.raises(TypeError, match=rf"{fn}\(\).*'min_sample'.*min_samples.*encoding"):
            getattr(cards, fn)(table(pos, load), min_sample=10)
