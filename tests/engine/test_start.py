"""Automatic start (pumpid.engine.start): candidates, multistart with a guess, valley walk,
the wider search and the scan along the inertia."""

from __future__ import annotations

import math
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from pumpid import (
    FirstOrder,
    FitOptions,
    Kelvin,
    LevenbergMarquardt,
    MassSpringDamper,
    Maxwell,
    fit,
    simulate,
)
from pumpid.engine import drive
from pumpid.engine.problem import CardData, build_problem
from pumpid.engine.start import (
    InertiaLine,
    WidePlan,
    candidates,
    complete,
    find_starts,
    flat_spans,
    harmonic_scan,
    inertia_index,
    scan_inertia,
    search_wider,
    walk_valley,
)

from ..conftest import spread_card, stroke_problem, well_load

T = np.linspace(0.0, 20.0, 1001)
LOAD = well_load(T)
KELVIN = Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0)
ONE = np.zeros(1, dtype=np.int64)


def _err(params, truth) -> float:
    return max(abs(params[k] / v - 1) for k, v in truth.as_dict().items())


def _problem(cls, t, load, data, **opts):
    state = opts.pop("initial_state", "rest")
    period = opts.pop("period", None)
    return build_problem(cls, [CardData(t, load, data, state, period)], **opts)


@pytest.mark.parametrize("truth", [KELVIN, Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0),
                                   MassSpringDamper(m=2.0, c=30.0, k=90.0)],
                         ids=lambda m: type(m).__name__)
def test_model_class_means_automatic_start(truth) -> None:
    data = simulate(truth, T, LOAD)
    res = fit(type(truth), (T, LOAD, data))
    assert res.converged, res.reason
    assert _err(res.params, truth) < 1e-7
    assert res.start.note.startswith("automatic start") and res.start.candidates > 10


def test_first_order_automatic_start() -> None:
    t = np.linspace(0, 10, 501)
    f = np.sin(t) + 2
    data = simulate(FirstOrder(tau=0.8), t, f)
    res = fit(FirstOrder, (t, f, data))
    assert res.params["tau"] == pytest.approx(0.8, rel=1e-8)
    # The equation-error form itself finds the time constant of noiseless data.
    problem = _problem(FirstOrder, t, f, data)
    theta, _owner, kinds, _kind = candidates(problem, ONE)
    assert "equation error" in kinds
    assert np.any(np.abs(theta[:, 0] / 0.8 - 1) < 1e-3)


@pytest.mark.parametrize(("cls", "observe", "truth"), [
    (Kelvin, "u2", KELVIN), (Kelvin, "u", KELVIN),
    (Maxwell, "u", Maxwell(k0=90.0, m=2.0, c1=40.0, k1=70.0))])
def test_equation_error_recovers_noiseless_parameters(cls, observe, truth) -> None:
    data = simulate(truth, T, LOAD, observe=observe)
    problem = _problem(cls, T, LOAD, data, observe=observe)
    theta, _owner, kinds, _kind = candidates(problem, ONE)
    assert kinds[0] == "equation error"
    assert all(np.all(np.isfinite(c)) and np.all(c > 0) for c in theta)
    best = min(np.max(np.abs(c / truth.values - 1)) for c in theta)
    assert best < 1e-2


def test_candidates_are_ranked_with_their_best_scale_and_offset() -> None:
    data = simulate(KELVIN, T, LOAD) + 3.0
    problem = _problem(Kelvin, T, LOAD, data, offset=True)
    z, cost = complete(problem, ONE, KELVIN.values[None])
    assert z[0, -1] == pytest.approx(3.0, rel=1e-9) and cost[0] < 1e-12
    # A shape at the wrong stiffness level is rescaled (the scale symmetry), not refused.
    z, cost = complete(problem, ONE, 7.0 * KELVIN.values[None])
    assert np.exp(z[0, :4]) == pytest.approx(KELVIN.values, rel=1e-9) and cost[0] < 1e-12


def test_a_poor_guess_joins_the_multistart_and_loses() -> None:
    # A case built on the paper's observed output u2.
    data = simulate(KELVIN, T, LOAD, observe="u2")
    # A guess far away (factors 0.005 to 1.4): plain lm from it ends in another minimum,
    # not at the truth.
    guess = KELVIN.values * np.array([0.0052, 1.3856, 0.6288, 0.0068])
    plain = fit(Kelvin.from_values(guess), (T, LOAD, data),
                options=FitOptions(observe="u2", multistart=False))
    assert _err(plain.params, KELVIN) > 1e-3
    starts = find_starts(_problem(Kelvin, T, LOAD, data, observe="u2"), ONE, guess=guess[None])
    assert not starts.from_guess[0]
    guarded = fit(Kelvin.from_values(guess), (T, LOAD, data),
                  options=FitOptions(observe="u2", multistart=True))
    assert _err(guarded.params, KELVIN) < 1e-7
    assert "automatic" in guarded.start.note
    # The default ("auto") sees the first fit's poor quality and falls back to the same.
    auto = fit(Kelvin.from_values(guess), (T, LOAD, data), options=FitOptions(observe="u2"))
    assert _err(auto.params, KELVIN) < 1e-7


def test_a_good_guess_is_kept() -> None:
    data = simulate(KELVIN, T, LOAD)
    starts = find_starts(_problem(Kelvin, T, LOAD, data), ONE,
                         guess=(KELVIN.values * 1.01)[None])
    assert np.allclose(np.exp(starts.z[0, :4]), KELVIN.values, rtol=1e-3)


def _weak_arm_card(noise: float = 0.0):
    # A Maxwell arm much softer than the main spring (k0/k1 ~ 28), on a periodic card with
    # an offset: the data pin the arm only along a long, curved, flat valley.
    truth = Maxwell(k0=118.0, m=18.6, c1=52.0, k1=4.2)
    period, n = 8.0, 401
    t = np.arange(n) * period / n
    load = well_load(t, period=period, seed=5)
    data = simulate(truth, t, load, initial_state="periodic", period=period) + 12.0
    data = data + noise * np.ptp(data) * np.random.default_rng(0).standard_normal(n)
    return truth, t, load, data, {"initial_state": "periodic", "period": period,
                                  "offset": True}


def _floor_point(problem, truth, jump):
    """A point on the valley's floor far from the truth: a jump along the weakest direction
    from the truth, dropped back to the floor by a short polish that runs out there."""
    from pumpid.engine import drive, lm

    # The solver's offset is the offset of the response to the load less its mean.
    z_truth = np.r_[np.log(truth.values), 12.0 + float(problem.offset_gap(0, truth.values, 1.0))]
    data, model, settings = problem.arrays
    rows = np.empty((problem.q + 1, problem.n_samples(0)))
    assert drive.residual_rows(z_truth, 0, data, model, settings, rows)
    span = float(np.ptp(problem.card(0)[2]))
    rows[problem.q - 1] *= span
    r_fac = np.zeros((problem.q, problem.q))
    lm.householder(rows, problem.q, r_fac, np.zeros(problem.q))
    _u, s, vt = np.linalg.svd(r_fac)
    assert s[-1] / s[0] < 1e-4  # a valley the walk is meant for
    z = z_truth + jump * vt[-1] * np.r_[np.ones(4), span]
    out = LevenbergMarquardt(tol=1e-10).solve(problem, ONE, z[None], budget=10)
    assert out.stops[0].key == "budget"
    return out.z[0], float(out.cost[0])


@pytest.mark.parametrize("jump", [1.0, 2.0])
def test_valley_walk_reaches_the_truth_on_a_weak_maxwell_arm(jump) -> None:
    truth, t, load, data, opts = _weak_arm_card()
    problem = _problem(Maxwell, t, load, data, **opts)
    z, cost = _floor_point(problem, truth, jump)
    names = truth.param_names()
    assert _err(dict(zip(names, np.exp(z[:4]), strict=True)), truth) > 1.0
    zw, cw = walk_valley(problem, 0, z, cost)
    assert cw < 1e-15 * cost
    assert _err(dict(zip(names, np.exp(zw[:4]), strict=True)), truth) < 1e-9
    res = fit(Maxwell, (t, load, data), options=FitOptions(**opts))
    assert _err(res.params, truth) < 1e-6


def test_valley_walk_stays_put_on_noisy_data() -> None:
    # With noise the valley floor is flat at the noise level: nothing to gain by walking.
    truth, t, load, data, opts = _weak_arm_card(noise=0.01)
    problem = _problem(Maxwell, t, load, data, **opts)
    res = fit(truth, (t, load, data), options=FitOptions(**opts))
    z = np.r_[np.log(res.model.values),
              res.offset + float(problem.offset_gap(0, res.model.values, 1.0))]
    _zw, cw = walk_valley(problem, 0, z, res.cost)
    assert cw >= 0.95 * res.cost * (1 - 1e-9) or math.isclose(cw, res.cost)


def _mixed_problem():
    """Three cards: a periodic stroke, a record from rest, one from equilibrium."""
    period = 7.5
    t_p = np.arange(200) * period / 200
    load_p = well_load(t_p, period)
    y_p = simulate(KELVIN, t_p, load_p, initial_state="periodic", period=period) + 3.0
    cards = [CardData(t_p, load_p, y_p, "periodic", period),
             CardData(T, LOAD, simulate(KELVIN, T, LOAD)),
             CardData(T, LOAD + 500.0, simulate(KELVIN, T, LOAD + 500.0,
                                                initial_state="equilibrium"), "equilibrium")]
    return build_problem(Kelvin, cards, offset=True)


def test_equation_error_by_kind_equals_card_by_card() -> None:
    # Periodic strokes go to the harmonic estimate, other records to the time-domain one;
    # a mixed call gives each card what it gets alone.
    from pumpid.engine.start import equation_error_items
    from pumpid.engine.start.equation_error import _periodic_cards
    from pumpid.engine.start.pool import _bandwidths

    problem = _mixed_problem()
    cards = np.array([2, 0, 1], dtype=np.int64)
    assert _periodic_cards(cards, problem.arrays[0]).tolist() == [False, True, False]
    form = Kelvin.equation_error["u"]
    packed = (form.target[0] == "f", int(form.target[1]), np.array(form.y_orders),
              np.array(form.f_orders), int(form.order))
    lams = _bandwidths(problem, cards)
    together = equation_error_items(cards, lams, problem.arrays[0], packed, 1.0, True)
    assert np.isfinite(together).any(axis=(1, 2)).all()
    for i in range(cards.size):
        alone = equation_error_items(cards[i:i + 1], lams[i:i + 1], problem.arrays[0],
                                     packed, 1.0, True)
        np.testing.assert_array_equal(alone[0], together[i])


def test_a_periodic_card_does_not_compile_the_time_domain_estimate() -> None:
    # A fresh process that starts a periodic stroke compiles (or loads) only the harmonic
    # estimate: a first run does not pay for the time-domain filters it never uses.
    import subprocess
    import sys

    code = (
        "import numpy as np\n"
        "from pumpid import Kelvin, simulate\n"
        "from pumpid.engine import start\n"
        "from pumpid.engine.start import equation_error\n"
        "from pumpid.engine.problem import CardData, build_problem\n"
        "from tests.conftest import well_load\n"
        "t = np.arange(200) * 7.5 / 200\n"
        "f = well_load(t, 7.5)\n"
        "y = simulate(Kelvin(k0=120.0, m=2.0, c1=60.0, k1=90.0), t, f,\n"
        "             initial_state='periodic', period=7.5)\n"
        "p = build_problem(Kelvin, [CardData(t, f, y, 'periodic', 7.5)], offset=True)\n"
        "start.candidates(p, np.zeros(1, dtype=np.int64))\n"
        "print(len(equation_error._harmonic_items.signatures),\n"
        "      len(equation_error._time_items.signatures))\n")
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=root, check=True)
    assert done.stdout.split() == ["1", "0"]


class _FinalsSpy(LevenbergMarquardt):
    """The solver the wider search runs its finals with, recording each call's budget."""

    calls: ClassVar[list] = []

    def solve(self, problem, cards, z0, **kwargs):  # type: ignore[override]
        out = super().solve(problem, cards, z0, **kwargs)
        self.calls.append((kwargs.get("budget"), out.evaluations.copy()))
        return out


def test_the_wider_search_stops_its_finals_at_their_budget() -> None:
    # A final only has to tell basins apart; on a flat valley the solver's whole budget
    # (400 per coordinate) would be spent crawling along it.
    problem = stroke_problem(3)
    z, cost = complete(problem, ONE, np.array([[1200.0, 0.2, 600.0, 900.0]]))
    _FinalsSpy.calls = []
    plan = WidePlan(rounds=1, final_evaluations=6)
    _z, best_cost, polished = search_wider(problem, ONE, z, cost, plan=plan,
                                           solver=_FinalsSpy())
    assert _FinalsSpy.calls
    assert all(budget == 6 for budget, _ in _FinalsSpy.calls)
    assert max(int(evals.max()) for _, evals in _FinalsSpy.calls) <= 6
    assert polished[0] > 0 and best_cost[0] <= cost[0]


@pytest.mark.parametrize("cls, observe", [(Kelvin, "u"), (Kelvin, "u2"), (Maxwell, "u"),
                                          (MassSpringDamper, "u"), (FirstOrder, "u")])
def test_the_harmonic_scan_costs_each_shape_by_its_transfer_function(cls, observe) -> None:
    # The scan's response at each harmonic (Cramer's rule up to 3 states) against the
    # model's own transfer function, solved by numpy.
    n = 64
    t = np.arange(n) * 6.0 / n
    rng = np.random.default_rng(4)
    f, d = well_load(t, 6.0), rng.standard_normal(n)
    p = len(cls.param_names())
    shapes = np.exp(rng.uniform(-2.0, 2.0, (6, p)))
    costs, factors = harmonic_scan(t, f, d, shapes, cls.code(), cls.n_states(),
                                   cls.output_index(observe), True, False, 1.0, 8)
    ks = np.arange(1, 9)
    fk, dk = np.fft.fft(f)[ks], np.fft.fft(d)[ks]
    for s in range(6):
        h = cls.from_values(shapes[s]).transfer_function(2j * np.pi * ks / 6.0, observe)
        assert costs[s] == pytest.approx(float(np.sum(np.abs(h * fk - dk) ** 2)), rel=1e-9)
    assert np.all(factors == 1.0)


def test_the_ranking_on_the_harmonics_that_carry_a_card_keeps_its_best_shapes() -> None:
    # The wider search ranks the dense grid on WidePlan().harmonics harmonics: on a card's
    # own few, the best 24 shapes (its three rounds' pool) are nearly those of many more.
    plan = WidePlan()
    assert plan.harmonics < 64
    n, period = 256, 7.5
    t = np.arange(n) * period / n
    shapes = Kelvin.shape_grid(2.0 * np.pi / period, dense=True)
    for seed in range(3):
        f = well_load(t, period, seed=seed)
        d = simulate(Kelvin(k0=5200.0, m=20.0, c1=900.0, k1=5200.0), t, f,
                     initial_state="periodic", period=period)
        d = d + 0.01 * np.random.default_rng(seed).standard_normal(n)
        costs = [harmonic_scan(t, f, d, shapes, Kelvin.code(), 3, Kelvin.output_index("u"),
                               True, True, 1.0, kmax)[0] for kmax in (plan.harmonics, 64)]
        few, many = (set(np.argsort(c)[:24].tolist()) for c in costs)
        assert len(few & many) >= 21


def _monic_polynomials():
    """Monic polynomials (coefficients by power) from their roots: stable, marginal (a
    root on the imaginary axis) and unstable ones of degree 0 to 5."""
    rng = np.random.default_rng(5)
    cases = [np.array([1.0])]
    for degree in range(1, 6):
        for _ in range(12):
            real = rng.uniform(-3.0, 1.0, degree)
            roots = real.astype(complex)
            for j in range(0, degree - 1, 2):
                # A complex pair in place of two real roots, damped or not.
                imag = rng.uniform(0.1, 5.0)
                roots[j], roots[j + 1] = real[j] + 1j * imag, real[j] - 1j * imag
            cases.append(np.real(np.poly(roots))[::-1].copy())
        cases.append(np.real(np.poly([-1.0, 2j, -2j]))[::-1].copy())  # marginal pair
        cases.append(np.real(np.poly([0.0, -1.0]))[::-1].copy())  # a root at zero
    return cases


@pytest.mark.parametrize("poly", _monic_polynomials())
def test_the_stability_test_agrees_with_the_roots(poly) -> None:
    from pumpid.engine.start import equation_error

    roots = np.roots(poly[::-1])
    margin = float(np.max(roots.real)) if roots.size else -math.inf
    if abs(margin) < 1e-9:
        # On the axis: neither strictly inside, whatever the rounding says.
        assert not equation_error.hurwitz_stable(poly)
    else:
        assert equation_error.hurwitz_stable(poly) is bool(margin < 0.0)


def test_the_stability_test_refuses_what_is_not_finite() -> None:
    from pumpid.engine.start import equation_error

    assert not equation_error.hurwitz_stable(np.array([2.0, np.nan, 1.0]))
    assert not equation_error.hurwitz_stable(np.array([np.inf, 3.0, 1.0]))


def _lstsq_cases():
    rng = np.random.default_rng(8)
    full = rng.standard_normal((40, 5)) * np.array([1.0, 1e3, 1e-3, 5.0, 1e6])
    dependent = full.copy()
    dependent[:, 3] = 2.0 * dependent[:, 0] - dependent[:, 1] / 1e3
    zero_column = full.copy()
    zero_column[:, 2] = 0.0
    wide = rng.standard_normal((3, 5))
    return [full, dependent, zero_column, wide]


@pytest.mark.parametrize("mat", _lstsq_cases())
def test_the_least_squares_solve_is_lapacks(mat) -> None:
    from pumpid.engine.start import equation_error

    rng = np.random.default_rng(9)
    target = rng.standard_normal(mat.shape[0])
    coef = equation_error.unit_column_lstsq(mat, target)
    # LAPACK's minimum-norm solution, on the same unit-norm columns.
    norms = np.linalg.norm(mat, axis=0)
    keep = norms > 0.0
    reference = np.zeros(mat.shape[1])
    reference[keep] = np.linalg.lstsq(mat[:, keep] / norms[keep], target,
                                      rcond=None)[0] / norms[keep]
    np.testing.assert_allclose(mat @ coef, mat @ reference, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(coef * norms, reference * norms, rtol=1e-7, atol=1e-9)


def test_the_least_squares_solve_says_when_there_is_nothing_to_solve() -> None:
    from pumpid.engine.start import equation_error

    mat = np.ones((6, 2))
    assert np.all(np.isnan(equation_error.unit_column_lstsq(np.zeros((6, 2)), np.ones(6))))
    bad = mat.copy()
    bad[2, 1] = np.nan
    assert np.all(np.isnan(equation_error.unit_column_lstsq(bad, np.ones(6))))
    assert np.all(np.isnan(equation_error.unit_column_lstsq(mat, np.full(6, np.inf))))


def _spread_problem(index: int):
    card, truth = spread_card(index)
    problem = build_problem(Kelvin, [CardData(card.t, card.load, card.position, "periodic",
                                              card.period)], offset=True)
    return problem, truth


def _solved(problem, theta) -> tuple[np.ndarray, np.ndarray]:
    z, _cost = complete(problem, ONE, np.asarray(theta, dtype=float)[None])
    out = LevenbergMarquardt().solve(problem, ONE, z)
    return out.z, out.cost


def test_the_scan_along_the_inertia_leaves_a_ripple_of_the_cost() -> None:
    # The resonance at 35 times the stroke frequency: the card sees m only through weak
    # harmonics. From m = 8.2 (true 3.82) the solver converges in a ripple of the cost
    # along m; the scan finds the dip the solver reaches from the truth.
    problem, truth = _spread_problem(31)
    z_ripple, c_ripple = _solved(problem, [5021.1, 8.215, 2189.2, 3227.8])
    _z, c_truth = _solved(problem, truth)
    assert c_ripple[0] > c_truth[0] * 1.02
    z, cost, runs = scan_inertia(problem, ONE, z_ripple, c_ripple)
    assert runs[0] >= 1
    assert cost[0] <= c_truth[0] * (1 + 1e-9)
    assert math.exp(z[0, 1]) == pytest.approx(3.82, rel=0.1)


def test_the_scan_along_the_inertia_never_returns_a_higher_cost() -> None:
    # From the best dip there is nothing lower: the point comes back as it went in.
    problem, truth = _spread_problem(31)
    z_best, c_best = _solved(problem, truth)
    z, cost, _runs = scan_inertia(problem, ONE, z_best, c_best)
    assert cost[0] == c_best[0]
    assert np.array_equal(z, z_best)


def test_the_scan_needs_a_free_inertia() -> None:
    problem, _truth = _spread_problem(31)
    assert inertia_index(problem) == 1
    held = build_problem(Kelvin, [CardData(*problem.card(0), "periodic", problem.period[0])],
                         offset=True, fixed={"m": 3.82})
    assert inertia_index(held) is None
    first = build_problem(FirstOrder, [CardData(T, LOAD, simulate(FirstOrder(tau=2.0), T,
                                                                      LOAD), "rest", None)])
    assert inertia_index(first) is None
    z = np.zeros((1, held.q))
    z_same, cost, runs = scan_inertia(held, ONE, z, np.array([1.0]))
    assert np.array_equal(z_same, z) and cost[0] == 1.0 and runs[0] == 0


def test_the_flat_span_along_the_inertia_holds_the_answer_and_the_threshold() -> None:
    # On the best dip of a card whose resonance sits at 35 times the stroke frequency, with
    # every other value held, the cost stays within 5 % of its value from a thirtieth of
    # the mass to 2.6 times it; every value reported lies within the threshold, the
    # answer's own included, and a tighter threshold gives a narrower span.
    problem, truth = _spread_problem(31)
    z, cost = _solved(problem, truth)
    m = math.exp(z[0, 1])
    same_card = np.zeros(4, dtype=np.int64)
    factors = np.array([1.05, 1.02, 1 + 1e-9, 0.5])
    wide, tight, exact, below = flat_spans(problem, same_card, np.repeat(z, 4, axis=0),
                                           cost[0] * factors)
    lo, hi = wide
    assert lo < 0.1 * m and hi > 2.0 * m
    assert tight is not None and lo < tight[0] < m < tight[1] < hi
    assert exact == (m, m)
    assert below is None
    for value in (lo, hi, *tight):
        point = z.copy()
        point[0, 1] = math.log(value)
        assert drive.cost_items(ONE, point, *problem.arrays)[0] <= cost[0] * 1.05
    # A card with no finite limit: no span.
    assert flat_spans(problem, ONE, z, np.array([math.nan])) == [None]


def test_the_flat_span_reuses_the_scans_line_from_the_same_point_only() -> None:
    # The scan records its first line; the span from it is the span costed afresh. A line
    # taken from another point is not used (its costs are another line's): changing the
    # recorded costs changes nothing there, and changes the span where it is used.
    problem, truth = _spread_problem(31)
    z, cost = _solved(problem, truth)
    lines: list[InertiaLine | None] = [None]
    scan_inertia(problem, ONE, z, cost, lines=lines)
    line = lines[0]
    assert line is not None and np.array_equal(line.z, z[0])
    limit = cost * 1.05
    fresh = flat_spans(problem, ONE, z, limit)
    assert flat_spans(problem, ONE, z, limit, known=lines) == fresh
    flat = InertiaLine(line.z, line.values, np.full_like(line.costs, cost[0]))
    lowest, highest = math.exp(line.values.min()), math.exp(line.values.max())
    assert flat_spans(problem, ONE, z, limit, known=[flat]) == [(lowest, highest)]
    moved = z.copy()
    moved[0, 0] += 1e-3
    elsewhere = InertiaLine(moved[0], line.values, flat.costs)
    assert flat_spans(problem, ONE, z, limit, known=[elsewhere]) == fresh
