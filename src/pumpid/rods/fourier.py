"""Gibbs' Fourier solution of the damped wave equation, batched over cards.

The rod displacement ``u(x, t)`` (upwards, ``x`` the depth) obeys, in each taper,
``u_tt = a^2 u_xx - c u_t`` with ``a = sqrt(E/rho)``; the rod tension is
``F = -E A u_x``. A periodic card is a sum of harmonics ``exp(i n w t)``; for each harmonic
the taper carries ``(U, F)`` from its top to its bottom by a 2x2 transfer matrix

    U(L) = cos(kL) U(0) - sin(kL) / (E A k) F(0)
    F(L) = E A k sin(kL) U(0) + cos(kL) F(0),      k^2 = (w_n^2 - i w_n c) / a^2,

which is Gibbs' separated solution written per taper; displacement and force are continuous
at each joint, so the string's matrix is the product of its tapers'. Gravity and the static
weight are not in these equations: the loads here are the dynamic part (the measured load
minus the string's buoyant weight), see :mod:`pumpid.rods.diagnose`.

Two uses, both exact for band-limited data:

* diagnostic: surface ``(U, F)`` known -> ``(U, F)`` at every joint and at the pump;
* predictive: surface ``U`` and pump ``F`` known -> surface ``F`` (and the pump's ``U``),
  the mixed problem a pump model needs (:mod:`pumpid.rods.predict`).

Cards of one batch share their sample count; wells may differ (strings are padded with
zero-length tapers, whose matrix is the identity).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .well import Well

__all__ = ["StringArrays", "fourier_diagnostic", "fourier_predict", "harmonic_count",
           "string_transfer", "trig_refine"]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]


@dataclass(frozen=True)
class StringArrays:
    """Per-taper arrays of a batch of rod strings, padded to the longest string.

    Attributes
    ----------
    length, stiffness, wave_speed : ndarray, shape (B, T)
        Taper length (m), axial stiffness E*A (N), wave speed (m/s); padding tapers have
        length 0 (and stiffness and wave speed 1, never used).
    count : ndarray of int, shape (B,)
        The real number of tapers of each string.
    """

    length: Array
    stiffness: Array
    wave_speed: Array
    count: NDArray[np.int64]

    @classmethod
    def of(cls, wells: list[Well] | tuple[Well, ...]) -> StringArrays:
        """Stack the strings of a list of wells (one per card)."""
        tmax = max(len(w.tapers) for w in wells)
        shape = (len(wells), tmax)
        length, ea, a = np.zeros(shape), np.ones(shape), np.ones(shape)
        seen: dict[int, dict[str, Array]] = {}
        for i, w in enumerate(wells):
            if id(w) not in seen:
                seen[id(w)] = w.arrays()
            arr = seen[id(w)]
            n = len(w.tapers)
            length[i, :n], ea[i, :n], a[i, :n] = arr["length"], arr["stiffness"], arr[
                "wave_speed"]
        count = np.array([len(w.tapers) for w in wells], dtype=np.int64)
        return cls(length=length, stiffness=ea, wave_speed=a, count=count)

    @property
    def travel_time(self) -> Array:
        """One-way wave travel time of each string, s."""
        return np.asarray((self.length / self.wave_speed).sum(axis=1), dtype=float)


def harmonic_count(n_samples: int, harmonics: int | None) -> int:
    """The highest harmonic used: all the samples resolve (``N // 2``) unless fewer asked."""
    top = n_samples // 2
    if harmonics is None:
        return top
    if int(harmonics) < 1:
        raise ValueError(f"harmonics must be at least 1, got {harmonics}")
    return min(int(harmonics), top)


def trig_refine(values: ArrayLike, factor: int) -> Array:
    """Trigonometric interpolation of one period (last axis) at ``factor`` times the rate.

    The band-limited periodic function through the samples, the same reading of a card
    the Fourier method makes; it passes through the samples exactly.
    """
    x = np.asarray(values, dtype=float)
    if factor == 1:
        return x.copy()
    n = x.shape[-1]
    spec = np.fft.rfft(x, axis=-1)
    if n % 2 == 0:
        spec[..., -1] *= 0.5  # the Nyquist term splits between +/- frequencies
    fine = np.zeros((*spec.shape[:-1], n * factor // 2 + 1), dtype=complex)
    fine[..., : spec.shape[-1]] = spec
    return np.asarray(np.fft.irfft(fine, n=n * factor, axis=-1) * factor, dtype=float)


def _wavenumbers(omega: Array, c: Array, a: Array) -> CArray:
    """k (B, T, H) for harmonic frequencies omega (B, H), damping c (B,), speeds a (B, T)."""
    k2 = (omega[:, None, :] ** 2 - 1j * omega[:, None, :] * c[:, None, None]) / (
        a[:, :, None] ** 2)
    return np.sqrt(k2)


def _taper_terms(k: CArray, length: Array, ea: Array) -> tuple[CArray, CArray, CArray]:
    """cos(kL), sin(kL)/(EA k) and EA k sin(kL), with the k -> 0 limits at w = 0."""
    kl = k * length[:, :, None]
    cos = np.cos(kl)
    sin = np.sin(kl)
    small = np.abs(kl) < 1e-8
    safe_k = np.where(small, 1.0, k)
    # sin(kL)/k -> L and k sin(kL) -> k^2 L as kL -> 0 (the static stretch of the mean load).
    sin_over_k = np.where(small, length[:, :, None] + 0j, sin / safe_k)
    k_sin = np.where(small, k * k * length[:, :, None], safe_k * sin)
    return cos, sin_over_k / ea[:, :, None], k_sin * ea[:, :, None]


def _spectra(values: Array, hmax: int) -> CArray:
    """One-sided spectrum, harmonics 0..hmax, of samples over one period (last axis)."""
    spec = np.fft.rfft(values, axis=-1)
    spec[..., hmax + 1:] = 0.0
    return spec


def _setup(n: int, period: Array, strings: StringArrays, nu: Array,
           harmonics: int | None) -> tuple[int, tuple[CArray, CArray, CArray]]:
    hmax = harmonic_count(n, harmonics)
    nbins = n // 2 + 1
    # Cards of one well at one speed share their transfer matrices: computed once per
    # distinct (string, period, damping), the costly complex sines taken only there.
    key = np.column_stack([strings.length, strings.stiffness, strings.wave_speed,
                           period, nu])
    unique, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    tcount = strings.length.shape[1]
    length = unique[:, :tcount]
    ea = unique[:, tcount: 2 * tcount]
    a = unique[:, 2 * tcount: 3 * tcount]
    per, damp = unique[:, -2], unique[:, -1]
    omega = 2.0 * np.pi * np.arange(nbins)[None, :] / per[:, None]
    travel = (length / a).sum(axis=1)
    c = np.pi * damp / (2.0 * travel)
    k = _wavenumbers(omega, c, a)
    terms = _taper_terms(k, length, ea)
    return hmax, (terms[0][inverse], terms[1][inverse], terms[2][inverse])


def _batch(position: ArrayLike, load: ArrayLike, period: ArrayLike, nu: ArrayLike,
           count: int) -> tuple[Array, Array, Array, Array]:
    u = np.atleast_2d(np.asarray(position, dtype=float))
    f = np.atleast_2d(np.asarray(load, dtype=float))
    if u.shape != f.shape:
        raise ValueError(f"position {u.shape} and load {f.shape} differ in shape")
    if u.shape[0] != count:
        raise ValueError(f"{u.shape[0]} cards but {count} strings")
    per = np.broadcast_to(np.asarray(period, dtype=float), (count,)).copy()
    damp = np.broadcast_to(np.asarray(nu, dtype=float), (count,)).copy()
    if not (np.all(per > 0) and np.all(np.isfinite(per))):
        raise ValueError("every period must be positive and finite")
    if not (np.all(damp >= 0) and np.all(np.isfinite(damp))):
        raise ValueError("every damping factor must be a non-negative finite number")
    return u, f, per, damp


def fourier_diagnostic(position: ArrayLike, load: ArrayLike, period: ArrayLike,
                       strings: StringArrays, nu: ArrayLike,
                       harmonics: int | None = None) -> tuple[Array, Array]:
    """Position and dynamic load at the bottom of every taper from the surface card.

    Parameters
    ----------
    position : array_like, shape (B, N)
        Polished-rod position (m, upwards), N samples uniform in time over one period.
    load : array_like, shape (B, N)
        Dynamic polished-rod load (N): measured load minus the string's buoyant weight.
    period : array_like, shape (B,) or scalar
        Stroke period, s.
    strings : StringArrays
        The B rod strings.
    nu : array_like, shape (B,) or scalar
        Gibbs' dimensionless damping factor (0: undamped).
    harmonics : int, optional
        Highest harmonic kept (default: all, ``N // 2``); fewer smooth the result as
        vendors do.

    Returns
    -------
    position, load : ndarray, shape (B, T, N)
        At the bottom of each taper (the last real taper's is the pump's; padding tapers
        repeat it), at the card's sample times; position in m, dynamic tension in N.
    """
    u, f, per, damp = _batch(position, load, period, nu, strings.length.shape[0])
    n = u.shape[1]
    hmax, (cos, s_over, k_sin) = _setup(n, per, strings, damp, harmonics)
    uh, fh = _spectra(u, hmax), _spectra(f, hmax)
    tcount = strings.length.shape[1]
    pos = np.empty((u.shape[0], tcount, n))
    ten = np.empty((u.shape[0], tcount, n))
    for j in range(tcount):
        uh, fh = (cos[:, j] * uh - s_over[:, j] * fh, k_sin[:, j] * uh + cos[:, j] * fh)
        pos[:, j] = np.fft.irfft(uh, n=n, axis=-1)
        ten[:, j] = np.fft.irfft(fh, n=n, axis=-1)
    return pos, ten


def string_transfer(n: int, period: ArrayLike, strings: StringArrays,
                    nu: ArrayLike) -> tuple[CArray, CArray, CArray, CArray]:
    """The whole string's transfer matrix per card and harmonic, ``(m11, m12, m21, m22)``.

    ``[U, F]`` at the pump is ``[[m11, m12], [m21, m22]] @ [U, F]`` at the polished rod for
    each harmonic ``0 .. n // 2`` of a card of ``n`` samples; each array has shape
    ``(B, n // 2 + 1)``. A model fitted to surface cards (damping, pump parameters) can
    build its predictions, and their sensitivities, on these.
    """
    count = strings.length.shape[0]
    per = np.broadcast_to(np.asarray(period, dtype=float), (count,)).copy()
    damp = np.broadcast_to(np.asarray(nu, dtype=float), (count,)).copy()
    _hmax, (cos, s_over, k_sin) = _setup(n, per, strings, damp, None)
    shape = (count, n // 2 + 1)
    m11, m21 = np.ones(shape, dtype=complex), np.zeros(shape, dtype=complex)
    m12, m22 = np.zeros(shape, dtype=complex), np.ones(shape, dtype=complex)
    # Columns of the matrix: the bottom state for a unit surface displacement and for a
    # unit surface force, carried through every taper.
    for j in range(strings.length.shape[1]):
        m11, m21 = cos[:, j] * m11 - s_over[:, j] * m21, k_sin[:, j] * m11 + cos[:, j] * m21
        m12, m22 = cos[:, j] * m12 - s_over[:, j] * m22, k_sin[:, j] * m12 + cos[:, j] * m22
    return m11, m12, m21, m22


def fourier_predict(position: ArrayLike, pump_load: ArrayLike, period: ArrayLike,
                    strings: StringArrays, nu: ArrayLike,
                    harmonics: int | None = None) -> tuple[Array, Array]:
    """Surface load from the surface position and a pump load given in time (mixed problem).

    Parameters
    ----------
    position : array_like, shape (B, N)
        Polished-rod position, m, uniform samples over one period.
    pump_load : array_like, shape (B, N)
        Dynamic (effective) pump load at the same times, N.
    period, strings, nu, harmonics
        As for :func:`fourier_diagnostic`.

    Returns
    -------
    surface_load, pump_position : ndarray, shape (B, N)
        Dynamic polished-rod load (N; add the buoyant weight for the measured load) and the
        plunger position (m).

    Notes
    -----
    Exact for band-limited data. Undamped, a harmonic at a natural frequency of the
    string with a fixed top and free bottom has no solution (the string resonates); a tiny
    damping regularises it.
    """
    u, p, per, damp = _batch(position, pump_load, period, nu, strings.length.shape[0])
    n = u.shape[1]
    hmax = harmonic_count(n, harmonics)
    uh, ph = _spectra(u, hmax), _spectra(p, hmax)
    m11, m12, m21, m22 = string_transfer(n, per, strings, damp)
    live = np.zeros(uh.shape, dtype=bool)
    live[:, : hmax + 1] = True
    safe = np.where(live & (np.abs(m22) > 0), m22, 1.0)
    fh = np.where(live, (ph - m21 * uh) / safe, 0.0)
    ubottom = m11 * uh + m12 * fh
    return np.fft.irfft(fh, n=n, axis=-1), np.fft.irfft(ubottom, n=n, axis=-1)
