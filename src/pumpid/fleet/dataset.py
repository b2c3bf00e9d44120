"""Cards stored in the Parquet long layout: one row per sample, many wells and cards.

Layout (one file, or a folder of files read one by one in sorted order):

``well_id`` (str, required)
    Constant within a card.
``card_id`` (str, required)
    Unique within a file; a card's rows need not be contiguous.
``position``, ``load`` (float, required)
    One sample each.
``sample`` (int) or ``t`` (float, seconds from the card's start)
    At least one is required. A ``t`` of dates and times (datetime64) is turned into
    seconds from the card's first sample, with a note; it is never read as epoch counts.
    Samples are put in order of ``sample`` (or of ``t``), which must not repeat. With
    ``t`` the time comes from the file (a card that holds one stroke, sampled uniformly,
    is one period, as the card files' readers take it); otherwise the card is one
    stroke sampled uniformly in time and its time is rebuilt from ``spm``
    (``t_i = i T / N``, ``T = 60 / spm``; marked periodic; a card that holds several
    strokes is timed per stroke and is a record, :func:`pumpid.cards.time_from_rate`), as
    pumpid's other readers do;
    a last sample that repeats the first (a duplicated closing point) is then dropped, as
    they do too. Padding at a card's end or start (a run of one repeated point, see
    :func:`pumpid.cards.trailing_padding`) is dropped, as the card files' readers do.
``time`` (datetime, optional)
    The card's time; constant within a card; kept as a UTC ``pandas.Timestamp`` in
    ``Card.metadata["time"]`` (naive times are taken as UTC, with a note).
``spm`` (float, optional)
    Strokes per minute, constant within a card and positive.
``position_unit``, ``load_unit`` (str, optional)
    Constant within a card; a unit given by the caller wins.

Other columns are ignored. Every problem is a :class:`pumpid.cards.CardError` naming the
file, the card and the column; each card is checked on its own, so a broken card (a
non-numeric ``sample``, a NaN load) never costs the file's other cards.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pumpid.cards import (
    Card,
    CardError,
    one_period,
    padding_dropped,
    repeats_first,
    stroke_period,
    stroke_rate_warning,
    time_from_rate,
    with_record_warnings,
)

__all__ = ["ParquetCardError", "iter_parquet_cards", "read_parquet_cards"]

_REQUIRED = ("well_id", "card_id", "position", "load")


class ParquetCardError(CardError):
    """A :class:`~pumpid.cards.CardError` for one card of a file, with the card's ids.

    Attributes
    ----------
    card_id : str
        The card's ``card_id``.
    well_id : str or None
        Its ``well_id`` where the rows agree on one, else None.
    """

    def __init__(self, error: CardError, *, card_id: str, well_id: str | None) -> None:
        super().__init__(error.reason, path=error.path, line=error.line, field=error.field,
                         card_id=card_id, well_id=well_id)


def _well_of(frame: pd.DataFrame) -> str | None:
    wells = frame["well_id"].dropna().astype(str).unique()
    return str(wells[0]) if len(wells) == 1 and wells[0].strip() else None


def _files(path: Path) -> list[Path]:
    if path.is_dir():
        files = sorted(p for p in path.rglob("*.parquet") if p.is_file())
        if not files:
            raise CardError("no .parquet files in the folder", path=path)
        return files
    if not path.exists():
        raise CardError("no such file or folder", path=path)
    return [path]


def _constant(
    frame: pd.DataFrame, column: str, *, path: Path, card: str
) -> Any:
    values = frame[column]
    first = values.iloc[0]
    same = values.isna().all() if pd.isna(first) else bool((values == first).all())
    if not same:
        raise CardError(
            f"card {card!r}: {column} changes within the card ({first!r}, then "
            f"{values[values != first].iloc[0]!r})",
            path=path,
            field=column,
        )
    return None if pd.isna(first) else first


def _numeric(
    frame: pd.DataFrame, column: str, err: Any, notes: list[str]
) -> np.ndarray:
    """A column as floats, or a CardError naming it.

    Dates and times are never taken as their integer epoch counts: in ``t`` they are turned
    into seconds from the card's first sample (noted), elsewhere refused.
    """
    values = frame[column]
    if pd.api.types.is_datetime64_any_dtype(values) or pd.api.types.is_timedelta64_dtype(values):
        if column != "t":
            raise err(f"{column} holds dates or durations, not numbers", column)
        if values.isna().any():
            raise err("missing value (NaT) in t", column)
        seconds = (values - values.min()).dt.total_seconds().to_numpy(dtype=float)
        notes.append("t holds dates and times: converted to seconds from the card's first "
                     "sample")
        return seconds
    if not pd.api.types.is_numeric_dtype(values):  # text: numbers written as text, or not
        numbers = pd.to_numeric(values, errors="coerce")
        wrong = numbers.isna() & values.notna()
        if wrong.any():
            raise err(f"{column} is not numeric (it holds {str(values[wrong].iloc[0])[:40]!r})",
                      column)
        values = numbers
    try:
        return values.to_numpy(dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise err(f"{column} is not numeric ({exc})", column) from exc


def _card(
    frame: pd.DataFrame,
    card_id: str,
    *,
    path: Path,
    position_unit: str | None,
    load_unit: str | None,
    min_samples: int,
    given: float | None = None,
) -> Card:
    def err(message: str, column: str | None = None) -> CardError:
        return CardError(f"card {card_id!r}: {message}", path=path, field=column)

    order_col = "sample" if "sample" in frame.columns else "t"
    notes = [f"read from the Parquet long layout ({path.name})"]
    order = _numeric(frame, order_col, err, notes)
    if not np.all(np.isfinite(order)):
        raise err(f"missing or non-finite {order_col}", order_col)
    frame = frame.iloc[np.argsort(order, kind="stable")]
    order = np.sort(order)
    if order.size > 1 and np.any(np.diff(order) <= 0):
        k = int(np.flatnonzero(np.diff(order) <= 0)[0]) + 1
        raise err(f"{order_col} {order[k]:g} appears twice", order_col)
    well = _constant(frame, "well_id", path=path, card=card_id)
    if well is None or not str(well).strip():
        raise err("empty well_id", "well_id")
    arrays = {}
    for col in ("position", "load"):
        arr = _numeric(frame, col, err, notes)
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            kind = "NaN" if np.isnan(arr[bad[0]]) else "infinite"
            raise err(f"{kind} value in {col} (sample {int(bad[0])})", col)
        arrays[col] = arr
    # As the card files' readers do: a fixed-length record's fill is no part of the stroke
    # (its samples, its order and its times dropped alike).
    span, dropped = padding_dropped(arrays["position"], arrays["load"],
                                    (position_unit, load_unit))
    arrays = {k: v[span] for k, v in arrays.items()}
    order = order[span]
    notes += [note for _where, note in dropped]
    if order_col == "sample" and repeats_first(arrays["position"], arrays["load"]):
        # As every reader of a card without time does: kept, the closing point made the
        # same card 200 samples here and 199 from its .ts file, and its status another.
        arrays = {k: v[:-1] for k, v in arrays.items()}
        notes.append("duplicated closing point dropped: the last sample repeats the first in "
                     "position and load")
    n = arrays["position"].size
    if n < min_samples:
        raise err(f"only {n} samples, at least {min_samples} needed", "position")
    for col in ("load", "position"):
        if np.ptp(arrays[col]) == 0:
            raise err(f"constant {col} ({arrays[col][0]:.6g} in every sample)", col)
    spm = None
    if "spm" in frame.columns:
        spm = _constant(frame, "spm", path=path, card=card_id)
        if spm is not None:
            spm = float(spm)
            if not (math.isfinite(spm) and spm > 0):
                raise err(f"spm must be positive and finite, got {spm}", "spm")
    units: dict[str, str | None] = {"position": position_unit, "load": load_unit}
    for kind in ("position", "load"):
        col = f"{kind}_unit"
        stated = _constant(frame, col, path=path, card=card_id) if col in frame.columns else None
        if units[kind] is None and stated is not None:
            units[kind] = str(stated)
    t = None
    period = None
    time_source = "none"
    periodic = False
    warnings: list[str] = []
    if given is not None and order_col == "t":
        notes.append(f"the stroke rate {60.0 / given:.6g} SPM (given by the caller) is not "
                     "used: the card's time comes from the file")
    elif given is not None:
        # The caller's rate first, then the file's, as the card files' readers take them: a
        # run's --spm re-timed its CSV and JSON cards and left its Parquet ones, unsaid.
        if spm is not None:
            notes.append("stroke rate given by the caller overrides the one in the file "
                         "(the spm column)")
            if not math.isclose(60.0 / spm, given, rel_tol=1e-9):
                warnings.append(f"the card's time is rebuilt from the stroke rate given "
                                f"({60.0 / given:.6g} SPM), not from the file's own "
                                f"({spm:.6g} SPM, the spm column)")
        spm = 60.0 / given
    if order_col == "t":
        t = order
        time_source = "file"
        notes.append("time taken from the file (t)")
    elif spm is not None:
        period = 60.0 / spm
        time_source = "spm"
        t, several = time_from_rate(card_id, arrays["position"], period, f"{spm:.6g} SPM")
        if several:
            warnings.append(several)
        else:
            periodic = True
            notes.append(
                f"time rebuilt from {spm:.6g} SPM assuming uniform sampling over one stroke: "
                f"t_i = i*T/N with T = {period:.6g} s, N = {n}"
            )
    else:
        notes.append("no t column and no spm column: the card has no time axis")
    stamp = None
    if "time" in frame.columns:
        value = _constant(frame, "time", path=path, card=card_id)
        if value is not None:
            try:
                stamp = pd.Timestamp(value)
            except (TypeError, ValueError) as exc:
                raise err(f"time {value!r} is not a date and time", "time") from exc
            if stamp.tzinfo is None:
                stamp = stamp.tz_localize("UTC")
                notes.append("card time has no time zone: taken as UTC")
            else:
                stamp = stamp.tz_convert("UTC")
    try:
        card = Card(
            position=arrays["position"],
            load=arrays["load"],
            t=t,
            position_unit=units["position"],
            load_unit=units["load"],
            source=f"{path.name}, card {card_id}",
            card_id=card_id,
            well_id=str(well),
            spm=spm,
            period=period,
            time_source=time_source,
            periodic=periodic,
            notes=tuple(notes),
            metadata={"time": stamp},
            warnings=tuple(warnings),
        )
    except CardError as exc:
        raise err(exc.reason, exc.field) from exc
    # One stroke in its own time is one period, as the card files' readers take it: from
    # Parquet the same stroke was fitted from rest. A stroke no pumping unit has is said.
    card = one_period(card) if order_col == "t" else card
    slow = stroke_rate_warning(card_id, stroke_period(card), "t" if order_col == "t" else None,
                               "the stroke rate given" if given is not None else "the spm column")
    return with_record_warnings(card, slow)


def iter_parquet_cards(
    path: str | os.PathLike[str],
    *,
    position_unit: str | None = None,
    load_unit: str | None = None,
    spm: float | None = None,
    period: float | None = None,
    min_samples: int = 20,
) -> Iterator[Card | CardError]:
    """Read cards from the Parquet long layout, yielding an error in place of a bad card.

    For batch runs: one bad card (or one unreadable file) does not stop the others.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.parquet`` file, or a folder whose ``*.parquet`` files (searched recursively)
        are read in sorted order.
    position_unit, load_unit : str, optional
        Units of every card; they win over the files' unit columns.
    spm, period : float, optional
        The stroke rate (strokes per minute) or period (s) of every card without a ``t``
        column; they win over the files' ``spm`` column (a warning says where they differ).
        At most one.
    min_samples : int, default 20
        Fewer samples than this in a card is an error.

    Yields
    ------
    pumpid.cards.Card or pumpid.cards.CardError
        Cards in order of first appearance in each file; a :class:`ParquetCardError`
        (naming the file, the card and the column, and carrying the card's ids) in place of
        a card that fails a check; a :class:`CardError` in place of a whole file that cannot
        be read or lacks a required column.

    Raises
    ------
    CardError
        Only when ``path`` itself does not exist or a folder holds no Parquet file.
    """
    if spm is not None and period is not None:
        raise ValueError("give the stroke rate (spm) or the period, not both")
    given = None
    for value, name in ((spm, "spm"), (period, "period")):
        if value is not None:
            if not (math.isfinite(float(value)) and float(value) > 0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
            given = 60.0 / float(value) if name == "spm" else float(value)
    for file in _files(Path(os.fspath(path))):
        try:
            frame = pd.read_parquet(file)
        except Exception as exc:  # pyarrow raises several types for a corrupt file
            yield CardError(f"cannot read the Parquet file: {exc}", path=file)
            continue
        missing = [c for c in _REQUIRED if c not in frame.columns]
        if "sample" not in frame.columns and "t" not in frame.columns:
            missing.append("sample (or t)")
        if missing:
            yield CardError(
                f"missing column(s) {', '.join(missing)}; the file has "
                f"{', '.join(map(str, frame.columns))}",
                path=file,
                field=missing[0],
            )
            continue
        if frame["card_id"].isna().any():
            yield CardError("empty card_id", path=file, field="card_id")
            continue
        for card_id, group in frame.groupby(frame["card_id"].astype(str), sort=False):
            try:
                yield _card(
                    group,
                    str(card_id),
                    path=file,
                    position_unit=position_unit,
                    load_unit=load_unit,
                    min_samples=min_samples,
                    given=given,
                )
            except CardError as exc:
                yield ParquetCardError(exc, card_id=str(card_id), well_id=_well_of(group))
            except (TypeError, ValueError, ArithmeticError) as exc:  # one card's odd values
                problem = CardError(f"card {str(card_id)!r}: unreadable values "
                                    f"({type(exc).__name__}: {exc})", path=file)
                yield ParquetCardError(problem, card_id=str(card_id), well_id=_well_of(group))


def read_parquet_cards(
    path: str | os.PathLike[str],
    *,
    position_unit: str | None = None,
    load_unit: str | None = None,
    spm: float | None = None,
    period: float | None = None,
    min_samples: int = 20,
) -> list[Card]:
    """Read every card of the Parquet long layout; stop at the first problem.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.parquet`` file or a folder of them (see :func:`iter_parquet_cards`).
    position_unit, load_unit : str, optional
        Units of every card; they win over the files' unit columns.
    spm, period : float, optional
        The stroke rate or period of every card without time (see
        :func:`iter_parquet_cards`).
    min_samples : int, default 20
        Fewer samples than this in a card is an error.

    Returns
    -------
    list of pumpid.cards.Card

    Raises
    ------
    CardError
        For the first card or file that fails a check, naming the file, the card and the
        column. Use :func:`iter_parquet_cards` to read past bad cards.
    """
    cards = []
    for item in iter_parquet_cards(
        path, position_unit=position_unit, load_unit=load_unit, spm=spm, period=period,
        min_samples=min_samples,
    ):
        if isinstance(item, CardError):
            raise item
        cards.append(item)
    return cards
