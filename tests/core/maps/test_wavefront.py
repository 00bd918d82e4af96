"""The wavefront navigation function: geodesic distances, no local minimum, corridors, cut-off goals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import NoPathFoundError
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid
from mrs_nav.maps.wavefront import wavefront


def _wall_with_gap() -> OccupancyGrid:
    values = np.zeros((40, 40), dtype=np.int8)
    values[:, 20] = OCCUPIED  # a wall at x = 2.0-2.1 m ...
    values[30:34, 20] = 0  # ... with a gap at y = 3.0-3.4 m
    return OccupancyGrid(values, 0.1, (0.0, 0.0, 0.0))


def test_distances_go_round_the_wall_and_have_no_local_minimum() -> None:
    grid = _wall_with_gap()
    wave = wavefront(grid, (3.05, 1.05), cell_m=0.1)
    # From (1.05, 1.05), 2 m straight across the wall, the way leads through the gap: about 2 x hypot(1, 2.1).
    far = float(wave.at(np.array([[1.05, 1.05]]))[0])
    assert 2 * math.hypot(1.0, 2.1) - 0.1 <= far <= 1.09 * 2 * math.hypot(1.0, 2.1)
    reachable = np.flatnonzero(np.isfinite(wave.distance.ravel()))
    nxt = wave.towards.ravel()[reachable]
    moving = nxt >= 0
    assert np.all(wave.distance.ravel()[nxt[moving]] < wave.distance.ravel()[reachable[moving]])
    assert np.count_nonzero(~moving) == 1  # only the goal has nowhere further down to go


def test_the_corridor_runs_from_the_start_through_the_gap_to_the_goal() -> None:
    grid = _wall_with_gap()
    path = wavefront(grid, (3.05, 1.05), cell_m=0.1).corridor(np.array([1.05, 1.05]))
    assert path is not None
    np.testing.assert_allclose(path[[0, -1]], [[1.05, 1.05], [3.05, 1.05]])
    crossing = path[np.abs(path[:, 0] - 2.05) < 0.06]
    assert np.all((crossing[:, 1] > 3.0) & (crossing[:, 1] < 3.4))
    assert grid.is_free(path).all()


def test_a_goal_walled_off_has_no_corridor_and_infinite_distance() -> None:
    grid = _wall_with_gap()
    values = grid.values.copy()
    values[30:34, 20] = OCCUPIED
    closed = OccupancyGrid(values, 0.1)
    wave = wavefront(closed, (3.05, 1.05), cell_m=0.1)
    with pytest.raises(NoPathFoundError, match=r"the goal \(3.05, 1.05\) cannot be reached from \(1.05, 1.05\)"):
        wave.corridor(np.array([1.05, 1.05]))
    assert math.isinf(float(wave.at(np.array([[1.05, 1.05]]))[0]))


def test_coarse_cells_are_free_only_when_all_their_cells_are_unless_optimistic() -> None:
    grid = _wall_with_gap()
    strict = wavefront(grid, (3.05, 1.05), cell_m=0.4)  # 4 x 4 blocks: the 0.4 m gap straddles two blocks
    loose = wavefront(grid, (3.05, 1.05), cell_m=0.4, optimistic=True)
    with pytest.raises(NoPathFoundError):
        strict.corridor(np.array([1.05, 1.05]))
    assert loose.corridor(np.array([1.05, 1.05])).shape[1] == 2
