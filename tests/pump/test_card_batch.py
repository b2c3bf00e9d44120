"""The batched main job gives each card the answer it gets alone.

``pumpid.fit`` on a list of cards shares their work (one solver loop, finished slots
refilled, threads); it must not change any card's answer. On cards of the three families the
benchmark measures (periodic strokes with an offset, records from rest with a slow creep,
controller-like cards), statuses are identical and every parameter the data determine (by
the fit's own identifiability analysis) agrees to 1e-8. ``benchmarks/bench_main_job.py``
runs the same comparison on 1,000 cards of each family.
"""

from __future__ import annotations

import pytest

import pumpid

from ..families import family

N_CARDS = {"periodic": 24, "rest": 8, "controller": 24}


def determined(res) -> list[str]:
    """The model parameters the fit's identifiability analysis calls determined."""
    return [p for p in res.determined.get("parameters", ()) if p in res.params]


@pytest.mark.parametrize("name", sorted(N_CARDS))
def test_batch_equals_each_card_alone(name: str) -> None:
    cards = family(name, N_CARDS[name], seed=11)
    batch = pumpid.fit(pumpid.Kelvin, cards, workers=2)
    assert len(batch.results) == len(cards)
    for card, together in zip(cards, batch.results, strict=True):
        alone = pumpid.fit(pumpid.Kelvin, card)
        assert together.status == alone.status, card.card_id
        assert together.card is not None and together.card.id == card.card_id
        for p in determined(alone):
            a, b = alone.params[p], together.params[p]
            assert abs(b - a) <= 1e-8 * abs(a), (card.card_id, p, a, b)
        assert together.cost == pytest.approx(alone.cost, rel=1e-8)
