"""Synthetic dynamometer cards and fields of wells, with the truth they were made from.

Three layers, each usable alone:

Pumping-unit kinematics (:class:`CrankRocker`, :func:`polished_rod_position`)
    A conventional (crank-rocker) beam pumping unit is a four-bar linkage: the gearbox crank
    (radius R) turns at constant speed, the pitman (length P) pulls the rear arm (length C)
    of the walking beam, which pivots on the saddle bearing; the horsehead at the end of the
    front arm (length A) is an arc centred on the saddle bearing, so the polished rod moves
    by exactly ``A`` times the beam's change of angle. The linkage is solved exactly at each
    crank angle (no small-angle or harmonic approximation). Sampling is uniform in time over
    one stroke, from bottom dead centre, ``N`` samples, the closing sample (which repeats
    the first) left out: ``t_i = i T / N``, ``T = 60 / SPM``.

Load from a model (:func:`periodic_load`, :func:`synthetic_card`)
    The load a linear model needs to move the polished rod along that path in the periodic
    steady state, computed exactly per harmonic from the model's transfer function ``H``
    (:meth:`pumpid.Model.transfer_function`): ``F_k = X_k / H_k``, plus a constant static
    load (the buoyant rod weight). A constant load only moves the model's position by the
    constant ``H(0) W``, which a fit absorbs in its position offset; the card keeps the
    kinematic position. ``H_k`` is, by default (``hold="linear"``), the response at the
    sample instants to a load whose samples are joined by straight lines, which is what a
    recorder's samples mean to :func:`pumpid.simulate`::

        H_k = sum over all integers m of  sinc²(w_m / 2) H(i w_m / h),
        w_m = 2 pi k / N + 2 pi m,  h = T / N,  sinc(x) = sin(x) / x

    (the hat function's spectrum folded onto the sample grid). The sum is taken over
    ``|m| <= 64`` and its tail from the transfer function's high-frequency asymptote
    ``c / s^r`` in closed form (Hurwitz zeta), so ``pumpid.simulate(model, t, load,
    initial_state="periodic")`` gives back the kinematic position to about 1e-12 of the
    stroke. With ``hold="none"`` ``H_k = H(i k 2 pi / T)``: the band-limited load of the
    continuous model, which a simulation on the card's own samples reproduces only up to
    the straight-line error, of order ``(k 2 pi / N)² / 12`` relative at harmonic ``k``.

Fields of wells (:func:`synthetic_field`)
    Many wells, each with its own parameters, rod weight, stroke and SPM, cards at regular
    times with a small card-to-card jitter, optional step changes at known cards and broken
    cards, written in the file layouts pumpid reads, and returned with the truth table.

File layouts written by :func:`synthetic_field`
-----------------------------------------------
Values are in inches (position) and pounds-force (load). Card ids are
``<well>_<YYYYmmddTHHMM>Z`` (the card's time, UTC), unique in the field. Every card of a
well goes to one file, except for broken cards (each in a file of its own, so that the
rest of the well stays readable) and the whitespace layout (one card per file).

``csv/<well>.csv``
    Header ``card_id,well_id,timestamp,spm,position_in,load_lbf``; one row per sample;
    ``timestamp`` is ISO 8601 with ``Z`` (the readers keep it in ``Card.metadata``).
``scada/<well>.txt``
    Pipe-delimited controller export, one card per row:
    ``Well|Card ID|Timestamp|SPM|Surface Positions (in)|Surface Loads (lbf)``.
``json/<well>.json``
    ``{"well": ..., "units": {"position": "in", "load": "lbf"}, "cards": [{"card_id": ...,
    "timestamp": ..., "spm": ..., "position": [...], "load": [...]}, ...]}``.
``whitespace/<well>/<card_id>.txt``
    Two columns without header (position, load), ``#`` comments on top; the format has no
    place for ids, rate or time: the card id is the file name, and well id and SPM come
    from the truth table; a linear model's smooth loop does not tell its columns apart,
    so name them (``read_cards(path, well_id=..., spm=..., columns={"position": 0,
    "load": 1})``).
``parquet/<well>.parquet``
    The long layout, one row per sample (read with
    :func:`pumpid.fleet.dataset.read_parquet_cards`): ``well_id`` (str), ``card_id`` (str),
    ``time`` (datetime64[ns, UTC], the card's time), ``sample`` (int, 0-based order within
    the card), ``position``, ``load`` (float), ``spm`` (float, constant within a card),
    ``position_unit``, ``load_unit`` (str, constant).

Broken cards (``broken_fraction``) are of the kinds ``"nan"`` (a NaN load sample),
``"truncated"`` (the load list shorter than the position list; in the Parquet layout, a card
of 5 samples), ``"constant-load"`` and, once per field, ``"unreadable"`` (a file of binary
garbage). Every one of them makes the readers raise :class:`pumpid.cards.CardError`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import scipy.optimize
import scipy.special
from numpy.typing import ArrayLike, NDArray

from pumpid import Model, model_class
from pumpid.cards import Card

__all__ = [
    "BROKEN_KINDS",
    "FIELD_FORMATS",
    "CrankRocker",
    "StepChange",
    "periodic_load",
    "polished_rod_position",
    "synthetic_card",
    "synthetic_field",
]

#: File layouts :func:`synthetic_field` can write.
FIELD_FORMATS = ("csv", "scada", "json", "whitespace", "parquet")
#: Kinds of broken card :func:`synthetic_field` can make.
BROKEN_KINDS = ("nan", "truncated", "constant-load", "unreadable")

# Alias terms summed explicitly on each side; the rest comes from the asymptote in closed
# form. 64 leaves a residual far below 1e-12 of the response for the rod-pump models.
_ALIAS_TERMS = 64
# Harmonics of the position smaller than this (relative to the largest) carry only
# rounding; inverting them would amplify rounding by 1/|H|, so they get no load.
_HARMONIC_FLOOR = 1e-13


# --------------------------------------------------------------------------- kinematics
@dataclass(frozen=True)
class CrankRocker:
    """Geometry of a conventional crank-rocker beam pumping unit (a four-bar linkage).

    Lengths are in any one unit; only their ratios shape the motion. In a frame with the
    crankshaft at the origin, ``x`` towards the well and ``y`` up, the saddle bearing
    (the beam's pivot) is at ``(horizontal, height)``, the crank pin at
    ``crank * (cos theta, sin theta)`` with the crank angle ``theta`` increasing
    (counter-clockwise) at constant speed, the pitman joins the crank pin to the end of the
    beam's rear arm, and the horsehead is at the end of the front arm.

    The defaults (metres) are a unit of ordinary proportions with a stroke of about
    2.3 m (90 in) and a beam swing of about 44 degrees; :func:`polished_rod_position`
    rescales the front arm to any stroke, which leaves the shape of the motion unchanged.

    Parameters
    ----------
    front_arm : float
        Saddle bearing to horsehead arc (API's dimension A).
    rear_arm : float
        Saddle bearing to the pitman's (equalizer) bearing (C).
    pitman : float
        Pitman length (P).
    crank : float
        Crank radius (R).
    horizontal : float
        Horizontal distance from the crankshaft to the saddle bearing (I).
    height : float
        Height of the saddle bearing above the crankshaft.

    Raises
    ------
    ValueError
        If a length is not positive and finite, or the linkage cannot be assembled at every
        crank angle (the crank must turn fully: ``|C - P| <= K - R`` and ``K + R <= C + P``
        with ``K`` the crankshaft-to-saddle distance).
    """

    front_arm: float = 3.0
    rear_arm: float = 2.4
    pitman: float = 3.3
    crank: float = 0.9
    horizontal: float = 2.4
    height: float = 3.2

    def __post_init__(self) -> None:
        for name in ("front_arm", "rear_arm", "pitman", "crank", "horizontal", "height"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"CrankRocker: {name} must be positive and finite, got {value}")
            object.__setattr__(self, name, value)
        k = math.hypot(self.horizontal, self.height)
        if k - self.crank < abs(self.rear_arm - self.pitman) or (
            k + self.crank > self.rear_arm + self.pitman
        ):
            raise ValueError(
                "CrankRocker: the linkage cannot be assembled at every crank angle "
                f"(crankshaft-to-saddle distance {k:.6g}, crank {self.crank:.6g}, "
                f"rear arm {self.rear_arm:.6g}, pitman {self.pitman:.6g})"
            )

    def beam_angle(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Beam angle (rad, front arm up positive) at crank angles ``theta`` (rad).

        The pitman's far end E is on the circle of radius ``rear_arm`` about the saddle
        bearing S and on the circle of radius ``pitman`` about the crank pin Q. With
        ``D = S - Q`` and the beam's forward unit vector ``u(psi)``, ``|D - C u| = P`` gives
        ``cos(psi - atan2(D)) = (|D|² + C² - P²) / (2 C |D|)``; the root with the rear arm
        above the crank (the assembled unit) is ``psi = atan2(D) - arccos(...)``.
        """
        th = np.asarray(theta, dtype=float)
        dx = self.horizontal - self.crank * np.cos(th)
        dy = self.height - self.crank * np.sin(th)
        d = np.hypot(dx, dy)
        c = (d * d + self.rear_arm**2 - self.pitman**2) / (2.0 * self.rear_arm * d)
        return np.arctan2(dy, dx) - np.arccos(np.clip(c, -1.0, 1.0))

    def bottom_dead_centre(self) -> float:
        """Crank angle (rad, in [0, 2 pi)) at which the polished rod is lowest."""
        return self._extreme(lowest=True)

    def top_dead_centre(self) -> float:
        """Crank angle (rad, in [0, 2 pi)) at which the polished rod is highest."""
        return self._extreme(lowest=False)

    def _extreme(self, *, lowest: bool) -> float:
        sign = 1.0 if lowest else -1.0
        grid = np.linspace(0.0, 2.0 * np.pi, 721)
        i = int(np.argmin(sign * self.beam_angle(grid)))
        lo, hi = grid[max(i - 1, 0)] - 0.01, grid[min(i + 1, grid.size - 1)] + 0.01
        res = scipy.optimize.minimize_scalar(
            lambda th: sign * float(self.beam_angle(th)),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-12},
        )
        return float(res.x) % (2.0 * np.pi)

    def swing(self) -> float:
        """Total beam swing (rad) between bottom and top dead centre."""
        return float(
            self.beam_angle(self.top_dead_centre()) - self.beam_angle(self.bottom_dead_centre())
        )

    def stroke_length(self) -> float:
        """Polished-rod stroke in the geometry's length unit: ``front_arm * swing``."""
        return self.front_arm * self.swing()


def polished_rod_position(
    n_samples: int, *, stroke: float | None = None, geometry: CrankRocker | None = None
) -> NDArray[np.float64]:
    """Polished-rod position over one stroke of a crank-rocker unit.

    Parameters
    ----------
    n_samples : int
        Samples per stroke (>= 8), uniform in time (the crank turns at constant speed):
        sample ``i`` is at crank angle ``theta_BDC + 2 pi i / N``; the closing sample
        (``i = N``, equal to the first) is not included.
    stroke : float, optional
        Stroke length in the caller's unit. The front arm is scaled to give it, which does
        not change the shape of the motion. Default: the geometry's own stroke.
    geometry : CrankRocker, optional
        Default: ``CrankRocker()``.

    Returns
    -------
    ndarray, shape (n_samples,)
        Position above bottom dead centre: 0 at sample 0, rising to ``stroke`` at top dead
        centre and falling back (a single hump).

    Raises
    ------
    ValueError
        If ``n_samples < 8`` or ``stroke`` is not positive and finite.
    """
    geo = CrankRocker() if geometry is None else geometry
    n = int(n_samples)
    if n < 8:
        raise ValueError(f"n_samples must be at least 8, got {n_samples}")
    bdc = geo.bottom_dead_centre()
    psi = geo.beam_angle(bdc + 2.0 * np.pi * np.arange(n) / n)
    psi_min = float(geo.beam_angle(bdc))
    full = geo.stroke_length()
    if stroke is None:
        scale = geo.front_arm
    else:
        stroke = float(stroke)
        if not (math.isfinite(stroke) and stroke > 0):
            raise ValueError(f"stroke must be positive and finite, got {stroke}")
        scale = geo.front_arm * stroke / full
    # The minimiser finds bottom dead centre to ~1e-12 rad; clip the rounding below zero.
    return np.maximum(scale * (psi - psi_min), 0.0)


# --------------------------------------------------------------------------- load
def _asymptote(model: Model, observe: str | None, omega: float) -> tuple[int, float]:
    """Relative degree r and constant c of ``H(s) ~ c / s^r`` for large ``|s|``."""
    h1, h2 = model.transfer_function(np.array([1j * omega, 10j * omega]), observe)
    r = round(math.log10(abs(h1) / abs(h2)))
    c = float(((1j * omega) ** r * h1).real)
    return r, c


def _sampled_response(
    model: Model, observe: str | None, k: NDArray[np.int64], n: int, period: float, hold: str
) -> NDArray[np.complex128]:
    """The model's response at harmonic(s) ``k`` of an ``n``-sample stroke (see module doc)."""
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


def _as_timestamp(value: Any) -> pd.Timestamp | None:
    if value is None:
        return None
    ts = pd.Timestamp(value)
    if ts is pd.NaT:
        return None
    return ts.tz_localize("UTC") if ts.tzinfo is None else ts.tz_convert("UTC")


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
    well_id: str | None = None,
    card_id: str = "synthetic",
    time: Any = None,
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
    well_id, card_id : str
        Identifiers stored on the card.
    time : datetime-like, optional
        The card's time (naive means UTC); stored as a UTC ``pandas.Timestamp`` in
        ``card.metadata["time"]``.
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
        card_id=card_id,
        well_id=well_id,
        spm=spm,
        period=period,
        time_source="spm",
        periodic=True,
        notes=(
            f"synthetic card: crank-rocker kinematics, {n} samples at {spm:.6g} SPM, load "
            f"from the {_model_key(type(model))} model's transfer function (hold={hold}), "
            f"noise {pos_noise:g} / {load_noise:g} of the range on position / load",
        ),
        metadata={
            "time": _as_timestamp(time),
            "model": _model_key(type(model)),
            "observe": obs,
            "parameters": model.as_dict(),
            "rod_weight": float(rod_weight),
        },
    )


# --------------------------------------------------------------------------- fields
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


#: Centre values of the field's parameters per model (inches, pounds-force, seconds).
_CENTRES: dict[str, dict[str, float]] = {
    "kelvin": {"k0": 200.0, "m": 8.8, "c1": 40.0, "k1": 130.0},
    "maxwell": {"k0": 80.0, "m": 8.8, "c1": 40.0, "k1": 130.0},
    "msd": {"m": 8.8, "c": 25.0, "k": 80.0},
}


def _model_key(cls: type[Model]) -> str:
    """The model's short name, found through :func:`pumpid.model_class` alone."""
    for key in ("kelvin", "maxwell", "msd", "first-order"):
        if model_class(key) is cls:
            return key
    return cls.__name__.lower()


def _log_uniform(rng: np.random.Generator, centre: float, spread: float) -> float:
    return float(centre * math.exp(rng.uniform(-math.log(spread), math.log(spread))))


def _card_stamp(ts: pd.Timestamp) -> str:
    return ts.strftime("%Y%m%dT%H%MZ")


def _fmt_values(values: ArrayLike) -> list[str]:
    return [f"{v:.8g}" for v in np.asarray(values, dtype=float)]


def _break_card(
    kind: str, position: NDArray[np.float64], load: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    pos, ld = position.copy(), load.copy()
    if kind == "nan":
        ld[ld.size // 3] = np.nan
    elif kind == "truncated":
        ld = ld[: ld.size - 7]
    elif kind == "constant-load":
        ld[:] = round(float(ld.mean()), 1)
    return pos, ld


def _write_csv(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    lines = ["card_id,well_id,timestamp,spm,position_in,load_lbf"]
    for c in cards:
        stamp = c["time"].strftime("%Y-%m-%dT%H:%M:%SZ")
        pos, load = _fmt_values(c["position"]), _fmt_values(c["load"])
        for i in range(max(len(pos), len(load))):
            p = pos[i] if i < len(pos) else ""
            if i < len(load):
                lines.append(f"{c['card_id']},{c['well_id']},{stamp},{c['spm']:.6g},{p},{load[i]}")
            else:  # a truncated card: the row simply stops after the position
                lines.append(f"{c['card_id']},{c['well_id']},{stamp},{c['spm']:.6g},{p}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _write_scada(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    lines = ["Well|Card ID|Timestamp|SPM|Surface Positions (in)|Surface Loads (lbf)"]
    for c in cards:
        stamp = c["time"].strftime("%Y-%m-%d %H:%M:%S")
        lines.append(
            f"{c['well_id']}|{c['card_id']}|{stamp}|{c['spm']:.6g}|"
            f"{','.join(_fmt_values(c['position']))}|{','.join(_fmt_values(c['load']))}"
        )
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _write_json(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    doc = {
        "well": cards[0]["well_id"],
        "units": {"position": "in", "load": "lbf"},
        "cards": [
            {
                "card_id": c["card_id"],
                "timestamp": c["time"].strftime("%Y-%m-%dT%H:%M:%SZ"),
                "spm": round(float(c["spm"]), 6),
                "position": [float(v) for v in _fmt_values(c["position"])],
                "load": [float(v) for v in _fmt_values(c["load"])],
            }
            for c in cards
        ],
    }
    # NaN is written as the bare token NaN (not strict JSON, but what such exports contain).
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")


def _write_whitespace(path: Path, card: dict[str, Any]) -> None:
    pos, load = _fmt_values(card["position"]), _fmt_values(card["load"])
    lines = [
        f"# synthetic card {card['card_id']} of well {card['well_id']}",
        f"# time {card['time'].strftime('%Y-%m-%dT%H:%M:%SZ')}, {card['spm']:.6g} SPM",
        "# columns: position (in), load (lbf)",
    ]
    for i in range(len(pos)):
        lines.append(f"{pos[i]:>14} {load[i]:>14}" if i < len(load) else f"{pos[i]:>14}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _write_parquet(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    frames = []
    for c in cards:
        pos, load = np.asarray(c["position"], float), np.asarray(c["load"], float)
        n = pos.size
        if load.size != n:  # the long layout cannot hold unequal lists: a short card instead
            n = 5
            pos, load = pos[:n], load[:n]
        frames.append(
            pd.DataFrame(
                {
                    "well_id": c["well_id"],
                    "card_id": c["card_id"],
                    "time": pd.Series([c["time"]] * n, dtype="datetime64[ns, UTC]"),
                    "sample": np.arange(n, dtype=np.int64),
                    "position": pos,
                    "load": load,
                    "spm": float(c["spm"]),
                    "position_unit": "in",
                    "load_unit": "lbf",
                }
            )
        )
    pd.concat(frames, ignore_index=True).to_parquet(path, index=False)


def _write_unreadable(path: Path, rng: np.random.Generator) -> None:
    path.write_bytes(b"\x00\x8f\xff" + rng.bytes(509))


def _write_cards(
    fmt: str, folder: Path, stem: str, cards: Sequence[dict[str, Any]]
) -> list[Path]:
    """Write a well's cards (or one broken card) in one layout; return the file per card."""
    if fmt == "whitespace":
        sub = folder / "whitespace" / cards[0]["well_id"]
        sub.mkdir(parents=True, exist_ok=True)
        paths = []
        for c in cards:
            p = sub / f"{c['card_id']}.txt"
            _write_whitespace(p, c)
            paths.append(p)
        return paths
    ext = {"csv": "csv", "scada": "txt", "json": "json", "parquet": "parquet"}[fmt]
    sub = folder / fmt
    sub.mkdir(parents=True, exist_ok=True)
    p = sub / f"{stem}.{ext}"
    {"csv": _write_csv, "scada": _write_scada, "json": _write_json,
     "parquet": _write_parquet}[fmt](p, cards)  # fmt: skip
    return [p] * len(cards)


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
    observe: str | None = None,
    n_samples: int = 100,
    noise: float | tuple[float, float] = 0.003,
    jitter: float = 0.02,
    spread: float = 1.5,
    start: Any = "2024-01-01",
    hold: str = "linear",
) -> pd.DataFrame:
    """Write a field of synthetic wells to files and return the truth table.

    Each well gets parameters drawn log-uniformly within a factor ``spread`` of realistic
    centre values (inches, pounds-force), its own rod weight (4,000-9,000 lbf), stroke
    (64-144 in) and SPM (5-10), and a file layout (``formats`` in turn). Its cards come
    at regular times (``cards_per_day`` a day from ``start``, for ``days`` days); each
    card's parameters are the well's times independent log-normal factors of standard
    deviation ``jitter`` (a steady well's card-to-card scatter), and after a
    :class:`StepChange` the changed parameter is multiplied by its factor. Layouts and
    broken cards are described in the module docstring.

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
    observe : str, optional
        The model state that follows the polished rod (default: the model's own).
    n_samples : int, default 100
        Samples per card.
    noise : float or (float, float), default 0.003
        As for :func:`synthetic_card`.
    jitter : float, default 0.02
        Card-to-card log-normal scatter of each parameter (0.02: about 2 %).
    spread : float, default 1.5
        Wells' parameters lie within ``centre / spread`` and ``centre * spread``.
    start : datetime-like, default "2024-01-01"
        Time of the first card (naive means UTC).
    hold : {"linear", "none"}, default "linear"
        See :func:`periodic_load`.

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
    key = _model_key(cls)
    if key not in _CENTRES:
        raise ValueError(f"synthetic fields use kelvin, maxwell or msd models, not {key!r}")
    bad = [f for f in formats if f not in FIELD_FORMATS]
    if bad or not formats:
        raise ValueError(f"unknown layout(s) {bad}; choose from {', '.join(FIELD_FORMATS)}")
    if min(n_wells, days, cards_per_day, n_samples) < 1:
        raise ValueError("n_wells, days, cards_per_day and n_samples must be positive")
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
    t0 = _as_timestamp(start)
    if t0 is None:
        raise ValueError("start must be a date or time")
    times = [t0 + pd.Timedelta(days=1) * (i / cards_per_day) for i in range(n_cards)]
    n_total = n_wells * n_cards
    n_broken = 0 if broken_fraction == 0 else max(1, round(broken_fraction * n_total))
    broken_at = set(rng.choice(n_total, size=n_broken, replace=False).tolist())
    broken_order = sorted(broken_at)
    kinds = {j: ("unreadable" if r == 0 else BROKEN_KINDS[(r - 1) % 3])
             for r, j in enumerate(broken_order)}  # fmt: skip
    rows: list[dict[str, Any]] = []
    for w, wid in enumerate(well_ids):
        base = {p: _log_uniform(rng, c, spread) for p, c in _CENTRES[key].items()}
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
                _write_unreadable(path, rng)
            else:
                bpos, bload = _break_card(kind, pos, load)
                path = _write_cards(
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
            paths = _write_cards(fmt, out, wid, good)
            by_id = {c["card_id"]: p for c, p in zip(good, paths, strict=True)}
            for row in rows[-n_cards:]:
                if row["card_id"] in by_id:
                    row["file"] = by_id[row["card_id"]].relative_to(out).as_posix()
    truth = pd.DataFrame(rows)
    truth["time"] = pd.to_datetime(truth["time"], utc=True).astype("datetime64[ns, UTC]")
    truth["broken"] = truth["broken"].astype(object).where(truth["broken"].notna(), None)
    return truth
