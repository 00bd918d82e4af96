import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.grid import OCCUPIED_LOGODDS, LogOddsGrid
from mrs_nav.slam.scan import LaserScanData, split_beams


def one_beam(r: float, range_max: float = 10.0) -> LaserScanData:
    return LaserScanData(0.0, 0.01, 0.1, range_max, np.array([r]))


def cell_value(grid: LogOddsGrid, x: float, y: float) -> float:
    ix, iy = grid.cell_of(np.array([x]), np.array([y]))
    return float(grid.logodds_at(iy, ix)[0])


def test_a_beam_clears_its_path_and_marks_its_end():
    grid = LogOddsGrid(0.05, (-5, -5, 5, 5))
    grid.integrate(Pose2D(0.0, 0.0, 0.0), split_beams(one_beam(2.0), 8.0))
    for x in np.arange(0.02, 1.9, 0.05):
        assert cell_value(grid, x, 0.01) < 0.0, x
    assert cell_value(grid, 2.01, 0.01) > 0.0
    assert cell_value(grid, 2.3, 0.01) == 0.0  # beyond the end: unknown


def test_beams_beyond_usable_range_only_clear_up_to_it():
    grid = LogOddsGrid(0.05, (-5, -5, 5, 5))
    grid.integrate(Pose2D(0.0, 0.0, 0.0), split_beams(one_beam(4.0), max_usable=2.0))
    assert cell_value(grid, 1.5, 0.01) < 0.0
    assert cell_value(grid, 2.5, 0.01) == 0.0
    assert not grid.occupied().any()


@pytest.mark.parametrize("reading", [math.nan, math.inf, -math.inf, -1.0, 0.05, 10.0, 25.0])
def test_invalid_and_no_return_readings_leave_the_map_alone(reading):
    grid = LogOddsGrid(0.05, (-5, -5, 5, 5))
    grid.integrate(Pose2D(0.0, 0.0, 0.0), split_beams(one_beam(reading), 8.0))
    assert not grid.dense()[0].any()


def test_end_points_stay_occupied_under_repeated_observation():
    grid = LogOddsGrid(0.05, (-5, -5, 5, 5), lmax=3.0)
    beams = split_beams(LaserScanData(-0.3, 0.01, 0.1, 10.0, np.full(61, 2.0)), 8.0)
    for _ in range(20):
        grid.integrate(Pose2D(0.0, 0.0, 0.0), beams)
    assert grid.dense()[0].max() == pytest.approx(3.0)
    assert grid.dense()[0].min() == pytest.approx(-3.0)
    assert (grid.to_occupancy() == 100).sum() > 20


def test_grid_grows_when_the_scan_leaves_the_extent():
    grid = LogOddsGrid(0.05, (-1, -1, 1, 1))
    grid.integrate(Pose2D(3.0, -4.0, 0.5), split_beams(one_beam(2.0), 8.0))
    end = (3.0 + 2.0 * math.cos(0.5), -4.0 + 2.0 * math.sin(0.5))
    assert cell_value(grid, *end) > 0.0
    assert grid.origin_x <= 1.0
    assert grid.origin_y <= -4.0


def test_fixed_extent_is_honoured():
    grid = LogOddsGrid(0.05, (-1, -1, 1, 1), grows=False)
    shape = grid.dense()[0].shape
    grid.integrate(Pose2D(0.0, 0.0, 0.0), split_beams(one_beam(3.0), 8.0))
    assert grid.dense()[0].shape == shape
    assert (grid.dense()[0] < 0).sum() >= 15  # the part of the beam inside the extent was still used
    assert not grid.occupied().any()


def test_bad_extent_is_rejected():
    with pytest.raises(InvalidInputError, match="extent"):
        LogOddsGrid(0.05, (1, 0, 0, 1))


def test_growth_keeps_every_cell_where_it_was():
    """Growing by cells that are not whole tiles shifts the cells within their tiles; the map stays put."""
    grid = LogOddsGrid(0.05, (-1, -1, 1, 1))
    for yaw in (0.0, 1.0, 2.5):
        grid.integrate(Pose2D(0.2, -0.1, yaw), split_beams(one_beam(0.9), 8.0))
    before, origin = grid.dense(), (grid.origin_x, grid.origin_y)
    grid.ensure_contains(-1.37, -2.91, 4.03, 1.0)
    assert (grid.shift_x, grid.shift_y) != (0, 0)
    dx = round((origin[0] - grid.origin_x) / 0.05)
    dy = round((origin[1] - grid.origin_y) / 0.05)
    for old, new in zip(before, grid.dense(), strict=True):
        height, width = old.shape
        np.testing.assert_array_equal(new[dy : dy + height, dx : dx + width], old)
        assert np.count_nonzero(new) == np.count_nonzero(old)
    assert (grid.to_occupancy() >= 0).sum() == (before[0] < 0).sum() + (before[0] >= OCCUPIED_LOGODDS).sum()
