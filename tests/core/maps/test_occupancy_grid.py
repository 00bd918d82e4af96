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


def _square_distance(points: np.ndarray, row: int, col: int, res: float) -> np.ndarray:
    """Distance from points to the square of cell (row, col) of a grid at the origin."""
    dx = np.maximum(np.maximum(col * res - points[:, 0], points[:, 0] - (col + 1) * res), 0.0)
    dy = np.maximum(np.maximum(row * res - points[:, 1], points[:, 1] - (row + 1) * res), 0.0)
    return np.asarray(np.hypot(dx, dy))


@pytest.mark.parametrize(("radius", "res"), [(0.105, 0.05), (0.1, 0.05), (0.22, 0.1), (0.03, 0.05)])
def test_inflation_keeps_a_disc_anywhere_in_a_free_cell_off_every_occupied_square(radius: float, res: float) -> None:
    values = np.zeros((15, 15), dtype=np.int8)
    values[7, 7] = OCCUPIED
    values[0, 0] = UNKNOWN
    inflated = OccupancyGrid(values, res, (0.0, 0.0, 0.0)).inflate(radius)
    rng = np.random.default_rng(0)
    for row, col in zip(*np.nonzero(inflated.free_mask), strict=True):
        points = (np.array([col, row]) + rng.random((64, 2))) * res
        corners = (np.array([col, row]) + np.array([[0, 0], [0, 1], [1, 0], [1, 1]])) * res
        assert _square_distance(np.vstack([points, corners]), 7, 7, res).min() >= radius - 1e-12
    # Tight: from every newly blocked cell some point's disc does overlap the obstacle's square.
    for row, col in zip(*np.nonzero(inflated.occupied_mask & ~OccupancyGrid(values, res).occupied_mask), strict=True):
        nearest = np.clip([[7.5 * res, 7.5 * res]], [[col * res, row * res]], [[(col + 1) * res, (row + 1) * res]])
        assert _square_distance(nearest, 7, 7, res)[0] < radius + 1e-9
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


def test_inflating_by_a_large_radius_marks_the_cells_whose_squares_come_within_it() -> None:
    values = np.zeros((41, 41), dtype=np.int8)
    values[20, 20] = 100
    grown = OccupancyGrid(values, 0.1, (0.0, 0.0, 0.0)).inflate(1.0)
    rows, cols = np.mgrid[0:41, 0:41]
    gap_rows, gap_cols = np.maximum(np.abs(rows - 20) - 1, 0), np.maximum(np.abs(cols - 20) - 1, 0)
    expected = np.hypot(gap_rows, gap_cols) * 0.1 < 1.0 + 1e-9
    assert np.array_equal(grown.values == 100, expected)
