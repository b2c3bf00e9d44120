"""The predictive march: a stiff pump stays stable, warm starts land on the same stroke."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid.rods import PumpModel
from pumpid.rods.predict import StringGrid, pump_vector

from .strings import surface_motion, three_tapers

SPM = 8.0


def _grid_and_pump(fill: float, transfer: float, ratio: float = 0.02):
    well = three_tapers()
    s = surface_motion(n=200, period=60 / SPM)
    fluid = 0.9 * 1000 * 9.80665 * well.pump.depth * well.pump.area
    pump = PumpModel(fluid_load=fluid, fillage=fill, intake_ratio=ratio, transfer=transfer)
    return StringGrid.of(well, 60 / SPM, s.size, 30), s, pump_vector(pump.arrays(1), 0, 1.2)


@pytest.mark.parametrize("fill", [1.0, 0.7])
def test_stiff_transfer_reaches_a_periodic_stroke(fill: float) -> None:
    # Two centimetres of plunger travel for the whole fluid load: stiffer than the explicit
    # step allows at the bottom node; the implicit pump spring keeps the stroke periodic
    # (it oscillated by 10-20 % of the load range from stroke to stroke before).
    grid, s, pump = _grid_and_pump(fill, transfer=0.02)
    run = grid.march(s, pump, 0.15, None, max_cycles=200, tol=1e-9)
    assert run.change < 1e-9
    assert run.cycles < 60
    assert np.all(np.isfinite(run.out))


def test_warm_start_lands_on_the_cold_stroke() -> None:
    grid, s, pump = _grid_and_pump(0.6, transfer=0.05)
    cold = grid.march(s, pump, 0.1, None, max_cycles=300, tol=1e-11)
    other = pump.copy()
    other[0] *= 1.2
    other[1] = 0.9
    far = grid.march(s, other, 0.2, None, max_cycles=300, tol=1e-11)
    warm = grid.march(s, pump, 0.1, far, max_cycles=300, tol=1e-11)
    span = np.ptp(cold.out[0])
    assert np.max(np.abs(warm.out - cold.out)[0]) < 1e-8 * span
    assert np.max(np.abs(warm.out[2] - cold.out[2])) < 1e-8 * np.ptp(cold.out[2])
    # Started from a nearby stroke it needs fewer strokes than from rest.
    assert warm.cycles < cold.cycles


def test_a_stroke_that_never_repeats_stops_when_its_change_stalls() -> None:
    # Undamped, the string's free vibration never dies out: the march stops once its change
    # has not halved over STALL strokes, not after every stroke allowed.
    from pumpid.rods.march import STALL

    grid, s, pump = _grid_and_pump(1.0, transfer=0.05)
    stuck = grid.march(s, pump, 0.0, None, max_cycles=2000, tol=1e-9)
    assert stuck.change > 1e-6
    assert stuck.cycles <= 3 * STALL
    # Barely damped, the same pump repeats (it alternated between two strokes 0.5 % of the
    # load range apart while the pump's spring ran past the valve's opening within a
    # step); a slow but steady approach is not cut short.
    for nu in (0.02, 0.1):
        assert grid.march(s, pump, nu, None, max_cycles=2000, tol=1e-9).change < 1e-9


def test_gas_settles_in_few_strokes() -> None:
    # Raising the barrel's reference to the stroke's lowest point takes the content above
    # it along: the pressure is unchanged, and a gassy barrel settles with the string
    # (it took 143 strokes at nu 0.05 when the content stayed behind).
    grid, s, pump = _grid_and_pump(0.7, transfer=0.05, ratio=0.3)
    run = grid.march(s, pump, 0.05, None, max_cycles=2000, tol=1e-9)
    assert run.change < 1e-9
    assert run.cycles < 40


@pytest.mark.parametrize("fill", [1.0, 0.6])
def test_a_march_carried_from_another_grid_lands_on_the_stroke_from_rest(fill: float) -> None:
    # A coarser grid's periodic stroke, carried over (StringGrid.carry), starts the finer
    # grid's march near its own: the same stroke as from rest, in fewer strokes.
    grid, s, pump = _grid_and_pump(fill, transfer=0.05)
    coarse = StringGrid.of(grid.well, 60 / SPM, s.size, 15)
    assert coarse.depth[-1] == pytest.approx(grid.depth[-1]) and coarse.depth.size < 20
    before = coarse.march(s, pump, 0.1, None, max_cycles=300, tol=1e-11)
    cold = grid.march(s, pump, 0.1, None, max_cycles=300, tol=1e-11)
    carried = grid.carry(before, coarse)
    assert carried.nodes.shape == (2, grid.mass.size)
    warm = grid.march(s, pump, 0.1, carried, max_cycles=300, tol=1e-11)
    span = float(np.ptp(cold.out[0]))
    assert np.max(np.abs(warm.out - cold.out)[0]) < 1e-8 * span
    assert warm.cycles < cold.cycles


@pytest.mark.parametrize(("fill", "ratio"), [(1.0, 0.02), (0.6, 0.02), (0.7, 0.3)])
def test_a_periodic_start_stops_after_one_stroke_on_its_stroke(fill: float,
                                                               ratio: float) -> None:
    # A march whose state ends the stroke where it began is periodic: started from its own
    # periodic end state it stops after one stroke (it took two, to compare two strokes'
    # loads), and a march stopped that way is as close to the periodic stroke as its
    # tolerance says.
    grid, s, pump = _grid_and_pump(fill, transfer=0.05, ratio=ratio)
    tight = grid.march(s, pump, 0.1, None, max_cycles=2000, tol=1e-13)
    again = grid.march(s, pump, 0.1, tight, max_cycles=2000, tol=1e-9)
    assert again.cycles == 1
    assert again.change < 1e-9
    span = float(np.ptp(tight.out[0]))
    for tol in (1e-5, 1e-7, 1e-9):
        # From a nearby pump's stroke: off by the transient the march left.
        other = pump.copy()
        other[0] *= 1.01
        near = grid.march(s, other, 0.1, tight, max_cycles=2000, tol=1e-13)
        run = grid.march(s, pump, 0.1, near, max_cycles=2000, tol=tol)
        assert run.change < tol
        assert np.max(np.abs(run.out[0] - tight.out[0])) < 3 * tol * span
