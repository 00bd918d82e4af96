"""Planned paths keep the robot's radius from the exact world geometry (not only from the rasterised cells)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.trees import arcs
from mrs_nav.trees.rrt_star import RRTStarConfig, rrt_star
from mrs_nav.trees.scenarios import OFFICE_GOALS, OFFICE_START

QUERIES = {
    "office": (OFFICE_START, list(OFFICE_GOALS)),
    "cluttered": (Pose2D(-3.5, -3.5, 0.0), [(3.5, 3.5), (3.5, -3.0), (-3.0, 3.5)]),
}


def _world(name: str) -> tuple[OccupancyGrid, Obstacles]:
    world = load_world(WORLDS_DIR / f"{name}.world")
    return planning_grid(rasterize_world(world, 0.05), BURGER_RADIUS), Obstacles.from_world(world)


@pytest.mark.parametrize("name", ["simple", "office", "cluttered"])
def test_every_point_of_the_free_planning_cells_is_a_robot_radius_from_the_world(name: str) -> None:
    """Checked on the free cells within two cells of a blocked one: the closest to the obstacles."""
    grid, obstacles = _world(name)
    inner = ndimage.binary_erosion(grid.free_mask, structure=np.ones((5, 5), bool), border_value=0)
    rows, cols = np.nonzero(grid.free_mask & ~inner)
    sub = np.arange(5) / 4.0  # corners, edges and interior of each cell
    offsets = np.stack(np.meshgrid(sub, sub), axis=-1).reshape(-1, 2)
    cells = np.stack([cols, rows], axis=1)
    for chunk in range(0, len(cells), 1000):
        points = (cells[chunk : chunk + 1000, None, :] + offsets[None]) * grid.resolution + grid.origin[:2]
        distance, _ = obstacles.surface(points.reshape(-1, 2))
        assert distance.min() >= BURGER_RADIUS - 1e-9


@pytest.mark.parametrize("name", sorted(QUERIES))
def test_rrt_star_paths_keep_the_robot_radius_from_the_exact_geometry(name: str) -> None:
    grid, obstacles = _world(name)
    start, goals = QUERIES[name]
    for seed, goal in enumerate(goals):
        config = RRTStarConfig(iterations=600, time_budget=None)
        result = rrt_star(start, np.array(goal), grid, config, np.random.default_rng(seed))
        path = result.path
        dense, _ = arcs.sample(arcs.connect(path[:-1, :2], path[:-1, 2], path[1:, :2]), 0.005)
        distance, _ = obstacles.surface(dense[:, :2])
        assert distance.min() >= BURGER_RADIUS, (name, goal, float(distance.min()))
