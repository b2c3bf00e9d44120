"""Models: parameters, matrices, derivatives, transfer functions (MODEL-NOTES section 1)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pumpid import FirstOrder, Kelvin, MassSpringDamper, Maxwell, model_class

KELVIN = Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0)
MAXWELL = Maxwell(k0=4.0, m=1.0, c1=0.2, k1=4.0)
ALL = [FirstOrder(tau=5.0), MassSpringDamper(m=9.88, c=4.94, k=247.0),
       Kelvin(k0=3.0, m=1.7, c1=0.9, k1=5.0), Maxwell(k0=3.0, m=1.7, c1=0.9, k1=5.0)]


def test_parameters_are_fields_with_units_and_bounds() -> None:
    assert Kelvin.param_names() == ("k0", "m", "c1", "k1")
    info = {p.name: p for p in Kelvin.param_info()}
    assert info["m"].unit_for("lbf", "in") == "lbf*s^2/in"
    assert info["c1"].unit_for("N", "m") == "N*s/m"
    assert all(p.lower == 0 and p.upper == np.inf for p in info.values())
    assert KELVIN.as_dict() == {"k0": 4.0, "m": 1.0, "c1": 0.2, "k1": 4.0}


def test_models_are_immutable_and_validated() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        KELVIN.k0 = 5.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="k1 = -1 is outside"):
        Kelvin(k0=1, m=1, c1=1, k1=-1)
    with pytest.raises(ValueError, match="nan"):
        MassSpringDamper(m=float("nan"), c=1, k=1)
    assert KELVIN.replace(k0=5.0).k0 == 5.0
    assert Kelvin.from_values([4, 1, 0.2, 4]) == KELVIN
    with pytest.raises(ValueError, match="takes 4 parameters"):
        Kelvin.from_values([1, 2, 3])


def test_model_lookup_by_name() -> None:
    assert model_class("kelvin") is Kelvin
    assert model_class("Mass_Spring_Damper") is MassSpringDamper
    with pytest.raises(ValueError, match="unknown model"):
        model_class("voigt")


def test_observed_output_is_selectable() -> None:
    assert Kelvin.output_index(None) == Kelvin.states.index("u")
    assert Kelvin.output_index("u2") == 2
    assert Kelvin.output_index("u") == 0
    with pytest.raises(ValueError, match="cannot observe 'F0'"):
        Kelvin.output_index("F0")


def test_transfer_functions_match_model_notes() -> None:
    s = np.array([0.3j, 1.1 + 2j, -0.2 + 0.7j, 5.0])
    k0, m, c1, k1 = 3.0, 1.7, 0.9, 5.0
    kel = Kelvin(k0=k0, m=m, c1=c1, k1=k1)
    den = m * c1 * s**3 + m * (k0 + k1) * s**2 + c1 * k0 * s + k0 * k1
    np.testing.assert_allclose(kel.transfer_function(s, "u2"), k0 / den, rtol=1e-12)
    np.testing.assert_allclose(kel.transfer_function(s, "u"), (c1 * s + k0 + k1) / den,
                               rtol=1e-12)
    mx = Maxwell(k0=k0, m=m, c1=c1, k1=k1)
    den_mx = m * c1 * s**3 + m * k1 * s**2 + (k0 + k1) * c1 * s + k0 * k1
    np.testing.assert_allclose(mx.transfer_function(s), (c1 * s + k1) / den_mx, rtol=1e-12)
    msd = MassSpringDamper(m=2.0, c=0.5, k=7.0)
    np.testing.assert_allclose(msd.transfer_function(s), 1 / (2 * s**2 + 0.5 * s + 7), rtol=1e-12)
    fo = FirstOrder(tau=5.0)
    np.testing.assert_allclose(fo.transfer_function(s), 1 / (s + 0.2), rtol=1e-12)


def test_static_gains_match_model_notes() -> None:
    assert KELVIN.static_gain("u2") == pytest.approx(1 / 4)
    assert KELVIN.static_gain("u") == pytest.approx(1 / 4 + 1 / 4)
    assert MAXWELL.static_gain() == pytest.approx(1 / 4)
    assert FirstOrder(tau=5.0).static_gain() == pytest.approx(5.0)
    assert MassSpringDamper(m=1, c=1, k=8).static_gain() == pytest.approx(1 / 8)


@pytest.mark.parametrize("model", ALL, ids=lambda m: type(m).__name__)
def test_matrix_derivatives_match_central_differences(model) -> None:
    da, db = model.matrix_derivatives()
    for i, name in enumerate(model.param_names()):
        h = 1e-6 * getattr(model, name)
        ap, bp = model.replace(**{name: getattr(model, name) + h}).matrices()
        am, bm = model.replace(**{name: getattr(model, name) - h}).matrices()
        np.testing.assert_allclose(da[i], (ap - am) / (2 * h), rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(db[i], (bp - bm) / (2 * h), rtol=1e-6, atol=1e-8)


def test_batched_matrices_agree_with_single() -> None:
    thetas = np.array([[4, 1, 0.2, 4], [3, 1.7, 0.9, 5.0]])
    a, b, da, db = Kelvin.system_batch(thetas)
    for j, th in enumerate(thetas):
        single = Kelvin.from_values(th)
        np.testing.assert_array_equal(a[j], single.matrices()[0])
        np.testing.assert_array_equal(b[j], single.matrices()[1])
        np.testing.assert_array_equal(da[j], single.matrix_derivatives()[0])
        np.testing.assert_array_equal(db[j], single.matrix_derivatives()[1])


def test_kelvin_coefficients_invert_as_in_model_notes() -> None:
    # MODEL-NOTES: k1 = a0/b0, c1 = a1/b0, k0 = a2 c1 - k1, m = k0/a1 (monic denominator).
    k0, m, c1, k1 = 3.0, 1.7, 0.9, 5.0
    lead = m * c1
    a2, a1, a0, b0 = m * (k0 + k1) / lead, c1 * k0 / lead, k0 * k1 / lead, k0 / lead
    k1_, c1_ = a0 / b0, a1 / b0
    k0_ = a2 * c1_ - k1_
    assert (k0_, k0_ / a1, c1_, k1_) == pytest.approx((k0, m, c1, k1))


def test_derived_quantities_hold_where_one_spring_is_1e15_times_the_other() -> None:
    # A field card's fit at its limits: k0 1.2e8, k1 3.6e-7. A holds (k0 + k1) / c1, where
    # k1 is lost to rounding: the static stiffness came out 3.40e-7 (not 3.59e-7) and the
    # creep time constant 1.6e7 s (not 1.0e8 s) from A's eigenvalues and solve.
    k0, m, c1, k1 = 115197287.6, 2.655873956, 36.52264732, 3.587616569e-07
    values = dict(zip(
        [i.name for i in Kelvin.derived_info()],
        Kelvin.derived_values(np.array([k0, m, c1, k1])), strict=True))
    assert values["static_stiffness"] == pytest.approx(k0 * k1 / (k0 + k1), rel=1e-12)
    # The creep pole is -k1 / c1 to within (k1 m / c1^2) of itself.
    assert values["time_constant"] == pytest.approx(c1 / k1, rel=1e-9)
    # The fast pair: m s^2 + c1 s + k0 (k0 far above the rest).
    assert values["natural_frequency"] == pytest.approx(math.sqrt(k0 / m) / (2 * math.pi),
                                                        rel=1e-6)
    # An ordinary Kelvin model: the same poles and gain as A's.
    model = Kelvin(k0=9000.0, m=45.0, c1=900.0, k1=5200.0)
    a, b = model.matrices()
    eig = np.sort_complex(np.linalg.eigvals(a))
    np.testing.assert_allclose(np.sort_complex(model.poles()), eig, rtol=1e-12)
    assert model.static_gain() == pytest.approx(-np.linalg.solve(a, b)[0], rel=1e-13)
    assert model.static_gain("u2") == pytest.approx(-np.linalg.solve(a, b)[2], rel=1e-13)
