"""Seeded statistical checks (reduced counts; the 200-count versions are benchmarks/stat_*.py).

* basin: from starts log-uniform within x10 of the truth the default fit reaches the global
  minimum (the automatic start joins the user's guess in a small multistart);
* no guess: the automatic start alone recovers random well-like parameter sets;
* coverage: the 95 % intervals contain the truth about 95 % of the time under 1 % white noise,
  and the autocorrelation-robust ones under AR(1) noise, where the white ones fail.

The well-like generator lives here so that the benchmark scripts share it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from pumpid import FitOptions, Kelvin, Maxwell, Model, fit, simulate, simulate_sensitivities

from .conftest import well_load

#: Below this relative smallest singular value of the log-scaled Jacobian at the truth, a
#: noiseless recovery to 1e-6 is beyond double precision: it would need residual changes of
#: 1e-6 times that value, i.e. below 1e-14 of the response (round-off). Such sets are reported
#: separately by the benchmark, never silently dropped (none occurred in the seeds used).
ILL_CONDITIONED = 1e-8


@dataclass
class Case:
    """One synthetic card: truth, record and the fit options a real card would use."""

    truth: Model
    t: np.ndarray
    load: np.ndarray
    data: np.ndarray
    options: FitOptions


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return math.exp(rng.uniform(math.log(low), math.log(high)))


def well_like_case(rng: np.random.Generator, model_cls: type[Model], mode: str) -> Case:
    """Random, physically plausible Kelvin/Maxwell parameters and a card-like record (lbf, in).

    Stroke period 6-10 s; static stiffness 20-300 lbf/in (strokes of tens of inches under
    loads of thousands of lbf); natural frequency 1-8 x the stroke frequency; damping ratio
    0.05-1; k0/k1 between 0.3 and 30; all log-uniform. ``mode="periodic"``: one stroke of
    400-1000 samples in its periodic steady state with a position offset (as real cards are
    fitted); ``"rest"``: three strokes from rest, 600-2000 samples.
    """
    period = _log_uniform(rng, 6.0, 10.0)
    w_stroke = 2 * math.pi / period
    k_static = _log_uniform(rng, 20.0, 300.0)
    wn = _log_uniform(rng, 1.0, 8.0) * w_stroke
    zeta = _log_uniform(rng, 0.05, 1.0)
    ratio = _log_uniform(rng, 0.3, 30.0)  # k0 / k1
    m = k_static / wn**2
    if model_cls is Kelvin:
        k1 = k_static * (1 + ratio) / ratio  # springs in series give k_static
        k0 = ratio * k1
        c1 = 2 * zeta * math.sqrt(k1 * m)
    else:
        k0 = k_static
        k1 = k0 / ratio
        c1 = 2 * zeta * math.sqrt(k0 * m)
    truth = model_cls(k0=k0, m=m, c1=c1, k1=k1)
    seed = int(rng.integers(2**31))
    if mode == "periodic":
        n = int(rng.integers(400, 1001))
        t = np.arange(n) * period / n
        load = well_load(t, period=period, seed=seed)
        offset = rng.uniform(-50.0, 50.0)
        data = simulate(truth, t, load, initial_state="periodic", period=period) + offset
        options = FitOptions(initial_state="periodic", period=period, offset=True)
    elif mode == "rest":
        n = int(rng.integers(600, 2001))
        t = np.linspace(0.0, 3 * period, n)
        load = well_load(t, period=period, seed=seed)
        data = simulate(truth, t, load)
        options = FitOptions()
    else:
        raise ValueError(mode)
    return Case(truth, t, load, data, options)


def conditioning(case: Case) -> float:
    """Relative smallest singular value of the log-scaled Jacobian at the truth."""
    opts = case.options
    _y, dy = simulate_sensitivities(case.truth, case.t, case.load,
                                    initial_state=opts.initial_state or "rest",
                                    period=opts.period)
    cols = [dy * case.truth.values]
    if opts.offset:
        cols.append(np.full((dy.shape[0], 1), float(np.ptp(case.data))))
    s = np.linalg.svd(np.column_stack(cols), compute_uv=False)
    return float(s[-1] / s[0])


def max_rel_error(params: dict[str, float], truth: Model) -> float:
    """Largest relative error of the fitted parameters."""
    return max(abs(params[k] / v - 1.0) for k, v in truth.as_dict().items())


def guarded_fit(guess: Model, t, load, data, options: FitOptions | None = None) -> Any:
    """The default fit from a user's guess: ``fit(guess, ...)`` with ``multistart="auto"``.

    lm runs from the guess first; a failed, boundary or poor (R^2 < 0.99) result is retried
    with the automatic start's multistart, which the guess joins.
    """
    return fit(guess, (t, load, data), options=options)


# --------------------------------------------------------------------------- tests
BASIN_T = np.linspace(0.0, 20.0, 1001)
BASIN_LOAD = well_load(BASIN_T)


@pytest.mark.slow
@pytest.mark.parametrize("truth", [Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0),
                                   Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0)],
                         ids=lambda m: type(m).__name__)
def test_basin_default_reaches_global_minimum_from_within_x10(truth) -> None:
    data = simulate(truth, BASIN_T, BASIN_LOAD)
    rng = np.random.default_rng(11)
    n = 20
    starts = truth.values * np.exp(rng.uniform(-math.log(10), math.log(10), (n, 4)))
    hits = 0
    for s in starts:
        res = guarded_fit(type(truth).from_values(s), BASIN_T, BASIN_LOAD, data)
        hits += max_rel_error(res.params, truth) < 1e-6
    assert hits == n  # full run (200 starts, benchmarks/stat_basin.py): 100 %


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["periodic", "rest"])
@pytest.mark.parametrize("model_cls", [Kelvin, Maxwell], ids=lambda c: c.__name__)
def test_no_guess_recovers_well_like_sets(model_cls, mode) -> None:
    rng = np.random.default_rng({"periodic": 21, "rest": 22}[mode] + (model_cls is Maxwell))
    for _ in range(8):
        case = well_like_case(rng, model_cls, mode)
        assert conditioning(case) > ILL_CONDITIONED
        res = fit(model_cls, (case.t, case.load, case.data), options=case.options)
        assert max_rel_error(res.params, case.truth) < 1e-6, (case.truth, res.params)


@pytest.mark.slow
def test_coverage_of_95_percent_intervals() -> None:
    truth = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)
    t = np.linspace(0.0, 20.0, 801)
    load = well_load(t)
    clean = simulate(truth, t, load)
    rng = np.random.default_rng(31)
    n = 40
    inside = dict.fromkeys(truth.param_names(), 0)
    for _ in range(n):
        data = clean + 0.01 * np.ptp(clean) * rng.standard_normal(t.size)
        res = fit(truth, (t, load, data))
        for name, value in truth.as_dict().items():
            low, high = res.ci95[name]
            inside[name] += low <= value <= high
    # Binomial band: P(X <= 32 | n = 40, p = 0.95) = 0.07 %; the 200-replicate run is
    # benchmarks/stat_coverage.py.
    for name, hits in inside.items():
        assert 33 <= hits <= n, (name, hits)


@pytest.mark.slow
def test_robust_intervals_hold_under_autocorrelated_noise() -> None:
    truth = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)
    t = np.linspace(0.0, 20.0, 801)
    load = well_load(t)
    clean = simulate(truth, t, load)
    rng = np.random.default_rng(32)
    rho, n = 0.8, 40
    inside = {"ci95_white": dict.fromkeys(truth.param_names(), 0),
              "ci95": dict.fromkeys(truth.param_names(), 0)}
    for _ in range(n):
        shocks = rng.standard_normal(t.size)
        shocks[0] /= math.sqrt(1.0 - rho**2)
        noise = np.empty_like(shocks)
        noise[0] = shocks[0]
        for k in range(1, t.size):
            noise[k] = rho * noise[k - 1] + shocks[k]
        data = clean + 0.01 * np.ptp(clean) * math.sqrt(1.0 - rho**2) * noise
        res = fit(truth, (t, load, data))
        for kind, hits in inside.items():
            for name, value in truth.as_dict().items():
                low, high = res.extra[kind][name]
                hits[name] += low <= value <= high
    # The white-noise intervals (ci95_white) are about 3 times too narrow here and cover
    # about half the time (benchmarks/stat_coverage.py, 200 replicates: 43.5-52.0 %, so
    # P(X >= 31 | n = 40, p = 0.6) = 1.6 % is generous); the intervals shown by default
    # (ci95: the robust ones, since the residuals are serially correlated) cover 93-98 % at
    # rho 0.8, and P(X <= 31 | n = 40, p = 0.88) = 4.4 %.
    for name in truth.param_names():
        assert inside["ci95_white"][name] <= 30, (name, inside)
        assert inside["ci95"][name] >= 32, (name, inside)
