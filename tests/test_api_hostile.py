"""Hostile input through the Python API: documented exceptions naming the field, or a result
whose status says what it is worth.

The API's contract (``pumpid.fit``): bad input raises ``ValueError`` (or ``TypeError`` for a
wrong kind of argument) naming the problem; a fit that fails is a result with status
``failed``. A usable status (``converged``, ``boundary``) never comes with a NaN quality.
A fit whose R^2 is undefined or low is ``poor-fit``, and a time axis far outside
floating point's reach is refused with a ``ValueError``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import pumpid

T = np.linspace(0.0, 20.0, 401)
LOAD = 10 + 3 * np.sin(0.9 * T) + np.sin(2.3 * T)
DISP = pumpid.simulate(pumpid.Kelvin(k0=4, m=1, c1=2, k1=4), T, LOAD, observe="u")



def _fit(t: np.ndarray, load: np.ndarray, disp: np.ndarray) -> pumpid.FitResult | None:
    """The fit, or None when it raised the documented ValueError."""
    try:
        return pumpid.fit(pumpid.Kelvin, (t, load, disp), options=pumpid.FitOptions(observe="u"))
    except ValueError as exc:
        assert str(exc)  # a message, naming the problem
        return None


def _usable_means_finite(res: pumpid.FitResult | None) -> None:
    if res is None:
        return
    if res.status in (pumpid.Status.CONVERGED, pumpid.Status.BOUNDARY):
        assert math.isfinite(res.r2) and math.isfinite(res.rmse), (res.status, res.r2)
    else:
        assert res.reason


@pytest.mark.parametrize(("what", "factor"), [
    ("t", 1e-100), ("t", 1e100),
    ("t", 1e-200), ("t", 1e200),  # refused: a duration far outside floating point's reach
    ("load", 1e-300), ("load", 1e-200), ("load", 1e200), ("load", 1e300),
    ("disp", 1e-100), ("disp", 1e100), ("disp", 1e200), ("disp", 1e300),
    # Displacements near 1e-200 leave R^2 undefined: the quality gate says poor-fit.
    ("disp", 1e-200), ("disp", 1e-300),
])
def test_wrong_scale_is_refused_or_honest(what: str, factor: float) -> None:
    args = {"t": T, "load": LOAD, "disp": DISP}
    args[what] = args[what] * factor
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = _fit(args["t"], args["load"], args["disp"])
    _usable_means_finite(res)


@pytest.mark.parametrize(("field", "bad", "words"), [
    ("load", LOAD + 0j, "complex"),
    ("load", LOAD[:-1], "length"),
    ("disp", np.where(np.arange(T.size) == 7, np.nan, DISP), "index 7"),
    ("disp", np.full_like(DISP, np.inf), "non-finite"),
    ("t", T[::-1], "strictly increasing"),
    ("load", np.array(["a"] * T.size), ""),
])
def test_bad_arrays_raise_value_errors_naming_the_field(field: str, bad: np.ndarray,
                                                        words: str) -> None:
    args = {"t": T, "load": LOAD, "disp": DISP}
    args[field] = bad
    with pytest.raises(ValueError) as info:
        pumpid.fit(pumpid.Kelvin, (args["t"], args["load"], args["disp"]),
                   options=pumpid.FitOptions(observe="u"))
    name = {"disp": "displacement"}.get(field, field)
    assert str(info.value).startswith(name) or name in str(info.value)
    assert words in str(info.value)


def test_a_batch_keeps_going_past_bad_rows() -> None:
    loads = np.tile(LOAD, (5, 1))
    disps = np.tile(DISP, (5, 1))
    loads[1, 3] = np.nan
    loads[2, :] = 1.0
    disps[3, 10] = np.inf
    batch = pumpid.fit(pumpid.Kelvin, (T, loads, disps), options=pumpid.FitOptions(observe="u"))
    assert [s.key for s in batch.status] == ["converged", "invalid-input", "invalid-input",
                                             "invalid-input", "converged"]
    assert batch.invalid[1].startswith("load:") and "index 3" in batch.invalid[1]
    assert batch.invalid[2].startswith("load: constant")
    assert batch.invalid[3].startswith("displacement:") and "index 10" in batch.invalid[3]
    with pytest.raises(ValueError, match="card 1 is not valid: load"):
        batch.result(1)


def test_wrong_kind_of_model_is_a_type_error() -> None:
    with pytest.raises(TypeError, match="model must be"):
        pumpid.fit({"k0": 4.0}, (T, LOAD, DISP))  # type: ignore[arg-type]


def test_a_start_mapping_is_checked_as_the_other_forms_are() -> None:
    # x0={"k0": -100, ...} became k0 = 1.0 without a word in a single fit.
    for bad in (-100.0, 0.0):
        with pytest.raises(ValueError, match=r"x0: .*k0"):
            pumpid.fit(pumpid.Kelvin, (T, LOAD, DISP),
                       x0={"k0": bad, "m": 1.0, "c1": 1.0, "k1": 1.0})


def test_units_of_the_wrong_type_are_a_type_error() -> None:
    # units="lbf" read as three entries for one record.
    for bad in ("lbf", ("lbf", "in")):
        with pytest.raises(TypeError, match=r"pumpid\.Units"):
            pumpid.fit(pumpid.Kelvin, (T, LOAD, DISP), units=bad)  # type: ignore[arg-type]


def test_an_empty_record_is_told_the_fits_minimum() -> None:
    with pytest.raises(ValueError, match="a fit needs at least 10"):
        pumpid.fit(pumpid.Kelvin, (np.zeros(0), np.zeros(0), np.zeros(0)))


def test_a_period_given_makes_arrays_periodic() -> None:
    # FitOptions.for_cards(period=T) on arrays was fitted from rest (715 times the cost of
    # the periodic fit, converged, no warning).
    period = 7.5
    t = np.arange(200) * period / 200
    load = 5000 + 2000 * np.sin(2 * np.pi * t / period) + 300 * np.sin(4 * np.pi * t / period)
    pos = pumpid.simulate(pumpid.Kelvin(k0=40, m=1, c1=20, k1=40), t, load,
                          initial_state="periodic", period=period)
    res = pumpid.fit("kelvin", (t, load, pos), options=pumpid.FitOptions.for_cards(period=period))
    assert res.initial_state == "periodic" and res.r2 > 0.999999
    with pytest.raises(ValueError, match="would not use it"):
        pumpid.FitOptions(period=period, initial_state="rest")
    # A record that states its own start keeps it, and is told (it became periodic).
    with pytest.raises(ValueError, match="initial_state 'equilibrium' would not use it"):
        pumpid.fit("kelvin", pumpid.CardData(t, load, pos, "equilibrium"),
                   options=pumpid.FitOptions(period=period))


@pytest.mark.parametrize("factor", [1e-160, 1e-200])
def test_data_whose_squares_underflow_are_refused(factor: float) -> None:
    # Positions of 1e-160 gave "failed" beside R^2 0.9994; of 1e-200, "R^2 = not defined is
    # below the quality threshold". Overflow was already refused.
    with pytest.raises(ValueError, match="underflow the floating-point range; rescale"):
        pumpid.fit(pumpid.Kelvin, (T, LOAD, DISP * factor))
