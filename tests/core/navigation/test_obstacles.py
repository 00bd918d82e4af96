"""Marking and clearing of obstacles the map lacks (navigation.obstacles), as costmap_2d's obstacle layer."""

from __future__ import annotations

import math

import numpy as np

from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid
from mrs_nav.navigation.obstacles import ScanObstacles, beam_cells

RES = 0.05


def room() -> OccupancyGrid:
    """10 m x 10 m, free inside a one-cell wall, origin at (-5, -5)."""
    values = np.zeros((200, 200), dtype=np.int8)
    values[0, :] = values[-1, :] = values[:, 0] = values[:, -1] = OCCUPIED
    return OccupancyGrid(values, RES, (-5.0, -5.0, 0.0))


def marked_at(layer: ScanObstacles, x: float, y: float) -> bool:
    assert layer.marks is not None
    assert layer._raw is not None
    rows, cols, _ = layer._raw.cells(np.array([[x, y]]))
    return bool(layer.marks[rows[0], cols[0]])


def test_a_box_pushed_back_a_few_centimetres_leaves_no_mark_in_front_of_its_new_face() -> None:
    layer = ScanObstacles()
    layer.set_map(room())
    layer.add_scan([0.0, 0.0], [[1.02, 0.0]], [True])
    assert marked_at(layer, 1.02, 0.0)
    layer.add_scan([0.0, 0.0], [[1.055, 0.0]], [True])  # the cell of 1.02 is the one right before the return
    assert marked_at(layer, 1.055, 0.0)
    assert not marked_at(layer, 1.02, 0.0)


def test_a_beam_clears_every_cell_it_crosses_even_at_a_corner() -> None:
    grid = room()
    origin = np.array([0.01, 0.013])
    ends = np.array([[math.cos(a) * 3.0, math.sin(a) * 3.0] for a in np.linspace(0.1, 1.4, 40)]) + origin
    rows, cols = beam_cells(grid, origin, ends, np.zeros(len(ends), dtype=bool))
    crossed = set(zip(rows.tolist(), cols.tolist(), strict=True))
    # every cell a densely sampled beam touches is among them
    t = np.linspace(0.0, 1.0, 20001)[:, None]
    for end in ends:
        r, c, _ = grid.cells(origin + t * (end - origin))
        assert set(zip(r.tolist(), c.tolist(), strict=True)) <= crossed


def test_returns_beyond_the_obstacle_range_are_not_marked_and_beams_clear_up_to_the_raytrace_range() -> None:
    layer = ScanObstacles(obstacle_range_m=3.0, raytrace_range_m=3.5)
    layer.set_map(room())
    layer.add_scan([0.0, 0.0], [[3.4, 0.0], [0.0, 2.0], [0.0, -3.3]], [True, True, False])
    assert not marked_at(layer, 3.4, 0.0)  # the laser still sees it, but too far to trust its place
    assert marked_at(layer, 0.0, 2.0)
    layer.add_scan([0.0, 1.3], [[0.0, 4.8]], [True])  # a beam past the mark, returning beyond the clear range
    assert not marked_at(layer, 0.0, 2.0)
    layer.add_scan([0.0, 0.0], [[0.0, 2.0]], [True])
    layer.add_scan([0.0, -1.6], [[0.0, 3.5]], [False])  # 3.6 m away: out of the clearing range
    assert marked_at(layer, 0.0, 2.0)


def test_a_scan_that_may_not_mark_still_clears() -> None:
    layer = ScanObstacles()
    layer.set_map(room())
    layer.add_scan([0.0, 0.0], [[1.0, 0.0]], [True], mark=False)
    assert not marked_at(layer, 1.0, 0.0)
    layer.add_scan([0.0, 0.0], [[1.0, 0.0]], [True])
    assert layer.add_scan([0.0, 0.0], [[2.0, 0.0]], [True], mark=False)
    assert not marked_at(layer, 1.0, 0.0)
    assert not marked_at(layer, 2.0, 0.0)


def test_clear_drops_marks_beyond_a_distance_or_all() -> None:
    layer = ScanObstacles()
    layer.set_map(room())
    layer.add_scan([0.0, 0.0], [[1.0, 0.0], [-2.5, 0.0]], [True, True])
    assert layer.clear([0.0, 0.0], 2.0) == 1
    assert marked_at(layer, 1.0, 0.0)
    assert not marked_at(layer, -2.5, 0.0)
    assert layer.clear() == 1
    assert not marked_at(layer, 1.0, 0.0)
