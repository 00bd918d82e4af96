"""The compiled kernels of the tree planners agree with the numpy arc algebra, the grid's own lookups and brute
force, and their collision check is conservative: an arc passed as free has no point in a blocked cell."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.trees import arcs, kernels


@pytest.fixture(scope="module")
def cluttered() -> OccupancyGrid:
    return planning_grid(rasterize_world(load_world(WORLDS_DIR / "cluttered.world"), 0.05))


def _random_arcs(grid: OccupancyGrid, n: int, seed: int) -> arcs.Arcs:
    rng = np.random.default_rng(seed)
    xmin, ymin, xmax, ymax = grid.extent
    start = rng.uniform([xmin, ymin], [xmax, ymax], (n, 2))
    target = start + rng.normal(0.0, 0.8, (n, 2))
    return arcs.connect(start, rng.uniform(-math.pi, math.pi, n), target)


def test_connect_one_is_the_numpy_arc() -> None:
    batch = _random_arcs(OccupancyGrid(np.zeros((10, 10), np.int8), 1.0, (-5.0, -5.0, 0.0)), 500, 1)
    ends = batch.start + batch.chord[:, None] * np.stack(
        [np.cos(batch.yaw + batch.alpha), np.sin(batch.yaw + batch.alpha)], axis=1
    )
    for i in range(len(batch.yaw)):
        alpha, curvature, length, end_yaw = kernels.connect_one(*batch.start[i], batch.yaw[i], *ends[i])
        assert (alpha, curvature, length) == pytest.approx(
            (batch.alpha[i], batch.curvature[i], batch.length[i]), rel=1e-9, abs=1e-9
        )
        assert math.cos(end_yaw - batch.end_yaw[i]) == pytest.approx(1.0, abs=1e-12)


def test_chain_poses_are_the_numpy_samples_of_each_arc_joined() -> None:
    rng = np.random.default_rng(4)
    for count in (1, 2, 7):
        points = np.cumsum(rng.normal(0.0, 0.7, (count + 1, 2)), axis=0)
        yaw = rng.uniform(-math.pi, math.pi, count)
        chain = arcs.connect(points[:-1], yaw, points[1:])
        poses, first = arcs.sample(chain, 0.05)
        keep = np.ones(len(poses), dtype=bool)
        keep[first[1:-1]] = False  # each later arc's first pose repeats the one before
        compiled = kernels.chain_poses(points[:-1].copy(), yaw, points[1:].copy(), 0.05)
        assert compiled.shape == (int(keep.sum()), 3)
        np.testing.assert_allclose(compiled[:, :2], poses[keep, :2], rtol=0, atol=1e-12)
        assert np.allclose(np.cos(compiled[:, 2] - poses[keep, 2]), 1.0, atol=1e-12)


def test_free_arcs_have_no_point_in_a_blocked_cell_and_arcs_through_one_are_refused(cluttered: OccupancyGrid) -> None:
    batch = _random_arcs(cluttered, 1500, 2)
    free = arcs.collision_free(batch, cluttered)
    # Every point at res / 32 (the kernel samples at res and res / 8): one blocked point means the arc is blocked.
    dense, first = arcs.sample(batch, cluttered.resolution / 32.0, with_yaw=False)
    truly_free = np.logical_and.reduceat(cluttered.is_free(dense[:, :2]), first[:-1])
    assert not np.any(free & ~truly_free)
    # Not a check that refuses everything: almost every truly free arc passes, the fine check included (arcs
    # whose samples leave the conservative mask but stay in free cells).
    assert np.count_nonzero(free) >= 0.97 * np.count_nonzero(truly_free) > 250
    cons = np.logical_and.reduceat(cluttered.lookup(cluttered.conservative_free_mask, dense[:, :2]), first[:-1])
    assert np.count_nonzero(free & ~cons) > 10


def test_where_limits_the_check_to_those_arcs(cluttered: OccupancyGrid) -> None:
    batch = _random_arcs(cluttered, 200, 3)
    where = np.arange(200) % 2 == 0
    assert np.array_equal(arcs.collision_free(batch, cluttered, where), arcs.collision_free(batch, cluttered) & where)


def test_lookups_match_the_grid_on_a_rotated_grid() -> None:
    rng = np.random.default_rng(4)
    values = np.where(rng.random((40, 60)) < 0.3, 100, 0).astype(np.int8)
    grid = OccupancyGrid(values, 0.1, (1.0, -2.0, 0.7))
    points = rng.uniform(-6.0, 8.0, (5000, 2))
    args = kernels.grid_args(grid)
    cons, free = args[:2]
    assert np.array_equal(kernels.lookup(points, free, args), grid.is_free(points))
    assert np.array_equal(kernels.lookup(points, cons, args), grid.lookup(grid.conservative_free_mask, points))
    one = [kernels.lookup_one(x, y, free, args) for x, y in points[:200]]
    assert one == grid.is_free(points[:200]).tolist()


def test_nearest_and_within_are_brute_force() -> None:
    rng = np.random.default_rng(5)
    position = rng.uniform(-10.0, 10.0, (3000, 2))
    n = 2500  # rows past n are not nodes yet
    for point in rng.uniform(-11.0, 11.0, (50, 2)):
        d = np.hypot(*(position[:n] - point).T)
        ids, dist = kernels.nearest_k(position, n, *point, 8)
        assert ids.tolist() == np.argsort(d, kind="stable")[:8].tolist()
        assert np.allclose(dist, np.sort(d)[:8])
        assert kernels.within_radius(position, n, *point, 1.5).tolist() == np.flatnonzero(d <= 1.5).tolist()
    assert len(kernels.nearest_k(position, 3, 0.0, 0.0, 8)[0]) == 3


def test_best_parent_is_the_cheapest_feasible_free_arc(cluttered: OccupancyGrid) -> None:
    rng = np.random.default_rng(6)
    position = rng.uniform(-4.0, 4.0, (400, 2))
    yaw = rng.uniform(-math.pi, math.pi, 400)
    cost = rng.uniform(0.0, 3.0, 400)
    args = kernels.grid_args(cluttered)
    found = 0
    for target in rng.uniform(-4.0, 4.0, (100, 2)):
        near = np.flatnonzero(np.hypot(*(position - target).T) < 1.5)
        into = arcs.connect(position[near], yaw[near], target)
        ok = arcs.checked(into, cluttered, math.pi / 2)
        through = np.where(ok, cost[near] + into.length, np.inf)
        parent, end_yaw, total = kernels.best_parent(
            near, position, yaw, cost, *target, arcs.alpha_limit(math.pi / 2), 0.0, args
        )
        if not ok.any():
            assert parent == -1
            continue
        found += 1
        k = int(np.argmin(through))
        assert (parent, total) == (near[k], pytest.approx(through[k]))
        assert end_yaw == pytest.approx(into.end_yaw[k])
    assert found > 20
