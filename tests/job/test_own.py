"""A model that brings its own simulator and sensitivities, through ``pumpid.fit``.

The step response of a first-order system with a signed gain and a baseline,
y = b + g (1 - exp(-t / tau)): tau positive (log scale), g and b signed. Closed form, so
the fitted values, their errors and the coverage of the intervals can be checked exactly.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import pumpid
from pumpid import CardData, OwnModel, Parameter


class Step(OwnModel):
    name = "step response"
    parameters = (Parameter("tau", "s", start=1.0),
                  Parameter("g", "V", lower=-math.inf, start=1.0),
                  Parameter("b", "V", lower=-math.inf, start=0.0))
    output, output_unit = "voltage", "V"

    def simulate(self, values, data, sensitivities):
        tau, g, b = values
        t = np.asarray(data.t, dtype=float)
        e = np.exp(-t / tau)
        y = b + g * (1.0 - e)
        if not sensitivities:
            return y, None
        return y, np.column_stack([-g * e * t / tau**2, 1.0 - e, np.ones_like(t)])


T = np.linspace(0.0, 10.0, 200)
TRUTH = np.array([2.0, -3.0, 0.5])


def _record(seed: int, noise: float = 0.02) -> CardData:
    y, _ = Step().simulate(TRUTH, CardData(T, T, T), False)
    rng = np.random.default_rng(seed)
    return CardData(T, np.zeros_like(T), y + noise * rng.standard_normal(T.size))


def test_an_own_model_is_fitted_with_errors_statuses_and_words() -> None:
    res = pumpid.fit(Step(), _record(1))
    assert isinstance(res, pumpid.FitResult)
    assert res.status is pumpid.Status.CONVERGED
    assert res.model_name == "step response"
    assert res.r2 > 0.99
    for name, truth in zip(("tau", "g", "b"), TRUTH, strict=True):
        se = res.stderr[name]
        assert 0 < se < 0.2 * abs(truth)
        assert abs(res.params[name] - truth) < 5 * se
        lo, hi = res.ci95[name]
        assert lo < res.params[name] < hi
    # A signed parameter's interval is symmetric; a positive one's is on the log scale.
    lo, hi = res.ci95["g"]
    assert hi - res.params["g"] == pytest.approx(res.params["g"] - lo)
    lo, hi = res.ci95["tau"]
    assert res.params["tau"] / lo == pytest.approx(hi / res.params["tau"])
    assert res.param_units() == {"tau": "s", "g": "V", "b": "V"}
    assert set(res.determined["parameters"]) == {"tau", "g", "b"}
    assert "tau" in res.to_json() and "step response" in res.report()


def test_intervals_cover_the_truth_about_95_percent() -> None:
    hits = np.zeros(3)
    n = 200
    for seed in range(n):
        res = pumpid.fit(Step(), _record(seed))
        for j, name in enumerate(("tau", "g", "b")):
            lo, hi = res.ci95[name]
            hits[j] += lo <= TRUTH[j] <= hi
    coverage = hits / n
    assert np.all((coverage > 0.89) & (coverage < 0.995)), coverage


def test_correlated_noise_shows_the_robust_errors() -> None:
    rng = np.random.default_rng(5)
    e = np.zeros(T.size)
    for i in range(1, T.size):
        e[i] = 0.9 * e[i - 1] + 0.02 * rng.standard_normal()
    rec = _record(0, noise=0.0)
    rec = CardData(rec.t, rec.load, np.asarray(rec.data) + e)
    res = pumpid.fit(Step(), rec)
    assert res.uncertainty.shown == "robust"
    assert res.stderr["tau"] > 2 * res.uncertainty.stderr_white["tau"]


def test_a_parameter_the_data_cannot_see_is_a_boundary() -> None:
    # A flat record: the response never rises, so tau runs to a limit.
    flat = 0.5 + 0.01 * np.random.default_rng(2).standard_normal(T.size)
    rec = CardData(T, np.zeros_like(T), flat)
    res = pumpid.fit(Step(), rec, x0={"tau": 1.0, "g": 0.0001, "b": 0.5},
                     options=pumpid.FitOptions(min_r2=-1.0))
    assert res.status in (pumpid.Status.BOUNDARY, pumpid.Status.UNDETERMINED)
    assert "tau" not in res.determined.get("parameters", [])


class CappedStep(Step):
    """Step with its gain declared at most -3.5 V: the data (g = -3) want it beyond."""

    parameters = (Parameter("tau", "s", start=1.0),
                  Parameter("g", "V", lower=-math.inf, upper=-3.5, start=-4.0),
                  Parameter("b", "V", lower=-math.inf, start=0.0))


def test_a_value_held_at_its_declared_bound_is_worded_as_that_bound() -> None:
    # The words said "it runs to zero ... only an upper bound exists" for a gain held at its
    # upper bound: the data want it higher, so only a lower bound exists.
    res = pumpid.fit(CappedStep(), _record(1))
    assert res.status is pumpid.Status.BOUNDARY
    assert [(b.name, b.direction) for b in res.boundary.limits] == [("g", "upper")]
    said = next(s for s in res.identifiability if s.startswith("g is at a boundary"))
    assert "runs to its upper bound" in said and "only a lower bound exists" in said
    assert "zero" not in said


def test_many_records_fixed_parameters_and_refusals() -> None:
    batch = pumpid.fit(Step(), [_record(1), _record(2), CardData(T[:2], T[:2], T[:2])],
                       options=pumpid.FitOptions(fixed={"b": 0.5}))
    assert isinstance(batch, pumpid.FitBatch)
    assert batch.results[0].params["b"] == 0.5 and batch.results[0].free == ("tau", "g")
    assert batch.results[2] is None and "at least 3 samples" in batch.invalid[2]
    with pytest.raises(ValueError, match="does not apply to an own model"):
        pumpid.fit(Step(), _record(1), options=pumpid.FitOptions(observe="u"))
    with pytest.raises(ValueError, match="unknown parameter"):
        pumpid.fit(Step(), _record(1), options=pumpid.FitOptions(fixed={"k": 1.0}))
    with pytest.raises(TypeError, match="LevenbergMarquardt"):
        pumpid.fit(Step(), _record(1), solver=pumpid.PaperNewton())


def test_an_own_models_report_speaks_of_its_own_output(tmp_path) -> None:
    from pumpid.report import write_outputs

    res = pumpid.fit(Step(), _record(1))
    write_outputs(res, tmp_path)
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "step response" in html and "input 1, output V" in html
    assert "output scale factor" not in html and "additive position offset" not in html
    assert json.loads((tmp_path / "result.json").read_text())["params"]["g"] < 0


class CountingStep(Step):
    """Step that counts its simulations and cannot differentiate at some starts."""

    def __init__(self, starts=None, broken=()) -> None:
        self.starts = starts
        self.broken = {float(v) for v in broken}
        self.plain = 0
        self.with_sensitivities = 0

    def start(self, data):
        return np.array(self.starts) if self.starts is not None else super().start(data)

    def simulate(self, values, data, sensitivities):
        if sensitivities:
            self.with_sensitivities += 1
            if float(values[0]) in self.broken:
                raise ArithmeticError("no sensitivities here")
        else:
            self.plain += 1
        return super().simulate(values, data, sensitivities)


def test_rejected_steps_cost_no_sensitivities_and_the_noise_test_stops() -> None:
    # A trial point is costed first: sensitivities only where the step is accepted.
    model = CountingStep()
    res = pumpid.fit(model, _record(3), x0={"tau": 8.0, "g": 1.0, "b": 0.0})
    assert res.status is pumpid.Status.CONVERGED
    # sensitivities: the start, each accepted step and the final analysis; no more
    assert model.with_sensitivities <= res.iterations + 2 < res.nfev
    assert "{" not in res.reason  # the stop's words are filled in
    # The same answer as a fit that differentiates at every trial point, to well within
    # its errors (the noise test stops within sqrt(2e-6) standard errors of the optimum).
    exact = pumpid.fit(Step(), _record(3), x0={"tau": 8.0, "g": 1.0, "b": 0.0},
                       solver=pumpid.LevenbergMarquardt(noise_tol=0.0))
    for name in ("tau", "g", "b"):
        assert abs(res.params[name] - exact.params[name]) < 0.01 * res.stderr[name]


def test_a_start_without_sensitivities_hands_over_to_the_next() -> None:
    # The best start by cost can be simulated but not differentiated (a simulator that
    # differentiates by perturbing can fail there): the next start is solved instead.
    model = CountingStep(starts=[[2.1, -3.0, 0.5], [1.5, -2.0, 0.0]], broken=[2.1])
    res = pumpid.fit(model, _record(4))
    assert res.status is pumpid.Status.CONVERGED
    assert abs(res.params["tau"] - TRUTH[0]) < 5 * res.stderr["tau"]
    assert "solved from 2" in res.start.note


def test_the_answer_s_sensitivities_are_not_computed_twice() -> None:
    # The analysis of the answer asks for the sensitivities at the solver's last accepted
    # point, which the solver has just computed: a simulator that differentiates by finite
    # differences would pay for them twice.
    calls: list[bytes] = []

    class Counted(Step):
        def simulate(self, values, data, sensitivities):
            if sensitivities:
                calls.append(np.asarray(values, dtype=float).tobytes())
            return super().simulate(values, data, sensitivities)

    res = pumpid.fit(Counted(), _record(1))
    assert res.status is pumpid.Status.CONVERGED and len(calls) >= 2
    assert len(set(calls)) == len(calls)
    assert res.jacobian is not None and res.uncertainty is not None


def test_a_model_that_asks_for_no_analysis_gets_its_optimum_alone() -> None:
    # A search's fit: the same optimum, the fit's statistics and the solver's status, no
    # errors or identifiability, and no sensitivities asked for at the answer beyond the
    # solver's own.
    calls: list[bytes] = []

    class Search(Step):
        analyse = False

        def simulate(self, values, data, sensitivities):
            if sensitivities:
                calls.append(np.asarray(values, dtype=float).tobytes())
            return super().simulate(values, data, sensitivities)

    full = pumpid.fit(Step(), _record(2))
    res = pumpid.fit(Search(), _record(2))
    assert res.status is pumpid.Status.CONVERGED
    assert res.params == full.params and res.cost == full.cost and res.r2 == full.r2
    assert res.uncertainty is None and res.jacobian is None and res.derived == {}
    assert res.identifiability[0].startswith("not analysed")
    assert len(calls) <= res.iterations + 1  # the start and each accepted step
    np.testing.assert_array_equal(res.fitted, full.fitted)


def test_a_model_is_told_which_parameters_each_fit_holds() -> None:
    # Before each fit the engine names the held parameters: a model that differentiates by
    # finite differences need not simulate their columns, which the solver never reads.
    told: list[frozenset[str]] = []

    class Lazy(Step):
        def hold(self, names):
            told.append(names)

        def simulate(self, values, data, sensitivities):
            y, dy = super().simulate(values, data, sensitivities)
            if dy is not None:
                dy = dy.copy()
                dy[:, [i for i, p in enumerate(self.parameters) if p.name in told[-1]]] = 0.0
            return y, dy

    free = pumpid.fit(Step(), _record(3), options=pumpid.FitOptions(fixed={"b": 0.5}))
    lazy = Lazy()
    res = pumpid.fit(lazy, _record(3), options=pumpid.FitOptions(fixed={"b": 0.5}))
    assert told == [frozenset({"b"})]
    assert res.params == free.params and res.stderr == free.stderr
    pumpid.fit(lazy, _record(3))
    assert told[-1] == frozenset()


class BoundedStep(Step):
    """Step with tau declared within 0.5-1.5 s: the data (tau = 2 s) want it beyond."""

    parameters = (Parameter("tau", "s", lower=0.5, upper=1.5, start=1.0),
                  Parameter("g", "V", lower=-math.inf, start=1.0),
                  Parameter("b", "V", lower=-math.inf, start=0.0))


def test_a_positive_value_on_its_declared_bound_is_at_that_bound() -> None:
    # tau stopped on its declared upper bound was said to "run to infinity (fitted value
    # 1.5 is arbitrary ...)", while pushing it on lowers the cost.
    res = pumpid.fit(BoundedStep(), _record(1))
    assert res.params["tau"] == pytest.approx(1.5)
    assert [(b.name, b.direction) for b in res.boundary.limits] == [("tau", "upper")]
    said = " ".join(res.identifiability) + " ".join(res.warnings)
    assert "runs to its upper bound" in said
    assert "infinity" not in said and "arbitrary" not in said


def test_an_own_models_misuse_is_said_plainly() -> None:
    class NoSensitivities(Step):
        def simulate(self, values, data, sensitivities):
            return super().simulate(values, data, False)

    with pytest.raises(ValueError, match="returned no sensitivities when asked"):
        pumpid.fit(NoSensitivities(), _record(1))
    # Held values outside the declared bounds were fitted and reported (tau = 50 above an
    # upper bound of 1.5, converged).
    for fixed in ({"tau": 50.0}, {"tau": -1.0}, {"tau": 0.1}):
        with pytest.raises(ValueError, match="is outside its bounds"):
            pumpid.fit(BoundedStep(), _record(1), options=pumpid.FitOptions(fixed=fixed))
    with pytest.raises(ValueError, match="above 0"):
        pumpid.fit(Step(), _record(1), options=pumpid.FitOptions(fixed={"tau": 0.0}))
    # The class for an instance: "must be a model instance ... or a model class".
    with pytest.raises(TypeError, match=r"as an instance.*Step\(\.\.\.\)"):
        pumpid.fit(Step, _record(1))
