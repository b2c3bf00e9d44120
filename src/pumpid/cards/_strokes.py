"""Splitting a multi-stroke time record into single strokes."""

from __future__ import annotations

from datetime import datetime, timedelta
from itertools import pairwise

import numpy as np

from ._errors import CardError
from ._rises import BAND_LOW, SEVERAL, mid_stroke_band
from ._types import Card

__all__ = ["split_strokes"]

# A position minimum at the edge of the record is a real bottom of stroke only if the rod is
# seen turning around there (TURN of the range) or it sits at the usual bottom level (LEVEL).
_TURN, _LEVEL = 0.05, 0.01


def _noise_sd(x: np.ndarray) -> float:
    """Robust sample-noise estimate from second differences (smooth motion barely has any)."""
    if x.size < 5:
        return 0.0
    d2 = np.diff(x, n=2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def _run_start(x: np.ndarray, i: int) -> int:
    """The first sample of the run of samples equal to ``x[i]`` that holds sample ``i``."""
    while i > 0 and x[i - 1] == x[i]:
        i -= 1
    return i


def _run_end(x: np.ndarray, i: int) -> int:
    """The last sample of the run of samples equal to ``x[i]`` that holds sample ``i``."""
    while i + 1 < x.size and x[i + 1] == x[i]:
        i += 1
    return i


def _whole(card: Card) -> Card:
    """A card holding one stroke, returned whole and marked as one period."""
    changes: dict[str, object] = {"card_id": f"{card.card_id}#0", "periodic": True}
    note = (
        "single stroke (no complete stroke between two bottoms found): returned whole and "
        "treated as one period of a periodic motion"
    )
    if card.period is None and card.dt is not None:
        period = card.n * card.dt
        changes.update(period=period, spm=60.0 / period)
        note += f"; period taken as N*dt = {period:.6g} s"
    return card.replace(note=note, **changes)


def split_strokes(card: Card, *, min_samples: int = 20) -> list[Card]:
    """Split a time record into strokes at the bottom of each stroke.

    Boundaries are the position minima between successive upward crossings of the
    mid-stroke band (below 35 % then above 65 % of the robust position range), so noise and
    small wiggles do not create strokes. Partial strokes at the start and end of the record
    are dropped unless the record visibly turns around at the bottom there. Each stroke
    holds the samples from one bottom up to (not including) the next, so with ``N`` samples
    its period is the time from its first sample to the next stroke's first sample.

    Parameters
    ----------
    card : Card
        A single stroke or a multi-stroke record.
    min_samples : int, default 20
        Strokes with fewer samples are dropped (and the other strokes' notes say so).

    Returns
    -------
    list of Card
        Strokes with ids ``"<card_id>#<k>"`` (k from 0), time restarted at 0 (original start
        in ``metadata["t0"]``; a record dated by its first sample's stamp has each stroke's
        ``metadata["time"]`` moved on by it), ``period``/``spm`` from the boundary times
        when time is known, ``periodic=True`` and a note. A card holding a single stroke (no
        two bottoms of stroke with the rod seen turning around at both) is returned whole, as
        one stroke ``"<card_id>#0"`` marked ``periodic``.

    Raises
    ------
    CardError
        If the position is constant, no complete stroke is found, or every stroke is
        shorter than ``min_samples``.
    """
    where = card.source or None
    raw = card.position
    if card.n < 2 or raw.max() == raw.min():
        raise CardError(
            f"card {card.card_id!r}: constant position, no strokes", path=where, field="position"
        )
    scaled, p_lo, span, ups = mid_stroke_band(raw)
    pos = scaled

    lo = p_lo + BAND_LOW * span
    if ups.size == 0:
        return [_whole(card)]
    if ups.size == 1:
        # One upward crossing: normally a single stroke. Only if the record visibly turns
        # around at the bottom both before and after it does it hold more than one stroke,
        # and then exactly one complete stroke lies between those two bottoms.
        head = int(np.argmin(pos[: ups[0]]))
        tail = int(ups[0] + np.argmin(pos[ups[0] :]))
        turn = _TURN * span
        if not (
            pos[: head + 1].max() - pos[head] >= turn
            and pos[tail] < lo
            and pos[tail:].max() - pos[tail] >= turn
        ):
            return [_whole(card)]
        interior: list[int] = []
        head_ok = tail_ok = True
    else:
        # Minima are taken on a lightly smoothed copy (window about 5 % of a stroke) so that
        # sample noise on the flat bottom of the stroke does not move the boundary around.
        width = 2 * int(np.median(np.diff(ups)) // 40) + 1
        if width > 1:
            padded = np.pad(pos, width // 2, mode="reflect")
            pos = np.convolve(padded, np.ones(width) / width, mode="valid")
        interior = [int(a + np.argmin(pos[a:b])) for a, b in pairwise(ups)]
        bottom = float(np.median(pos[interior]))
        head = int(np.argmin(pos[: ups[0]]))
        tail = int(ups[-1] + np.argmin(pos[ups[-1] :]))
        # "At the usual bottom level" must allow for noise and drift, measured by how much
        # the interior bottoms scatter and by the sample noise of the raw position.
        level = max(_LEVEL * span, float(np.ptp(pos[interior])), 3.0 * _noise_sd(scaled))
        # The head minimum lies below ``lo`` by construction (the record was below it before
        # the first upward crossing); the tail minimum must be checked, or a record ending
        # near the top would give a bogus short last stroke.
        head_ok = (pos[: head + 1].max() - pos[head] >= _TURN * span) or (
            pos[head] - bottom <= level
        )
        tail_ok = pos[tail] < lo and (
            (pos[tail:].max() - pos[tail] >= _TURN * span) or (pos[tail] - bottom <= level)
        )
    bounds = ([head] if head_ok else []) + interior + ([tail] if tail_ok else [])
    if tail_ok and interior and _run_end(raw, tail) == card.n - 1:
        # The record ends on a flat bottom of stroke (samples holding one lowest position),
        # cut short by its end: its boundary goes where the other bottoms' boundaries sit
        # in their flat runs. Three copies of one stroke whose bottom was its last sample
        # and its first two had the last stroke end a sample early, with another period
        # and fit.
        shift = int(np.median([b - _run_start(raw, b) for b in interior]))
        bounds[-1] = min(card.n, _run_start(raw, tail) + shift)
    if len(bounds) < 2:
        raise CardError(
            f"card {card.card_id!r}: no complete stroke found (a record with several strokes "
            "needs two bottoms of stroke)",
            path=where,
            field="position",
        )
    segments = list(pairwise(bounds))
    kept = [(a, b) for a, b in segments if b - a >= min_samples]
    if not kept:
        raise CardError(
            f"card {card.card_id!r}: every stroke is shorter than {min_samples} samples",
            path=where,
            field="position",
        )
    dropped = []
    if bounds[0] > 0:
        dropped.append(f"partial stroke before sample {bounds[0]}")
    if bounds[-1] < card.n:
        dropped.append(f"partial stroke after sample {bounds[-1] - 1}")
    if len(kept) < len(segments):
        dropped.append(f"{len(segments) - len(kept)} stroke(s) shorter than {min_samples} samples")

    strokes = []
    for k, (a, b) in enumerate(kept):
        t = period = spm = None
        meta = {**card.metadata, "stroke_index": k, "sample_range": (a, b)}
        if card.t is not None:
            t = card.t[a:b] - card.t[a]
            # A stroke that ends the record ends one step after its last sample.
            end = (float(card.t[b]) if b < card.n
                   else float(card.t[-1]) + float(np.median(np.diff(card.t))))
            period = end - float(card.t[a])
            spm = 60.0 / period
            meta["t0"] = float(card.t[a])
            when = card.metadata.get("time")
            if isinstance(when, datetime) and "first_sample_time" in card.metadata:
                # A record dated by its first sample's stamp: each stroke was recorded later
                # (a date alone, or a controller's stamp, may not be that sample's).
                meta["time"] = when + timedelta(seconds=float(card.t[a] - card.t[0]))
                meta["first_sample_time"] = meta["time"].isoformat()
        for key, value in card.metadata.items():
            # Per-sample extra columns follow the samples they belong to.
            if isinstance(value, np.ndarray) and value.shape == (card.n,):
                meta[key] = value[a:b]
        note = (
            # The ids count from 0 (CARD#0): "stroke 0 of 6" read as one short.
            f"stroke #{k} ({k + 1} of {len(kept)}) cut from {card.card_id!r} at position minima "
            f"(samples {a}-{b - 1}"
            + (f", t0 = {card.t[a]:.6g} s, time restarted at 0" if card.t is not None else "")
            + "); treated as one period"
        )
        if dropped:
            note += "; dropped: " + ", ".join(dropped)
        strokes.append(
            card.replace(
                position=card.position[a:b],
                load=card.load[a:b],
                t=t,
                period=period,
                spm=spm,
                card_id=f"{card.card_id}#{k}",
                periodic=True,
                # The record's source names its whole span of lines: the stroke's samples
                # say which part of it this card is.
                source=f"{card.source}, samples {a}-{b - 1}" if card.source else "",
                metadata=meta,
                # The record's warning that it holds several strokes is not this stroke's.
                warnings=tuple(w for w in card.warnings if SEVERAL not in w),
                note=note,
            )
        )
    return strokes
