"""Corridor-guided RRT*: across the office and a 100 m building in few iterations, with valid arc paths."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mrs_nav.errors import NoPathFoundError
from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.trees import arcs
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star, rrt_star
from mrs_nav.trees.scenarios import OFFICE_GOALS, OFFICE_START, building_grid, office_grid


def _valid(path: np.ndarray, grid: OccupancyGrid) -> bool:
    pieces = arcs.connect(path[:-1, :2], path[:-1, 2], path[1:, :2])
    dense, _ = arcs.sample(pieces, 0.01)
    return bool(arcs.feasible(pieces).all() and grid.is_free(dense).all())


@pytest.fixture(scope="module")
def office() -> OccupancyGrid:
    return planning_grid(office_grid())


def test_guided_rrt_star_crosses_the_office_in_few_iterations_where_uniform_sampling_does_not(
    office: OccupancyGrid,
) -> None:
    guided, uniform_found = [], 0
    for seed, goal in enumerate(OFFICE_GOALS):
        config = RRTStarConfig(iterations=150, time_budget=None, stop_at_first=True, guide_bias=0.7)
        guided.append(rrt_star(OFFICE_START, np.array(goal), office, config, np.random.default_rng(seed)))
        config = RRTStarConfig(iterations=150, time_budget=None, stop_at_first=True, guide_bias=0.0)
        try:
            rrt_star(OFFICE_START, np.array(goal), office, config, np.random.default_rng(seed))
        except NoPathFoundError:
            continue
        uniform_found += 1
    assert all(_valid(r.path, office) for r in guided)
    assert uniform_found <= 1


def test_guided_rrt_star_crosses_a_building_of_25_offices() -> None:
    raw = building_grid()
    grid = planning_grid(raw)
    tile = raw.width // 5 * raw.resolution
    goal = np.array([5.0 + 4 * tile, 5.0 + 4 * tile])  # the north-east office, about 125 m away
    config = RRTStarConfig(iterations=1500, time_budget=None, stop_at_first=True)
    result = grow_rrt_star(OFFICE_START, goal, grid, config, np.random.default_rng(0)).result
    assert _valid(result.path, grid)
    assert result.length_m > 160.0  # doors and rooms in the way: longer than the 130 m diagonal


def test_rrt_star_still_never_lengthens_its_best_path_with_the_guide(office: OccupancyGrid) -> None:
    improved = 0
    for seed in range(3):
        config = RRTStarConfig(iterations=1200, time_budget=None)
        search = grow_rrt_star(OFFICE_START, np.array(OFFICE_GOALS[0]), office, config, np.random.default_rng(seed))
        lengths = [length for _, _, length in search.history]
        assert all(b < a for a, b in itertools.pairwise(lengths))
        assert search.result.length_m == lengths[-1]
        improved += len(lengths) - 1
    assert improved >= 2  # the guide only seeds the first path; RRT* keeps shortening it


def test_a_start_facing_away_from_the_corridor_is_turned_onto_it_before_sampling() -> None:
    from mrs_nav.geometry import Pose2D
    from mrs_nav.maps.rasterize import rasterize_world
    from mrs_nav.maps.world import load_world
    from mrs_nav.resources import WORLDS_DIR
    from mrs_nav.trees.tree import NoPathInTreeError

    grid = planning_grid(rasterize_world(load_world(WORLDS_DIR / "cluttered.world"), 0.05))
    start, goal = Pose2D(-4.07, -4.46, 3.05), np.array([-0.2, -1.77])  # facing west, the way runs east
    config = RRTStarConfig(iterations=0, time_budget=None, stop_at_first=True)
    with pytest.raises(NoPathInTreeError) as failed:
        grow_rrt_star(start, goal, grid, config, np.random.default_rng(0))
    tree = failed.value.tree
    assert len(tree) >= 3  # the root, the turn, the straight onto the corridor
    edges = tree.edges()
    assert arcs.checked(edges, grid).all()
    last = len(tree) - 1
    heading = np.array([np.cos(tree.yaw[last]), np.sin(tree.yaw[last])])
    assert float(heading @ (goal - tree.position[last])) > 0.0  # now facing the goal's side
    found = grow_rrt_star(
        start, goal, grid, RRTStarConfig(iterations=60, time_budget=None, stop_at_first=True), np.random.default_rng(0)
    )
    assert _valid(found.result.path, grid)
