"""Derived quantities: values from the poles and the static gain, errors by the delta method."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pumpid

from ..conftest import well_load


def test_mass_spring_damper_quantities_are_the_textbook_ones() -> None:
    m, c, k = 2.0, 0.8, 50.0
    values = dict(zip([d.name for d in pumpid.MassSpringDamper.derived_info()],
                      pumpid.MassSpringDamper.derived_values([m, c, k]), strict=True))
    assert values["natural_frequency"] == pytest.approx(math.sqrt(k / m) / (2 * math.pi))
    assert values["damping_ratio"] == pytest.approx(c / (2 * math.sqrt(k * m)))
    assert values["static_stiffness"] == pytest.approx(k)


def test_overdamped_pair_continues_through_critical_damping() -> None:
    m, k = 1.0, 4.0
    for zeta in (0.5, 0.999, 1.001, 3.0):
        c = 2 * zeta * math.sqrt(k * m)
        vals = pumpid.MassSpringDamper.derived_values([m, c, k])
        assert vals[0] == pytest.approx(math.sqrt(k / m) / (2 * math.pi), rel=1e-9)
        assert vals[1] == pytest.approx(zeta, rel=1e-9)


def test_kelvin_quantities_tend_to_the_rigid_limit() -> None:
    # k0 -> infinity: the mass-spring-dashpot m, c1, k1 (and a real pole running off).
    m, c1, k1 = 3.0, 1.5, 40.0
    names = [d.name for d in pumpid.Kelvin.derived_info()]
    vals = dict(zip(names, pumpid.Kelvin.derived_values([1e9, m, c1, k1], "u"), strict=True))
    assert vals["natural_frequency"] == pytest.approx(math.sqrt(k1 / m) / (2 * math.pi),
                                                      rel=1e-6)
    assert vals["damping_ratio"] == pytest.approx(c1 / (2 * math.sqrt(k1 * m)), rel=1e-6)
    assert vals["static_stiffness"] == pytest.approx(k1, rel=1e-6)
    assert vals["time_constant"] < 1e-6


def test_first_order_has_its_time_constant_only() -> None:
    info = pumpid.FirstOrder.derived_info()
    assert [d.name for d in info] == ["time_constant"]
    assert pumpid.FirstOrder.derived_values([2.5])[0] == pytest.approx(2.5)


def test_delta_method_error_of_an_identity_equals_the_parameters() -> None:
    # For the mass-spring-dashpot, the static stiffness is k itself: same value, same errors.
    t = np.linspace(0.0, 15.0, 600)
    load = well_load(t, 7.5, seed=3) / 1000.0
    truth = pumpid.MassSpringDamper(m=0.02, c=0.1, k=1.0)
    clean = pumpid.simulate(truth, t, load)
    data = clean + 0.01 * np.ptp(clean) * np.random.default_rng(0).standard_normal(t.size)
    res = pumpid.fit(pumpid.MassSpringDamper, (t, load, data))
    d = res.derived["static_stiffness"]
    assert d.value == pytest.approx(res.params["k"], rel=1e-9)
    assert d.stderr == pytest.approx(res.stderr["k"], rel=1e-4)
    assert d.stderr_hac == pytest.approx(res.stderr_hac["k"], rel=1e-4)
    assert d.determined
    row = res.to_row()
    assert row["d_static_stiffness"] == d.value
    assert row["d_static_stiffness_unit"] == "N/m"
    js = res.to_dict()["derived"]["natural_frequency"]
    assert set(js) >= {"value", "unit", "stderr", "determined"}


def test_quantities_stay_determined_where_parameters_are_not() -> None:
    # Data from the Kelvin's rigid limit: k0 is poorly determined (or runs to its limit),
    # the oscillating pair and the static stiffness are determined and right.
    t = np.linspace(0.0, 15.0, 800)
    load = well_load(t, 7.5, seed=1)
    truth = pumpid.MassSpringDamper(m=20.0, c=300.0, k=5000.0)
    clean = pumpid.simulate(truth, t, load)
    data = clean + 0.005 * np.ptp(clean) * np.random.default_rng(2).standard_normal(t.size)
    res = pumpid.fit(pumpid.Kelvin, (t, load, data), options=pumpid.FitOptions(observe="u"))
    assert res.status in (pumpid.Status.BOUNDARY, pumpid.Status.CONVERGED)
    assert not res.stderr["k0"] < res.params["k0"] / 3
    d = res.derived
    assert d["natural_frequency"].determined
    assert d["natural_frequency"].value == pytest.approx(
        math.sqrt(5000.0 / 20.0) / (2 * math.pi), rel=0.02)
    assert d["static_stiffness"].determined
    assert d["static_stiffness"].value == pytest.approx(5000.0, rel=0.02)


def test_a_quantity_that_follows_a_boundary_parameter_is_not_determined() -> None:
    """k0 -> infinity: the third pole's time constant only says where k0 stopped."""
    from pumpid.pump.synthetic import synthetic_card

    rigid = pumpid.Kelvin(k0=1e9, m=20.0, c1=900.0, k1=5200.0)
    card = synthetic_card(rigid, spm=8.0, n_samples=400, observe="u", noise=0.0005, seed=4)
    res = pumpid.fit(pumpid.Kelvin, card)
    assert res.boundary is not None
    assert ("k0", "infinity") in {(b.name, b.direction) for b in res.boundary.limits}
    # The status's own words first, the solver's stop after (the reason began "converged:"
    # beside the JSON's converged: false).
    assert res.reason.startswith("k0 ran to a bound: the solution is a limiting model")
    assert "(the solver's stop: converged:" in res.reason and not res.converged
    tau = res.derived["time_constant"]
    assert tau.stderr == math.inf and not tau.determined
    stiff = res.derived["static_stiffness"]
    assert stiff.determined and stiff.value == pytest.approx(5200.0, rel=0.02)
    # The report's table prints an unbounded error as n/a, as every other text and HTML
    # output does (it printed "inf" where the parameter table beside it said "n/a").
    row = next(line for line in res.report().splitlines()
               if line.strip().startswith("time_constant"))
    assert "inf" not in row.split() and row.split()[2:4] == ["n/a", "n/a"]
