"""Pumping-unit kinematics: the polished rod's path under a crank-rocker beam unit."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

__all__ = ["CrankRocker", "polished_rod_position"]


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
