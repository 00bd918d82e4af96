"""The RRT and RRT* planners of ``mrs-nav plan``: their options, map loading and optional PNG.

``mrs-nav plan`` looks planners up by name; :data:`TREE_PLANNERS` holds these two, each a function of the
parsed arguments, the start pose and the goal returning a :class:`~mrs_nav.planning.PlanResult` (or raising
:class:`~mrs_nav.errors.NoPathFoundError`; ``--png`` draws the tree either way).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from functools import partial

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.limits import MAX_BUDGET_S, MAX_ITERATIONS, MAX_SIZE_M
from mrs_nav.maps.map_io import load_map
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.rasterize import DEFAULT_RESOLUTION, rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.options import budget_option, count_option, number_option
from mrs_nav.planning import PlanResult
from mrs_nav.trees.rrt import RRTConfig, grow_rrt
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.tree import ArcTree, NoPathInTreeError, Search

#: RRT* runs for this long when neither --time-budget nor --iterations is given (seconds).
DEFAULT_STAR_BUDGET = 0.5
#: --resolution range, metres per cell: finer than a millimetre or coarser than 10 m is not a map of a building.
MIN_RESOLUTION_M, MAX_RESOLUTION_M = 1e-3, 10.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options only the tree planners read (``--map`` belongs to the map/world source group of ``plan``)."""
    group = parser.add_argument_group("rrt / rrt_star")
    group.add_argument(
        "--time-budget",
        type=budget_option,
        default=None,
        metavar="S",
        help=f"planning time, at most {MAX_BUDGET_S:g} s (rrt_star default {DEFAULT_STAR_BUDGET} s; rrt: none)",
    )
    group.add_argument(
        "--iterations",
        type=count_option,
        default=None,
        metavar="N",
        help=f"samples to draw, at most {MAX_ITERATIONS} (rrt default 2000; rrt_star: none)",
    )
    group.add_argument(
        "--resolution",
        type=number_option(MIN_RESOLUTION_M, MAX_RESOLUTION_M),
        default=DEFAULT_RESOLUTION,
        metavar="M",
        help=f"cell size for --world, {MIN_RESOLUTION_M:g}..{MAX_RESOLUTION_M:g} m (default {DEFAULT_RESOLUTION})",
    )
    group.add_argument(
        "--min-turning-radius",
        type=number_option(0.0, MAX_SIZE_M),
        default=0.0,
        metavar="R",
        help="reject tighter arcs (metres; default 0)",
    )


def load_grid(args: argparse.Namespace) -> OccupancyGrid:
    """The map of ``--map``, or ``--world`` rasterised at ``--resolution``."""
    if getattr(args, "map", None) is not None:
        return load_map(args.map)
    if getattr(args, "world", None) is not None:
        return rasterize_world(load_world(args.world), args.resolution)
    raise InvalidInputError("the tree planners need a map: give --map or --world")


def _inflated(args: argparse.Namespace) -> tuple[OccupancyGrid, OccupancyGrid]:
    grid = load_grid(args)
    return grid, grid.inflate(args.robot_radius)


def _finish(
    args: argparse.Namespace,
    grow: Callable[[], Search],
    *,
    grid: OccupancyGrid,
    planning: OccupancyGrid,
    start: Pose2D,
    goal: tuple[float, float],
    title: str,
) -> PlanResult:
    """Run ``grow`` and, with ``--png``, draw its tree (and path, when it found one)."""

    def draw(tree: ArcTree, result: PlanResult | None) -> None:
        if args.png is not None:
            from mrs_nav.figures.tree_drawing import draw_search  # noqa: PLC0415 - matplotlib only when drawing

            draw_search(tree, result, grid, planning, start=start, goal=np.array(goal), title=title, out=args.png)

    try:
        search = grow()
    except NoPathInTreeError as err:
        draw(err.tree, None)
        raise
    draw(search.tree, search.result)
    return search.result


def plan_with_rrt(args: argparse.Namespace, start: Pose2D, goal: tuple[float, float]) -> PlanResult:
    grid, planning = _inflated(args)
    iterations = args.iterations if args.iterations is not None or args.time_budget is not None else 2000
    config = RRTConfig(iterations=iterations, time_budget=args.time_budget, min_turning_radius=args.min_turning_radius)
    grow = partial(grow_rrt, start, np.array(goal), planning, config, np.random.default_rng(args.seed))
    return _finish(args, grow, grid=grid, planning=planning, start=start, goal=goal, title=f"RRT (seed {args.seed})")


def plan_with_rrt_star(args: argparse.Namespace, start: Pose2D, goal: tuple[float, float]) -> PlanResult:
    grid, planning = _inflated(args)
    budget = args.time_budget if args.time_budget is not None or args.iterations is not None else DEFAULT_STAR_BUDGET
    config = RRTStarConfig(iterations=args.iterations, time_budget=budget, min_turning_radius=args.min_turning_radius)
    grow = partial(grow_rrt_star, start, np.array(goal), planning, config, np.random.default_rng(args.seed))
    return _finish(args, grow, grid=grid, planning=planning, start=start, goal=goal, title=f"RRT* (seed {args.seed})")


TREE_PLANNERS: dict[str, Callable[[argparse.Namespace, Pose2D, tuple[float, float]], PlanResult]] = {
    "rrt": plan_with_rrt,
    "rrt_star": plan_with_rrt_star,
}
