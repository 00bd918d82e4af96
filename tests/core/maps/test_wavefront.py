"""The wavefront navigation function: geodesic distances, no local minimum, corridors, cut-off goals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import NoPathFoundError
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid
from mrs_nav.maps.route_kernels import goal_search, landmark_fields
from mrs_nav.maps.wavefront import coarse_mask, goal_field, wavefront


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


def _rooms() -> OccupancyGrid:
    """Four 2 m rooms in a row, each wall with one door, at alternating ends (a detour the octile bound misses)."""
    values = np.zeros((20, 80), dtype=np.int8)
    for k, wall in enumerate((20, 40, 60)):
        values[:, wall] = OCCUPIED
        door = slice(1, 4) if k % 2 else slice(16, 19)
        values[door, wall] = 0
    return OccupancyGrid(values, 0.1, (0.0, 0.0, 0.0))


@pytest.mark.parametrize("landmarks", [0, 3])
def test_the_goal_field_settles_exact_distances_and_the_same_corridor_length_as_the_full_wavefront(
    landmarks: int,
) -> None:
    grid = _rooms()
    start, goal = np.array([0.55, 0.55]), np.array([7.55, 0.55])
    full = wavefront(grid, goal, cell_m=0.1)
    free = coarse_mask(grid, 0.1)
    seeds = np.array([5 * 80 + 75], dtype=np.intp)
    fields = landmark_fields(free, landmarks)
    dist, _ = goal_search(free, seeds, 5 * 80 + 5, fields)
    settled = np.isfinite(dist)
    np.testing.assert_allclose(dist[settled] * 0.1, full.distance.ravel()[settled], atol=1e-12)
    assert 0 < settled.sum() < np.isfinite(full.distance).sum()  # a band, not the map
    field = goal_field(grid, goal, start, cell_m=0.1)
    assert field.at(start[None])[0] == pytest.approx(full.at(start[None])[0])
    corridor = field.corridor(start)
    assert math.isclose(
        np.hypot(*np.diff(corridor, axis=0).T).sum(),
        np.hypot(*np.diff(full.corridor(start), axis=0).T).sum(),
        rel_tol=0.05,
    )
    assert grid.is_free(corridor).all()


def test_landmarks_narrow_the_band_a_detour_makes_the_search_settle() -> None:
    free = coarse_mask(_rooms(), 0.1)
    seeds, start = np.array([5 * 80 + 75], dtype=np.intp), 5 * 80 + 5
    plain, _ = goal_search(free, seeds, start, landmark_fields(free, 0))
    guided, _ = goal_search(free, seeds, start, landmark_fields(free, 3))
    assert np.isfinite(guided).sum() < 0.7 * np.isfinite(plain).sum()
    assert guided[start] == pytest.approx(plain[start])
