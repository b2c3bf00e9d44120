"""The fleet report: its files, a self-contained page, every alerted well named."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pumpid.fleet.changes import card_counts, detect_changes
from pumpid.fleet.report import write_fleet_report

from .test_changes import results_table

STEPS = {2: ("stiffness", 1.3, 60), 5: ("damping_ratio", 0.7, 80)}


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    frame = results_table(12, 150, cv=0.03, seed=21, steps=STEPS)
    rng = np.random.default_rng(2)
    rows = frame.index[rng.choice(len(frame), 60, replace=False)]
    frame.loc[rows[:40], "status"] = "failed"
    frame.loc[rows[40:], "status"] = "invalid-input"
    frame.loc[rows[:40], ["d_stiffness", "d_natural_frequency", "d_damping_ratio"]] = np.nan
    frame.loc[frame.index[0], "well_id"] = "<b>odd & well</b>"  # text must be escaped
    return frame


def test_report_files_and_page(table: pd.DataFrame, tmp_path: Path) -> None:
    path = tmp_path / "results.parquet"
    table.to_parquet(path)
    files = write_fleet_report(path, tmp_path / "out", max_wells_plotted=5, steady_sample=2)
    for key in ("report", "alerts", "wells", "status", "distribution_stiffness"):
        assert files[key].is_file() and files[key].stat().st_size > 0
    pngs = sorted(p.name for p in (tmp_path / "out").glob("*.png"))
    assert pngs == sorted(f"{k}.png" for k in files if k not in ("report", "alerts", "wells"))
    for png in pngs:
        assert (tmp_path / "out" / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = files["report"].read_text(encoding="utf-8")
    # self-contained: nothing fetched from anywhere, no script
    # (the embedded PNGs' base64 text may spell anything)
    assert "http" not in re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", page).lower()
    assert not re.search(r"<(script|link|iframe)\b", page, re.IGNORECASE)
    assert all(src.startswith("data:image/png;base64,")
               for src in re.findall(r'src="([^"]*)"', page))
    assert "<b>odd" not in page and "&lt;b&gt;odd &amp; well&lt;/b&gt;" in page
    alerts = pd.read_csv(files["alerts"])
    assert set(alerts["well_id"]) == {"W0002", "W0005"}
    for well in alerts["well_id"]:
        assert f"Well {well}" in page  # drawn, with its heading
        assert page.count(well) >= 3  # and in the alerts and wells tables
    for section in ("Run summary", "Alerts", "Wells", "Quantities across wells",
                    "Trends per well"):
        assert f"<h2>{section}</h2>" in page
    assert "13 wells" in page and "1800 cards" in page and "40 cards (2.2%)" in page
    assert "lbf/in" in page and "Hz" in page
    assert ("both wells with an alert; 2 of the 11 wells without an alert for comparison, "
            "picked at random") in page


def test_alerts_csv_round_trips(table: pd.DataFrame, tmp_path: Path) -> None:
    alerts = detect_changes(table)
    files = write_fleet_report(table, tmp_path, alerts=alerts, steady_sample=0)
    back = pd.read_csv(files["alerts"], parse_dates=["first_time", "alarm_time"])
    pd.testing.assert_frame_equal(back, alerts, check_dtype=False)
    wells = pd.read_csv(files["wells"])
    assert len(wells) == table["well_id"].nunique()
    assert wells["well_id"].iloc[:2].tolist() == alerts.assign(
        s=alerts["change_se"].abs()).sort_values("s", ascending=False)["well_id"].tolist()
    assert "alerts given by the caller" in files["report"].read_text(encoding="utf-8")


def test_many_wells_are_sampled_and_no_alerts(tmp_path: Path) -> None:
    frame = results_table(900, 36, cv=0.03, seed=4)
    frame.loc[frame["well_id"] == "W0003", "time"] = pd.NaT
    empty = detect_changes(frame.iloc[:0])
    files = write_fleet_report(frame, tmp_path, alerts=empty, quantities=["stiffness"],
                               steady_sample=3, max_wells_listed=50)
    page = files["report"].read_text(encoding="utf-8")
    assert "No persistent change was found" in page
    assert "The first 50 of 900 wells are listed" in page
    assert "3 of the 900 wells without an alert for comparison, picked at random" in page
    assert len([k for k in files if k.startswith("well_")]) == 3
    assert len(pd.read_csv(files["wells"])) == 900


def test_parameters_shown_with_their_units(table: pd.DataFrame, tmp_path: Path) -> None:
    frame = table.assign(p_k0=200.0 * np.exp(0.02 * np.sin(np.arange(len(table)))),
                         p_k0_se=1.5)
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness", "p_k0"],
                               steady_sample=1)
    page = files["report"].read_text(encoding="utf-8")
    assert "p_k0 [lbf/in]" in page and "stiffness [lbf/in]" in page
    assert "distribution_p_k0" in files


def test_rows_without_a_well_are_not_a_well_and_counts_agree(tmp_path: Path) -> None:
    frame = results_table(3, 90, cv=0.03, seed=5, steps={1: ("stiffness", 1.4, 45)})
    lost = frame.index[[5, 100, 200]]
    frame.loc[lost, "well_id"] = None
    frame.loc[lost, "status"] = "invalid-input"
    alerts = detect_changes(frame, ["stiffness"])
    assert len(alerts) == 1
    files = write_fleet_report(frame, tmp_path, alerts=alerts, quantities=["stiffness"])
    page = files["report"].read_text(encoding="utf-8")
    assert "3 wells, 270 cards, 1 alert." in page
    assert "<td>wells</td><td>3 wells</td>" in page
    assert re.search(r"<td>cards without a well id \(filed under \(unknown well\), with any "
                     r"unreadable input\S+ rows\)</td><td>3 cards</td>", page)
    # The cards without a well id come last in the wells table, not among the named wells.
    wells = pd.read_csv(files["wells"])["well_id"].tolist()
    assert wells[-1] == "(unknown well)" and len(wells) == 4


def test_cards_without_well_ids_are_not_called_unreadable_or_too_short(tmp_path: Path) -> None:
    # A public set without well ids: the report said "0 wells", "cards without a well
    # (unreadable input)", "cards used for trends (converged, boundary, poor-fit)" beside
    # undetermined ones counted in, and "every well's history is too short" for 90 cards.
    frame = results_table(1, 90, cv=0.03, seed=5).assign(well_id=None)
    frame.loc[frame.index[::3], "status"] = "undetermined"
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"])
    page = files["report"].read_text(encoding="utf-8")
    assert "unreadable input)</td><td>90 cards" not in page
    assert ("cards used for trends (converged, boundary, undetermined, with a well id)"
            "</td><td>0 cards") in page
    assert "too short" not in page.split('id="alerts"')[1].split("</section>")[0]
    assert "the cards carry no well id" in page


def test_cards_without_well_ids_are_counted_not_trended(tmp_path: Path) -> None:
    # The pool of cards without a well id (they may come from several wells) was tested and
    # drawn as a well, and could raise an alert beside "0 wells tested"; and a repeated
    # card was set aside without wells.csv counting it.
    frame = results_table(1, 90, cv=0.03, seed=5).assign(well_id=None)
    frame.loc[frame.index[45:], "d_stiffness"] *= 3.0  # a step no pool may be alerted on
    frame["duplicate_of"] = None
    frame.loc[frame.index[10], "duplicate_of"] = frame["card_id"].iloc[9]
    assert detect_changes(frame, ["stiffness"]).empty
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"])
    page = files["report"].read_text(encoding="utf-8")
    assert "well_(unknown well)" not in files and "No well has a usable card to draw" in page
    assert "Each panel shows" not in page  # no panel drawn, none described
    wells = pd.read_csv(files["wells"])
    assert wells.loc[0, "duplicates"] == 1 and wells.loc[0, "cards"] == 89
    assert wells.loc[0, "tested"] == "not tested (no well id)"
    assert card_counts(frame) == {"cards": 89, "repeats": 1, "wells": 0, "unnamed": 89,
                                  "undated": 0}
    # Nothing of it is trended, and the summary says why beside the quantity (it said "no
    # usable value", where the values are usable and the missing well id is the reason).
    assert ("stiffness [lbf/in] (usable values only on cards without a well id: not "
            "trended)") in page
    assert "stiffness: usable values only on cards without a well id." in page
    assert "<td>quantities asked for</td>" in page and "quantities trended" not in page


def test_failed_and_invalid_cards_of_a_well_are_drawn(tmp_path: Path) -> None:
    from PIL import Image

    frame = results_table(2, 60, cv=0.03, seed=6)
    hit = frame.index[(frame["well_id"] == "W0001") & frame.index.isin([70, 80, 95])]
    frame.loc[hit, "status"] = "invalid-input"
    frame.loc[hit, ["d_stiffness", "d_stiffness_se"]] = np.nan
    empty = detect_changes(frame.iloc[:0])
    files = write_fleet_report(frame, tmp_path, alerts=empty, quantities=["stiffness"],
                               steady_sample=2)
    red = {}
    for well in ("W0000", "W0001"):
        rgb = np.asarray(Image.open(files[f"well_{well}"]).convert("RGB")).astype(int)
        # the crosses' colour; with no alert nothing else on the figure has it
        red[well] = int((np.abs(rgb - (176, 0, 32)).sum(axis=2) < 60).sum())
    assert red["W0000"] == 0 and red["W0001"] > 20


def test_tables_state_units_once_and_fit_a_window(table: pd.DataFrame, tmp_path: Path) -> None:
    files = write_fleet_report(table, tmp_path, quantities=["stiffness"], steady_sample=0)
    page = files["report"].read_text(encoding="utf-8")
    alerts_table = page[page.index('<section id="alerts">'):page.index('<section id="wells">')]
    wells_table = page[page.index('<section id="wells">'):page.index('id="distributions"')]
    assert alerts_table.count("<th>") <= 9
    assert "<th>latest stiffness [lbf/in]</th>" in wells_table
    assert "lbf/in</td>" not in wells_table  # the unit is in the header, not in every row


def _no_time_constant(wells: int, cards: int, seed: int) -> pd.DataFrame:
    """A results table whose time constant (unit s) no card determined."""
    return results_table(wells, cards, cv=0.02, seed=seed).assign(
        d_time_constant=np.nan, d_time_constant_se=np.nan, d_time_constant_determined=False,
        d_time_constant_unit="s")


def test_a_quantity_no_card_determined_keeps_its_unit(tmp_path: Path) -> None:
    # Real Kelvin wells: the third pole's time constant undetermined on every card. Its
    # unit (s) does not depend on that; the page said "[dimensionless]" in three places.
    files = write_fleet_report(_no_time_constant(6, 40, seed=8), tmp_path, steady_sample=1)
    page = files["report"].read_text(encoding="utf-8")
    assert "time_constant [s]" in page
    # No well has a latest value of it: its column is left out of the wells table, and said.
    assert "<th>latest time_\u200bconstant" not in page
    assert "no latest usable value of time_constant in these wells" in page
    assert "dimensionless" not in page.replace("damping_ratio [dimensionless]", "").replace(
        "damping_\u200bratio [dimensionless]", "")


def _blue_rows(png: Path) -> tuple[int, int]:
    """Rows spanned by the value line's colour, and by the band's (the panel's height when
    the band runs off the axis)."""
    from PIL import Image

    rgb = np.asarray(Image.open(png).convert("RGB")).astype(int)
    # the data's left part, clear of the legend (above the axes on the right)
    left = rgb[:, rgb.shape[1] // 5: rgb.shape[1] // 2]
    hit = np.flatnonzero((np.abs(left - (8, 81, 156)).sum(axis=2) < 40).any(axis=1))
    band = np.flatnonzero((np.abs(left - (198, 219, 239)).sum(axis=2) < 20).any(axis=1))
    return int(hit.max() - hit.min()), int(band.max() - band.min())


def test_one_well_reads_right(tmp_path: Path) -> None:
    # One well, 76 cards, stiffness 100-200 lbf/in with standard errors so large that the
    # +-2 SE bands run from about 0 to over 1000.
    frame = results_table(1, 76, cv=0.02, seed=9)
    frame["d_stiffness"] = np.random.default_rng(1).uniform(100.0, 200.0, 76)
    frame["d_stiffness_se"] = 0.6 * frame["d_stiffness"]
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"])
    page = files["report"].read_text(encoding="utf-8")
    assert "Drawn: the well without an alert." in page
    assert "0 of 0" not in page
    assert "too few wells for a histogram" in page
    # the values span most of the panel's height, not a sliver of an axis made for bands
    span, height = _blue_rows(files["well_W0000"])
    assert span > 0.45 * height, (span, height)  # about 0.15 when scaled to the bands
    from PIL import Image

    rgb = np.asarray(Image.open(files["well_W0000"]).convert("RGB")).astype(int)
    assert rgb.shape[1] >= 1200  # the page's width
    marked = (np.abs(rgb - (107, 174, 214)).sum(axis=2) < 30).sum()
    assert marked > 50  # the cut bands' triangles
    assert 'class="wide"' in page


def test_the_wells_tables_headers_wrap_so_the_table_fits_a_window(table: pd.DataFrame,
                                                                   tmp_path: Path) -> None:
    # A header word that cannot wrap sets its column's least width: the quantities' names
    # (natural_frequency, static_stiffness) made the wells table wider than a 1400 px window.
    files = write_fleet_report(table, tmp_path, steady_sample=0)
    page = files["report"].read_text(encoding="utf-8")
    wells = page[page.index("<h2>Wells</h2>"):page.index("<h2>Quantities across wells</h2>")]
    headers = re.findall(r"<th[^>]*>(.*?)</th>", wells)
    assert any("natural_" in h for h in headers)
    words = [w for h in headers for w in re.split(r"[\s\u200b-]+", h)]
    assert max(len(w) for w in words) <= len("[dimensionless]"), max(words, key=len)


def test_the_wells_table_leaves_out_columns_empty_in_every_well(tmp_path: Path) -> None:
    # A pump field: 9 quantities and 6 statuses made the wells table scroll sideways at
    # 1400 px although three quantities had no value and four statuses no card.
    files = write_fleet_report(_no_time_constant(4, 30, seed=3), tmp_path, steady_sample=1)
    page = files["report"].read_text(encoding="utf-8")
    wells = page[page.index("<h2>Wells</h2>"):page.index("<h2>Quantities across wells</h2>")]
    headers = re.findall(r"<th[^>]*>(.*?)</th>", wells)
    assert "converged" in headers and "failed" not in headers and "poor-fit" not in headers
    assert not any("time_" in h for h in headers)
    assert "Columns left out: no card of these wells has status" in wells
    assert "failed" in wells and "time_constant" in wells  # said in words


def test_the_plots_leave_out_what_a_card_calls_an_echo_of_the_stroke() -> None:
    # The change detection skips a value its card calls an echo of the stroke (not the
    # well's); the plots drew it, a row of points on the stroke frequency.
    from pumpid.fleet.figures import quantity_values

    frame = results_table(1, 30, seed=2)
    frame["d_stiffness_well_property"] = [i % 3 != 0 for i in range(len(frame))]
    _value, _se, ok = quantity_values(frame, "stiffness")
    assert not ok[frame["d_stiffness_well_property"] == False].any()  # noqa: E712
    assert ok[frame["d_stiffness_well_property"]].all()


def test_a_pump_run_gives_the_identifications_beside_the_fits(tmp_path: Path) -> None:
    # The report gave only the lumped fits' statuses: an undetermined pump's quantities read
    # like any other's, and the batch's "pumps identified: undetermined 1" appeared nowhere.
    frame = results_table(2, 12, cv=0.02, seed=4)
    frame["identify_status"] = "converged"
    first = frame.index[frame["well_id"] == frame["well_id"].iloc[0]]
    frame.loc[first[:3], "identify_status"] = "undetermined"
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"])
    page = files["report"].read_text(encoding="utf-8")
    well = str(frame["well_id"].iloc[0])
    assert "<th>pump identifications</th>" in page
    assert "<th>converged (lumped fit)</th>" in page  # the column is not the pump's
    assert "converged 9, undetermined 3" in page
    assert re.search(r"pump identifications \(the status the pump quantities count by\)"
                     r"</td><td>converged 21, undetermined 3</td>", page)
    assert "the pump quantities count by the pump identification" in page
    wells = pd.read_csv(files["wells"]).set_index("well_id")
    assert wells.loc[well, "pump_identifications"] == "converged 9, undetermined 3"
    # A run without identification has no such column.
    files = write_fleet_report(frame.drop(columns=["identify_status"]), tmp_path / "plain",
                               quantities=["stiffness"])
    assert "pump identifications" not in files["report"].read_text(encoding="utf-8")


def test_the_comparison_wells_are_drawn_from_the_tested_ones(tmp_path: Path) -> None:
    # Wells with too few usable cards to test came up in the random comparison, drawn as
    # mostly empty panels, while tested wells went undrawn.
    frame = results_table(8, 40, cv=0.02, seed=6)
    wells = sorted(frame["well_id"].unique())
    short = wells[:5]
    keep = ~frame["well_id"].isin(short) | (frame.groupby("well_id").cumcount() < 3)
    files = write_fleet_report(frame[keep], tmp_path, quantities=["stiffness"],
                               steady_sample=2, seed=3)
    page = files["report"].read_text(encoding="utf-8")
    drawn = re.findall(r"<h3>Well (\S+) \(", page)
    assert len(drawn) == 2 and not set(drawn) & set(short), drawn


def test_a_latest_value_older_than_the_wells_last_card_says_its_date(tmp_path: Path) -> None:
    # The wells table's "latest" value had no date: one from 13 cards before the well's last
    # read as current.
    frame = results_table(2, 40, cv=0.02, seed=8)
    first = frame["well_id"] == frame["well_id"].iloc[0]
    stale = frame.index[first][-13:]
    frame.loc[stale, "d_stiffness"] = np.nan
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"])
    page = files["report"].read_text(encoding="utf-8")
    when = pd.Timestamp(frame.loc[frame.index[first][-14], "time"])
    assert f"(of {when:%Y-%m-%d %H:%M})" in page
    assert page.count("(of ") == 1  # the other well's latest is its last card's


def _well_axes(frame: pd.DataFrame, quantity: str) -> object:
    from pumpid.fleet.figures import well_figure

    empty = detect_changes(frame.iloc[:0])
    fig = well_figure(frame, [quantity], {quantity: "lbf/in"}, empty, "W0000")
    return fig.axes[0]


def test_the_time_axis_runs_to_the_wells_last_card() -> None:
    import matplotlib.dates as mdates

    # The last 10 cards leave the stiffness undetermined: the axis stopped at card 49.
    frame = results_table(1, 60, cv=0.03, seed=8)
    frame.loc[frame.index[50:], "d_stiffness_determined"] = False
    right = _well_axes(frame, "stiffness").get_xlim()[1]
    last = mdates.date2num(frame["time"].iloc[-1].tz_localize(None))
    assert right >= last


def test_a_single_cards_band_is_drawn_whole() -> None:
    # One card of 1000 lbf/in +- 2000: the axis spanned 1 % of the value and clipped the
    # band to it, a thousand times narrower than it is.
    frame = results_table(1, 1, cv=0.03, seed=8)
    frame["d_stiffness"], frame["d_stiffness_se"] = 1000.0, 2000.0
    bottom, top = _well_axes(frame, "stiffness").get_ylim()
    lo, hi = 1000.0 / np.exp(4.0), 1000.0 * np.exp(4.0)
    assert bottom <= lo and top >= hi


def test_a_well_of_two_cards_shows_its_cards_not_a_middle_half() -> None:
    # Two cards gave a "middle half" bar, an interpolation between them.
    from pumpid.fleet.figures import few_wells_figure

    frame = results_table(2, 2, cv=0.03, seed=8)
    fig = few_wells_figure(frame, "stiffness", "lbf/in", set())
    ax = fig.axes[0]
    assert "each card (tick)" in ax.get_xlabel()
    thick = [c for c in ax.collections if max(c.get_linewidths(), default=0) >= 5]
    assert not thick


def test_a_steady_well_is_not_drawn_at_the_scale_of_its_noise() -> None:
    # A full pump's fillage, 0.98825-0.98950, filled its panel as a steep zigzag.
    frame = results_table(1, 30, cv=0.0004, seed=8)
    frame["d_stiffness"] = 0.9888 + 0.0006 * np.sin(np.arange(30))
    bottom, top = _well_axes(frame, "stiffness").get_ylim()
    assert top - bottom >= 0.02 * 0.9894


def test_a_quantity_no_well_has_is_not_drawn(tmp_path: Path) -> None:
    # Three panels of every pump well's figure said "no card of the well determined this
    # quantity" for quantities the summary already called not trended.
    frame = results_table(3, 40, cv=0.02, seed=3)
    frame["d_damping_ratio_determined"] = False
    page = write_fleet_report(frame, tmp_path, quantities=["stiffness", "damping_ratio"],
                              steady_sample=2)["report"].read_text(encoding="utf-8")
    assert "Quantities no well has a usable value of are not drawn: damping_ratio." in page


def test_quantities_without_a_value_are_said_above_the_figures(tmp_path: Path) -> None:
    # As grid cells of their own, they left half-empty rows beside the figures.
    frame = results_table(3, 40, cv=0.02, seed=3)
    frame["d_damping_ratio_determined"] = False
    page = write_fleet_report(frame, tmp_path, quantities=["stiffness", "damping_ratio"],
                              steady_sample=0)["report"].read_text(encoding="utf-8")
    section = page[page.index('id="distributions"'):page.index('id="trends"')]
    grid = section[section.index('<div class="grid">'):]
    assert "damping_ratio:" in section and "damping_ratio:" not in grid


def test_wells_in_other_units_are_converted_for_the_views_across_wells(tmp_path: Path) -> None:
    # A field of three controllers' exports (lbf/in, kN/m): the distribution's one axis,
    # labelled with the most common unit, plotted each well's medians in its own unit.
    from pumpid.fleet.figures import per_well_median
    from pumpid.report.units import unit_factor

    frame = results_table(6, 40, cv=0.02, seed=4)
    metric = frame["well_id"].isin(["W0004", "W0005"])
    to_si = unit_factor("lbf/in", "kN/m")
    assert to_si == pytest.approx(0.17512683524647635)
    frame.loc[metric, "d_stiffness"] *= to_si
    frame.loc[metric, "d_stiffness_se"] *= to_si
    frame.loc[metric, "d_stiffness_unit"] = "kN/m"
    plain = results_table(6, 40, cv=0.02, seed=4)
    np.testing.assert_allclose(per_well_median(frame, "stiffness", "lbf/in"),
                               per_well_median(plain, "stiffness"), rtol=1e-12)
    files = write_fleet_report(frame, tmp_path, quantities=["stiffness"], steady_sample=0)
    page = files["report"].read_text(encoding="utf-8")
    assert "Values stated in kN/m are converted to lbf/in." in page
    # A unit that cannot be converted is left out of those views, and said.
    frame.loc[frame["well_id"] == "W0005", "d_stiffness_unit"] = "furlongs"
    assert "W0005" not in per_well_median(frame, "stiffness", "lbf/in").index
    page = write_fleet_report(frame, tmp_path / "b", quantities=["stiffness"],
                              steady_sample=0)["report"].read_text(encoding="utf-8")
    assert "40 cards in a unit that cannot be converted to it are left out." in page
    # Five wells left: the figure's view and its caption agree (one well less: one by one).
    frame.loc[frame["well_id"] == "W0004", "d_stiffness_unit"] = "furlongs"
    page = write_fleet_report(frame, tmp_path / "c", quantities=["stiffness"],
                              steady_sample=0)["report"].read_text(encoding="utf-8")
    assert "too few wells for a histogram" in page


def test_a_small_alerted_change_is_labelled_with_its_size() -> None:
    # An alerted change of 0.3 % was labelled "+0%" on its panel (the alerts' text said
    # +0.3 %).
    from pumpid.fleet.figures import well_figure

    frame = results_table(1, 80, cv=0.0005, seed=3, steps={0: ("stiffness", 1.003, 40)})
    frame["d_stiffness_se"] = 1e-4 * frame["d_stiffness"]
    alerts = detect_changes(frame, ["stiffness"])
    assert len(alerts) == 1
    fig = well_figure(frame, ["stiffness"], {"stiffness": "lbf/in"}, alerts, "W0000")
    labels = [t.get_text() for t in fig.axes[0].texts]
    assert f"{alerts['change_rel'].iloc[0]:+.1%}" in labels and "+0%" not in labels


def test_a_parameter_with_infinite_errors_is_not_drawn_from_an_older_table() -> None:
    # The change detection reads an infinite error as not determined where a table has no
    # p_NAME_determined; the figures drew those values all the same.
    from pumpid.fleet.figures import quantity_values

    frame = results_table(1, 20, seed=2)
    frame["p_c1"] = 50.0
    frame["p_c1_se"] = np.where(np.arange(20) < 5, np.inf, 1.0)
    _value, _se, ok = quantity_values(frame, "p_c1")
    assert ok.tolist() == [False] * 5 + [True] * 15
