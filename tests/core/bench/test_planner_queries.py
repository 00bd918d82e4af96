"""The planners bench's drawn queries: admissible, far enough apart, the same on every run."""

from __future__ import annotations

import numpy as np

from mrs_nav.bench.planner_queries import drawn_queries
from mrs_nav.maps.occupancy_grid import planning_grid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.trees.rrt import check_query


def test_drawn_queries_are_admissible_apart_and_repeatable() -> None:
    grid = planning_grid(rasterize_world(load_world(WORLDS_DIR / "cluttered.world"), 0.05))
    queries = drawn_queries(grid, 8, 7)
    assert len(queries) == 8
    for start, goal in queries:
        check_query(grid, start, goal)  # raises when the start or goal is not admissible
        assert np.hypot(*(goal - start.position)) >= grid.width * grid.resolution / 3.0
        assert grid.lookup(grid.conservative_free_mask, np.array([start.position, goal])).all()
    again = drawn_queries(grid, 8, 7)
    assert all(a[0] == b[0] and np.array_equal(a[1], b[1]) for a, b in zip(queries, again, strict=True))
    assert len({(s.x, s.y) for s, _ in queries}) == 8
