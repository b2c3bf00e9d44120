"""Hostile inputs through the API are refused with errors that name the argument."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import pumpid
from pumpid.cards import Card, CardError

TH = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)
POS = 50 * (1 - np.cos(TH))
LOAD = 6000 + 2000 * np.sin(TH + 0.3)
STAMPS = pd.date_range("2024-01-01", periods=40, freq="200ms")


@pytest.mark.parametrize("kwargs, field", [
    ({"spm": "8"}, "spm"), ({"period": "7.5"}, "period"), ({"spm": True}, "spm"),
    ({"notes": 5}, "notes"), ({"warnings": 1.5}, "warnings"), ({"card_id": 3}, "card_id"),
    ({"well_id": 3}, "well_id"), ({"metadata": 5}, "metadata"),
])
def test_card_arguments_of_the_wrong_type_are_named(kwargs, field) -> None:
    with pytest.raises(CardError) as info:
        Card(position=POS, load=LOAD, **kwargs)
    assert info.value.field == field and field in str(info.value)


def test_card_keeps_text_and_numbers_it_is_given() -> None:
    card = Card(position=POS, load=LOAD, spm=np.float64(8), notes=["a"], warnings="w")
    assert card.spm == 8.0 and card.notes == ("a",) and card.warnings == ("w",)


@pytest.mark.parametrize("t", [STAMPS, STAMPS.to_numpy(), list(STAMPS),
                               STAMPS.to_pydatetime().tolist(), STAMPS - STAMPS[0]],
                         ids=["DatetimeIndex", "datetime64", "Timestamps", "datetime",
                              "timedelta"])
def test_dates_as_time_are_refused_not_read_as_epoch_counts(t) -> None:
    with pytest.raises(CardError, match="dates, times or durations") as info:
        Card(position=POS, load=LOAD, t=t)
    assert info.value.field == "t"
    with pytest.raises(ValueError, match="t: dates, times or durations are not numbers"):
        pumpid.fit(pumpid.Kelvin, (t, LOAD, POS))


def test_aware_datetime_series_is_refused_too() -> None:
    t = pd.Series(STAMPS).dt.tz_localize("UTC")
    with pytest.raises(ValueError, match="dates, times or durations"):
        pumpid.fit(pumpid.Kelvin, (t, LOAD, POS))


def test_fit_names_an_item_that_is_not_a_card() -> None:
    card = Card(position=POS, load=LOAD, t=np.arange(40) * 0.2)
    with pytest.raises(TypeError, match=r"data\[1\] is a NoneType: a sequence to fit holds Card"):
        pumpid.fit(pumpid.Kelvin, [card, None])
    with pytest.raises(TypeError, match=r"a pumpid\.cards\.Card.*got dict"):
        pumpid.fit(pumpid.Kelvin, {"position": POS})  # type: ignore[arg-type]


def test_subnormal_data_are_refused_by_name() -> None:
    card = Card(position=POS * 1e-321, load=LOAD, t=np.arange(40) * 0.2, period=8.0,
                periodic=True, time_source="file")
    with pytest.raises(ValueError, match="outside the floating-point range; rescale"):
        pumpid.fit(pumpid.Kelvin, card)
    batch = pumpid.fit("msd", [card, Card(position=POS, load=LOAD, t=np.arange(40) * 0.2)])
    assert "floating-point range" in batch.invalid[0]
