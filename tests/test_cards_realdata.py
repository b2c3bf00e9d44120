"""Read the third-party cards kept outside the repository (skipped when they are absent).

The data live in ``../shared/data/raw/`` next to the repository root; each folder has a
SOURCE.md describing provenance and quirks. Nothing from there is copied into this
repository: these tests only read it and check that the readers honour what each file says.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from pumpid.cards import CardError, open_stroke, read_card, read_cards, split_strokes

from .conftest import REPORTED

RAW = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "raw"

if not RAW.is_dir():
    pytest.skip(f"third-party card folder {RAW.name!r} not present", allow_module_level=True)

pytestmark = pytest.mark.realdata

# Files that are not cards (or hold no samples), with the reason they are not read.
NOT_CARDS = {
    "SOURCE.md": "provenance notes",
    "subset_row_indices.txt": "list of row indices of the subset, not a card",
    # The repository's own card header table: one row per card with date, stroke length and a
    # placeholder period; it holds no position/load samples at all.
    "orig_dyno-card-headers.csv": "card header table without samples",
    # The contest's well data (depths, rod diameters ...) beside its two cards: no samples.
    "wells.json": "well data without samples",
}

# How each folder must be read, following its SOURCE.md.
OPTIONS: dict[str, dict[str, Any]] = {
    # Header names carry the units (position_in, load_lbf, t_s); nothing to add.
    "sandia_dds": {},
    # No header: pseudo-angle, position (in), load (klbf); no time and no SPM.
    "dzhang123_dynacard_realdata": {
        "columns": {"position": 1, "load": 2},
        "position_unit": "in",
        "load_unit": "klbf",
    },
    # Whitespace, no header: column 1 load (unit not stated), column 2 position in metres.
    "cupb_dynamometer_card": {"columns": {"load": 0, "position": 1}, "position_unit": "m"},
    # sktime .ts: dim0 position (m), dim1 load (apparently kN).
    "shapeformer_oilfield2d": {"position_unit": "m", "load_unit": "kN"},
}

# The repository's own mis-aligned card table (SOURCE.md: loads offset by 4 samples, header
# numbers inside the load column). It is read only as a generic headerless CSV, to show the
# generic reader copes with it; its values must not be used as cards.
ORIG_DETAILS = {"columns": {"card": 0, "position": 2, "load": 3}}


def _options(path: Path) -> dict[str, Any]:
    if path.name == "orig_dyno-card-details.csv":
        return ORIG_DETAILS
    return OPTIONS.get(path.parent.name, {})


ALL_FILES = sorted(p for p in RAW.rglob("*") if p.is_file() and p.name not in NOT_CARDS)


@pytest.mark.parametrize("path", ALL_FILES, ids=[str(p.relative_to(RAW)) for p in ALL_FILES])
def test_every_file_reads(path):
    cards = read_cards(path, **_options(path))
    assert cards
    for card in cards:
        assert card.n >= 20
        assert np.all(np.isfinite(card.position)) and np.all(np.isfinite(card.load))
        assert card.source.startswith(path.name)
        assert any(note.startswith("read as ") for note in card.notes)


def test_known_folders_present():
    folders = {p.name for p in RAW.iterdir() if p.is_dir()}
    assert set(OPTIONS) <= folders


# --------------------------------------------------------------------------- Sandia
class TestSandia:
    def test_surface_cards(self):
        cards = read_cards(RAW / "sandia_dds" / "surface_cards.csv")
        assert [c.card_id for c in cards] == ["SX6E03A", "SX6E03B", "SX6I03A", "SX6I03B"]
        # 94/95 rows per card; the flagged closure row is dropped.
        assert [c.n for c in cards] == [93, 93, 94, 94]
        for card, spm in zip(cards, (8.4827, 8.481, 8.5028, 8.5039), strict=True):
            assert (card.position_unit, card.load_unit) == ("in", "lbf")
            assert card.spm == spm and card.time_source == "spm" and card.periodic
            assert card.dt == pytest.approx(60.0 / spm / card.n)
            assert any("closure point" in n and "dropped" in n for n in card.notes)
            assert any("time rebuilt from" in n and "t_i = i*T/N" in n for n in card.notes)
            assert 140 < card.position.max() < 145 and card.position.min() >= -1
            assert 4_000 < card.load.min() < card.load.max() < 15_000
            # Derived columns are kept, aligned with the kept samples.
            assert card.metadata["t_s_uniform"].shape == (card.n,)
            assert card.metadata["n_points"] == card.n + 1

    def test_surface_cards_with_documented_sample_interval(self):
        # SOURCE.md: a constant sample interval of about 0.075 s fits better than the SPM.
        card = read_cards(RAW / "sandia_dds" / "surface_cards.csv")[0].with_dt(0.075)
        assert card.time_source == "dt" and card.dt == pytest.approx(0.075)
        assert card.period == pytest.approx(93 * 0.075)
        assert "dt = 0.075 s" in card.notes[-1]

    def test_downhole_time_records_split_into_strokes(self):
        records = read_cards(RAW / "sandia_dds" / "downhole_timeseries.csv")
        assert [r.card_id for r in records] == ["3X6E03", "3X6I03"]
        for rec in records:
            assert rec.n == 3001 and rec.time_source == "file"
            assert rec.dt == pytest.approx(0.02) and rec.t[-1] == pytest.approx(60.0)
            strokes = split_strokes(rec)
            # About 7 periods in 60 s; partial strokes at both ends are dropped.
            assert 6 <= len(strokes) <= 7
            for s in strokes:
                assert 8.0 < s.period < 8.8 and s.periodic
                assert 380 < s.n < 450
                assert s.card_id.startswith(rec.card_id + "#")

    def test_orig_details_read_generically(self):
        cards = read_cards(RAW / "sandia_dds" / "orig_dyno-card-details.csv", **ORIG_DETAILS)
        assert [c.card_id for c in cards] == [str(k) for k in range(1, 9)]
        assert all(c.position_unit is None and c.load_unit is None for c in cards)

    def test_orig_headers_hold_no_samples(self):
        with pytest.raises(CardError, match="no position or load column"):
            read_cards(RAW / "sandia_dds" / "orig_dyno-card-headers.csv")


# --------------------------------------------------------------------------- dzhang123
class TestDzhang:
    FOLDER = RAW / "dzhang123_dynacard_realdata"

    def test_all_cards(self):
        files = sorted(self.FOLDER.glob("*.csv"))
        assert len(files) == 10
        for f in files:
            rows = len(f.read_text().split())
            card = read_card(f, **OPTIONS[self.FOLDER.name])
            assert card.n in (rows, rows - 1)
            assert (card.n == rows - 1) == any("duplicated closing point" in n for n in card.notes)
            assert (card.position_unit, card.load_unit) == ("in", "klbf")
            assert card.t is None and card.time_source == "none"
            assert card.position.min() >= 0 and card.position.max() <= 200
            if f.stem.endswith("__surface"):
                assert 5 < card.load.min() < card.load.max() < 28
            else:
                assert -4 < card.load.min() < card.load.max() < 7.5
            angle = card.metadata["column_0"]  # pseudo-angle kept, not used as time
            assert angle.shape == (card.n,) and 0 <= angle.min() and angle.max() < 366

    def test_duplicate_surface_files_noted_in_source_md_are_identical(self):
        a = read_card(self.FOLDER / "rod_parted__surface.csv", **OPTIONS[self.FOLDER.name])
        b = read_card(self.FOLDER / "unanchored_tbg__surface.csv", **OPTIONS[self.FOLDER.name])
        np.testing.assert_array_equal(a.load, b.load)

    def test_time_only_as_fraction_of_period(self):
        card = read_card(self.FOLDER / "anchored_tbg__surface.csv", **OPTIONS[self.FOLDER.name])
        unit = card.with_period(1.0)  # normalised time: the SPM is unknown
        assert unit.t[0] == 0 and unit.t[-1] == pytest.approx(1 - 1 / card.n)


# --------------------------------------------------------------------------- CUPB
class TestCupb:
    FOLDER = RAW / "cupb_dynamometer_card"
    RANGES: ClassVar[dict[str, tuple[int, int]]] = {
        "DK3": (28, 75),
        "DK6": (3_800, 8_900),
        "S22": (2_300, 6_800),
    }

    def test_cards(self):
        for stem, (lo, hi) in self.RANGES.items():
            card = read_card(self.FOLDER / f"{stem}.txt", **OPTIONS[self.FOLDER.name])
            assert card.n == 67 and card.position_unit == "m"
            assert card.load_unit is None  # not stated anywhere: left unknown, with a note
            assert any("load unit not stated" in n for n in card.notes)
            assert 5.4 < card.position.max() < 5.75 and 0 < card.position.min() < 0.01
            assert lo < card.load.min() < card.load.max() < hi
            assert int(np.argmax(card.position)) == 36  # row 37: top of stroke

    def test_declaring_the_load_unit_allows_conversion(self):
        card = read_card(self.FOLDER / "DK3.txt", **OPTIONS[self.FOLDER.name])
        with pytest.raises(CardError, match="unknown"):
            card.to_units(load="N")
        kn = card.with_units(load="kN").to_units(load="N")
        assert kn.load.max() == pytest.approx(card.load.max() * 1000)

    def test_explicit_columns_win_even_when_wrong_and_a_warning_says_so(self):
        card = read_card(self.FOLDER / "DK3.txt", columns={"position": 0, "load": 1})
        assert card.position.max() > 70  # obeyed: loads taken for positions
        assert card.metadata["column_roles"]["method"] == "given by the caller (columns=)"
        assert any("look swapped" in w for w in card.warnings)


# --------------------------------------------------------------------------- headerless sets
# The two public headerless sets, and where position and load really are (SOURCE.md).
HEADERLESS = {"cupb_dynamometer_card": (1, 0), "dzhang123_dynacard_realdata": (1, 2)}
HEADERLESS_FILES = [
    p
    for folder in HEADERLESS
    for p in sorted((RAW / folder).glob("*"))
    if p.is_file() and p.name not in NOT_CARDS
]


@pytest.mark.parametrize(
    "path", HEADERLESS_FILES, ids=[str(p.relative_to(RAW)) for p in HEADERLESS_FILES]
)
def test_headerless_sets_read_the_right_way_round_without_options(path):
    want = HEADERLESS[path.parent.name]
    card = read_card(path)
    roles = card.metadata["column_roles"]
    assert (roles["position"], roles["load"]) == want
    assert roles["confidence"] >= 0.95 and roles["words"] in ("high", "very high")
    assert any("recognised from their shapes" in n for n in card.notes)
    assert not card.warnings
    named = read_card(path, columns={"position": want[0], "load": want[1]})
    np.testing.assert_array_equal(card.position, named.position)
    np.testing.assert_array_equal(card.load, named.load)


def test_headerless_sets_present_and_confidence_reported():
    assert len(HEADERLESS_FILES) == 13
    conf = [read_card(p).metadata["column_roles"]["confidence"] for p in HEADERLESS_FILES]
    REPORTED.append(
        f"column roles of {len(conf)} headerless public cards recognised without options: "
        f"confidence {min(conf):.4f} to {max(conf):.4f}"
    )


# --------------------------------------------------------------------------- ShapeFormer
class TestShapeformer:
    PATH = RAW / "shapeformer_oilfield2d" / "OilfieldData2d_TEST_subset360.ts"

    def test_cards_and_labels(self):
        cards = read_cards(self.PATH, **OPTIONS["shapeformer_oilfield2d"])
        assert len(cards) == 360
        labels = [c.metadata["label"] for c in cards]
        assert len(set(labels)) == 12
        assert all(labels.count(lab) == 30 for lab in set(labels))
        closed = [any("duplicated closing point" in n for n in c.notes) for c in cards]
        for card, was_closed in zip(cards, closed, strict=True):
            assert card.n + was_closed in (200, 250)
            assert (card.position_unit, card.load_unit) == ("m", "kN")
            assert card.position.min() >= 0 and card.position.max() <= 10.5
            assert card.load.min() >= 0 and card.load.max() <= 120
            assert card.t is None
        assert cards[5].card_id == "OilfieldData2d_TEST_subset360[5]"
        assert cards[5].metadata["series_index"] == 5

    def test_single_strokes_stay_whole(self):
        card = read_cards(self.PATH, **OPTIONS["shapeformer_oilfield2d"])[0]
        (stroke,) = split_strokes(card)
        assert stroke.n == card.n and stroke.periodic


def test_the_oilfield_cards_that_do_not_close():
    # 3 of the 360 oilfield cards end 85 % of their stroke from where they start (SOURCE.md
    # warns of mis-cut cards), and one 40 %: cut short and padded with (0, 0), which its
    # padding had hidden; every other card of the public sets read as one stroke closes.
    path = RAW / "shapeformer_oilfield2d" / "OilfieldData2d_TEST_subset360.ts"
    cards = read_cards(path, spm=6, **OPTIONS["shapeformer_oilfield2d"])
    open_ones = [i for i, c in enumerate(cards) if open_stroke(c.position) is not None]
    assert open_ones == [110, 132, 250, 276]
    assert all(0.84 < open_stroke(cards[i].position)[0] < 0.86 for i in (110, 250, 276))
    assert 0.39 < open_stroke(cards[132].position)[0] < 0.41
    assert any("padding dropped: the last 50 of 250 samples" in n for n in cards[132].notes)
    surface = read_cards(RAW / "sandia_dds" / "surface_cards.csv")
    assert all(open_stroke(c.position) is None for c in surface)
