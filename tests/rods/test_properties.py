"""Properties over random strings and cards: the predictive and diagnostic solutions invert
each other, and the two diagnostic methods agree."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pumpid.rods import (
    MATERIALS,
    Fluid,
    Pump,
    StringArrays,
    Taper,
    Well,
    fd_diagnostic,
    fourier_diagnostic,
    fourier_predict,
)


@st.composite
def cases(draw):
    tapers = draw(st.integers(1, 4))
    lengths = [draw(st.floats(100.0, 900.0)) for _ in range(tapers)]
    diameters = sorted((draw(st.floats(0.012, 0.032)) for _ in range(tapers)), reverse=True)
    kinds = [draw(st.sampled_from(sorted(MATERIALS))) for _ in range(tapers)]
    well = Well("p", tuple(Taper(length, d, *MATERIALS[k])
                           for length, d, k in zip(lengths, diameters, kinds, strict=True)),
                Pump(sum(lengths), 0.044), fluid=Fluid(1000.0))
    n = draw(st.sampled_from([64, 100, 128]))
    period = draw(st.floats(4.0, 15.0))
    nu = draw(st.floats(0.01, 0.5))
    seed = draw(st.integers(0, 2**31 - 1))
    return well, n, period, nu, seed


def band_limited(rng: np.random.Generator, n: int, harmonics: int, scale: float) -> np.ndarray:
    phase = 2 * np.pi * np.arange(n) / n
    out = np.zeros(n)
    for h in range(1, harmonics + 1):
        out += scale / h**2 * (rng.normal() * np.cos(h * phase) + rng.normal() * np.sin(h * phase))
    return out


@settings(max_examples=15, deadline=None)
@given(cases())
def test_predict_then_diagnose_is_the_identity(case) -> None:
    well, n, period, nu, seed = case
    rng = np.random.default_rng(seed)
    strings = StringArrays.of([well])
    position = band_limited(rng, n, 8, 1.0)
    pump = 10000 + band_limited(rng, n, 8, 3000.0)
    surface, plunger = fourier_predict(position, pump, period, strings, nu)
    pos, ten = fourier_diagnostic(position, surface, period, strings, nu)
    assert np.max(np.abs(ten[0, -1] - pump)) < 1e-7 * np.ptp(pump)
    assert np.max(np.abs(pos[0, -1] - plunger[0])) < 1e-9 * max(np.ptp(plunger), 1.0)


@settings(max_examples=8, deadline=None)
@given(cases())
def test_fourier_and_finite_differences_agree(case) -> None:
    well, n, period, nu, seed = case
    rng = np.random.default_rng(seed)
    strings = StringArrays.of([well])
    position = band_limited(rng, n, 6, 1.0)
    load = 20000 + band_limited(rng, n, 6, 4000.0)
    _p, four = fourier_diagnostic(position, load, period, strings, nu)
    _q, fd = fd_diagnostic(position, load, period, strings, nu)
    span = np.ptp(four[0, -1])
    assert np.max(np.abs(four[0, -1] - fd[0, -1])) < 1e-3 * span
