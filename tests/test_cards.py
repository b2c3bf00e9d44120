"""Tests of the card readers, the Card type, units and stroke splitting.

Fixtures in tests/data/cards/ are small made-up cards (synthetic shapes); malformed inputs are
written into tmp_path by the tests themselves.
"""

from __future__ import annotations

import json
import math
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from pumpid.cards import (
    FORMATS,
    LOAD_UNITS,
    POSITION_UNITS,
    Card,
    CardError,
    convert_load,
    convert_position,
    detect_format,
    loop_work,
    normalize_load_unit,
    normalize_position_unit,
    open_stroke,
    parse_cards,
    read_card,
    read_cards,
    read_cards_and_errors,
    split_strokes,
)

DATA = Path(__file__).parent / "data" / "cards"


def synthetic_stroke(n: int = 40, stroke: float = 100.0, phase: float = 0.0):
    """One made-up card: sinusoidal position, load high on the upstroke."""
    th = 2 * np.pi * np.arange(n) / n + phase
    pos = stroke / 2 * (1 - np.cos(th))
    load = 8000 + 2000 * np.tanh(4 * np.sin(th))
    return pos, load


def write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def csv_text(n: int = 30, header: str = "t,position,load", with_t: bool = True) -> str:
    pos, load = synthetic_stroke(n)
    rows = [header]
    for i in range(n):
        row = ([f"{i * 0.25:.4f}"] if with_t else []) + [f"{pos[i]:.5f}", f"{load[i]:.3f}"]
        rows.append(",".join(row))
    return "\n".join(rows) + "\n"


# =========================================================================== units
class TestUnits:
    def test_exact_factors(self):
        assert convert_position([1.0], "in", "m")[0] == 0.0254
        assert convert_position([1.0], "ft", "in")[0] == pytest.approx(12.0, rel=1e-15)
        assert convert_load([1.0], "lbf", "N")[0] == 4.4482216152605
        assert convert_load([1.0], "kgf", "N")[0] == 9.80665
        assert convert_load([1.0], "klbf", "lbf")[0] == pytest.approx(1000.0, rel=1e-15)
        assert convert_load([2.0], "kN", "N")[0] == 2000.0

    @pytest.mark.parametrize(
        ("alias", "canonical"),
        [("inch", "in"), ("Inches", "in"), ("feet", "ft"), ("metre", "m"), ("meters", "m"),
         ("metres", "m"), ("MM", "mm"), ("cm", "cm"), ("meter", "m")],
    )  # fmt: skip
    def test_position_aliases(self, alias, canonical):
        assert normalize_position_unit(alias) == canonical

    @pytest.mark.parametrize(
        ("alias", "canonical"),
        [("lb", "lbf"), ("lbs", "lbf"), ("kip", "klbf"), ("kips", "klbf"), ("n", "N"),
         ("KN", "kN"), ("kgf", "kgf"), ("daN", "daN"), ("newtons", "N")],
    )  # fmt: skip
    def test_load_aliases(self, alias, canonical):
        assert normalize_load_unit(alias) == canonical

    def test_unknown_unit_names_it_and_lists_known(self):
        with pytest.raises(CardError, match="furlong") as info:
            normalize_position_unit("furlong")
        for known in POSITION_UNITS:
            assert known in str(info.value)
        with pytest.raises(CardError, match="unknown load unit 'stone'") as info:
            normalize_load_unit("stone")
        for known in LOAD_UNITS:
            assert known in str(info.value)

    def test_card_error_is_value_error(self):
        assert issubclass(CardError, ValueError)
        err = CardError("bad", path="f.csv", line=3, field="load")
        assert str(err) == "f.csv, line 3, field 'load': bad"
        assert (err.path, err.line, err.field, err.reason) == ("f.csv", 3, "load", "bad")


# =========================================================================== Card
class TestCard:
    def make(self, **kw) -> Card:
        pos, load = synthetic_stroke(40)
        return Card(
            position=pos, load=load, position_unit="in", load_unit="lbf", card_id="c1", **kw
        )

    def test_basic_properties(self):
        card = self.make()
        assert len(card) == card.n == 40
        assert card.t is None and card.dt is None and not card.is_uniform
        assert card.time_source == "none"
        assert "c1" in repr(card) and "n=40" in repr(card)
        assert card.stroke_length == pytest.approx(100.0)

    def test_arrays_are_read_only_copies(self):
        pos, load = synthetic_stroke(40)
        card = Card(position=pos, load=load)
        pos[0] = 123.0
        assert card.position[0] == 0.0
        with pytest.raises(ValueError):
            card.position[0] = 1.0
        with pytest.raises(AttributeError):
            card.spm = 5.0  # type: ignore[misc]

    def test_with_spm_rebuilds_uniform_time_over_one_stroke(self):
        card = self.make().with_spm(6.0)
        assert card.time_source == "spm" and card.periodic
        assert card.period == pytest.approx(10.0)
        np.testing.assert_allclose(card.t, np.arange(40) * 10.0 / 40)
        assert card.dt == pytest.approx(0.25) and card.is_uniform
        assert "6 SPM" in card.notes[-1] and "t_i = i*T/N" in card.notes[-1]

    def test_with_period_and_with_dt(self):
        card = self.make().with_period(8.0)
        assert card.spm == pytest.approx(7.5) and card.time_source == "period"
        assert card.t[-1] == pytest.approx(8.0 * 39 / 40)
        card2 = card.with_dt(0.075)
        assert card2.time_source == "dt" and card2.period == pytest.approx(3.0)
        assert "replacing time" in card2.notes[-1]
        with pytest.raises(CardError, match="spm"):
            card.with_spm(0)
        with pytest.raises(CardError):
            card.with_period(float("nan"))

    def test_dt_none_for_non_uniform_time(self):
        t = np.cumsum(np.r_[0.0, np.full(39, 0.1)])
        t[20:] += 0.05
        card = self.make(t=t, time_source="file")
        assert card.dt is None and not card.is_uniform

    def test_to_units_converts_and_notes(self):
        card = self.make()
        m = card.to_units(position="m", load="kN")
        np.testing.assert_allclose(m.position, card.position * 0.0254)
        np.testing.assert_allclose(m.load, card.load * 4.4482216152605e-3)
        assert (m.position_unit, m.load_unit) == ("m", "kN")
        assert any("position converted from in to m" in n for n in m.notes)
        back = m.to_units(position="inches", load="lb")
        np.testing.assert_allclose(back.position, card.position, rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(back.load, card.load, rtol=1e-14)
        assert card.to_units(position="in") is card  # nothing to do, nothing noted

    def test_to_units_errors(self):
        with pytest.raises(CardError, match="unknown position unit 'parsec'"):
            self.make().to_units(position="parsec")
        pos, load = synthetic_stroke(30)
        bare = Card(position=pos, load=load)
        with pytest.raises(CardError, match="unknown"):
            bare.to_units(load="N")
        declared = bare.with_units(position="m", load="kN")
        assert declared.to_units(load="N").load[0] == pytest.approx(load[0] * 1000)
        with pytest.raises(CardError, match="already"):
            declared.with_units(position="in")

    @pytest.mark.parametrize(
        ("kwargs", "fragment"),
        [
            ({"position": [1.0, 2.0], "load": [1.0]}, "samples"),
            ({"position": [1.0, float("nan")], "load": [1.0, 2.0]}, "non-finite"),
            ({"position": [[1.0, 2.0]], "load": [[1.0, 2.0]]}, "one-dimensional"),
            ({"position": [1.0, 2.0], "load": [1.0, 2.0], "t": [0.0, 0.0]}, "strictly increasing"),
            ({"position": [1.0, 2.0], "load": [1.0, 2.0], "position_unit": "cubit"}, "cubit"),
            ({"position": [1.0, 2.0], "load": [1.0, 2.0], "time_source": "guess"}, "time_source"),
        ],
    )
    def test_constructor_validation(self, kwargs, fragment):
        with pytest.raises(CardError, match=fragment):
            Card(**kwargs)


# =========================================================================== fixtures
class TestCsv:
    def test_single_stroke_with_time_column(self):
        card = read_card(DATA / "stroke_with_time.csv")
        assert card.n == 30 and card.card_id == "stroke_with_time"
        assert (card.position_unit, card.load_unit) == ("in", "lbf")
        assert card.time_source == "file" and card.dt == pytest.approx(8.0 / 30, rel=1e-4)
        assert card.position.max() == pytest.approx(120.0, abs=1e-3)
        assert card.source.startswith("stroke_with_time.csv, lines 3-32")
        # One stroke in its own time is one period, as the same stroke with a rate is: it
        # was fitted from rest, without an offset, to another status.
        assert card.periodic and card.period == pytest.approx(8.0, rel=1e-4)
        assert any("one stroke in the file's time" in n for n in card.notes)

    def test_a_stroke_fits_alike_with_its_time_or_its_rate(self, tmp_path):
        import pumpid

        pos, load = synthetic_stroke(60)
        dt = 7.5 / 60
        timed = write(tmp_path, "timed.csv", "\n".join(
            ["t,position_in,load_lbf"] + [f"{i * dt:.6f},{p},{f}" for i, (p, f)
                                          in enumerate(zip(pos, load, strict=True))]))
        rated = write(tmp_path, "rated.csv", "\n".join(
            ["position_in,load_lbf"] + [f"{p},{f}" for p, f in zip(pos, load, strict=True)]))
        a = pumpid.fit(pumpid.Kelvin, read_card(timed))
        b = pumpid.fit(pumpid.Kelvin, read_card(rated, spm=8.0))
        assert a.initial_state == b.initial_state == "periodic"
        assert a.status is b.status and "offset" in a.free
        assert a.cost == pytest.approx(b.cost, rel=1e-6)

    def test_a_loop_turning_backwards_is_warned(self, tmp_path):
        # A card stored in reverse time order (or its position measured downwards) fitted
        # as a poor fit with an absurd offset and no word of why.
        pos, load = synthetic_stroke(60)
        rows = ["position_in,load_lbf"]
        forward = write(tmp_path, "f.csv", "\n".join(
            rows + [f"{p},{f}" for p, f in zip(pos, load, strict=True)]))
        backward = write(tmp_path, "b.csv", "\n".join(
            rows + [f"{p},{f}" for p, f in zip(pos[::-1], load[::-1], strict=True)]))
        said = "loop turns the wrong way for a card in time order"
        assert not any(said in w for w in read_card(forward, spm=8.0).warnings)
        assert any(said in w for w in read_card(backward, spm=8.0).warnings)
        assert loop_work(pos, load) > 0 > loop_work(pos[::-1], load[::-1])

    def test_a_stroke_that_does_not_close_is_warned(self, tmp_path):
        # A card that ends 85 % of its stroke from where it starts (3 of the 360 oilfield
        # cards), fitted as one period, was a poor fit whose reason pointed at the model.
        import pumpid

        pos, load = synthetic_stroke(60)
        assert open_stroke(pos) is None
        part = slice(0, 40)  # a stroke cut two thirds of the way round
        share, steps = open_stroke(pos[part])
        assert share == pytest.approx(abs(pos[39] - pos[0]) / np.ptp(pos[:40]))
        assert share > 0.5 and steps > 10
        rows = ["position_in,load_lbf"]
        cut = write(tmp_path, "cut.csv", "\n".join(
            rows + [f"{p},{f}" for p, f in zip(pos[part], load[part], strict=True)]))
        said = "the card does not close: it ends"
        fit = pumpid.fit(pumpid.Kelvin, read_card(cut, spm=8.0))
        assert any(w.startswith(said) and " in (" in w for w in fit.warnings), fit.warnings
        whole = write(tmp_path, "whole.csv", "\n".join(
            rows + [f"{p},{f}" for p, f in zip(pos, load, strict=True)]))
        assert not any(said in w for w in pumpid.fit(pumpid.Kelvin,
                                                      read_card(whole, spm=8.0)).warnings)

    def test_card_column_closure_flags_and_spm(self):
        cards = read_cards(DATA / "two_cards_closure.csv")
        assert [c.card_id for c in cards] == ["WX-1A", "WX-1B"]
        a, b = cards
        assert a.n == b.n == 24  # the flagged closure row is dropped
        assert any("closure point" in n and "line 26" in n for n in a.notes)
        assert a.spm == 8.0 and b.spm == 8.1 and a.time_source == "spm" and a.periodic
        np.testing.assert_allclose(a.t, np.arange(24) * 7.5 / 24)
        assert any("time rebuilt from 8 SPM" in n for n in a.notes)

    def test_one_card_of_one_well_is_named_by_its_file(self, tmp_path):
        # A per-card export with a well column and no card column: 16 files of one well
        # had each card called by the well's id (the run then told them apart by source).
        pos, load = synthetic_stroke(30)
        rows = ["well_id,position_in,load_lbf"] + [
            f"W-7,{p},{f}" for p, f in zip(pos, load, strict=True)]
        card = read_card(write(tmp_path, "W-7_0412.csv", "\n".join(rows)), spm=6.0)
        assert (card.card_id, card.well_id) == ("W-7_0412", "W-7")

    def test_tsv_with_well_column_ms_time_and_bracket_units(self):
        # Two wells in one file without a card column: each well's card by its well.
        cards = read_cards(DATA / "two_wells.tsv")
        assert [(c.card_id, c.well_id) for c in cards] == [("PAD-3", "PAD-3"), ("PAD-4", "PAD-4")]
        assert all(c.position_unit == "m" and c.load_unit == "kN" for c in cards)
        assert cards[0].dt == pytest.approx(0.32)  # milliseconds converted to seconds
        assert any("x 0.001" in n for n in cards[0].notes)

    def test_semicolon_and_decimal_comma(self):
        card = read_card(DATA / "semicolon_decimal_comma.csv")
        assert card.n == 22 and card.position.max() == pytest.approx(2.0, abs=1e-3)
        assert "decimal commas read as decimal points" in card.notes
        assert card.position_unit is None and card.load_unit is None
        assert any("left unknown" in n for n in card.notes)

    def test_caller_units_and_rates(self, tmp_path):
        p = write(tmp_path, "c.csv", csv_text(with_t=False, header="position_in,load_lbf"))
        card = read_card(p, position_unit="m", load_unit="kN", spm=5.0)
        assert (card.position_unit, card.load_unit) == ("m", "kN")
        assert any("overrides in" in n for n in card.notes)
        assert card.period == pytest.approx(12.0) and card.time_source == "spm"
        card = read_card(p, period=4.0)
        assert card.time_source == "period" and card.spm == pytest.approx(15.0)
        assert read_card(p).t is None and read_card(p).time_source == "none"
        with pytest.raises(CardError, match="disagree"):
            read_card(p, spm=5.0, period=4.0)

    def test_time_column_wins_over_spm(self, tmp_path):
        p = write(tmp_path, "c.csv", csv_text())
        card = read_card(p, spm=6.0)
        assert card.time_source == "file" and card.dt == pytest.approx(0.25)
        # The rate given is not used, and the card says so (its spm was 6.0 beside a time
        # axis of another rate); a single stroke's rate is its own, N*dt.
        assert any("stroke rate 6 SPM (given by the caller) is not used" in n
                   for n in card.notes)
        assert card.spm is None or card.spm == pytest.approx(60.0 / (card.n * card.dt))

    def test_columns_override_and_disable(self, tmp_path):
        pos, load = synthetic_stroke(25)
        lines = ["A,B,C,D"] + [f"{i},{load[i]},{pos[i]},{i * 0.1:.2f}" for i in range(25)]
        p = write(tmp_path, "odd.csv", "\n".join(lines))
        with pytest.raises(CardError, match="no position or load column") as info:
            read_cards(p)
        # The command line's options beside the API's (only columns={...} was said).
        assert "--position-col NAME --load-col NAME" in str(info.value)
        card = read_card(p, columns={"position": "C", "load": "b", "t": "D"})
        np.testing.assert_allclose(card.position, pos)
        assert card.dt == pytest.approx(0.1)
        assert np.array_equal(card.metadata["A"], np.arange(25.0))  # extra column kept
        card = read_card(p, columns={"position": 2, "load": 1})
        assert card.t is None
        p2 = write(tmp_path, "t.csv", csv_text())
        assert read_card(p2, columns={"t": None}).time_source == "none"

    def test_headerless_csv_roles_detected_and_indices(self, tmp_path):
        pos, load = synthetic_stroke(25)
        p = write(tmp_path, "h.csv", "\n".join(f"{i * 14.6},{pos[i]},{load[i]}" for i in range(25)))
        card = read_card(p)  # column 0 is a monotone angle: neither position nor load
        assert any("column 1 read as position and column 2 as load" in n for n in card.notes)
        assert card.metadata["column_roles"]["position"] == 1
        np.testing.assert_allclose(card.position, pos)
        card = read_card(p, columns={"position": 1, "load": 2}, position_unit="in")
        np.testing.assert_allclose(card.load, load)
        assert "column_0" in card.metadata
        with pytest.raises(CardError, match="no header row"):
            read_card(p, columns={"position": "pos", "load": "load"})
        with pytest.raises(CardError, match="out of range"):
            read_card(p, columns={"position": 1, "load": 7})

    def test_duplicated_closing_point_dropped_only_without_time(self, tmp_path):
        pos, load = synthetic_stroke(25)
        pos, load = np.r_[pos, pos[0]], np.r_[load, load[0]]
        body = "\n".join(f"{float(x)!r},{float(f)!r}" for x, f in zip(pos, load, strict=True))
        card = read_card(write(tmp_path, "c.csv", "position,load\n" + body), spm=6.0)
        assert card.n == 25 and any("duplicated closing point dropped" in n for n in card.notes)
        # The card's lines are those kept: the dropped closing point's line 27 is not one.
        assert card.source == "c.csv, lines 2-26"
        np.testing.assert_allclose(card.t, np.arange(25) * 10.0 / 25)
        keep = read_card(
            write(tmp_path, "c.csv", "position,load\n" + body), drop_closing_point=False
        )
        assert keep.n == 26
        body_t = "\n".join(
            f"{i},{float(x)!r},{float(f)!r}" for i, (x, f) in enumerate(zip(pos, load, strict=True))
        )
        timed = read_card(write(tmp_path, "t.csv", "t,position,load\n" + body_t))
        assert timed.n == 26  # a time record keeps its last sample

    def test_content_detection_not_extension(self, tmp_path):
        p = write(tmp_path, "misleading.json", csv_text())
        assert read_card(p).n == 30
        assert any("read as csv (format detected" in n for n in read_card(p).notes)
        with pytest.raises(CardError, match="invalid JSON"):
            read_card(p, format="json")
        assert read_card(p, format="csv").n == 30

    def test_iso_stamps_are_read_as_seconds_from_the_cards_first(self, tmp_path):
        # A controller's export stamps each sample; the card's time is seconds from its
        # first stamp, and that stamp is the card's recording time.
        pos, load = synthetic_stroke(25)
        rows = [f"2021-06-01 06:00:{10 + 0.4 * i:06.3f},{pos[i]},{load[i]}" for i in range(25)]
        p = write(tmp_path, "ts.csv", "time,position,load\n" + "\n".join(rows))
        card = read_card(p)
        assert card.time_source == "file" and card.t[0] == 0.0
        np.testing.assert_allclose(card.t, 0.4 * np.arange(25), atol=1e-9)
        assert card.metadata["time"].isoformat() == "2021-06-01T06:00:10+00:00"
        assert any("no time zone: taken as UTC" in n for n in card.notes)
        assert any("column 'time' holds ISO 8601 date/time stamps" in n for n in card.notes)
        # With a zone, and a column named otherwise given as the time.
        rows = [f"2021-06-01T06:00:{10 + 0.4 * i:06.3f}+02:00,{pos[i]},{load[i]}"
                for i in range(25)]
        p = write(tmp_path, "tz.csv", "stamp,position,load\n" + "\n".join(rows))
        card = read_card(p, columns={"t": "stamp"})
        assert card.metadata["time"].isoformat() == "2021-06-01T04:00:10+00:00"
        np.testing.assert_allclose(card.t, 0.4 * np.arange(25), atol=1e-9)

    def test_times_of_day_run_past_midnight(self, tmp_path):
        pos, load = synthetic_stroke(25)
        clock = [(86_395.0 + 0.5 * i) % 86_400 for i in range(25)]
        rows = [f"{int(c // 3600):02d}:{int(c % 3600 // 60):02d}:{c % 60:04.1f},{pos[i]},{load[i]}"
                for i, c in enumerate(clock)]
        assert rows[0].startswith("23:59:55.0") and rows[-1].startswith("00:00:07.0")
        card = read_card(write(tmp_path, "tod.csv", "time,position,load\n" + "\n".join(rows)))
        np.testing.assert_allclose(card.t, 0.5 * np.arange(25), atol=1e-9)
        assert "time" not in card.metadata  # a time of day has no date

    def test_one_stamp_a_card_is_its_recording_time(self, tmp_path):
        pos, load = synthetic_stroke(25)
        rows = [f"A,2021-06-01 06:00:00,{pos[i]},{load[i]}" for i in range(25)]
        rows += [f"B,2021-06-01 07:00:00,{pos[i]},{load[i]}" for i in range(25)]
        p = write(tmp_path, "per_card.csv", "card,time,position,load\n" + "\n".join(rows))
        a, b = read_cards(p, spm=6)
        assert a.time_source == "spm" and a.metadata["time"].hour == 6
        assert b.metadata["time"].hour == 7
        assert any("one date/time stamp for the whole card" in n for n in a.notes)

    def test_stamps_days_into_a_file_time_each_card_in_equal_steps(self, tmp_path):
        # Seconds after the file's first stamp, days before, kept a card's 0.02 s steps only
        # to 3e-9 of them: the fit took the card as non-uniformly sampled, 1000x slower.
        pos, load = synthetic_stroke(25)
        rows = []
        for day in (0, 9):
            start = np.datetime64("2024-03-01T00:00:00") + np.timedelta64(day, "D")
            rows += [f"C{day},{start + np.timedelta64(20 * i, 'ms')},{pos[i]},{load[i]}"
                     for i in range(25)]
        p = write(tmp_path, "days.csv", "card,time,position,load\n" + "\n".join(rows))
        first, late = read_cards(p)
        assert np.all(np.diff(late.t) == np.diff(first.t))
        np.testing.assert_allclose(late.t, 0.02 * np.arange(25), rtol=0, atol=1e-15)
        assert late.metadata["time"].isoformat() == "2024-03-10T00:00:00+00:00"

    def test_stamps_without_a_header_or_split_by_spaces(self, tmp_path):
        # A headerless file's first row of stamps was taken for a header; in a whitespace
        # table the README's own form was two fields.
        pos, load = synthetic_stroke(25)
        rows = [f"2021-06-01 06:00:{0.4 * i:06.3f},{pos[i]},{load[i]}" for i in range(25)]
        card = read_card(write(tmp_path, "bare.csv", "\n".join(rows)))
        assert any("no header: column 0 holds date/time stamps" in n for n in card.notes)
        np.testing.assert_allclose(card.t, 0.4 * np.arange(25), atol=1e-12)
        assert card.metadata["time"].isoformat() == "2021-06-01T06:00:00+00:00"
        rows = [f"2021-06-01 06:00:{0.4 * i:06.3f}  {pos[i]}  {load[i]}" for i in range(25)]
        card = read_card(write(tmp_path, "ws.txt", "time position load\n" + "\n".join(rows)))
        np.testing.assert_allclose(card.t, 0.4 * np.arange(25), atol=1e-12)

    def test_a_time_of_day_takes_its_date_from_a_date_column(self, tmp_path):
        pos, load = synthetic_stroke(25)
        rows = [f"2021-06-01,06:00:{0.4 * i:06.3f},{pos[i]},{load[i]}" for i in range(25)]
        p = write(tmp_path, "dated.csv", "date,time,position,load\n" + "\n".join(rows))
        assert read_card(p).metadata["time"].isoformat() == "2021-06-01T06:00:00+00:00"
        # Not read as time, the times of day leave the date column's date alone (a time
        # without a date had taken its place and been refused, so the card had none).
        card = read_card(p, columns={"t": None}, spm=6)
        assert card.metadata["time"].isoformat() == "2021-06-01T00:00:00+00:00"
        # A whitespace table whose header names the date and the time apart.
        rows = [f"2021-06-01 06:00:{0.4 * i:06.3f} {pos[i]} {load[i]}" for i in range(25)]
        p = write(tmp_path, "apart.txt", "date time position load\n" + "\n".join(rows))
        card = read_card(p)
        np.testing.assert_allclose(card.t, 0.4 * np.arange(25), atol=1e-12)
        assert card.metadata["time"].isoformat() == "2021-06-01T06:00:00+00:00"

    def test_stamps_not_read_as_time_still_date_the_card(self, tmp_path):
        pos, load = synthetic_stroke(25)
        rows = [f"2021-06-01 06:00:{i:02d},{pos[i]},{load[i]}" for i in range(25)]
        p = write(tmp_path, "ts.csv", "time,position,load\n" + "\n".join(rows))
        card = read_card(p, columns={"t": None}, spm=6)
        assert card.time_source == "spm"
        assert card.metadata["time"].isoformat() == "2021-06-01T06:00:00+00:00"

    @pytest.mark.parametrize(("cells", "line", "words"), [
        (["06/01/2021 06:00:00", "06/01/2021 06:00:01"], 2,
         "'06/01/2021 06:00:00' is not a date and time in ISO 8601 form; convert the column"),
        (["2021-06-01 06:00:00", "06:00:01"], 3,
         "all dates with times or all times of day, not both; write every stamp"),
        (["2021-06-01 06:00:00", "2021-06-01 06:00:01+00:00"], 3, "a time zone or none does"),
        (["2021-06-01 06:00:00", "1.5"], 3, "'1.5' is not a date and time"),
        (["2021-06-01 06:00:00", ""], 3, "an empty time cell is not"),
        (["0.0", "2021-06-01 06:00:01"], 3, "follows numbers"),
        # Stamps without a zone across a clock change, and stamps coarser than the samples.
        (["2021-03-28 01:59:59", "2021-03-28 03:00:00"], 3, "jump ahead by an hour between "
         "lines 2 and 3: a change between summer and winter time?"),
        (["2021-06-01 06:00:00", "2021-06-01 06:00:00"], 3, "stamps of lines 2 and 3 are "
         "the same"),
    ])
    def test_other_stamps_are_refused_with_the_way_round(self, tmp_path, cells, line, words):
        pos, load = synthetic_stroke(25)
        cells = cells + [f"2021-06-01 06:00:{i:02d}" for i in range(2, 25)]
        rows = [f"{cells[i]},{pos[i]},{load[i]}" for i in range(25)]
        p = write(tmp_path, "ts.csv", "time,position,load\n" + "\n".join(rows))
        with pytest.raises(CardError, match=r"no time column .* columns=\{'t': None\}") as info:
            read_cards(p)
        assert words in str(info.value)
        assert info.value.line == line and info.value.field == "time"
        assert read_card(p, columns={"t": None}).time_source == "none"

    def test_a_time_column_rounded_by_its_file_is_uniform(self, tmp_path):
        # 1/30 s written to six decimals: steps equal to 3e-5 of one. The card called itself
        # uniformly sampled and the fit did not: simulated step by step, 21 s a fit.
        pos, load = synthetic_stroke(30)
        for record in (False, True):
            rows = [f"{i / 30:.6f},{pos[i % 30]},{load[i % 30]}" for i in range(60 if record
                                                                               else 30)]
            card = read_card(write(tmp_path, "r.csv", "t_s,position,load\n" + "\n".join(rows)))
            steps = np.diff(card.t)
            assert np.ptp(steps) <= 1e-12 * steps[0]
            assert steps[0] == pytest.approx(1 / 30, rel=1e-6)
            assert any("time written to 1e-06 s, a uniform grid rounded (steps equal to "
                       "3e-05 of one)" in n for n in card.notes)
        # A record whose rate changes by 0.09 % halfway keeps its times: off the grid by a
        # step and more, not rounded.
        t = np.cumsum(np.r_[0.0, np.where(np.arange(5999) < 3000, 0.02, 0.02 * 1.0009)])
        rows = [f"{t[i]:.9f},{pos[i % 30]},{load[i % 30]}" for i in range(6000)]
        card = read_card(write(tmp_path, "r.csv", "t_s,position,load\n" + "\n".join(rows)))
        np.testing.assert_allclose(card.t, t, atol=1e-9)
        assert not any("a uniform grid rounded" in n for n in card.notes)
        # Milliseconds at 30 samples a second: steps of 33 and 34 ms, a grid rounded.
        rows = [f"{i / 30:.3f},{pos[i % 30]},{load[i % 30]}" for i in range(90)]
        card = read_card(write(tmp_path, "ms.csv", "t_s,position,load\n" + "\n".join(rows)))
        assert np.ptp(np.diff(card.t)) <= 1e-12 and card.dt == pytest.approx(1 / 30, rel=1e-4)

    def test_whitespace_table_with_header(self, tmp_path):
        pos, load = synthetic_stroke(25)
        rows = [f"{i * 0.3:.2f}  {load[i]:.3f}  {pos[i]:.4f}" for i in range(25)]
        p = write(tmp_path, "h.txt", "time_s   load_kN   position_m\n" + "\n".join(rows))
        card = read_card(p)
        assert (card.position_unit, card.load_unit) == ("m", "kN")
        assert card.dt == pytest.approx(0.3)
        np.testing.assert_allclose(card.position, pos, atol=1e-4)

    def test_read_card_requires_exactly_one(self):
        with pytest.raises(CardError, match="exactly one card, found 2"):
            read_card(DATA / "two_cards_closure.csv")

    def test_utf8_bom_and_crlf(self, tmp_path):
        p = tmp_path / "bom.csv"
        p.write_bytes(b"\xef\xbb\xbf" + csv_text().replace("\n", "\r\n").encode())
        assert read_card(p).n == 30


class TestScada:
    def test_surface_cards_with_downhole_in_metadata(self):
        cards = read_cards(DATA / "controller_export.txt")
        assert len(cards) == 3
        c = cards[0]
        assert c.card_id == "HILL-12@2021-06-01 06:00:00" and c.well_id == "HILL-12"
        assert c.n == 28  # closing point repeated in the export is dropped
        assert any("duplicated closing point" in n for n in c.notes)
        assert (c.position_unit, c.load_unit) == ("in", "lbf")
        assert c.spm == 6.2 and c.time_source == "spm"
        assert c.metadata["Stroke Length"] == 86.0 and c.metadata["Stroke Period"] == 9.677
        assert c.metadata["downhole_position"].shape == (28,)
        assert c.source == "controller_export.txt, line 2"

    def test_downhole_and_both(self):
        down = read_cards(DATA / "controller_export.txt", scada_cards="downhole")
        assert [c.card_id.endswith("/downhole") for c in down] == [True] * 3
        assert down[0].metadata["card_type"] == "downhole"
        both = read_cards(DATA / "controller_export.txt", scada_cards="both")
        assert len(both) == 6
        with pytest.raises(CardError, match="scada_cards"):
            read_cards(DATA / "controller_export.txt", scada_cards="pump")

    def test_period_only_and_no_units(self, tmp_path):
        pos, load = synthetic_stroke(24)
        text = (
            "Well|Date|Stroke Period|Surface Positions|Surface Loads\n"
            f"W1|2020-01-01|8.0|{','.join(map(str, pos))}|{','.join(map(str, load))}\n"
        )
        card = read_card(write(tmp_path, "x.txt", text))
        assert card.time_source == "period" and card.spm == pytest.approx(7.5)
        assert card.position_unit is None and detect_format(text) == "scada"


class TestJson:
    def test_cards_list_with_shared_fields(self):
        cards = read_cards(DATA / "cards.json")
        assert [c.card_id for c in cards] == ["json-0", "json-1"]
        assert all(c.well_id == "J-7" and c.position_unit == "m" for c in cards)
        assert cards[1].metadata["label"] == "gas" and cards[0].spm == 5.5
        assert cards[0].source == "cards.json, cards[0]"

    def test_single_object_with_time(self):
        card = read_card(DATA / "single_card.json")
        assert card.n == 21 and card.time_source == "file" and card.dt == pytest.approx(0.4)

    def test_top_level_list(self, tmp_path):
        pos, load = synthetic_stroke(20)
        doc = [{"pos": list(pos), "force": list(load), "period": 6.0}] * 2
        cards = read_cards(write(tmp_path, "l.json", json.dumps(doc)))
        assert len(cards) == 2 and cards[1].card_id == "l[1]" and cards[0].period == 6.0

    def test_a_list_of_wells_each_holding_its_cards(self, tmp_path):
        # A per-well export, [{"well": ..., "cards": [...]}, ...], was refused as cards
        # without position and load.
        pos, load = synthetic_stroke(20)
        card = {"position": list(pos), "load": list(load)}
        doc = [{"well": "A", "spm": 6, "cards": [card, {**card, "card_id": "a2"}]},
               {"well": "B", "spm": 5, "position_unit": "in", "cards": [
                   {**card, "spm": 4}, {"card_id": "bad", "position": [1, 2]}]},
               {"well": "C", "cards": {}}]
        p = write(tmp_path, "wells.json", json.dumps(doc))
        read = read_cards_and_errors(p)
        assert [(c.card_id, c.well_id, c.spm) for c in read.cards] == [
            ("wells[0][0]", "A", 6.0), ("a2", "A", 6.0), ("wells[1][0]", "B", 4.0)]
        assert read.cards[2].position_unit == "in" and read.cards[0].position_unit is None
        assert read.cards[1].source == "wells.json, [0].cards[1]"
        bad, empty = read.errors
        assert (bad.card_id, bad.well_id, bad.field) == ("bad", "B", "[1].cards[1]")
        assert "missing 'load'" in str(bad)
        assert (empty.well_id, empty.field) == ("C", "[2].cards")
        assert "a group's 'cards' must be a non-empty list" in str(empty)
        # The same under a document's "wells", with the document's own fields shared.
        p = write(tmp_path, "field.json", json.dumps({"field": "North", "wells": doc[:1]}))
        cards = read_cards(p)
        assert [c.metadata["field"] for c in cards] == ["North", "North"]
        assert cards[0].source == "field.json, wells[0].cards[0]"

    def test_the_innermost_field_wins_however_it_is_spelled(self, tmp_path):
        # A group's "Well" and "SPM" lost to the document's "well" and "spm": every card of
        # the file went under the document's well, at its rate, without a word.
        pos, load = synthetic_stroke(20)
        card = {"position": list(pos), "load": list(load)}
        doc = {"well": "unassigned", "spm": 7.0, "wells": [
            {"Well": "SX6E03", "SPM": 8.5, "cards": [card, {**card, "well_id": "own"}]}]}
        cards = read_cards(write(tmp_path, "spell.json", json.dumps(doc)))
        assert [(c.well_id, c.spm) for c in cards] == [("SX6E03", 8.5), ("own", 8.5)]

    def test_a_group_s_units_and_recording_time_reach_its_cards(self, tmp_path):
        # A card's own units object replaced its group's whole (position and load units
        # lost); a group's recording "time" was dropped as if it were the cards' t.
        pos, load = synthetic_stroke(20)
        card = {"t": list(0.4 * np.arange(20)), "position": list(pos), "load": list(load)}
        doc = {"units": {"position": "in"}, "wells": [
            {"well": "A", "time": "2024-05-01T10:00:00Z", "units": {"load": "lbf"},
             "cards": [{**card, "units": {"t": "s"}}]}]}
        (read,) = read_cards(write(tmp_path, "u.json", json.dumps(doc)))
        assert (read.position_unit, read.load_unit) == ("in", "lbf")
        assert read.metadata["time"].isoformat() == "2024-05-01T10:00:00+00:00"
        np.testing.assert_allclose(read.t, 0.4 * np.arange(20))

    @pytest.mark.parametrize(("doc", "field", "words"), [
        ('[{"well": "A", "spm": abc, "cards": [{"position": [1], "load": [1]}]}]', "[0].spm",
         "unparsable value 'abc'"),
        ({"wells": [{"well": "A", "cards": []}], "cards": []}, "cards",
         "the document has both 'wells' and 'cards'"),
        ([{"well": "A", "spm": "fast", "cards": [{"position": [1.0], "load": [1.0]}]}],
         "[0].spm", "spm must be a number"),
        ([{"well": "A", "cards": [{"well": "B", "cards": []}]}], "[0].cards[0].cards",
         "groups do not nest"),
        ([{"t": ["2024-05-01 10:00:00"] * 20, "position": [1.0] * 20, "load": [1.0] * 20}],
         "[0].t[0]", "date/time stamps are read in tables only"),
    ])
    def test_json_groups_refused_where_they_are_wrong(self, tmp_path, doc, field, words):
        read = read_cards_and_errors if isinstance(doc, list | str) else read_cards
        p = write(tmp_path, "bad.json", doc if isinstance(doc, str) else json.dumps(doc))
        try:
            found = read(p)
            (error,) = found.errors
        except CardError as exc:
            error = exc
        assert words in str(error) and error.field == field


class TestWhitespace:
    def test_fortran_numbers_and_column_order(self):
        card = read_card(DATA / "fortran_table.dat", columns={"load": 0, "position": 1})
        assert card.n == 32
        assert card.position[0] == 0.0 and card.position[1] == pytest.approx(0.04611533)
        assert card.load[0] == 45.0 and card.position.max() == pytest.approx(4.8)
        assert card.source == "fortran_table.dat, lines 2-33"

    def test_column_roles_recognised_and_stated(self):
        card = read_card(DATA / "fortran_table.dat")  # load first, then position
        assert card.load[0] == 45.0 and card.position.max() == pytest.approx(4.8)
        assert any("column 1 read as position and column 0 as load" in n for n in card.notes)
        roles = card.metadata["column_roles"]
        assert (roles["position"], roles["load"]) == (1, 0) and roles["confidence"] > 0.95

    def test_fortran_d_exponent(self, tmp_path):
        pos, load = synthetic_stroke(20)
        text = "\n".join(
            f"{x:.6E}".replace("E", "D") + f"   {f:.3f}" for x, f in zip(pos, load, strict=True)
        )
        card = read_card(write(tmp_path, "d.txt", text))
        np.testing.assert_allclose(card.position, pos, rtol=1e-6, atol=1e-12)


class TestTs:
    def test_two_dimensional_with_labels(self):
        cards = read_cards(DATA / "two_dim.ts", position_unit="m", load_unit="kN")
        assert [c.n for c in cards] == [24, 30, 27]
        assert [c.metadata["label"] for c in cards] == ["NORMAL", "LEAK", "NORMAL"]
        assert cards[1].card_id == "two_dim[1]" and cards[1].source == "two_dim.ts, line 11"
        assert cards[0].position.max() == pytest.approx(3.0) and cards[0].load.min() > 15

    def test_dimension_mapping(self):
        swapped = read_cards(DATA / "two_dim.ts", columns={"position": 1, "load": 0})
        normal = read_cards(DATA / "two_dim.ts")
        np.testing.assert_array_equal(swapped[0].position, normal[0].load)


# =========================================================================== malformed
def _ok_rows(n=25, sep=","):
    pos, load = synthetic_stroke(n)
    return [f"{i * 0.2:.2f}{sep}{pos[i]:.4f}{sep}{load[i]:.2f}" for i in range(n)]


def _csv(rows, header="t,position,load"):
    return "\n".join([header, *rows]) + "\n"


def _replace(rows, k, value):
    rows = list(rows)
    rows[k] = value
    return rows


def _scada(pos_list="", load_list="", header=None, extra=""):
    pos, load = synthetic_stroke(24)
    p = pos_list or ",".join(f"{x:.2f}" for x in pos)
    q = load_list or ",".join(f"{x:.0f}" for x in load)
    h = header or "Well|SPM|Surface Positions|Surface Loads"
    return f"{h}\nW1|{extra or '7.0'}|{p}|{q}\n"


def _ts(body=None, header="@dimensions 2\n@classLabel true A B\n@data\n"):
    pos, load = synthetic_stroke(24)
    good = ",".join(f"{x:.2f}" for x in pos) + ":" + ",".join(f"{x:.1f}" for x in load) + ":A"
    return header + (good if body is None else body) + "\n"


ROWS = _ok_rows()
POS24, LOAD24 = synthetic_stroke(24)
GOOD_JSON = {"position": list(POS24), "load": list(LOAD24)}

MALFORMED = [
    # (file name, content, message fragment, line or None)
    ("empty.csv", "", "empty file", None),
    ("blank.csv", "\n  \n\t\n", "empty file", None),
    ("comments.csv", "# nothing\n# here\n", "only comments", None),
    ("header_only.csv", "t,position,load\n", "header but no data rows", 1),
    ("nan.csv", _csv(_replace(ROWS, 4, "0.80,nan,9000")), "NaN value", 6),
    ("inf.csv", _csv(_replace(ROWS, 7, "1.40,12.0,inf")), "infinite value", 9),
    ("short.csv", _csv(ROWS[:12]), "only 12 samples, at least 20 needed", 2),
    ("time.csv", _csv(_replace(ROWS, 10, "1.00,50.0,9000")), "not strictly increasing", 12),
    ("ragged.csv", _csv(_replace(ROWS, 3, "0.6,1.0")), "expected 3 fields", 5),
    ("number.csv", _csv(_replace(ROWS, 5, "1.0,12.3.4,9000")), "unparsable number '12.3.4'", 7),
    ("empty_value.csv", _csv(_replace(ROWS, 5, "1.0,,9000")), "empty value", 7),
    ("const.csv", _csv([f"{i},{i},5000" for i in range(25)]), "constant load", None),
    ("constpos.csv", _csv([f"{i},3,{5000 + i}" for i in range(25)]), "constant position", None),
    ("unit.csv", _csv(ROWS, "t,position (furlong),load"), "unknown position unit 'furlong'", 1),
    ("tunit.csv", _csv(ROWS, "t (fortnight),position,load"), "unknown time unit", 1),
    ("nopos.csv", _csv(ROWS, "t,height,load"), "no position column", 1),
    ("spm.csv",
     _csv([f"A,{7 + (i > 5)},{r}" for i, r in enumerate(ROWS)], "card,spm,t,position,load"),
     "spm changes within card", 8),
    ("flag.csv", _csv([f"{r},{'maybe' if i == 3 else 0}" for i, r in enumerate(ROWS)],
                      "t,position,load,is_closure_point"), "yes/no flag", 5),
    ("emptyid.csv", _csv([f"{'' if i == 2 else 'A'},{r}" for i, r in enumerate(ROWS)],
                         "card_id,t,position,load"), "empty card identifier", 4),
    ("bin.csv", "\x00\x01\x02", "binary", None),
    # SCADA
    ("len.txt", _scada(load_list="1,2,3"), "has 24 values but", 2),
    ("list.txt", _scada(load_list="1,2,x3," + ",".join(["5"] * 21)), "unparsable number 'x3'", 2),
    ("nohdr.txt", _scada(header="Well|SPM|Surface Positions|Loads at pump"),
     "no 'Surface Loads'", 1),
    ("fields.txt", _scada() + "W2|7.0|1,2,3\n", "'|'-separated fields", 3),
    ("spmneg.txt", _scada(extra="-7"), "SPM must be a positive", 2),
    ("emptylist.txt", _scada(header="Well|SPM|Surface Positions|Surface Loads").replace(
        "|" + ",".join(f"{x:.2f}" for x in POS24), "| "), "empty list", 2),
    # JSON
    ("bad.json", '{"position": [1, 2,\n "load": [3]}', "invalid JSON", 2),
    ("noload.json", json.dumps({"position": [1.0] * 25}), "missing 'load'", None),
    ("str.json", json.dumps({**GOOD_JSON, "load": [*LOAD24[:3], "x", *LOAD24[4:]]}),
     "expected a number", None),
    ("null.json", json.dumps({**GOOD_JSON, "position": [None, *POS24[1:]]}),
     "expected a number", None),
    ("mism.json", json.dumps({**GOOD_JSON, "load": list(LOAD24[:20])}), "has 24 values but", None),
    ("units.json", json.dumps({**GOOD_JSON, "units": {"load": "stone"}}),
     "unknown load unit 'stone'", None),
    ("top.json", "[42]", "a card must be an object", None),
    ("spm.json", json.dumps({**GOOD_JSON, "spm": True}), "spm must be a number", None),
    ("nan.json", json.dumps({**GOOD_JSON, "load": [*LOAD24[:5], float("nan"), *LOAD24[6:]]}),
     "NaN value", None),
    ("cards.json", json.dumps({"cards": {"a": 1}}), "'cards' must be a list", None),
    ("emptylist.json", "[]", "no cards", None),
    # whitespace
    ("word.dat", "\n".join(f"{x:.3f} {f:.1f}" for x, f in zip(POS24, LOAD24, strict=True))
     + "\n 1.0 abc\n", "unparsable number 'abc'", 25),
    ("ragged.dat", "\n".join(f"{x:.3f} {f:.1f}" for x, f in zip(POS24, LOAD24, strict=True))
     + "\n1.0 2.0 3.0\n", "expected 2 fields", 25),
    ("onecol.dat", "\n".join(f"{x:.3f}" for x in POS24), "only 1 column", None),
    ("short.dat", "\n".join(f"{x:.3f} {f:.1f}" for x, f in zip(POS24[:9], LOAD24, strict=False)),
     "only 9 samples", 1),
    # sktime .ts
    ("nodata.ts", "@problemName x\n@dimensions 2\n", "no '@data'", None),
    ("missing.ts", _ts().replace(",", ",?,", 1), "missing value '?'", 4),
    ("dimlen.ts", _ts(body="1,2,3:" + ",".join(["1"] * 24) + ":A"), "has 3 values but", 4),
    ("univ.ts", _ts(header="@univariate true\n@data\n", body="1,2,3"), "univariate", None),
    ("dims.ts", _ts(body="1,2:3,4:5,6:A"), "expected 2 dimensions", 4),
    ("stray.ts", "@problemName x\nhello\n@data\n", "before the '@data'", 2),
    ("nums.ts", _ts(body=",".join(["1"] * 24) + ":" + ",".join(["z"] * 24) + ":A"),
     "unparsable number 'z'", 4),
]  # fmt: skip


@pytest.mark.parametrize(
    ("name", "content", "fragment", "line"), MALFORMED, ids=[m[0] for m in MALFORMED]
)
def test_malformed_files_raise_card_error(tmp_path, name, content, fragment, line):
    path = write(tmp_path, name, content)
    with pytest.raises(CardError) as info:
        read_cards(path)
    err = info.value
    assert fragment in str(err), str(err)
    assert str(path) in str(err) and err.path == str(path)
    if line is not None:
        assert err.line == line, str(err)
        assert f"line {line}" in str(err)


def test_errors_name_the_field(tmp_path):
    path = write(tmp_path, "f.csv", _csv(_replace(ROWS, 5, "1.0,oops,9000"), "t,position_in,load"))
    with pytest.raises(CardError) as info:
        read_cards(path)
    assert info.value.field == "position_in" and info.value.line == 7
    path = write(tmp_path, "f.json", json.dumps({**GOOD_JSON, "load": [*LOAD24[:3], "x"]}))
    with pytest.raises(CardError) as info:
        read_cards(path)
    assert info.value.field == "load[3]"


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"format": "xlsx"}, "unknown format 'xlsx'"),
        ({"position_unit": "furlong"}, "unknown position unit 'furlong'"),
        ({"load_unit": "stone"}, "unknown load unit 'stone'"),
        ({"columns": {"speed": 1}}, "unknown columns key 'speed'"),
        ({"columns": {"load": -1}}, ">= 0"),
        ({"spm": -3.0}, "positive"),
        ({"period": float("inf")}, "positive"),
        ({"min_samples": 1}, "min_samples"),
    ],
)
def test_bad_options(tmp_path, options, fragment):
    path = write(tmp_path, "ok.csv", csv_text())
    with pytest.raises(CardError, match=fragment):
        read_cards(path, **options)


def test_missing_file_and_forced_wrong_format(tmp_path):
    with pytest.raises(CardError, match="cannot read the file"):
        read_cards(tmp_path / "nope.csv")
    path = write(tmp_path, "ok.csv", csv_text())
    for fmt in ("ts", "scada", "json"):
        with pytest.raises(CardError):
            read_cards(path, format=fmt)
    with pytest.raises(CardError, match="no delimiter"):
        read_cards(DATA / "fortran_table.dat", format="csv")


def test_latin1_is_read_with_a_note(tmp_path):
    p = tmp_path / "l.csv"
    p.write_bytes(csv_text().encode() + b"# caf\xe9 (Latin-1 comment)\n")
    card = read_card(p)
    assert "file is not valid UTF-8; decoded as Latin-1" in card.notes


def test_detect_format():
    assert detect_format(csv_text()) == "csv"
    assert detect_format((DATA / "controller_export.txt").read_text()) == "scada"
    assert detect_format((DATA / "cards.json").read_text()) == "json"
    assert detect_format((DATA / "two_dim.ts").read_text()) == "ts"
    assert detect_format((DATA / "fortran_table.dat").read_text()) == "whitespace"
    assert set(FORMATS) == {"csv", "scada", "json", "whitespace", "ts"}


def test_forced_json_top_level_scalar():
    with pytest.raises(CardError, match="top level must be an object or a list"):
        parse_cards("42", name="x.json", format="json")


def test_parse_cards_from_memory():
    cards = parse_cards(csv_text().encode(), name="mem.csv", position_unit="in")
    assert cards[0].source.startswith("mem.csv") and cards[0].position_unit == "in"


# =========================================================================== strokes
def record(strokes=5, n=60, dt=0.1, phase=0.0, noise=0.0, seed=0):
    """A multi-stroke time record sampled through `strokes` periods, endpoint included."""
    rng = np.random.default_rng(seed)
    k = np.arange(strokes * n + 1)
    th = 2 * np.pi * k / n + phase
    pos = 50 * (1 - np.cos(th)) + noise * rng.standard_normal(k.size)
    load = 8000 + 2000 * np.tanh(4 * np.sin(th)) + 20 * noise * rng.standard_normal(k.size)
    return Card(position=pos, load=load, t=k * dt, time_source="file", card_id="rec",
                position_unit="in", load_unit="lbf")  # fmt: skip


class TestSplitStrokes:
    def test_clean_record(self):
        strokes = split_strokes(record())
        assert len(strokes) == 5
        assert [s.card_id for s in strokes] == [f"rec#{k}" for k in range(5)]
        for k, s in enumerate(strokes):
            assert s.n == 60 and s.periodic and s.t[0] == 0.0
            assert s.period == pytest.approx(6.0) and s.spm == pytest.approx(10.0)
            # Its id's number and its place among the strokes ("stroke 0 of 5" read as one
            # short).
            assert f"stroke #{k} ({k + 1} of 5) cut from 'rec'" in s.notes[-1]
        assert strokes[2].metadata["t0"] == pytest.approx(12.0)
        # A dated record dates each stroke by its start (every stroke had the record's).
        dated = record()
        dated.metadata["time"] = datetime(2024, 5, 1, 10, tzinfo=UTC)
        assert split_strokes(dated)[2].metadata["time"] == dated.metadata["time"]  # a date
        dated.metadata["first_sample_time"] = "2024-05-01T10:00:00Z"  # its first stamp
        assert split_strokes(dated)[2].metadata["time"] == datetime(2024, 5, 1, 10, 0, 12,
                                                                    tzinfo=UTC)
        # Each stroke's source says which samples of the record it is (every stroke said
        # the record's whole span of lines).
        cut = split_strokes(record().replace(source="rec.csv, lines 2-302"))
        assert cut[2].source == "rec.csv, lines 2-302, samples 120-179"
        assert len({c.source for c in cut}) == len(cut)

    def test_noise_and_wiggles_do_not_add_strokes(self):
        card = record(noise=1.5, seed=3)
        wiggle = card.position + 4.0 * np.sin(2 * np.pi * np.arange(card.n) / 7)
        card = card.replace(position=wiggle)
        strokes = split_strokes(card)
        assert len(strokes) == 5
        assert all(s.period == pytest.approx(6.0, rel=0.1) for s in strokes)

    def test_partial_head_and_tail_are_dropped(self):
        strokes = split_strokes(record(phase=1.3))
        assert len(strokes) == 4
        assert "partial stroke before sample" in strokes[0].notes[-1]
        assert "partial stroke after sample" in strokes[0].notes[-1]
        assert all(s.n == 60 for s in strokes)

    def test_a_flat_bottom_at_the_records_end_ends_the_last_stroke(self):
        # Three copies of one stroke whose bottom holds the lowest position for three
        # samples (its first two and its last, as a public card's): the last stroke lost
        # its last sample to the tail bottom, and with it its period and fit. The record's
        # own warning that it holds several strokes is not the strokes'.
        n = 60
        one = 50 * (1 - np.cos(2 * np.pi * np.arange(n) / n))
        one[[1, -1]] = 0.0
        pos = np.tile(one, 3)
        load = np.tile(8000 + 2000 * np.tanh(4 * np.sin(2 * np.pi * np.arange(n) / n)), 3)
        card = Card(position=pos, load=load, t=np.arange(3 * n) * 0.1, time_source="file",
                    card_id="flat", warnings=("card 'flat' holds several strokes in its own "
                                              "time: ...",))
        strokes = split_strokes(card)
        assert [s.n for s in strokes] == [n, n, n]
        assert all(s.period == pytest.approx(6.0) for s in strokes)
        np.testing.assert_array_equal(strokes[-1].position, strokes[0].position)
        assert not any("several strokes" in w for s in strokes for w in s.warnings)

    def test_a_short_last_stroke_keeps_its_end(self):
        # Strokes of 100, 100, 100 and 94 samples, then the first 5 of another upstroke:
        # the last stroke ends at its own bottom, the 5 are a partial stroke (a fix for
        # flat bottoms must not give them to it).
        parts = [50 * (1 - np.cos(2 * np.pi * np.arange(m) / m)) for m in (100, 100, 100, 94)]
        pos = np.concatenate([*parts, 50 * (1 - np.cos(2 * np.pi * np.arange(5) / 100))])
        load = 8000 + 40 * pos
        card = Card(position=pos, load=load, t=np.arange(pos.size) * 0.1,
                    time_source="file", card_id="short")
        strokes = split_strokes(card)
        assert [s.n for s in strokes] == [100, 100, 100, 94]
        assert strokes[-1].period == pytest.approx(9.4)
        assert "partial stroke after sample 393" in strokes[-1].notes[-1]

    def test_a_frozen_stretch_of_a_record_is_weighed_against_a_stroke(self, tmp_path):
        # 10 samples frozen in a record of five 60-sample strokes: a sixth of a stroke,
        # under 5 % of the record, went unsaid.
        rec = record()
        pos, load = rec.position.copy(), rec.load.copy()
        pos[100:110], load[100:110] = pos[100], load[100]
        rows = ["t,position_in,load_lbf"] + [
            f"{float(t)!r},{float(p)!r},{float(f)!r}"
            for t, p, f in zip(rec.t, pos, load, strict=True)]
        card = read_card(write(tmp_path, "frozen.csv", "\n".join(rows)))
        assert any("samples 100-109" in w and "frozen sensor" in w for w in card.warnings)

    def test_record_starting_at_top(self):
        strokes = split_strokes(record(strokes=4, phase=np.pi))
        assert len(strokes) == 3 and all(s.n == 60 for s in strokes)

    def test_single_stroke_returned_whole_and_periodic(self):
        card = read_card(DATA / "stroke_with_time.csv")
        (s,) = split_strokes(card)
        assert s.card_id == "stroke_with_time#0" and s.periodic and s.n == card.n
        assert "single stroke" in s.notes[-1]
        assert s.period == pytest.approx(8.0, rel=1e-4)

    def test_card_without_time(self):
        c = record()
        strokes = split_strokes(Card(position=c.position, load=c.load, card_id="x"))
        assert len(strokes) == 5 and strokes[0].t is None and strokes[0].period is None

    def test_min_samples_and_errors(self):
        with pytest.raises(CardError, match="shorter than 100"):
            split_strokes(record(), min_samples=100)
        flat = Card(position=np.ones(30), load=np.arange(30.0), card_id="f")
        with pytest.raises(CardError, match="constant position"):
            split_strokes(flat)

    def test_metadata_arrays_follow_the_samples(self):
        c = record()
        c = c.replace(metadata={"angle": np.arange(c.n, dtype=float), "label": "x"})
        s = split_strokes(c)[1]
        assert s.metadata["angle"][0] == s.metadata["sample_range"][0]
        assert s.metadata["label"] == "x"


def test_round_trip_time_grid_matches_rule():
    """t_i = i*T/N: the sample after the last one would be at exactly one period."""
    card = read_cards(DATA / "two_cards_closure.csv")[0]
    assert card.t[-1] + card.dt == pytest.approx(card.period)
    assert math.isclose(card.period, 60 / card.spm)
