"""Profile likelihood (pumpid.profile): two-sided and one-sided (boundary) intervals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.figure import Figure

import pumpid
from pumpid import FitOptions, Kelvin, MassSpringDamper, fit, simulate
from pumpid.profile import Profile, profile

from .conftest import well_load

T = np.linspace(0.0, 12.0, 801)
LOAD = well_load(T)
KELVIN = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)


def _noisy(model, seed):
    data = simulate(model, T, LOAD)
    rng = np.random.default_rng(seed)
    return data + 0.01 * np.ptp(data) * rng.standard_normal(data.size)


@pytest.fixture(scope="module")
def kelvin_fit():
    res = fit(KELVIN, (T, LOAD, _noisy(KELVIN, 0)), options=FitOptions(offset=True))
    return res


def test_profile_interval_agrees_with_wald_on_a_well_determined_fit(kelvin_fit) -> None:
    prof = profile(kelvin_fit, "m", n_points=9)
    assert isinstance(prof, Profile)
    assert not prof.one_sided and prof.lower is not None and prof.upper is not None
    assert prof.lower < kelvin_fit.params["m"] < prof.upper
    low, high = kelvin_fit.ci95["m"]
    # Nearly linear problem: likelihood-ratio and Wald intervals agree closely.
    assert prof.lower == pytest.approx(low, rel=0.01)
    assert prof.upper == pytest.approx(high, rel=0.01)
    assert np.all(np.diff(prof.values) > 0) and prof.values.size >= 9
    assert np.nanmin(prof.deviance) >= -1e-6
    assert prof.threshold > prof.cost_min
    d = prof.to_dict()
    assert d["one_sided"] is False and len(d["values"]) == len(d["cost"])


def test_profile_of_the_offset(kelvin_fit) -> None:
    prof = profile(kelvin_fit, "offset", n_points=7)
    assert not prof.positive
    low, high = kelvin_fit.ci95["offset"]
    assert prof.lower == pytest.approx(low, abs=0.05 * (high - low))
    assert prof.upper == pytest.approx(high, abs=0.05 * (high - low))


def test_plot_is_a_figure_with_units(kelvin_fit) -> None:
    prof = profile(kelvin_fit, "k0", n_points=5, span=1.2)
    fig = prof.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "k0 [N/m]"
    assert "sigma^2" in ax.get_ylabel()
    assert "interval" in ax.get_title()


def test_boundary_parameter_gets_a_one_sided_interval() -> None:
    # Mass-spring-dashpot data: the Kelvin series spring k0 is not bounded above.
    msd = MassSpringDamper(m=2.0, c=60.0, k=90.0)
    res = fit(Kelvin(k0=500.0, m=2.0, c1=60.0, k1=90.0), (T, LOAD, _noisy(msd, 1)))
    assert res.status == "boundary"
    prof = profile(res, "k0", n_points=7)
    assert prof.upper is None and prof.lower is not None
    assert prof.one_sided and prof.interval[1] == math.inf
    assert 0 < prof.lower < res.params["k0"]
    assert any("no upper bound" in n and "infinity" in n for n in prof.notes)


def test_profile_says_when_the_residuals_are_not_white(kelvin_fit) -> None:
    assert not any("not white" in n for n in profile(kelvin_fit, "c1", n_points=5).notes)
    # Slow model error on top of the noise: the profile interval inherits the white-noise
    # assumption, and says so.
    data = _noisy(KELVIN, 2) + 0.02 * np.ptp(simulate(KELVIN, T, LOAD)) * np.sin(0.7 * T)
    res = fit(KELVIN, (T, LOAD, data))
    assert not res.extra["uncertainty"]["whiteness"]["white"]
    prof = profile(res, "c1", n_points=5)
    note = next(n for n in prof.notes if "not white" in n)
    assert "too narrow" in note and "ci95_hac" in note


def test_profile_is_the_packages_profile_of_and_not_a_result_method(kelvin_fit) -> None:
    # The profile runs the job, which stands above the result: the result cannot call it.
    assert pumpid.profile_of is profile
    assert not hasattr(kelvin_fit, "profile")


def test_profile_rejects_unknown_names(kelvin_fit) -> None:
    with pytest.raises(ValueError, match="not a fitted value"):
        profile(kelvin_fit, "tau")
    with pytest.raises(ValueError, match="level"):
        profile(kelvin_fit, "m", level=1.5)


def test_the_interval_ends_lie_on_the_threshold(kelvin_fit) -> None:
    # A straight line across a coarse grid put an end where the profile had not reached
    # the threshold (a real card's c1: 56.86 for about 55.9); each end is now refined by
    # refits, so a refit held there costs the threshold.
    prof = profile(kelvin_fit, "c1", n_points=5, span=1.5)
    assert prof.lower is not None and prof.upper is not None
    rise = prof.threshold - prof.cost_min
    for end in (prof.lower, prof.upper):
        held = fit(KELVIN, (T, LOAD, kelvin_fit.data),
                   options=FitOptions(offset=True, fixed={"c1": end}),
                   x0=dict(kelvin_fit.params))
        assert held.cost == pytest.approx(prof.threshold, abs=2e-3 * rise)
