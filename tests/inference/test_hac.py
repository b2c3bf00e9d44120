"""The long-run covariance estimate behind the autocorrelation-robust (HAC) errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from pumpid.inference.hac import PREWHITEN_CAP, long_run_covariance


def _bartlett_by_lags(u: np.ndarray, m: int) -> np.ndarray:
    """The textbook sum over lags, sum_{|l| < m} (1 - |l|/m) Gamma_l, for comparison."""
    n = u.shape[0]
    out = u.T @ u
    for lag in range(1, m):
        gamma = u[lag:].T @ u[: n - lag]
        out += (1.0 - lag / m) * (gamma + gamma.T)
    return out


def _ar1(rng: np.random.Generator, rho: float, n: int, q: int = 1) -> np.ndarray:
    shocks = rng.standard_normal((n + 300, q))
    return scipy.signal.lfilter([1.0], [1.0, -rho], shocks, axis=0)[300:]


@pytest.mark.parametrize("m", [1, 2, 7, 40])
def test_window_sums_equal_the_weighted_sum_over_lags(m) -> None:
    rng = np.random.default_rng(3)
    u = rng.standard_normal((120, 3)) * np.array([1.0, 30.0, 0.01])
    omega, info = long_run_covariance(u, prewhiten=False, bandwidth=m)
    assert info["bandwidth"] == m and info["prewhitening"] == 0.0
    np.testing.assert_allclose(omega, _bartlett_by_lags(u, m), rtol=1e-12,
                               atol=1e-12 * np.abs(omega).max())


def test_one_dimensional_series_and_bandwidth_one_is_the_sum_of_squares() -> None:
    u = np.random.default_rng(4).standard_normal(50)
    omega, _ = long_run_covariance(u, prewhiten=False, bandwidth=1)
    assert omega.shape == (1, 1)
    assert omega[0, 0] == pytest.approx(float(u @ u), rel=1e-13)


def test_estimate_is_scale_equivariant_and_positive_semidefinite() -> None:
    rng = np.random.default_rng(5)
    u = _ar1(rng, 0.6, 400, q=3) + 0.3 * rng.standard_normal((400, 3))
    scale = np.array([1e-4, 1.0, 1e5])
    base, info = long_run_covariance(u)
    scaled, info_scaled = long_run_covariance(u * scale)
    np.testing.assert_allclose(scaled, base * np.outer(scale, scale), rtol=1e-9)
    assert info_scaled["bandwidth"] == info["bandwidth"]
    assert np.linalg.eigvalsh(base).min() >= -1e-12 * np.abs(base).max()


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8])
def test_ar1_long_run_variance_is_recovered(rho) -> None:
    # For x_t = rho x_{t-1} + e_t (unit shocks) the long-run variance of the sum is
    # n / (1 - rho)^2: 1, 4 and 25 per sample.
    rng = np.random.default_rng(6)
    n = 800
    ratios = []
    for _ in range(60):
        x = _ar1(rng, rho, n)
        x -= x.mean()
        omega, _ = long_run_covariance(x)
        ratios.append(omega[0, 0] / n * (1.0 - rho) ** 2)
    assert np.mean(ratios) == pytest.approx(1.0, abs=0.1)


def test_without_prewhitening_the_bandwidth_grows_with_the_persistence() -> None:
    # Andrews' rule for AR(1) data: 1.1447 (alpha n)^(1/3) with alpha = 4 rho^2 (1 - rho)^-2
    # (1 + rho)^-2: about 14 samples for rho = 0.5 and 51 for rho = 0.9 at n = 1000, and
    # 1-3 for white noise, up to sampling error in rho.
    rng = np.random.default_rng(7)
    widths = [long_run_covariance(_ar1(rng, rho, 1000), prewhiten=False)[1]["bandwidth"]
              for rho in (0.0, 0.5, 0.9)]
    assert widths[0] <= 4
    assert 9 <= widths[1] <= 20
    assert 35 <= widths[2] <= 75


def test_lopsided_var1_is_recoloured_the_right_way_round() -> None:
    # u_t = A u_{t-1} + e_t with a far-from-symmetric A: the long-run covariance per sample
    # is (I - A)^-1 (I - A)^-T for unit shocks; transposing A anywhere gives a different one.
    a = np.array([[0.5, 0.4], [0.0, 0.2]])
    rng = np.random.default_rng(10)
    n = 40000
    shocks = rng.standard_normal((n + 200, 2))
    u = np.zeros_like(shocks)
    for k in range(1, u.shape[0]):
        u[k] = a @ u[k - 1] + shocks[k]
    u = u[200:]
    inv = np.linalg.inv(np.eye(2) - a)
    truth = inv @ inv.T
    wrong = np.linalg.inv(np.eye(2) - a.T) @ np.linalg.inv(np.eye(2) - a.T).T
    assert np.max(np.abs(wrong - truth) / truth) > 0.6  # 64 % apart in the (2, 2) entry
    omega, info = long_run_covariance(u)
    np.testing.assert_allclose(omega / n, truth, rtol=0.1)
    assert info["prewhitening"] > 0.5 and not info["capped"]


def test_huge_and_tiny_magnitudes_do_not_overflow() -> None:
    u = _ar1(np.random.default_rng(11), 0.5, 300, q=2)
    base, _ = long_run_covariance(u)
    for scale in (1e-150, 1e150):
        omega, _ = long_run_covariance(u * scale)
        assert np.all(np.isfinite(omega)) and np.all(omega != 0)
        np.testing.assert_allclose(omega / scale**2, base, rtol=1e-9)


def test_near_unit_root_is_capped_and_stays_finite() -> None:
    walk = np.cumsum(np.random.default_rng(8).standard_normal((500, 2)), axis=0)
    omega, info = long_run_covariance(walk - walk.mean(axis=0))
    assert info["capped"] and info["prewhitening"] == pytest.approx(PREWHITEN_CAP)
    assert np.all(np.isfinite(omega))


def test_zero_and_collinear_columns() -> None:
    rng = np.random.default_rng(9)
    u = rng.standard_normal((200, 1))
    omega, _ = long_run_covariance(np.hstack([u, 2.0 * u, np.zeros((200, 1))]))
    assert np.all(np.isfinite(omega))
    assert omega[2, 2] == 0.0
    assert omega[1, 1] == pytest.approx(4.0 * omega[0, 0], rel=1e-9)


@pytest.mark.parametrize(
    ("scores", "kwargs", "message"),
    [
        (np.ones(2), {}, "N >= 3"),
        (np.ones((4, 2, 2)), {}, "N >= 3"),
        (np.array([1.0, np.nan, 2.0, 3.0]), {}, "finite"),
        (np.ones(10), {"bandwidth": 0}, "whole number"),
        (np.ones(10), {"bandwidth": 2.7}, "whole number"),
    ],
)
def test_bad_input_is_refused(scores, kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        long_run_covariance(scores, **kwargs)


def _circular_bartlett(u: np.ndarray, m: int) -> np.ndarray:
    """The sum over lags taken around the period: lag l pairs u_t with u_(t+l mod n)."""
    out = u.T @ u
    for lag in range(1, m):
        gamma = np.roll(u, -lag, axis=0).T @ u
        out += (1.0 - lag / m) * (gamma + gamma.T)
    return out


@pytest.mark.parametrize("m", [1, 3, 12])
def test_around_a_period_the_lags_wrap_and_the_start_does_not_matter(m) -> None:
    rng = np.random.default_rng(21)
    u = _ar1(rng, 0.7, 40, q=2) * np.array([1.0, 50.0])
    omega, info = long_run_covariance(u, prewhiten=False, bandwidth=m, circular=True)
    assert info["bandwidth"] == m
    np.testing.assert_allclose(omega, _circular_bartlett(u, m), rtol=1e-12,
                               atol=1e-12 * np.abs(omega).max())
    # With Andrews' bandwidth and the VAR(1) prewhitening too: every rotation of one period
    # gives the same estimate; a series with two ends does not.
    full, _ = long_run_covariance(u, circular=True)
    ends, _ = long_run_covariance(u)
    for shift in (1, 17, 33):
        rotated = np.roll(u, shift, axis=0)
        np.testing.assert_allclose(long_run_covariance(rotated, circular=True)[0], full,
                                   rtol=1e-10)
        assert not np.allclose(long_run_covariance(rotated)[0], ends, rtol=1e-3)


def test_around_a_period_no_window_is_longer_than_half_of_it() -> None:
    # A window longer than half the period meets itself from the other side: the estimate
    # fell by (n - m) / m, to 0 at m = n. The bandwidth is cut to n / 2.
    u = _ar1(np.random.default_rng(22), 0.9, 40, q=1)
    u -= u.mean()
    omega, info = long_run_covariance(u, prewhiten=False, bandwidth=40, circular=True)
    assert info["bandwidth"] == 20
    np.testing.assert_allclose(omega, _circular_bartlett(u, 20), rtol=1e-12)
    assert omega[0, 0] > 0
