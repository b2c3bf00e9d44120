"""The load a linear model needs to follow the polished rod, and the synthetic card.

How the load is computed per harmonic, and how exactly a simulation gives the position
back, is told in :mod:`pumpid.pump.synthetic`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import scipy.special
from numpy.typing import ArrayLike, NDArray

from pumpid.cards import Card
from pumpid.models import Model, model_class

from .kinematics import CrankRocker, polished_rod_position

__all__ = ["CardLabel", "as_timestamp", "model_key", "periodic_load", "synthetic_card"]

# Alias terms summed explicitly on each side; the rest comes from the asymptote in closed
# form. 64 leaves a residual far below 1e-12 of the response for the rod-pump models.
_ALIAS_TERMS = 64
# Harmonics of the position smaller than this (relative to the largest) carry only
# rounding; inverting them would amplify rounding by 1/|H|, so they get no load.
_HARMONIC_FLOOR = 1e-13


def _asymptote(model: Model, observe: str | None, omega: float) -> tuple[int, float]:
    """Relative degree r and constant c of ``H(s) ~ c / s^r`` for large ``|s|``."""
    h1, h2 = model.transfer_function(np.array([1j * omega, 10j * omega]), observe)
    r = round(math.log10(abs(h1) / abs(h2)))
    c = float(((1j * omega) ** r * h1).real)
    return r, c


def _sampled_response(
    model: Model, observe: str | None, k: NDArray[np.int64], n: int, period: float, hold: str
) -> NDArray[np.complex128]:
    """The model's response at harmonic(s) ``k`` of an ``n``-sample stroke.

    How, and why so, is told in :mod:`pumpid.pump.synthetic`.
    """
    h = period / n
    theta = 2.0 * np.pi * k / n
    if hold == "none":
        return model.transfer_function(1j * theta / h, observe)
    m = np.arange(-_ALIAS_TERMS, _ALIAS_TERMS + 1)
    w = theta[:, None] + 2.0 * np.pi * m[None, :]
    sinc2 = (np.sin(w / 2.0) / (w / 2.0)) ** 2  # w != 0: 0 < theta < 2 pi
    resp = model.transfer_function(1j * w / h, observe)
    total = (sinc2 * resp).sum(axis=1)
    r, c = _asymptote(model, observe, 1e3 * 2.0 * np.pi * (_ALIAS_TERMS + 1) / h)
    q = theta / (2.0 * np.pi)
    s = 2.0 + r
    tail = (
        4.0 * np.sin(theta / 2.0) ** 2 * c * h**r * (1j) ** (-r) * (2.0 * np.pi) ** (-s)
        * (scipy.special.zeta(s, _ALIAS_TERMS + 1 + q)
           + (-1.0) ** r * scipy.special.zeta(s, _ALIAS_TERMS + 1 - q))
    )
    return total + tail


def periodic_load(
    model: Model,
    position: ArrayLike,
    period: float,
    *,
    observe: str | None = None,
    static_load: float = 0.0,
    hold: str = "linear",
) -> NDArray[np.float64]:
    """The periodic load that makes a linear model follow a given periodic position.

    Parameters
    ----------
    model : pumpid.Model
        The model (its parameters in the card's units).
    position : array_like, shape (N,)
        One period of the position, sampled uniformly (``t_i = i T / N``, no closing
        sample).
    period : float
        The period ``T`` in seconds.
    observe : str, optional
        The model's observed state (default: the model's own default).
    static_load : float, default 0
        The load's mean (the buoyant rod weight). The model's position then has the mean
        ``H(0) static_load`` instead of the given one; every other harmonic is reproduced.
    hold : {"linear", "none"}, default "linear"
        ``"linear"``: the load's samples are taken to be joined by straight lines, as
        :func:`pumpid.simulate` takes them, so that simulating the result reproduces
        ``position - mean(position) + H(0) static_load`` to rounding. ``"none"``: the
        band-limited load of the continuous model (``F_k = X_k / H(i k 2 pi / T)``).

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    ValueError
        If the position is not a finite 1-D array of at least 4 samples, the period is not
        positive, ``hold`` is unknown, or the model does not respond at a needed harmonic.

    Notes
    -----
    With an even number of samples, the harmonic at half the sampling rate is seen by the
    samples only as ``(-1)^i``; its load is taken as that cosine, which the model's
    response reproduces at the samples exactly.
    """
    x = np.asarray(position, dtype=float)
    if x.ndim != 1 or x.size < 4 or not np.all(np.isfinite(x)):
        raise ValueError("position must be a finite 1-D array of at least 4 samples")
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period must be positive and finite, got {period}")
    if hold not in ("linear", "none"):
        raise ValueError(f"hold must be 'linear' or 'none', got {hold!r}")
    n = x.size
    spec = np.fft.rfft(x)
    mag = np.abs(spec)
    top = float(mag[1:].max()) if mag.size > 1 else 0.0
    k_all = np.arange(spec.size)
    keep = (k_all >= 1) & (mag > _HARMONIC_FLOOR * top)
    load_spec = np.zeros_like(spec)
    if keep.any():
        resp = _sampled_response(model, observe, k_all[keep], n, float(period), hold)
        if n % 2 == 0 and keep[-1]:
            # Half the sampling rate: the samples see only the cosine, (-1)^i, whose response
            # at the samples is the real part (with hold="linear" the folded sum is real).
            resp[-1] = resp[-1].real
        if not np.all(np.isfinite(resp)) or np.any(resp == 0):
            raise ValueError("the model does not respond at every harmonic of the position")
        load_spec[keep] = spec[keep] / resp
    load_spec[0] = float(static_load) * n
    return np.fft.irfft(load_spec, n)


def model_key(cls: type[Model]) -> str:
    """The model's short name, found through :func:`pumpid.model_class` alone.

    Parameters
    ----------
    cls : type of Model
        A model class.

    Returns
    -------
    str
        ``"kelvin"``, ``"maxwell"``, ``"msd"`` or ``"first-order"``; for another class its
        name in lower case.
    """
    for key in ("kelvin", "maxwell", "msd", "first-order"):
        if model_class(key) is cls:
            return key
    return cls.__name__.lower()


def as_timestamp(value: Any) -> pd.Timestamp | None:
    """A card's time as a UTC timestamp.

    Parameters
    ----------
    value : datetime-like or None
        Naive means UTC.

    Returns
    -------
    pandas.Timestamp or None
        None for None or a missing time (NaT).
    """
    if value is None:
        return None
    ts = pd.Timestamp(value)
    if ts is pd.NaT:
        return None
    return ts.tz_localize("UTC") if ts.tzinfo is None else ts.tz_convert("UTC")


@dataclass(frozen=True)
class CardLabel:
    """The identity a synthetic card is given: its well, its id and its time.

    Parameters
    ----------
    well_id : str, optional
        Well identifier stored on the card.
    card_id : str, default "synthetic"
        Card identifier stored on the card.
    time : datetime-like, optional
        The card's time (naive means UTC); kept as a UTC ``pandas.Timestamp`` (None for
        None or NaT).

    Raises
    ------
    ValueError
        For an identifier that is not a string, or a time pandas cannot read.
    """

    well_id: str | None = None
    card_id: str = "synthetic"
    time: Any = None

    def __post_init__(self) -> None:
        if self.well_id is not None and not isinstance(self.well_id, str):
            raise ValueError(f"well_id must be a string or None, got {self.well_id!r}")
        if not isinstance(self.card_id, str):
            raise ValueError(f"card_id must be a string, got {self.card_id!r}")
        try:
            stamp = as_timestamp(self.time)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"time must be a date or time, got {self.time!r}") from exc
        object.__setattr__(self, "time", stamp)


def synthetic_card(
    model: Model,
    *,
    spm: float = 8.0,
    n_samples: int = 200,
    stroke: float = 100.0,
    observe: str | None = None,
    rod_weight: float = 6000.0,
    noise: float | tuple[float, float] = 0.0,
    seed: int | np.random.Generator | None = None,
    label: CardLabel = CardLabel(),
    units: tuple[str, str] = ("in", "lbf"),
    geometry: CrankRocker | None = None,
    hold: str = "linear",
) -> Card:
    """A surface card made by a crank-rocker unit driving a linear model.

    Position: :func:`polished_rod_position` (0 at bottom dead centre). Load: the periodic
    load the model needs to follow it (:func:`periodic_load`) plus ``rod_weight``. Then
    Gaussian noise.

    Parameters
    ----------
    model : pumpid.Model
        A model instance, its parameters in ``units``.
    spm : float, default 8
        Strokes per minute; the card's time is ``t_i = i T / N`` with ``T = 60 / spm``.
    n_samples : int, default 200
        Samples per stroke.
    stroke : float, default 100
        Stroke length, in the position unit.
    observe : str, optional
        The observed state that follows the polished rod (default: the model's own).
    rod_weight : float, default 6000
        Static (buoyant rod-string) load, in the load unit: the load's mean.
    noise : float or (float, float), default 0
        Standard deviation of independent Gaussian noise as a fraction of the peak-to-peak
        range, ``(position, load)``; one number applies to both.
    seed : int or numpy.random.Generator, optional
        For the noise.
    label : CardLabel, default CardLabel()
        The card's ``well_id`` and ``card_id`` (stored on the card) and its ``time``
        (stored as a UTC ``pandas.Timestamp`` in ``card.metadata["time"]``); by default no
        well, id ``"synthetic"``, no time.
    units : (str, str), default ("in", "lbf")
        Position and load units.
    geometry : CrankRocker, optional
        Pumping-unit geometry (default ``CrankRocker()``).
    hold : {"linear", "none"}, default "linear"
        See :func:`periodic_load`.

    Returns
    -------
    pumpid.cards.Card
        Marked periodic, time from the SPM; ``metadata`` holds ``time``, ``model``,
        ``observe`` (as given, or ``"default"``), ``parameters`` and ``rod_weight``;
        ``source`` is ``"synthetic"``.

    Raises
    ------
    ValueError
        For a non-positive SPM, stroke or sample count, or negative noise.
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be a pumpid model instance, got {type(model).__name__}")
    if not isinstance(label, CardLabel):
        raise ValueError(f"label must be a CardLabel, got {type(label).__name__}")
    spm = float(spm)
    if not (math.isfinite(spm) and spm > 0):
        raise ValueError(f"spm must be positive and finite, got {spm}")
    pos_noise, load_noise = (noise, noise) if np.isscalar(noise) else noise  # type: ignore[misc]
    if not (pos_noise >= 0 and load_noise >= 0):
        raise ValueError(f"noise must be >= 0, got {noise}")
    period = 60.0 / spm
    n = int(n_samples)
    position = polished_rod_position(n, stroke=stroke, geometry=geometry)
    load = periodic_load(
        model, position, period, observe=observe, static_load=rod_weight, hold=hold
    )
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    if pos_noise > 0:
        position = position + pos_noise * np.ptp(position) * rng.standard_normal(n)
    if load_noise > 0:
        load = load + load_noise * np.ptp(load) * rng.standard_normal(n)
    obs = observe if observe is not None else "default"
    return Card(
        position=position,
        load=load,
        t=np.arange(n) * (period / n),
        position_unit=units[0],
        load_unit=units[1],
        source="synthetic",
        card_id=label.card_id,
        well_id=label.well_id,
        spm=spm,
        period=period,
        time_source="spm",
        periodic=True,
        notes=(
            f"synthetic card: crank-rocker kinematics, {n} samples at {spm:.6g} SPM, load "
            f"from the {model_key(type(model))} model's transfer function (hold={hold}), "
            f"noise {pos_noise:g} / {load_noise:g} of the range on position / load",
        ),
        metadata={
            "time": label.time,
            "model": model_key(type(model)),
            "observe": obs,
            "parameters": model.as_dict(),
            "rod_weight": float(rod_weight),
        },
    )
