"""Fields of wells: many synthetic wells written to files, and the truth they were made from."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pumpid.models import Model, model_class

from .card import as_timestamp, model_key, periodic_load
from .kinematics import polished_rod_position
from .layouts import BROKEN_KINDS, FIELD_FORMATS, break_card, write_cards, write_unreadable

__all__ = ["FieldCards", "StepChange", "synthetic_field"]


@dataclass(frozen=True)
class StepChange:
    """A persistent step in one parameter of one well of a synthetic field.

    Parameters
    ----------
    well : int or str
        Well index (0-based) or well id.
    parameter : str
        Model parameter name (e.g. ``"k0"``).
    factor : float
        The parameter is multiplied by this from card ``at`` on (1.3: a 30 % rise).
    at : int
        Index (0-based, in time order) of the well's first changed card.
    """

    well: int | str
    parameter: str
    factor: float
    at: int


@dataclass(frozen=True)
class FieldCards:
    """What each card of a synthetic field looks like: samples, noise, scatter, times.

    Parameters
    ----------
    observe : str, optional
        The model state that follows the polished rod (default: the model's own).
    n_samples : int, default 100
        Samples per card (>= 1).
    noise : float or (float, float), default 0.003
        As for :func:`synthetic_card` (>= 0).
    jitter : float, default 0.02
        Card-to-card log-normal scatter of each parameter (0.02: about 2 %; >= 0).
    spread : float, default 1.5
        Wells' parameters lie within ``centre / spread`` and ``centre * spread`` (>= 1).
    start : datetime-like, default "2024-01-01"
        Time of the first card (naive means UTC); kept as a UTC ``pandas.Timestamp``.
    hold : {"linear", "none"}, default "linear"
        See :func:`periodic_load`.

    Raises
    ------
    ValueError
        For a setting out of its range or a start that is not a time.
    """

    observe: str | None = None
    n_samples: int = 100
    noise: float | tuple[float, float] = 0.003
    jitter: float = 0.02
    spread: float = 1.5
    start: Any = "2024-01-01"
    hold: str = "linear"

    def __post_init__(self) -> None:
        if self.observe is not None and not isinstance(self.observe, str):
            raise ValueError(f"observe must be a state name or None, got {self.observe!r}")
        n = self.n_samples
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ValueError(f"n_samples must be a positive integer, got {n!r}")
        noise = np.broadcast_to(np.asarray(self.noise, dtype=float), (2,))
        if not (np.all(np.isfinite(noise)) and np.all(noise >= 0)):
            raise ValueError(f"noise must be >= 0 and finite, got {self.noise!r}")
        if not (math.isfinite(self.jitter) and self.jitter >= 0):
            raise ValueError(f"jitter must be >= 0 and finite, got {self.jitter!r}")
        if not (math.isfinite(self.spread) and self.spread >= 1):
            raise ValueError(f"spread must be >= 1 and finite, got {self.spread!r}")
        if self.hold not in ("linear", "none"):
            raise ValueError(f"hold must be 'linear' or 'none', got {self.hold!r}")
        try:
            start = as_timestamp(self.start)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"start must be a date or time, got {self.start!r}") from exc
        if start is None:
            raise ValueError("start must be a date or time")
        object.__setattr__(self, "n_samples", int(n))
        object.__setattr__(self, "start", start)


#: Centre values of the field's parameters per model (inches, pounds-force, seconds).
_CENTRES: dict[str, dict[str, float]] = {
    "kelvin": {"k0": 200.0, "m": 8.8, "c1": 40.0, "k1": 130.0},
    "maxwell": {"k0": 80.0, "m": 8.8, "c1": 40.0, "k1": 130.0},
    "msd": {"m": 8.8, "c": 25.0, "k": 80.0},
}


def _log_uniform(rng: np.random.Generator, centre: float, spread: float) -> float:
    return float(centre * math.exp(rng.uniform(-math.log(spread), math.log(spread))))


def _card_stamp(ts: pd.Timestamp) -> str:
    return ts.strftime("%Y%m%dT%H%MZ")


def synthetic_field(
    out_dir: str | Path,
    *,
    n_wells: int = 10,
    days: int = 30,
    cards_per_day: int = 1,
    change: StepChange | Sequence[StepChange] | None = None,
    broken_fraction: float = 0.0,
    formats: Sequence[str] = FIELD_FORMATS,
    seed: int = 0,
    model: str | type[Model] = "kelvin",
    cards: FieldCards = FieldCards(),
) -> pd.DataFrame:
    """Write a field of synthetic wells to files and return the truth table.

    Each well gets parameters drawn log-uniformly within a factor ``cards.spread`` of
    realistic centre values (inches, pounds-force), its own rod weight (4,000-9,000 lbf),
    stroke (64-144 in) and SPM (5-10), and a file layout (``formats`` in turn). Its cards
    come at regular times (``cards_per_day`` a day from ``cards.start``, for ``days``
    days); each card's parameters are the well's times independent log-normal factors of
    standard deviation ``cards.jitter`` (a steady well's card-to-card scatter), and after a
    :class:`StepChange` the changed parameter is multiplied by its factor. Layouts and
    broken cards are described in
    :mod:`pumpid.pump.synthetic.layouts`.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write into (created; existing files of the same names are replaced).
    n_wells, days, cards_per_day : int
        Size of the field: ``n_wells * days * cards_per_day`` cards.
    change : StepChange or sequence of StepChange, optional
        Step changes to put in.
    broken_fraction : float, default 0
        Fraction of the cards to break (at least one when positive). The first broken card
        is an unreadable file; the others cycle through NaN, truncated and constant load.
    formats : sequence of str
        Layouts to use, from :data:`FIELD_FORMATS`.
    seed : int, default 0
        Everything random derives from it.
    model : str or model class, default "kelvin"
        ``"kelvin"``, ``"maxwell"`` or ``"msd"``.
    cards : FieldCards, default FieldCards()
        What each card looks like: the observed state, samples per card, noise, card-to-card
        scatter, the spread of the wells' parameters, the first card's time and the load's
        hold (see :class:`FieldCards`).

    Returns
    -------
    pandas.DataFrame
        One row per card: ``well_id``, ``card_id``, ``time`` (datetime64[ns, UTC]),
        ``card_index`` (0-based within the well), ``file`` (path relative to ``out_dir``),
        ``format``, ``model``, ``observe`` (as given, or ``"default"``), ``p_<name>`` per
        parameter, ``spm``,
        ``stroke`` (in), ``rod_weight`` (lbf), ``n_samples``, ``position_unit``,
        ``load_unit``, ``changed`` (bool: a step change applies to this card) and
        ``broken`` (the kind, or None).

    Raises
    ------
    ValueError
        For an unknown model, layout or parameter, a step change naming an unknown well,
        or sizes that are not positive.
    """
    cls = model_class(model)
    key = model_key(cls)
    if key not in _CENTRES:
        raise ValueError(f"synthetic fields use kelvin, maxwell or msd models, not {key!r}")
    bad = [f for f in formats if f not in FIELD_FORMATS]
    if bad or not formats:
        raise ValueError(f"unknown layout(s) {bad}; choose from {', '.join(FIELD_FORMATS)}")
    if not isinstance(cards, FieldCards):
        raise ValueError(f"cards must be a FieldCards, got {type(cards).__name__}")
    observe, n_samples, noise, hold = cards.observe, cards.n_samples, cards.noise, cards.hold
    if min(n_wells, days, cards_per_day) < 1:
        raise ValueError("n_wells, days and cards_per_day must be positive")
    if not 0.0 <= broken_fraction <= 1.0:
        raise ValueError(f"broken_fraction must be in [0, 1], got {broken_fraction}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    width = max(3, len(str(n_wells - 1)))
    well_ids = [f"W{i:0{width}d}" for i in range(n_wells)]
    changes = [] if change is None else [change] if isinstance(change, StepChange) else change
    names = cls.param_names()
    steps: dict[str, list[StepChange]] = {}
    for ch in changes:
        wid = well_ids[ch.well] if isinstance(ch.well, int) else ch.well
        if wid not in well_ids:
            raise ValueError(f"step change for unknown well {ch.well!r}")
        if ch.parameter not in names:
            raise ValueError(f"{key} has no parameter {ch.parameter!r}; it has {names}")
        steps.setdefault(wid, []).append(ch)
    n_cards = days * cards_per_day
    t0 = cards.start
    times = [t0 + pd.Timedelta(days=1) * (i / cards_per_day) for i in range(n_cards)]
    n_total = n_wells * n_cards
    n_broken = 0 if broken_fraction == 0 else max(1, round(broken_fraction * n_total))
    broken_at = set(rng.choice(n_total, size=n_broken, replace=False).tolist())
    broken_order = sorted(broken_at)
    kinds = {j: ("unreadable" if r == 0 else BROKEN_KINDS[(r - 1) % 3])
             for r, j in enumerate(broken_order)}  # fmt: skip
    rows: list[dict[str, Any]] = []
    jitter = cards.jitter
    for w, wid in enumerate(well_ids):
        base = {p: _log_uniform(rng, c, cards.spread) for p, c in _CENTRES[key].items()}
        spm = float(rng.uniform(5.0, 10.0))
        stroke = _log_uniform(rng, 96.0, 1.5)
        rod_weight = _log_uniform(rng, 6000.0, 1.5)
        fmt = formats[w % len(formats)]
        period = 60.0 / spm
        position0 = polished_rod_position(n_samples, stroke=stroke)
        good: list[dict[str, Any]] = []
        for i, ts in enumerate(times):
            params = {p: v * math.exp(jitter * rng.standard_normal()) for p, v in base.items()}
            changed = False
            for ch in steps.get(wid, []):
                if i >= ch.at:
                    params[ch.parameter] *= ch.factor
                    changed = True
            mdl = cls(**params)
            load = periodic_load(
                mdl, position0, period, observe=observe, static_load=rod_weight, hold=hold
            )
            card_noise = (noise, noise) if np.isscalar(noise) else noise  # type: ignore[misc]
            pos = position0 + card_noise[0] * np.ptp(position0) * rng.standard_normal(n_samples)
            load = load + card_noise[1] * np.ptp(load) * rng.standard_normal(n_samples)
            card_id = f"{wid}_{_card_stamp(ts)}"
            kind = kinds.get(w * n_cards + i)
            entry = {"well_id": wid, "card_id": card_id, "time": ts, "spm": spm,
                     "position": pos, "load": load}  # fmt: skip
            if kind is None:
                good.append(entry)
                path = None
            elif kind == "unreadable":
                ext = {"csv": "csv", "scada": "txt", "json": "json", "whitespace": "txt",
                       "parquet": "parquet"}[fmt]  # fmt: skip
                (out / fmt).mkdir(parents=True, exist_ok=True)
                path = out / fmt / f"{card_id}_unreadable.{ext}"
                write_unreadable(path, rng)
            else:
                bpos, bload = break_card(kind, pos, load)
                path = write_cards(
                    fmt, out, f"{card_id}_{kind}", [{**entry, "position": bpos, "load": bload}]
                )[0]
            rows.append({
                "well_id": wid, "card_id": card_id, "time": ts, "card_index": i,
                "file": None if path is None else path.relative_to(out).as_posix(),
                "format": fmt, "model": key,
                "observe": observe if observe is not None else "default",
                **{f"p_{p}": params[p] for p in names},
                "spm": spm, "stroke": stroke, "rod_weight": rod_weight,
                "n_samples": n_samples, "position_unit": "in", "load_unit": "lbf",
                "changed": changed, "broken": kind,
            })  # fmt: skip
        if good:
            paths = write_cards(fmt, out, wid, good)
            by_id = {c["card_id"]: p for c, p in zip(good, paths, strict=True)}
            for row in rows[-n_cards:]:
                if row["card_id"] in by_id:
                    row["file"] = by_id[row["card_id"]].relative_to(out).as_posix()
    truth = pd.DataFrame(rows)
    truth["time"] = pd.to_datetime(truth["time"], utc=True).astype("datetime64[ns, UTC]")
    truth["broken"] = truth["broken"].astype(object).where(truth["broken"].notna(), None)
    return truth
