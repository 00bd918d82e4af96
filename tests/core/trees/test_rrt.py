"""RRT and RRT* on the course arena: valid arc paths, monotone RRT* improvement, failures that are not paths."""

from __future__ import annotations

import itertools
import math
import statistics
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.geometry import FloatArray, Pose2D, wrap_angles
from mrs_nav.maps.map_io import load_map
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid
from mrs_nav.trees import arcs
from mrs_nav.trees.rrt import RRTConfig, grow_rrt, rrt, sample_random_position
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star, rrt_star
from mrs_nav.trees.tree import ArcTree, NoPathInTreeError

REPO = Path(__file__).resolve().parents[3]
START = Pose2D(-1.5, -1.5, 0.0)
GOAL = np.array([1.5, 1.5])


@pytest.fixture(scope="module")
def arena() -> OccupancyGrid:
    return load_map(REPO / "maps" / "simple.yaml").inflate(0.105)


def assert_valid_path(path: FloatArray, grid: OccupancyGrid, start: Pose2D, goal: FloatArray, tol: float) -> None:
    """Starts at the start pose, ends within tol of the goal, and is a chain of forward, tangent-continuous arcs
    that is free in the inflated grid when sampled every 0.01 m."""
    assert np.allclose(path[0], [start.x, start.y, start.yaw])
    assert np.hypot(*(path[-1, :2] - goal)) <= tol
    pieces = arcs.connect(path[:-1, :2], path[:-1, 2], path[1:, :2])
    assert np.allclose(wrap_angles(pieces.end_yaw - path[1:, 2]), 0.0, atol=1e-6), "a yaw is not tangent"
    assert arcs.feasible(pieces).all(), "a piece drives backwards"
    dense, _ = arcs.sample(pieces, 0.01)
    assert grid.is_free(dense).all(), "the path touches an inflated obstacle"


def assert_valid_tree(tree: ArcTree, grid: OccupancyGrid) -> None:
    """Every edge is a feasible, collision-free arc whose end yaw is the child's yaw; costs add up; each node's
    linked list of children holds exactly the nodes whose parent it is (after every rewire)."""
    for node in range(len(tree)):
        children, child = [], tree.first_child[node]
        while child >= 0:
            children.append(int(child))
            child = tree.next_sibling[child]
        assert sorted(children) == np.flatnonzero(tree.parent[: len(tree)] == node).tolist()
    edges = tree.edges()
    child = np.arange(1, len(tree))
    assert np.allclose(wrap_angles(edges.end_yaw - tree.yaw[child]), 0.0, atol=1e-9)
    assert arcs.checked(edges, grid).all()
    assert np.allclose(tree.cost[child], tree.cost[tree.parent[child]] + edges.length)


def test_sample_random_position_stays_in_free_space_and_honours_goal_bias(arena: OccupancyGrid) -> None:
    rng = np.random.default_rng(0)
    points = np.array([sample_random_position(arena, rng) for _ in range(300)])
    assert arena.is_free(points).all()
    assert points[:, 0].min() < -1.5
    assert points[:, 0].max() > 1.5
    hits = sum(np.array_equal(sample_random_position(arena, rng, GOAL, 0.3), GOAL) for _ in range(1000))
    assert 240 < hits < 360


@pytest.mark.parametrize("seed", range(5))
def test_rrt_paths_are_valid_arcs(arena: OccupancyGrid, seed: int) -> None:
    search = grow_rrt(START, GOAL, arena, RRTConfig(), np.random.default_rng(seed))
    assert_valid_path(search.result.path, arena, START, GOAL, RRTConfig().goal_tolerance)
    assert_valid_tree(search.tree, arena)
    assert search.result.length_m > 4.29


@pytest.mark.parametrize("seed", range(5))
def test_rrt_star_paths_and_trees_stay_valid_after_rewiring(arena: OccupancyGrid, seed: int) -> None:
    config = RRTStarConfig(iterations=400, time_budget=None)
    search = grow_rrt_star(START, GOAL, arena, config, np.random.default_rng(seed))
    assert_valid_path(search.result.path, arena, START, GOAL, 1e-9)
    assert_valid_tree(search.tree, arena)
    lengths = [length for _, _, length in search.history]
    assert lengths == sorted(lengths, reverse=True)


def test_rrt_star_best_length_never_grows_with_iterations(arena: OccupancyGrid) -> None:
    lengths = [
        rrt_star(START, GOAL, arena, RRTStarConfig(iterations=n, time_budget=None), np.random.default_rng(7)).length_m
        for n in (60, 120, 250, 500)
    ]
    assert all(b <= a for a, b in itertools.pairwise(lengths))
    assert lengths[-1] < lengths[0]


def test_rrt_star_beats_rrt_over_twenty_seeds(arena: OccupancyGrid) -> None:
    star = [
        rrt_star(START, GOAL, arena, RRTStarConfig(iterations=250, time_budget=None), np.random.default_rng(s))
        for s in range(20)
    ]
    plain = [rrt(START, GOAL, arena, RRTConfig(), np.random.default_rng(s)) for s in range(20)]
    assert statistics.median(r.length_m for r in star) < statistics.median(r.length_m for r in plain)


def test_a_start_and_goal_next_to_the_inflated_walls_can_be_left_and_reached(arena: OccupancyGrid) -> None:
    start, goal = Pose2D(1.82, -1.0, math.pi / 2), np.array([-1.82, 1.82])
    assert not arena.lookup(arena.conservative_free_mask, start.position)[0]  # within a cell of the inflation
    config = RRTStarConfig(iterations=600, time_budget=None)
    search = grow_rrt_star(start, goal, arena, config, np.random.default_rng(0))
    assert_valid_path(search.result.path, arena, start, goal, 1e-9)


# Facing the goal nearly: one arc. Facing away: a turn of less than half a circle, then straight. Facing straight
# away: the turn exceeds what one arc turns (twice its alpha, below pi), so it is split in two arcs, then straight.
@pytest.mark.parametrize(("yaw", "nodes"), [(0.3, 2), (3.0, 3), (math.atan2(1.0, 15.0) - math.pi, 4)])
def test_rrt_star_takes_a_free_arc_or_turn_then_straight_to_a_far_goal_at_once_and_only_shortens_it(
    yaw: float, nodes: int
) -> None:
    grid = OccupancyGrid(np.zeros((200, 400), dtype=np.int8), 0.05, (0.0, 0.0, 0.0)).inflate(0.105)
    # 17.7 m away (many steps of 1.5 m); facing away from it, no single arc reaches it: turn, then straight
    start, goal = Pose2D(3.0, 5.0, yaw), np.array([18.0, 6.0])
    first = grow_rrt_star(start, goal, grid, RRTStarConfig(iterations=0, time_budget=None), np.random.default_rng(0))
    assert first.result.iterations == 0
    assert len(first.tree) == nodes  # the root, the end of each piece of the turn, the goal
    assert_valid_path(first.result.path, grid, start, goal, 1e-9)
    config = RRTStarConfig(iterations=300, time_budget=None)
    search = grow_rrt_star(start, goal, grid, config, np.random.default_rng(0))
    assert search.history[0][0] == 0
    assert search.result.length_m <= first.result.length_m


def test_minimum_turning_radius_is_respected(arena: OccupancyGrid) -> None:
    config = RRTStarConfig(iterations=400, time_budget=None, min_turning_radius=0.3)
    search = grow_rrt_star(START, GOAL, arena, config, np.random.default_rng(1))
    pieces = search.tree.edges()
    assert (np.abs(pieces.curvature) <= 1 / 0.3 + 1e-9).all()


def test_an_unreachable_goal_raises_no_path_found_not_a_path() -> None:
    values = np.zeros((60, 60), dtype=np.int8)
    values[40:50, 40] = values[40:50, 50] = values[40, 40:51] = values[50, 40:51] = OCCUPIED  # a closed box
    grid = OccupancyGrid(values, 0.05, (0.0, 0.0, 0.0))
    start, goal = Pose2D(0.5, 0.5, 0.0), np.array([2.25, 2.25])
    for grow, config in (
        (grow_rrt, RRTConfig(iterations=300)),
        (grow_rrt_star, RRTStarConfig(iterations=300, time_budget=None)),
    ):
        with pytest.raises(NoPathFoundError, match="no path found: iteration budget used up") as caught:
            grow(start, goal, grid, config, np.random.default_rng(0))
        assert isinstance(caught.value, NoPathInTreeError)
        assert caught.value.iterations == 300
        assert caught.value.nodes == len(caught.value.tree) > 1  # the tree it grew, for drawing


@pytest.mark.parametrize(
    ("start", "goal", "message"),
    [
        (Pose2D(0.3, 0.2, 0.0), GOAL, r"start \(0.300, 0.200\) is in an obstacle"),
        (START, np.array([1.95, 0.0]), r"goal \(1.950, 0.000\) is in an obstacle"),
        (START, np.array([5.0, 0.0]), "goal .* is outside the map"),
    ],
)
def test_bad_queries_raise_naming_start_or_goal(
    arena: OccupancyGrid, start: Pose2D, goal: FloatArray, message: str
) -> None:
    with pytest.raises(InvalidInputError, match=message):
        rrt_star(start, goal, arena, RRTStarConfig(iterations=10, time_budget=None))


def test_unknown_space_is_never_a_goal() -> None:
    values = np.zeros((10, 10), dtype=np.int8)
    values[:, 5:] = -1
    grid = OccupancyGrid(values, 0.1, (0.0, 0.0, 0.0))
    with pytest.raises(InvalidInputError, match="unknown space"):
        rrt(Pose2D(0.2, 0.2), np.array([0.8, 0.5]), grid)


def test_budget_must_be_given() -> None:
    with pytest.raises(InvalidInputError, match="iteration count or a time budget"):
        RRTStarConfig(iterations=None, time_budget=None)
    with pytest.raises(InvalidInputError, match="time budget"):
        RRTStarConfig(time_budget=math.inf)
