"""The finite-difference diagnostic: march the damped wave equation down the string in depth.

In the manner of Everitt and Jennings (SPE 18189, 1992): the surface position and load are
the two boundary data at ``x = 0``; central differences in time (periodic) and in depth
turn ``a^2 u_xx = u_tt + c u_t`` into a recurrence that gives the displacement one depth
step down from the two above it,

    u[i+1] = 2 u[i] - u[i-1] + dx^2 / a^2 (D2 u[i] + c D1 u[i]),

started from the surface with the load (``u_x = -F / EA``) and carried through each joint
with the displacement and the tension (a ghost node below the joint gives the tension by a
central difference). The scheme is second order in ``dt`` and ``dx`` and stable for
``dx <= a dt``; with ``dx = a dt`` and no damping it is exact on its grid.

The card's samples are refined in time by trigonometric interpolation (the band-limited
periodic function through them, the same reading of the card as the Fourier method's, so
that the two methods differ only in how they solve the wave equation) until the time
differences resolve the card's harmonics.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .fourier import StringArrays, trig_refine

__all__ = ["DEFAULT_REFINE", "fd_diagnostic"]

Array = NDArray[np.float64]

#: Default refinement: the time grid has at least this many steps per stroke.
DEFAULT_REFINE = 2048


def _time_operator(u: Array, dt: float, c: float) -> Array:
    """u_tt + c u_t by periodic central differences (last axis)."""
    ahead, behind = np.roll(u, -1, axis=-1), np.roll(u, 1, axis=-1)
    return (ahead - 2.0 * u + behind) / dt**2 + c * (ahead - behind) / (2.0 * dt)


def _march(u0: Array, f0: Array, length: float, ea: float, a: float, dt: float, c: float,
           courant: float) -> tuple[Array, Array]:
    """Displacement and tension at the bottom of one taper from those at its top."""
    steps = max(1, math.ceil(length / (courant * a * dt)))
    dx = length / steps
    r = dx**2 / a**2
    prev = u0
    cur = u0 - dx * f0 / ea + 0.5 * r * _time_operator(u0, dt, c)
    for _ in range(steps):
        prev, cur = cur, 2.0 * cur - prev + r * _time_operator(cur, dt, c)
    # Now ``prev`` is the bottom node and ``cur`` the ghost node below it.
    below = cur
    above = 2.0 * prev - below + r * _time_operator(prev, dt, c)
    return prev, -ea * (below - above) / (2.0 * dx)


def fd_diagnostic(position: ArrayLike, load: ArrayLike, period: ArrayLike,
                  strings: StringArrays, nu: ArrayLike, refine: int | None = None,
                  courant: float = 1.0) -> tuple[Array, Array]:
    """Position and dynamic load at the bottom of every taper, by finite differences.

    Parameters
    ----------
    position, load, period, strings, nu
        As for :func:`pumpid.rods.fourier.fourier_diagnostic`.
    refine : int, optional
        Time refinement factor (default: the smallest giving at least
        :data:`DEFAULT_REFINE` steps per stroke).
    courant : float
        Depth step as a fraction of ``a dt`` (at most 1, the stability limit).

    Returns
    -------
    position, load : ndarray, shape (B, T, N)
        As for :func:`pumpid.rods.fourier.fourier_diagnostic`.
    """
    u = np.atleast_2d(np.asarray(position, dtype=float))
    f = np.atleast_2d(np.asarray(load, dtype=float))
    b, n = u.shape
    per = np.broadcast_to(np.asarray(period, dtype=float), (b,))
    damp = np.broadcast_to(np.asarray(nu, dtype=float), (b,))
    if not 0 < courant <= 1:
        raise ValueError(f"courant must be in (0, 1], got {courant}")
    factor = max(1, math.ceil(DEFAULT_REFINE / n)) if refine is None else int(refine)
    if factor < 1:
        raise ValueError(f"refine must be at least 1, got {refine}")
    ufine, ffine = trig_refine(u, factor), trig_refine(f, factor)
    c_all = np.pi * damp / (2.0 * strings.travel_time)
    tcount = strings.length.shape[1]
    pos = np.empty((b, tcount, n))
    ten = np.empty((b, tcount, n))
    for i in range(b):
        dt = per[i] / (n * factor)
        ui, fi = ufine[i], ffine[i]
        for j in range(tcount):
            if strings.length[i, j] > 0:
                ui, fi = _march(ui, fi, float(strings.length[i, j]),
                                float(strings.stiffness[i, j]), float(strings.wave_speed[i, j]),
                                dt, float(c_all[i]), courant)
            pos[i, j], ten[i, j] = ui[::factor], fi[::factor]
    return pos, ten
