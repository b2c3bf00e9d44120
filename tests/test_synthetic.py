"""Synthetic cards and fields: kinematics, the exact periodic load, files that read back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import pumpid
from pumpid.cards import CardError, read_cards
from pumpid.fleet.dataset import read_parquet_cards
from pumpid.pump.synthetic import (
    CardLabel,
    CrankRocker,
    FieldCards,
    StepChange,
    periodic_load,
    polished_rod_position,
    synthetic_card,
    synthetic_field,
)

MODELS = [
    (pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0), None),
    (pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0), "u"),
    (pumpid.Maxwell(k0=80.0, m=8.8, c1=40.0, k1=130.0), "u"),
    (pumpid.MassSpringDamper(m=8.8, c=25.0, k=80.0), "u"),
    (pumpid.FirstOrder(tau=2.0), "u"),
]


def _extrema(x: np.ndarray) -> tuple[int, int]:
    """Local maxima and minima of a periodic sequence."""
    nxt, prev = np.roll(x, -1), np.roll(x, 1)
    return int(np.sum((x > prev) & (x >= nxt))), int(np.sum((x < prev) & (x <= nxt)))


@pytest.mark.parametrize("n", [16, 100, 201])
def test_kinematics_single_hump(n: int) -> None:
    x = polished_rod_position(n, stroke=86.0)
    assert x.shape == (n,)
    assert x[0] == 0.0 and np.all(x >= 0)
    assert _extrema(x) == (1, 1)  # up from bottom dead centre to one top, and back
    assert 0.98 * 86.0 < x.max() <= 86.0 + 1e-9
    top = int(np.argmax(x))
    assert np.all(np.diff(x[: top + 1]) > 0) and np.all(np.diff(x[top:]) < 0)


def test_kinematics_geometry() -> None:
    geo = CrankRocker()
    assert 0.7 < geo.swing() < 0.8  # about 44 degrees of beam swing
    x = polished_rod_position(400, geometry=geo)
    assert np.ptp(x) == pytest.approx(geo.stroke_length(), rel=1e-3)
    # Uniform time, uneven motion: not a sinusoid (the linkage's harmonics are there)...
    spec = np.abs(np.fft.rfft(x))
    assert 1e-3 < spec[2] / spec[1] < 0.1
    # ... and the same shape at any stroke.
    np.testing.assert_allclose(polished_rod_position(64, stroke=1.0) * 144.0,
                               polished_rod_position(64, stroke=144.0), rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="assembled"):
        CrankRocker(crank=3.0)
    with pytest.raises(ValueError, match="n_samples"):
        polished_rod_position(4)


@pytest.mark.parametrize(("model", "observe"), MODELS)
@pytest.mark.parametrize("n", [64, 201])
def test_periodic_load_reproduced_by_simulate(model: pumpid.Model, observe: str | None,
                                              n: int) -> None:
    card = synthetic_card(model, n_samples=n, observe=observe, spm=7.0, stroke=100.0,
                          rod_weight=5000.0)
    y = pumpid.simulate(model, card.t, card.load, observe=observe, initial_state="periodic",
                        period=card.period)
    # Every harmonic but the mean: the static load moves the model by H(0) W instead.
    err = (y - y.mean()) - (card.position - card.position.mean())
    assert np.max(np.abs(err)) < 1e-9 * 100.0
    assert card.load.mean() == pytest.approx(5000.0, rel=1e-12)


@pytest.mark.parametrize(("model", "observe"), MODELS[1:4])
def test_band_limited_load_is_the_continuous_models(model: pumpid.Model,
                                                    observe: str | None) -> None:
    # hold="none": the continuous model's load. A simulation that joins samples by straight
    # lines converges to it as h²; two refinements and Richardson's step take it to 1e-9.
    n, period = 100, 7.5
    x = polished_rod_position(n, stroke=100.0)
    spec = np.fft.rfft(periodic_load(model, x, period, observe=observe, hold="none"))

    def at_card_samples(up: int) -> np.ndarray:
        fine = np.zeros(n * up // 2 + 1, dtype=complex)
        fine[: spec.size] = spec * up
        t = np.arange(n * up) * period / (n * up)
        y = pumpid.simulate(model, t, np.fft.irfft(fine, n * up), observe=observe,
                            initial_state="periodic", period=period)[::up]
        return y - y.mean()

    coarse, finer = at_card_samples(32), at_card_samples(64)
    target = x - x.mean()
    assert np.max(np.abs(finer - target)) > 1e-7  # the straight-line error is real...
    richardson = (4.0 * finer - coarse) / 3.0
    assert np.max(np.abs(richardson - target)) < 1e-9 * 100.0  # ...and it is all there is


def test_synthetic_card_fields() -> None:
    model = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)
    card = synthetic_card(model, spm=8.0, n_samples=120, noise=(0.001, 0.004), seed=4,
                          label=CardLabel(well_id="W9", card_id="W9-1", time="2024-03-01 06:00"))
    assert card.n == 120 and card.periodic and card.time_source == "spm"
    assert card.period == pytest.approx(7.5)
    np.testing.assert_allclose(card.t, np.arange(120) * 7.5 / 120)
    assert (card.well_id, card.card_id) == ("W9", "W9-1")
    assert (card.position_unit, card.load_unit) == ("in", "lbf")
    assert card.metadata["time"] == pd.Timestamp("2024-03-01 06:00", tz="UTC")
    assert card.metadata["parameters"] == model.as_dict()
    again = synthetic_card(model, spm=8.0, n_samples=120, noise=(0.001, 0.004), seed=4)
    np.testing.assert_array_equal(card.load, again.load)
    assert (again.well_id, again.card_id, again.metadata["time"]) == (None, "synthetic", None)
    with pytest.raises(ValueError, match="time"):
        CardLabel(time="not a time")
    with pytest.raises(ValueError, match="card_id"):
        CardLabel(card_id=3)  # type: ignore[arg-type]
    # a position with content at half the sampling rate is still followed exactly
    zigzag = np.tile([0.0, 1.0], 8) + np.sin(2 * np.pi * np.arange(16) / 16)
    load = periodic_load(model, zigzag, 7.5, observe="u")
    t = np.arange(16) * 7.5 / 16
    y = pumpid.simulate(model, t, load, observe="u", initial_state="periodic", period=7.5)
    np.testing.assert_allclose(y - y.mean(), zigzag - zigzag.mean(), atol=1e-10)
    with pytest.raises(ValueError, match="hold"):
        periodic_load(model, zigzag, 7.5, hold="cubic")


def _read(path: Path, row: pd.Series) -> list[pumpid.cards.Card]:
    if path.suffix == ".parquet":
        return read_parquet_cards(path)
    if row["format"] == "whitespace":
        # A linear model's card is a smooth loop: the column-role detector rightly will not
        # guess which column is which, so the reader is told (as a user would be asked to).
        return read_cards(path, well_id=row["well_id"], spm=row["spm"],
                          position_unit="in", load_unit="lbf",
                          columns={"position": 0, "load": 1})
    return read_cards(path)


def _card_time(card: pumpid.cards.Card) -> pd.Timestamp:
    meta = card.metadata
    for key in ("time", "timestamp", "Timestamp"):
        if meta.get(key) is not None:
            stamp = pd.Timestamp(meta[key])
            return stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp
    raise AssertionError(f"no time in {card.card_id}")


def test_field_reads_back(tmp_path: Path) -> None:
    truth = synthetic_field(tmp_path, n_wells=5, days=3, cards_per_day=2, seed=11,
                            broken_fraction=0.15, cards=FieldCards(n_samples=60),
                            change=StepChange(well=2, parameter="k0", factor=1.3, at=4))
    assert len(truth) == 5 * 6 and truth["card_id"].is_unique
    assert set(truth["format"]) == {"csv", "scada", "json", "whitespace", "parquet"}
    assert str(truth["time"].dtype) == "datetime64[ns, UTC]"
    kinds = truth["broken"].dropna().tolist()
    assert "unreadable" in kinds and len(kinds) == round(0.15 * 30)
    # the step is in the truth, at the card asked for, and only there
    w2 = truth[truth["well_id"] == "W002"]
    assert w2["changed"].tolist() == [False] * 4 + [True] * 2
    ratio = w2["p_k0"].iloc[4:].mean() / w2["p_k0"].iloc[:4].mean()
    assert 1.15 < ratio < 1.45
    assert not truth.loc[truth["well_id"] != "W002", "changed"].any()

    seen = set()
    for file, rows in truth.groupby("file"):
        first = rows.iloc[0]
        if first["broken"] is not None:
            with pytest.raises(CardError) as info:
                _read(tmp_path / file, first)
            assert str(tmp_path / file) in str(info.value)
            continue
        cards = _read(tmp_path / file, first)
        assert [c.card_id for c in cards] == rows["card_id"].tolist()
        for card, (_, row) in zip(cards, rows.iterrows(), strict=True):
            assert card.well_id == row["well_id"]
            assert card.n == 60 and card.periodic
            assert card.spm == pytest.approx(row["spm"], rel=1e-5)
            if row["format"] != "whitespace":  # the only layout without a place for time
                assert _card_time(card) == row["time"]
            seen.add(card.card_id)
    assert seen == set(truth.loc[truth["broken"].isna(), "card_id"])


def test_field_parameters_and_errors(tmp_path: Path) -> None:
    truth = synthetic_field(tmp_path, n_wells=3, days=2, model="msd", formats=("parquet",),
                            seed=1, cards=FieldCards(n_samples=40))
    assert {"p_m", "p_c", "p_k"} <= set(truth.columns)
    assert truth["broken"].isna().all()
    assert len(read_parquet_cards(tmp_path / "parquet")) == 6
    with pytest.raises(ValueError, match="layout"):
        synthetic_field(tmp_path, formats=("xml",))
    with pytest.raises(ValueError, match="parameter"):
        synthetic_field(tmp_path, change=StepChange(0, "k9", 1.2, 1))
    with pytest.raises(ValueError, match="first-order"):
        synthetic_field(tmp_path, model="first-order")
    for bad, match in (({"n_samples": 0}, "n_samples"), ({"noise": -0.1}, "noise"),
                       ({"hold": "cubic"}, "hold"), ({"start": None}, "start"),
                       ({"spread": 0.5}, "spread")):
        with pytest.raises(ValueError, match=match):
            FieldCards(**bad)


def test_field_truth_feeds_change_detection(tmp_path: Path) -> None:
    # The truth table, read as a results table of perfect fits, shows the step it was given.
    from pumpid.fleet.changes import detect_changes

    truth = synthetic_field(tmp_path, n_wells=4, days=20, cards_per_day=4, seed=5,
                            formats=("parquet",), cards=FieldCards(n_samples=32, hold="none"),
                            change=StepChange(well=1, parameter="k1", factor=0.7, at=45),
                            broken_fraction=0.02)
    table = truth.assign(status=np.where(truth["broken"].isna(), "converged", "invalid-input"))
    alerts = detect_changes(table, ["p_k1", "p_k0"])
    assert alerts[["well_id", "quantity", "direction"]].values.tolist() == [
        ["W001", "p_k1", "down"]]
    first = truth.set_index("card_id").loc[alerts["first_card_id"].iloc[0], "card_index"]
    assert abs(first - 45) <= 3
    assert alerts["unit"].iloc[0] == "lbf/in"
