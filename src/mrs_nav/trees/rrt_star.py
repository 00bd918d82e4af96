"""RRT* with circular-arc edges (assignment 3d): ExtendRRT* of Karaman & Frazzoli (arXiv:1005.0416, Alg. 4).

Each iteration:

1. sample a free position (the goal with probability ``goal_bias`` until a path exists; afterwards, with
   ``informed``, uniformly inside the ellipse of points that could shorten the best path: foci start and goal,
   major axis the best length, since no path through ``x`` is shorter than ``|x - start| + |x - goal|``);
2. steer from the nearest node towards it by at most ``step`` metres to ``x_new``;
3. choose as parent the near node (within ``r_n = min(step, gamma sqrt(log n / n))``) whose arc to ``x_new`` is
   feasible (forward, ``|alpha| <= max_alpha``, radius >= ``min_turning_radius``), collision-free and gives
   the least cost (arc length from the start); ``x_new`` takes that arc's end yaw;
4. rewire: every near node that becomes cheaper through ``x_new`` gets ``x_new`` as parent and the yaw of the
   arc from ``x_new``. Its yaw changes, so the arcs to its children change too: the whole subtree is
   re-derived level by level (each child keeps its position, takes the end yaw of the new arc from its
   parent) and the rewire is kept only when every re-derived arc is feasible and collision-free and no node of
   the subtree gets more expensive. Every edge of the tree thus stays a valid arc, and costs never grow.

``gamma = 2 gamma*`` unless given, where ``gamma* = 2 sqrt(1 + 1/2) sqrt(A_free / pi)`` is Karaman &
Frazzoli's lower bound for d = 2 (``A_free`` the free area of the grid): any gamma above the bound keeps
asymptotic optimality, and twice the bound rewires more widely early on, which reached short paths about a third
sooner in the arena benchmark. The search runs until the iteration or time budget ends (``stop_at_first`` ends it at
the first path) and returns the best path found; the tree's costs are monotone, so the best path's length never
grows with more iterations. The path ends exactly on the goal position (a goal node).

Before the first iteration the single arc from the start pose to the goal is tried (one compiled check, at any
distance), then a few turn-then-straight ways (:mod:`mrs_nav.trees.primitives`: the turn in one arc, or two for a
goal behind): a feasible and free one is the first path at once, and the search only shortens it. Else the
corridor of the guide (:mod:`mrs_nav.trees.guide`) is followed from corner to corner by such ways
(:func:`mrs_nav.trees.primitives.follow_corridor`): the first path when they reach the goal, else the tree's
first branch. Until a path exists, samples are drawn from the goal, the corridor guide and the map
(:mod:`mrs_nav.trees.samplers`), and the iterations run in compiled blocks (:mod:`mrs_nav.trees.search_kernels`);
afterwards samples come from the informed set, one iteration at a time.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.planning import PlanResult, path_length
from mrs_nav.trees import arcs, kernels, search_kernels
from mrs_nav.trees.guide import TRIES, CorridorSampler
from mrs_nav.trees.guide_kernels import field_at
from mrs_nav.trees.primitives import TURN_RADII, follow_corridor, turn_then_straight
from mrs_nav.trees.rrt import check_budget, check_query
from mrs_nav.trees.samplers import InformedSampler, UniformSampler
from mrs_nav.trees.search_kernels import GuideArgs
from mrs_nav.trees.tree import ArcTree, Search, budget_used_up

# Iterations per compiled call until the first path (the clock is read between calls).
_BLOCK = 32
# The guide's arguments when there is no guide (the kernel then never reads them).
_NO_AHEAD = np.zeros((0, TRIES))
_NO_NOISE = np.zeros((0, TRIES, 2))
_NO_GUIDE: GuideArgs = (0.0, np.zeros(1), np.zeros((1, 2)), np.zeros((1, 1)), 1)


@dataclass(frozen=True)
class RRTStarConfig:
    """Parameters of :func:`rrt_star` (counts, seconds, metres, radians); ``None`` budget = no limit on it."""

    iterations: int | None = None
    time_budget: float | None = 0.5
    goal_bias: float = 0.2
    step: float = 1.5
    max_alpha: float = math.pi / 2
    min_turning_radius: float = 0.0
    informed: bool = True
    gamma: float | None = None
    stop_at_first: bool = False
    guide_bias: float = 0.7
    guide_cell: float = 0.2

    def __post_init__(self) -> None:
        check_budget(self.iterations, self.time_budget)
        if not (0.0 <= self.goal_bias <= 1.0 and 0.0 <= self.guide_bias <= 1.0 - self.goal_bias):
            raise InvalidInputError(
                f"need goal_bias and guide_bias >= 0 with a sum <= 1, got {self.goal_bias}, {self.guide_bias}"
            )
        if not (math.isfinite(self.guide_cell) and self.guide_cell > 0.0):
            raise InvalidInputError(f"guide_cell must be positive, got {self.guide_cell}")
        if not (math.isfinite(self.step) and self.step > 0.0):
            raise InvalidInputError(f"step must be positive, got {self.step}")
        if not 0.0 < self.max_alpha <= math.pi / 2:
            raise InvalidInputError(f"max_alpha must lie in (0, pi/2], got {self.max_alpha}")
        if self.min_turning_radius < 0.0 or (self.gamma is not None and self.gamma <= 0.0):
            raise InvalidInputError("min_turning_radius must be >= 0 and gamma > 0")


#: The default gamma as a multiple of Karaman & Frazzoli's lower bound.
GAMMA_FACTOR = 2.0


def default_gamma(grid: OccupancyGrid) -> float:
    """``GAMMA_FACTOR`` x Karaman & Frazzoli's ``2 (1 + 1/d)^(1/d) (A_free / zeta_d)^(1/d)`` for d = 2, in metres."""
    bound = 2.0 * math.sqrt(1.5) * math.sqrt(max(grid.free_area(), grid.resolution**2) / math.pi)
    return GAMMA_FACTOR * bound


class _Planner:
    """One RRT* search; the state shared by the steps of an iteration."""

    def __init__(
        self,
        start: Pose2D,
        goal: FloatArray,
        grid: OccupancyGrid,
        config: RRTStarConfig,
        *,
        clock: Callable[[], float],
        t0: float,
    ) -> None:
        # Improvements are stamped in seconds of ``clock`` since ``t0``.
        self.clock, self.t0 = clock, t0
        self.start = start
        self.goal = goal
        self.grid = grid
        self.config = config
        self.tree = ArcTree(start, capacity=512)
        self.gamma = config.gamma if config.gamma is not None else default_gamma(grid)
        self.goal_node = -1
        self.grid_args = kernels.grid_args(grid)
        self.limit = arcs.alpha_limit(config.max_alpha)
        self.best_cost = math.inf
        self.best_path: FloatArray | None = None
        self.best_length = math.inf
        # Built when first sampled (a query answered by its first path never samples the map).
        self.uniform: UniformSampler | None = None
        self.informed: InformedSampler | None = None
        self.first_s: float | None = None
        self.history: list[tuple[int, float, float]] = []

    def grow_until_path(self, rng: np.random.Generator, guide: CorridorSampler | None, count: int) -> int:
        """Up to ``count`` iterations before the first path, in one compiled call
        (:func:`mrs_nav.trees.search_kernels.grow_until_path`: the sample, steps 2-4, the guide's frontier and the
        arc onto the goal); returns how many ran (fewer when a path was found)."""
        tree, config = self.tree, self.config
        tree.reserve(count + 1)
        draws = rng.random(count)
        if guide is not None:
            ahead, noise = guide.draw(rng, count)
            mixture = (config.goal_bias, config.guide_bias, guide.frontier)
            guide_args = guide.kernel_args
        else:
            ahead, noise, mixture, guide_args = _NO_AHEAD, _NO_NOISE, (config.goal_bias, 0.0, math.inf), _NO_GUIDE
        sampler = self.map_sampler()
        size, ran, goal_node, used, frontier = search_kernels.grow_until_path(
            tree.arrays,
            tree.size,
            self.goal[0],
            self.goal[1],
            draws,
            ahead,
            noise,
            sampler.peek(rng, count),
            mixture,
            (config.step, self.gamma, self.limit, config.min_turning_radius),
            guide_args,
            self.grid_args,
        )
        sampler.advance(used)
        tree.size = size
        self.goal_node = goal_node
        if guide is not None:
            guide.frontier = frontier
        return int(ran)

    def extend(self, target: FloatArray) -> int:
        """Steps 2-4 towards ``target`` (compiled: :func:`mrs_nav.trees.kernels.extend_star`); returns the new
        node's id or -1."""
        tree = self.tree
        tree.reserve()
        new = kernels.extend_star(
            tree.arrays,
            tree.size,
            float(target[0]),
            float(target[1]),
            False,
            1,
            self.config.step,
            self.gamma,
            self.limit,
            self.config.min_turning_radius,
            self.grid_args,
        )
        if new >= 0:
            tree.size += 1
        return new

    def try_goal(self, node: int, reach: float) -> None:
        """Connect ``node`` by one arc to the goal when it is within ``reach`` metres and the arc is feasible and
        free (from the root at any distance: the obvious path first, at the price of one arc check)."""
        tree = self.tree
        x, y = tree.position[node]
        if self.goal_node >= 0 or math.hypot(self.goal[0] - x, self.goal[1] - y) > reach:
            return
        length, yaw = kernels.checked_arc(
            x,
            y,
            tree.yaw[node],
            self.goal[0],
            self.goal[1],
            self.limit,
            self.config.min_turning_radius,
            self.grid_args,
        )
        if math.isfinite(length):
            self.goal_node = tree.add(self.goal, yaw, node, float(tree.cost[node] + length))

    def try_direct(self) -> None:
        """The obvious paths before any sampling: the single arc to the goal, else the shortest free
        turn-then-straight way (:func:`mrs_nav.trees.primitives.turn_then_straight`: the turn in one or more
        arcs, then a straight arc)."""
        self.try_goal(0, math.inf)
        if self.goal_node >= 0:
            return
        start, mtr = self.start, self.config.min_turning_radius
        way = turn_then_straight(
            start.x, start.y, start.yaw, self.goal[0], self.goal[1], TURN_RADII, self.limit, mtr, self.grid_args
        )
        if len(way):
            self.goal_node = self.tree.add_chain(way)[-1]

    def follow(self, guide: CorridorSampler) -> None:
        """Seed the tree with turn-then-straight ways from corner to corner of the corridor
        (:func:`mrs_nav.trees.primitives.follow_corridor`): the first path when they reach the goal, else as far
        as they go, with the guide's frontier moved there (guided targets lie ahead of it, and a start facing away
        from the corridor would otherwise wait for the few map samples that turn the tree round)."""
        start, (_, _, path, distance, factor) = self.start, guide.kernel_args
        way = follow_corridor(
            start.x, start.y, start.yaw, path, TURN_RADII, self.limit, self.config.min_turning_radius, self.grid_args
        )
        nodes = self.tree.add_chain(way)
        if nodes and math.hypot(*(self.goal - way[-1, :2])) <= kernels.COST_EPS:
            self.goal_node = nodes[-1]
            return
        for node in nodes:
            x, y = self.tree.position[node]
            guide.frontier = min(guide.frontier, field_at(x, y, distance, factor, self.grid_args))

    def improve(self, iteration: int) -> bool:
        """Keep the path to the goal node when it is shorter than the best so far (and start sampling the new
        informed set); True when the goal node's cost went down."""
        g, tree = self.goal_node, self.tree
        if g < 0 or tree.cost[g] >= self.best_cost - kernels.COST_EPS:
            return False
        # Arc cost and sampled-path length differ by the chords' sag (< 0.1 %): the kept path must be
        # shorter in the reported length too, so that the reported length never grows.
        self.best_cost = float(tree.cost[g])
        self.informed = None  # the informed set shrank
        path = tree.path_poses(tree.branch(g), self.grid.resolution)
        length = path_length(path)
        if length < self.best_length:
            self.best_path, self.best_length = path, length
            seconds = self.clock() - self.t0
            self.first_s = seconds if self.first_s is None else self.first_s
            self.history.append((iteration, seconds, length))
        return True

    def free_sample(self, rng: np.random.Generator) -> FloatArray:
        """A free position uniform in the informed set once a path exists (with ``informed``), else on the map."""
        if self.config.informed and math.isfinite(self.best_cost):
            if self.informed is None:
                self.informed = InformedSampler(self.grid, self.start.position, self.goal, self.best_cost)
            return self.informed.sample(rng)
        return self.map_sampler().sample(rng)

    def map_sampler(self) -> UniformSampler:
        """The sampler of free positions over the whole map (built when first needed)."""
        if self.uniform is None:
            self.uniform = UniformSampler(self.grid)
        return self.uniform


def grow_rrt_star(
    start: Pose2D,
    goal: FloatArray,
    grid: OccupancyGrid,
    config: RRTStarConfig,
    rng: np.random.Generator,
    *,
    clock: Callable[[], float] = time.perf_counter,
) -> Search:
    """Run RRT* from ``start`` to ``goal`` (x, y) on ``grid`` (inflated); the result, tree and improvements.

    Times and the budget are read from ``clock`` (wall time by default). Raises
    :class:`~mrs_nav.trees.tree.NoPathInTreeError` when the budget ends before any path reached the goal."""
    t0 = clock()
    goal = np.asarray(goal, dtype=np.float64)[:2]
    check_query(grid, start, goal)
    planner = _Planner(start, goal, grid, config, clock=clock, t0=t0)
    tree = planner.tree
    deadline = math.inf if config.time_budget is None else t0 + config.time_budget
    limit = config.iterations if config.iterations is not None else math.inf
    iteration = 0
    planner.try_direct()
    solved = planner.improve(iteration)
    # Goal and guided samples are drawn only until a path exists: with one already, the guide is not laid out.
    guide = (
        CorridorSampler.towards(
            grid, start.position, goal, cell_m=config.guide_cell, lookahead=config.step, spread=config.guide_cell
        )
        if config.guide_bias > 0.0 and not solved
        else None
    )
    if guide is not None:
        planner.follow(guide)
        solved = planner.improve(iteration)
    while not (solved and config.stop_at_first) and iteration < limit and clock() < deadline:
        if planner.goal_node < 0:
            # Until the first path: goal, guided and map samples, a block of iterations per compiled call.
            iteration += planner.grow_until_path(rng, guide, int(min(_BLOCK, limit - iteration)))
        else:
            iteration += 1
            if planner.extend(planner.free_sample(rng)) < 0:
                continue
        solved = planner.improve(iteration) or solved
    elapsed = clock() - t0
    if planner.best_path is None or planner.first_s is None:
        raise budget_used_up(tree, used_iterations=iteration >= limit, time_s=elapsed, iterations=iteration)
    result = PlanResult(
        planner.best_path,
        planner.best_length,
        elapsed,
        planner.first_s,
        iteration,
        len(tree),
        "best path within budget",
    )
    return Search(result, tree, tuple(planner.history))


def rrt_star(
    start: Pose2D,
    goal: FloatArray,
    grid: OccupancyGrid,
    config: RRTStarConfig | None = None,
    rng: np.random.Generator | None = None,
) -> PlanResult:
    """RRT* from ``start`` to ``goal`` on ``grid`` (already inflated); see the module docstring."""
    return grow_rrt_star(start, goal, grid, config or RRTStarConfig(), rng or np.random.default_rng()).result
