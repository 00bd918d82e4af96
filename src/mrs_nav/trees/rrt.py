"""RRT with circular-arc edges (assignment 3a-3b, LaValle's rapidly-exploring random tree).

Each iteration samples a free position (the goal itself with probability ``goal_bias``), picks as parent the
nearest node that is between ``min_step`` and ``max_step`` metres away with the sample ahead of it within
``max_alpha`` of its heading (the course's rule: 0.2 m, 1.5 m, 45 degrees), and adds the sample with the yaw
of the arc that reaches it (:func:`mrs_nav.trees.arcs.adjust_pose`) when that arc is collision-free. The search stops
at the first node within ``goal_tolerance`` of the goal; the path then ends on the goal itself when an arc from
that node reaches it, else on that node. New nodes within ``max_step`` of the goal also try the arc to the goal
directly, which finds the first path sooner.

The grid passed in is the one to stay inside: inflate it by the robot radius first
(:meth:`mrs_nav.maps.occupancy_grid.OccupancyGrid.inflate`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.admissible import grid_refusal
from mrs_nav.maps.occupancy_grid import IntArray, OccupancyGrid
from mrs_nav.planning import PlanResult, path_length
from mrs_nav.trees import arcs, kernels
from mrs_nav.trees.tree import ArcTree, Search, budget_used_up

# How many nearest nodes are screened for a parent before falling back to every node within max_step.
_PARENT_CANDIDATES = 16


@dataclass(frozen=True)
class RRTConfig:
    """Parameters of :func:`rrt`: counts, seconds, metres, radians.

    The search ends after ``iterations`` samples or ``time_budget`` seconds, whichever comes first (``None``
    means no limit on that count; at least one must be set).
    """

    iterations: int | None = 2000
    time_budget: float | None = None
    goal_bias: float = 0.05
    goal_tolerance: float = 0.2
    min_step: float = 0.2
    max_step: float = 1.5
    max_alpha: float = math.pi / 4
    min_turning_radius: float = 0.0
    connect_goal: bool = True

    def __post_init__(self) -> None:
        check_budget(self.iterations, self.time_budget)
        if not 0.0 <= self.goal_bias <= 1.0:
            raise InvalidInputError(f"goal_bias must lie in [0, 1], got {self.goal_bias}")
        if not 0.0 <= self.min_step < self.max_step:
            raise InvalidInputError(f"need 0 <= min_step < max_step, got {self.min_step}, {self.max_step}")
        if not 0.0 < self.max_alpha <= math.pi / 2:
            raise InvalidInputError(f"max_alpha must lie in (0, pi/2], got {self.max_alpha}")
        if not (self.goal_tolerance >= 0.0 and self.min_turning_radius >= 0.0):
            raise InvalidInputError("goal_tolerance and min_turning_radius must be >= 0")


def check_budget(iterations: int | None, time_budget: float | None) -> None:
    """Reject a budget with neither limit, a negative count or a non-finite / negative time."""
    if iterations is None and time_budget is None:
        raise InvalidInputError("a planner needs an iteration count or a time budget")
    if iterations is not None and iterations < 0:
        raise InvalidInputError(f"iterations must be >= 0, got {iterations}")
    if time_budget is not None and not (math.isfinite(time_budget) and time_budget >= 0.0):
        raise InvalidInputError(f"time budget must be finite and >= 0 s, got {time_budget}")


def check_query(grid: OccupancyGrid, start: Pose2D, goal: FloatArray) -> None:
    """Raise :class:`InvalidInputError` naming the problem when the start or goal is not admissible on ``grid``."""
    args = kernels.grid_args(grid)
    for what, point in (("start", start.position), ("goal", goal)):
        x, y = float(point[0]), float(point[1])
        # One compiled lookup answers the usual case (a free cell: what grid_refusal accepts); a refusal is
        # worded by grid_refusal.
        if math.isfinite(x) and math.isfinite(y) and kernels.lookup_one(x, y, args[1], args):
            continue
        why = grid_refusal(grid, x, y)
        if why:
            raise InvalidInputError(f"{what} ({point[0]:.3f}, {point[1]:.3f}) is {why}")


def sample_random_position(
    grid: OccupancyGrid,
    rng: np.random.Generator,
    goal: FloatArray | None = None,
    goal_bias: float = 0.0,
    max_tries: int = 100_000,
) -> FloatArray:
    """A position uniform over the grid's extent (origin to origin + resolution x shape) in its free space,
    or ``goal`` with probability ``goal_bias`` (assignment 3a). Draws in batches, so one call is a few numpy ops.
    """
    if goal is not None and goal_bias > 0.0 and rng.random() < goal_bias:
        return np.asarray(goal, dtype=np.float64)[:2].copy()
    x0, y0, _ = grid.origin
    span = np.array([grid.width, grid.height]) * grid.resolution
    c, s = math.cos(grid.origin[2]), math.sin(grid.origin[2])
    drawn = 0
    while drawn < max_tries:
        local = rng.random((32, 2)) * span
        points = np.stack([x0 + c * local[:, 0] - s * local[:, 1], y0 + s * local[:, 0] + c * local[:, 1]], axis=1)
        free = np.flatnonzero(grid.is_free(points))
        if len(free):
            out: FloatArray = points[free[0]]
            return out
        drawn += 32
    raise InvalidInputError(f"no free cell found in {max_tries} samples: the map has (almost) no free space")


def _pick_parent(tree: ArcTree, position: FloatArray, config: RRTConfig) -> int | None:
    """The nearest node with ``position`` between min_step and max_step away and ahead within max_alpha."""

    def first_ok(ids: IntArray, dist: FloatArray) -> int | None:
        heading = tree.yaw[ids]
        delta = position - tree.position[ids]
        # cos of the angle between the node's heading and the direction to the sample
        cos = (np.cos(heading) * delta[:, 0] + np.sin(heading) * delta[:, 1]) / np.maximum(dist, 1e-12)
        ok = np.flatnonzero((dist > config.min_step) & (dist < config.max_step) & (cos >= math.cos(config.max_alpha)))
        return int(ids[ok[0]]) if len(ok) else None

    ids, dist = tree.nearest(position, _PARENT_CANDIDATES)
    found = first_ok(ids, dist)
    if found is not None or len(ids) < _PARENT_CANDIDATES or dist[-1] >= config.max_step:
        return found
    near = tree.within(position, config.max_step)
    dist = np.hypot(*(tree.position[near] - position).T)
    order = np.argsort(dist, kind="stable")
    return first_ok(near[order], dist[order])


def grow_rrt(
    start: Pose2D,
    goal: FloatArray,
    grid: OccupancyGrid,
    config: RRTConfig,
    rng: np.random.Generator,
    *,
    clock: Callable[[], float] = time.perf_counter,
) -> Search:
    """Run RRT from ``start`` to ``goal`` (x, y) on ``grid``; return the result with its tree (for drawing).

    Raises :class:`~mrs_nav.trees.tree.NoPathInTreeError` (a :class:`NoPathFoundError` holding the tree) when the
    budget ends first, and :class:`InvalidInputError` when the start or goal is not admissible.

    Times and the budget are read from ``clock`` (wall time by default; benchmarks on a shared machine may pass
    :func:`time.process_time`)."""
    t0 = clock()
    goal = np.asarray(goal, dtype=np.float64)[:2]
    check_query(grid, start, goal)
    tree = ArcTree(start)
    deadline = math.inf if config.time_budget is None else t0 + config.time_budget
    limit = config.iterations if config.iterations is not None else math.inf
    iteration = 0
    while iteration < limit and clock() < deadline:
        iteration += 1
        position = sample_random_position(grid, rng, goal, config.goal_bias)
        parent = _pick_parent(tree, position, config)
        if parent is None:
            continue
        arc = arcs.connect(tree.position[parent], tree.yaw[parent], position)
        if not arcs.checked(arc, grid, config.max_alpha, config.min_turning_radius)[0]:
            continue
        node = tree.add(position, float(arc.end_yaw[0]), parent, float(tree.cost[parent] + arc.length[0]))
        to_goal = float(np.hypot(*(goal - position)))
        reached = to_goal <= config.goal_tolerance
        if (config.connect_goal and to_goal <= config.max_step) or reached:
            final = arcs.connect(position, tree.yaw[node], goal)
            if to_goal <= 1e-9 or arcs.checked(final, grid, math.pi / 2, config.min_turning_radius)[0]:
                return _solved(
                    tree, node, None if to_goal <= 1e-9 else goal, grid, elapsed=clock() - t0, iterations=iteration
                )
        if reached:
            return _solved(tree, node, None, grid, elapsed=clock() - t0, iterations=iteration)
    raise budget_used_up(tree, used_iterations=iteration >= limit, time_s=clock() - t0, iterations=iteration)


def _solved(
    tree: ArcTree, node: int, tail: FloatArray | None, grid: OccupancyGrid, *, elapsed: float, iterations: int
) -> Search:
    path = tree.path_poses(tree.branch(node), grid.resolution, tail)
    length = path_length(path)
    result = PlanResult(path, length, elapsed, elapsed, iterations, len(tree), "goal reached")
    return Search(result, tree, ((iterations, elapsed, length),))


def rrt(
    start: Pose2D,
    goal: FloatArray,
    grid: OccupancyGrid,
    config: RRTConfig | None = None,
    rng: np.random.Generator | None = None,
) -> PlanResult:
    """RRT from ``start`` to ``goal`` on ``grid`` (already inflated); see the module docstring and :func:`grow_rrt`."""
    return grow_rrt(start, goal, grid, config or RRTConfig(), rng or np.random.default_rng()).result
