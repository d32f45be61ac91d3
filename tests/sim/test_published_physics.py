"""The plastic and fluid materials against published measurements, at a small size
(`litl.sim.validation`; the resolved comparison is benchmarks/materials.py and its results page).

* Dam break: the surge front of Martin & Moyce's (1952) n^2 = 2 water column, their Table 2.
* Granular collapse: the run-out of a sand column against Lube et al. (2005), and its deposit's
  slope against the friction angle.
"""

import numpy as np
import pytest

from litl.sim import validation


@pytest.fixture(scope="module")
def dam():
    return validation.dam_break(n_grid=48, frames=60)


def test_the_dam_break_front_follows_martin_and_moyce(dam):
    table = np.asarray(validation.MARTIN_MOYCE_TABLE_2)
    times = validation.martin_moyce_time(dam.times, 0.1, 2.0)
    front = np.interp(table[:, 0], times, dam.fronts / 0.1)
    later = table[:, 0] >= 1.0
    # Published simulations lead the experiment (its gate took time to lift: Lethe shifts its
    # curve by 0.175 in T); at dx 1/64 and 1/128 litl leads by about 8-10%. 20% here, at dx 1/48.
    np.testing.assert_allclose(front[later], table[later, 1], rtol=0.2)
    # Never faster than the shallow-water (Ritter) front 1 + 2 T, and the column does collapse.
    assert np.all(dam.fronts / 0.1 < 1 + 2 * times + 0.05)
    assert front[-1] > 3.5


def test_water_keeps_its_volume(dam):
    """A weakly compressible fluid: its volume (the mean of det F) stays the column's to a few
    percent all the way (the front, not the volume, is what moves)."""
    # Bulk modulus K = 1e6 Pa: the hydrostatic head compresses it by rho g H / K = 0.2%, the surge's
    # dynamic pressure rho (2 sqrt(g H))^2 / K by 0.8%; 2% allows for MPM's own error in det F.
    np.testing.assert_allclose(dam.volume, 1.0, atol=0.02)
    assert dam.kinetic[-1] > 0  # still flowing at T = 3.4
    assert np.all(np.isfinite(dam.positions))


@pytest.mark.parametrize("aspect", [0.5, 1.0])
def test_a_sand_column_runs_out_as_lube_measured(aspect):
    run = validation.granular_collapse(aspect, n_grid=48)
    runout = (run.runout - 0.1) / 0.1
    # Lube et al. 2005 (quasi-2D channels): 1.2 a below a = 1.8. Plane-strain simulations of
    # these channel experiments are known to run out further (Kumar 2015; Dunatunga & Kamrin
    # 2015); litl lands at 0.86x-0.92x of Lube's fit at dx 1/64 and 0.97x-1.11x at dx 1/128.
    low, high = validation.lube_runout(aspect)
    assert 0.7 * low < runout < 1.4 * high
    assert run.kinetic[-1] < 1e-2 * run.kinetic.max()  # come to rest


@pytest.mark.parametrize("friction_angle", [20.0, 30.0])
def test_a_sand_slope_stands_below_its_friction_angle_and_avalanches_above(friction_angle):
    """The angle of repose lies near the friction angle: a heap 10 degrees shallower keeps its
    slope; one 10 degrees steeper avalanches (its slope falls, its toe runs out)."""
    n = 32
    standing = validation.sand_wedge(friction_angle - 10, friction_angle, n_grid=n, seconds=0.4)
    falling = validation.sand_wedge(friction_angle + 10, friction_angle, n_grid=n, seconds=0.4)
    before = [
        validation.deposit_slope(validation.wedge(0.4, a, n), 1 / n)
        for a in (friction_angle - 10, friction_angle + 10)
    ]
    assert validation.deposit_slope(standing.positions, 1 / n) == pytest.approx(before[0], abs=2.0)
    assert validation.deposit_slope(falling.positions, 1 / n) < before[1] - 5.0
    assert falling.runout - 0.4 > 1 / n
    assert standing.runout - 0.4 < 1 / n


def test_a_steeper_sand_runs_out_less():
    runs = [validation.granular_collapse(1.0, n_grid=32, friction_angle=phi) for phi in (20.0, 40.0)]
    assert runs[1].runout < 0.85 * runs[0].runout
