"""Shared fixtures: realistic loads and the location of the third-party cards."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SHARED_RAW = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "raw"

#: Figures that tests on real data report (printed in the terminal summary, even with -q).
REPORTED: list[str] = []


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    """Print what the real-data tests measured, so the figures are in every CI log."""
    if REPORTED:
        terminalreporter.section("figures measured on real cards")
        for line in REPORTED:
            terminalreporter.write_line(line)


def well_load(t: np.ndarray, period: float = 7.5, seed: int = 0) -> np.ndarray:
    """A varying, card-like load: rod weight, fluid load picked up and released, ripple."""
    rng = np.random.default_rng(seed)
    phase = (t / period) % 1.0
    pickup = 0.5 * (1 + np.tanh((phase - 0.08) / 0.04))
    release = 0.5 * (1 + np.tanh((phase - 0.55) / 0.05))
    ripple = (300 + 100 * rng.random()) * np.sin(2 * np.pi * 3 * phase + rng.random())
    return 6000.0 + 5000.0 * pickup * (1 - release) + ripple + 300 * np.sin(2 * np.pi * phase)


def stroke_problem(seed: int, n: int = 120, period: float = 6.0):
    """A solver problem (one periodic Kelvin stroke, noiseless, fitted offset): for tests of
    the engine's compiled entry points."""
    import pumpid
    from pumpid.engine.problem import CardData, build_problem

    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=seed)
    data = pumpid.simulate(pumpid.Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0), t, load,
                           initial_state="periodic", period=period)
    return build_problem(pumpid.Kelvin, [CardData(t, load, data, "periodic", period)],
                         offset=True)


def pinned_periodic_fit():
    """The verbs' pinned periodic card (Kelvin k0 = 4, m = 1, c1 = 0.2, k1 = 4; 120 samples
    of a 6 s period, an offset of 12 m, 1 % noise) fitted with its options."""
    import pumpid

    truth = pumpid.Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0)
    period = 6.0
    t = np.arange(120) * period / 120
    w = 2 * np.pi / period
    load = (1000 + 400 * np.sin(w * t) + 120 * np.sin(2 * w * t + 0.4)) / 300
    d = pumpid.simulate(truth, t, load, observe="u", initial_state="periodic",
                        period=period) + 12.0
    d = d + 0.01 * np.ptp(d) * np.random.default_rng(4).standard_normal(t.size)
    return pumpid.fit("kelvin", (t, load, d),
                      options=pumpid.FitOptions(observe="u", offset=True,
                                                initial_state="periodic", period=period))


def spread_card(index: int):
    """Card ``index`` of the best-optimum benchmark's synthetic family: periodic Kelvin
    cards spread log-uniformly over x100 around field-like values (seed 5; 1 % white noise
    on the position, an offset). The earlier cards' draws are replayed, not simulated.
    Returns the card and its true parameters."""
    import pumpid
    from pumpid.cards import Card

    rng = np.random.default_rng(5)
    centre = np.array([5200.0, 20.0, 900.0, 5200.0])
    for i in range(index + 1):
        theta = centre * np.exp(rng.uniform(-np.log(10), np.log(10), 4))
        period = 60.0 / rng.uniform(5.0, 10.0)
        n = int(rng.integers(100, 400))
        load_seed = int(rng.integers(2**31))
        if i < index:
            rng.standard_normal(n)
            rng.uniform(0, 50)
    t = np.arange(n) * period / n
    load = well_load(t, period, seed=load_seed)
    pos = pumpid.simulate(pumpid.Kelvin.from_values(theta), t, load,
                          initial_state="periodic", period=period)
    pos = pos + 0.01 * np.ptp(pos) * rng.standard_normal(n) + rng.uniform(0, 50)
    card = Card(position=pos, load=load, t=t, card_id=f"spread-{index}", source="test",
                position_unit="in", load_unit="lbf", time_source="file", periodic=True,
                period=period)
    return card, theta


@pytest.fixture
def shared_raw() -> Path:
    """The third-party card folder; the test is skipped when it is absent."""
    if not SHARED_RAW.is_dir():
        pytest.skip("third-party cards (../shared/data/raw) are not available")
    return SHARED_RAW


@pytest.fixture(scope="session", autouse=True)
def compiled_once() -> None:
    """Compile the main job once, before any test: a command's stderr then holds only what
    the test is about, not the one-time notice that a cold cache is being compiled (which
    tests/engine/test_compiled.py checks on its own)."""
    import pumpid
    from pumpid.engine import compiled
    from pumpid.pump.synthetic import synthetic_card

    if compiled.uncached():
        card = synthetic_card(pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0), spm=8.0,
                              n_samples=60, observe="u", noise=0.002, seed=0)
        pumpid.fit(pumpid.Kelvin, card)


def ar1_series(rng: np.random.Generator, rho: float, n: int) -> np.ndarray:
    """``n`` samples of an AR(1) series of coefficient ``rho`` (after 200 discarded, to
    forget the start), scaled to unit standard deviation."""
    e = rng.standard_normal(n + 200)
    out = np.empty_like(e)
    out[0] = e[0]
    for k in range(1, e.size):
        out[k] = rho * out[k - 1] + e[k]
    out = out[200:]
    return out / out.std()
