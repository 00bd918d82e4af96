"""Occupancy grids: cell addressing, free/occupied/unknown queries on arrays of points, inflation."""

from __future__ import annotations

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid


def _grid() -> OccupancyGrid:
    values = np.zeros((3, 4), dtype=np.int8)  # 3 rows (y), 4 columns (x)
    values[0, 3] = OCCUPIED
    values[2, 0] = UNKNOWN
    values[1, 1] = 40  # uncertain: neither free nor occupied
    return OccupancyGrid(values, 0.5, (-1.0, 2.0, 0.0))


def test_points_are_looked_up_by_column_x_and_row_y() -> None:
    grid = _grid()
    points = np.array(
        [
            [-0.9, 2.1],  # cell (0, 0): free
            [0.9, 2.1],  # cell (0, 3): occupied
            [-0.9, 3.4],  # cell (2, 0): unknown
            [-0.4, 2.6],  # cell (1, 1): uncertain
            [-1.1, 2.1],  # left of the grid
            [0.0, 3.6],  # above the grid
        ]
    )
    assert grid.is_free(points).tolist() == [True, False, False, False, False, False]
    assert grid.is_occupied(points).tolist() == [False, True, False, False, False, False]
    assert grid.extent == pytest.approx((-1.0, 2.0, 1.0, 3.5))


def test_message_data_is_row_major_with_width_columns() -> None:
    data = [0, 0, 0, 100, 0, 0, 0, 0, -1, 0, 0, 0]
    grid = OccupancyGrid.from_message_data(data, width=4, height=3, resolution=0.5, origin=(-1.0, 2.0, 0.0))
    expected = _grid().values.copy()
    expected[1, 1] = 0
    assert np.array_equal(grid.values, expected)
    with pytest.raises(InvalidInputError, match="12 cells, expected 5 x 3"):
        OccupancyGrid.from_message_data(data, width=5, height=3, resolution=0.5, origin=(0, 0, 0))


def test_rotated_origin_rotates_the_lookup() -> None:
    values = np.zeros((1, 2), dtype=np.int8)
    values[0, 1] = OCCUPIED
    grid = OccupancyGrid(values, 1.0, (0.0, 0.0, np.pi / 2))  # columns run along +y
    assert grid.is_occupied([[-0.5, 1.5], [1.5, 0.5]]).tolist() == [True, False]
    assert grid.is_free([[-0.5, 0.5]]).tolist() == [True]


def test_inflation_uses_a_disk_kernel_and_keeps_unknown_not_free() -> None:
    values = np.zeros((9, 9), dtype=np.int8)
    values[4, 4] = OCCUPIED
    values[0, 0] = UNKNOWN
    inflated = OccupancyGrid(values, 0.05, (0.0, 0.0, 0.0)).inflate(0.105)
    # cells whose centre is within 0.105 m: offsets with 0.05 * hypot(i, j) <= 0.105 -> 1 + 4 + 4 + 4 = 13
    assert int(np.count_nonzero(inflated.occupied_mask)) == 13
    assert inflated.occupied_mask[4, 6]
    assert inflated.occupied_mask[5, 5]
    assert not inflated.occupied_mask[5, 6]
    assert inflated.values[0, 0] == UNKNOWN
    assert not inflated.free_mask[0, 0]
    assert np.array_equal(OccupancyGrid(values, 0.05).inflate(0.0).values, values)


def test_bad_grids_are_rejected() -> None:
    with pytest.raises(InvalidInputError, match="resolution"):
        OccupancyGrid(np.zeros((2, 2), np.int8), 0.0)
    with pytest.raises(InvalidInputError, match=r"-1\.\.100"):
        OccupancyGrid(np.full((2, 2), -5, np.int8), 0.1)
    with pytest.raises(InvalidInputError, match="radius"):
        OccupancyGrid(np.zeros((2, 2), np.int8), 0.1).inflate(-1.0)


def test_inflating_by_a_large_radius_marks_the_disk_around_each_occupied_cell() -> None:
    values = np.zeros((41, 41), dtype=np.int8)
    values[20, 20] = 100
    grown = OccupancyGrid(values, 0.1, (0.0, 0.0, 0.0)).inflate(1.0)
    rows, cols = np.mgrid[0:41, 0:41]
    expected = np.hypot(rows - 20, cols - 20) * 0.1 <= 1.0 + 1e-9
    assert np.array_equal(grown.values == 100, expected)
