"""The :class:`Card` type: one stroke or one time record of load versus position."""

from __future__ import annotations

import dataclasses
import datetime
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._errors import CardError
from ._rises import time_from_rate
from ._units import (
    load_factor,
    normalize_load_unit,
    normalize_position_unit,
    position_factor,
)

__all__ = ["TIME_SOURCES", "Card"]

#: Allowed values of :attr:`Card.time_source`.
TIME_SOURCES = ("file", "spm", "period", "dt", "none")

# Relative tolerance used to call a time axis uniform. Files often print time with 3-4
# decimals, so exact equality of steps is too strict; 1e-3 of a step still rejects real jitter.
_UNIFORM_RTOL = 1e-3


def _as_vector(values: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        probe = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise CardError(f"{name} must be numeric: {exc}", field=name) from exc
    # float() of datetime64 gives epoch counts (ns), never seconds: refuse dates and times.
    if probe.dtype.kind in "mM" or (probe.dtype == object and probe.size and isinstance(
            probe.ravel()[0], datetime.date | datetime.timedelta)):
        raise CardError(
            f"{name} holds dates, times or durations, not numbers; give seconds from the "
            "record's start, e.g. (t - t[0]) / np.timedelta64(1, 's')", field=name)
    # float() of a complex array silently drops the imaginary part (numpy only warns).
    if np.iscomplexobj(probe) or (
        probe.dtype == object and any(isinstance(v, complex) for v in probe.ravel().tolist())
    ):
        raise CardError(f"{name} holds complex numbers; a card holds real numbers only", field=name)
    try:
        arr = np.array(probe, dtype=float)  # a copy: the card must not share caller memory
    except (TypeError, ValueError, OverflowError) as exc:
        raise CardError(f"{name} must be numeric: {exc}", field=name) from exc
    if arr.ndim != 1:
        raise CardError(f"{name} must be one-dimensional, got shape {arr.shape}", field=name)
    arr.setflags(write=False)  # frozen card: make the arrays read-only as well
    return arr


def _fmt(x: float) -> str:
    return f"{x:.6g}"


@dataclass(frozen=True, eq=False, repr=False)
class Card:
    """One dynamometer card: polished-rod (or downhole) load versus position.

    A card holds either one pump stroke or one longer time record (several strokes; see
    :func:`pumpid.cards.split_strokes`). Instances are immutable: the arrays are read-only
    copies and every transformation returns a new card with a line added to :attr:`notes`.

    Parameters
    ----------
    position, load : array_like
        1-D samples of equal length.
    t : array_like or None
        Sample times in seconds, strictly increasing, or None when unknown.
    position_unit, load_unit : str or None
        Canonical unit names (see :data:`POSITION_UNITS`, :data:`LOAD_UNITS`); None when
        neither the file nor the caller said.
    source : str
        File name and where in it the card came from.
    card_id : str
        Identifier of the card (stroke cards append ``#<k>``).
    well_id : str or None
        Well identifier when known.
    spm : float or None
        Strokes per minute when known.
    period : float or None
        Stroke period in seconds when known (``60 / spm``).
    time_source : {"file", "spm", "period", "dt", "none"}
        Where :attr:`t` came from.
    periodic : bool
        True when the card is taken to be exactly one period of a periodic motion (one
        stroke whose end joins its start).
    notes : tuple of str
        Plain-language record of everything done to the data since it left the file.
    metadata : dict
        Any other fields (class label, timestamps, extra columns ...). The readers add
        ``metadata["column_roles"]`` for tables: which columns were read as position and
        load, how sure the reader is, and how it decided.
    warnings : tuple of str
        What looks wrong with the data but was not refused: implausible magnitudes for a
        polished-rod card (see the thresholds in :mod:`pumpid.cards`), position and load
        that look swapped, column roles guessed with only moderate confidence. Filled by
        the readers; each message names the card and the value with its unit. Unlike
        :attr:`notes`, which say what was done to the data, warnings say what the user
        should check. Transformations carry them over unchanged.

    Raises
    ------
    CardError
        If arrays are not 1-D, lengths differ, values are not finite, time is not strictly
        increasing, a unit is unknown, or ``time_source`` is not one of :data:`TIME_SOURCES`.
    """

    position: NDArray[np.float64]
    load: NDArray[np.float64]
    t: NDArray[np.float64] | None = None
    position_unit: str | None = None
    load_unit: str | None = None
    source: str = ""
    card_id: str = ""
    well_id: str | None = None
    spm: float | None = None
    period: float | None = None
    time_source: str = "none"
    periodic: bool = False
    notes: tuple[str, ...] = ()
    metadata: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        pos = _as_vector(self.position, "position")
        load = _as_vector(self.load, "load")
        if pos.shape != load.shape:
            raise CardError(
                f"position has {pos.size} samples but load has {load.size}", field="load"
            )
        for name, arr in (("position", pos), ("load", load)):
            if not np.all(np.isfinite(arr)):
                k = int(np.flatnonzero(~np.isfinite(arr))[0])
                raise CardError(f"non-finite value {arr[k]} at sample {k}", field=name)
        t = None
        if self.t is not None:
            t = _as_vector(self.t, "t")
            if t.shape != pos.shape:
                raise CardError(f"t has {t.size} samples but position has {pos.size}", field="t")
            if not np.all(np.isfinite(t)):
                raise CardError("t contains non-finite values", field="t")
            if t.size > 1 and not np.all(np.diff(t) > 0):
                k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
                raise CardError(
                    f"time is not strictly increasing at sample {k} "
                    f"({_fmt(t[k - 1])} s then {_fmt(t[k])} s)",
                    field="t",
                )
        pu = None if self.position_unit is None else normalize_position_unit(self.position_unit)
        lu = None if self.load_unit is None else normalize_load_unit(self.load_unit)
        if self.time_source not in TIME_SOURCES:
            raise CardError(
                f"time_source must be one of {', '.join(TIME_SOURCES)}, got {self.time_source!r}",
                field="time_source",
            )
        for name in ("spm", "period"):
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, int | float | np.integer |
                                                         np.floating):
                raise CardError(f"{name} must be a number, got {type(value).__name__} "
                                f"{value!r}", field=name)
            if not (math.isfinite(value) and value > 0):
                raise CardError(f"{name} must be a positive finite number, got {value}", field=name)
        texts = {}
        for name in ("notes", "warnings"):
            value = getattr(self, name)
            if isinstance(value, str):
                value = (value,)
            if not isinstance(value, list | tuple):
                raise CardError(f"{name} must be a tuple of strings, got {type(value).__name__}",
                                field=name)
            texts[name] = tuple(str(n) for n in value)
        for name in ("source", "card_id"):
            if not isinstance(getattr(self, name), str):
                raise CardError(f"{name} must be a string, got "
                                f"{type(getattr(self, name)).__name__}", field=name)
        if self.well_id is not None and not isinstance(self.well_id, str):
            raise CardError(f"well_id must be a string or None, got {type(self.well_id).__name__}",
                            field="well_id")
        if not isinstance(self.metadata, dict):
            raise CardError(f"metadata must be a dict, got {type(self.metadata).__name__}",
                            field="metadata")
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "load", load)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "position_unit", pu)
        object.__setattr__(self, "load_unit", lu)
        object.__setattr__(self, "notes", texts["notes"])
        object.__setattr__(self, "warnings", texts["warnings"])
        object.__setattr__(self, "metadata", dict(self.metadata))
        object.__setattr__(self, "spm", None if self.spm is None else float(self.spm))
        object.__setattr__(self, "period", None if self.period is None else float(self.period))

    # ------------------------------------------------------------------ basic properties
    def __len__(self) -> int:
        return int(self.position.size)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.position.size)

    @property
    def is_uniform(self) -> bool:
        """True when :attr:`t` is known and its steps are equal (to 0.1 % of a step)."""
        return self.dt is not None

    @property
    def dt(self) -> float | None:
        """The constant sample step in seconds, or None if time is unknown or not uniform."""
        if self.t is None or self.t.size < 2:
            return None
        steps = np.diff(self.t)
        mean = float(steps.mean())
        if np.max(np.abs(steps - mean)) <= _UNIFORM_RTOL * mean:
            return mean
        return None

    @property
    def stroke_length(self) -> float:
        """Peak-to-peak position, in :attr:`position_unit`."""
        return float(np.ptp(self.position))

    def __repr__(self) -> str:
        return (
            f"Card(card_id={self.card_id!r}, n={self.n}, position_unit={self.position_unit!r}, "
            f"load_unit={self.load_unit!r}, time_source={self.time_source!r}, spm={self.spm!r}, "
            f"periodic={self.periodic}, source={self.source!r})"
        )

    # ------------------------------------------------------------------ transformations
    def replace(self, *, note: str | None = None, **changes: Any) -> Card:
        """Return a copy with some fields changed and, optionally, one note appended.

        Parameters
        ----------
        note : str, optional
            Added to :attr:`notes` of the copy.
        **changes
            Field values, as for :func:`dataclasses.replace`.
        """
        if note is not None:
            changes["notes"] = (*changes.get("notes", self.notes), note)
        return dataclasses.replace(self, **changes)

    def _with_time(self, period_s: float, source: str, what: str) -> Card:
        if not (math.isfinite(period_s) and period_s > 0):
            raise CardError(f"stroke period must be positive and finite, got {period_s}")
        n = self.n
        t, several = time_from_rate(self.card_id, self.position, period_s, what)
        replacing = "" if self.t is None else f" (replacing time from {self.time_source!r})"
        if several:
            return self.replace(t=t, spm=60.0 / period_s, period=period_s, time_source=source,
                                periodic=False, warnings=(*self.warnings, several + replacing))
        note = (
            f"time rebuilt from {what} assuming uniform sampling over one stroke: "
            f"t_i = i*T/N with T = {_fmt(period_s)} s, N = {n}{replacing}"
        )
        return self.replace(
            t=t, spm=60.0 / period_s, period=period_s, time_source=source, periodic=True, note=note
        )

    def with_period(self, period_s: float) -> Card:
        """Return the card with time rebuilt from a stroke period.

        The card is taken to be one stroke sampled uniformly in time, so with ``N`` samples
        ``t_i = i * T / N`` (the sample that would close the loop at ``t = T`` is not part of
        the card). The result is marked ``periodic`` and gets a note. A card whose position
        rises through mid-stroke twice or more holds several strokes: each gets the period
        (``t_i = i * T / S``, ``S`` the samples between two rises), the result is a record,
        not periodic, and a warning says so.

        Parameters
        ----------
        period_s : float
            Stroke period in seconds.

        Returns
        -------
        Card

        Raises
        ------
        CardError
            If the period is not positive and finite.
        """
        return self._with_time(float(period_s), "period", f"period {_fmt(period_s)} s")

    def with_spm(self, spm: float) -> Card:
        """Return the card with time rebuilt from strokes per minute (see :meth:`with_period`).

        Raises
        ------
        CardError
            If ``spm`` is not positive and finite.
        """
        spm = float(spm)
        if not (math.isfinite(spm) and spm > 0):
            raise CardError(f"spm must be positive and finite, got {spm}", field="spm")
        return self._with_time(60.0 / spm, "spm", f"{_fmt(spm)} SPM")

    def with_dt(self, dt_s: float) -> Card:
        """Return the card with time rebuilt from a known constant sample interval.

        ``t_i = i * dt``; the stroke period is then ``N * dt`` and SPM ``60 / (N * dt)``.
        Useful when the sampling rate of the recorder is known but the SPM is not reliable.

        Raises
        ------
        CardError
            If ``dt_s`` is not positive and finite.
        """
        dt_s = float(dt_s)
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise CardError(f"dt must be positive and finite, got {dt_s}", field="dt")
        period = dt_s * self.n
        note = (
            f"time rebuilt from a constant sample interval dt = {_fmt(dt_s)} s: "
            f"t_i = i*dt, one stroke of N = {self.n} samples, T = {_fmt(period)} s"
        )
        if self.t is not None:
            note += f" (replacing time from {self.time_source!r})"
        return self.replace(
            t=np.arange(self.n) * dt_s,
            spm=60.0 / period,
            period=period,
            time_source="dt",
            periodic=True,
            note=note,
        )

    def to_units(self, position: str | None = None, load: str | None = None) -> Card:
        """Return the card converted to other units, with a note per conversion.

        Parameters
        ----------
        position : str, optional
            Target position unit (any accepted spelling); None keeps the current one.
        load : str, optional
            Target load unit; None keeps the current one.

        Returns
        -------
        Card

        Raises
        ------
        CardError
            If a target unit is unknown, or the card's own unit is unknown (None): declare it
            first with :meth:`with_units`.
        """
        card = self
        if position is not None:
            target = normalize_position_unit(position)
            if card.position_unit is None:
                raise CardError(
                    "cannot convert position: the card's position unit is unknown; declare it "
                    "with with_units(position=...) first",
                    field="position_unit",
                )
            if target != card.position_unit:
                k = position_factor(card.position_unit, target)
                card = card.replace(
                    position=card.position * k,
                    position_unit=target,
                    note=f"position converted from {card.position_unit} to {target} (x {k:.12g})",
                )
        if load is not None:
            target = normalize_load_unit(load)
            if card.load_unit is None:
                raise CardError(
                    "cannot convert load: the card's load unit is unknown; declare it with "
                    "with_units(load=...) first",
                    field="load_unit",
                )
            if target != card.load_unit:
                k = load_factor(card.load_unit, target)
                card = card.replace(
                    load=card.load * k,
                    load_unit=target,
                    note=f"load converted from {card.load_unit} to {target} (x {k:.12g})",
                )
        return card

    def with_units(self, position: str | None = None, load: str | None = None) -> Card:
        """Declare units that were unknown (None), without changing any value.

        Raises
        ------
        CardError
            If a unit is unknown, or the card already has a different unit (use
            :meth:`to_units` to convert instead).
        """
        card = self
        for kind, new, old, norm in (
            ("position", position, self.position_unit, normalize_position_unit),
            ("load", load, self.load_unit, normalize_load_unit),
        ):
            if new is None:
                continue
            unit = norm(new)
            if old is not None and old != unit:
                raise CardError(
                    f"{kind} unit is already {old!r}; use to_units({kind}={unit!r}) to convert",
                    field=f"{kind}_unit",
                )
            if old is None:
                card = card.replace(
                    **{f"{kind}_unit": unit}, note=f"{kind} unit declared as {unit} by the caller"
                )
        return card
