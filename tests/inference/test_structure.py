"""The band test: structure left in a periodic residual's first harmonics."""

from __future__ import annotations

import math

import numpy as np

from pumpid.inference.structure import BAND_HARMONICS, low_band_excess


def test_white_noise_carries_no_excess_in_the_band() -> None:
    rng = np.random.default_rng(3)
    ratio, p = low_band_excess(rng.standard_normal(240))
    assert 0.5 < ratio < 1.6
    assert p > 0.01


def test_the_p_value_is_calibrated_on_white_noise() -> None:
    # The band's and the floor's periodogram ordinates are independent chi-squares on white
    # noise, so p is uniform: 5 % of records fall below 0.05.
    rng = np.random.default_rng(11)
    p = np.array([low_band_excess(rng.standard_normal(200))[1] for _ in range(2000)])
    assert 0.04 < np.mean(p < 0.05) < 0.06
    assert 0.006 < np.mean(p < 0.01) < 0.015


def test_a_response_left_in_the_band_is_seen_however_small_against_the_noise() -> None:
    # A third-harmonic wave whose RMS is half the noise's: the RMSE grows by 12 % only, the
    # band's power per harmonic 2.5-fold.
    rng = np.random.default_rng(5)
    n = 300
    phase = np.arange(n) / n
    residual = rng.standard_normal(n) + 0.5 * math.sqrt(2) * np.sin(2 * np.pi * 3 * phase)
    ratio, p = low_band_excess(residual)
    assert 2.0 < ratio < 3.5
    assert p < 1e-6


def test_the_band_is_cut_so_the_floor_keeps_most_harmonics() -> None:
    # 60 samples: 29 harmonics below the Nyquist frequency, a band of 7 (not 24).
    rng = np.random.default_rng(2)
    n = 60
    phase = np.arange(n) / n
    residual = 0.1 * rng.standard_normal(n) + np.sin(2 * np.pi * 8 * phase)
    assert low_band_excess(residual)[0] < 1.0  # harmonic 8 lies above the band
    assert low_band_excess(residual, harmonics=BAND_HARMONICS)[0] == low_band_excess(
        residual, harmonics=7)[0]


def test_no_test_without_a_floor_to_compare_with() -> None:
    assert all(math.isnan(v) for v in low_band_excess(np.ones(20)))  # too short
    assert all(math.isnan(v) for v in low_band_excess(np.zeros(200)))  # nothing above
    bad = np.ones(200)
    bad[3] = math.nan
    assert all(math.isnan(v) for v in low_band_excess(bad))
