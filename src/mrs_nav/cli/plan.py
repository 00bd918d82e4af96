"""``mrs-nav plan``: one planning query on a map, a world or a list of circles.

Exit status: 0 when the goal is reached, 2 when it is not (the planner's reason on stderr), 1 on bad input.
Planners are looked up in :data:`PLANNERS`: a name on the command line -> a function of the parsed
arguments, the start pose and the goal returning a :class:`~mrs_nav.planning.PlanResult`, or raising
:class:`~mrs_nav.errors.NoPathFoundError` when it does not reach the goal.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.atomic_write import check_not_inputs, final_target
from mrs_nav.cli import tree_planners
from mrs_nav.cli.common import fail, print_json
from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.fields.potential_field import DEFAULT_GOAL_FADE, Bounds, PotentialField, workspace_bounds
from mrs_nav.fields.randomized_potential_field import EscapeSettings, plan_potential_field
from mrs_nav.geometry import Pose2D
from mrs_nav.limits import MAX_ITERATIONS, MAX_ROBOT_RADIUS_M, MAX_SEED, MAX_SIZE_M
from mrs_nav.maps.admissible import obstacles_refusal
from mrs_nav.maps.map_io import map_image
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world
from mrs_nav.options import count_option, number_option, parse_floats, radius_option, seed_option
from mrs_nav.planning import PlanResult
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.textfiles import check_writable

Planner = Callable[[argparse.Namespace, Pose2D, tuple[float, float]], PlanResult]


def load_obstacles(args: argparse.Namespace) -> tuple[Obstacles, Bounds | None]:
    """The obstacles of ``--world`` (with its extent as bounds) or ``--circles`` (JSON text or file; no bounds)."""
    if args.world is not None:
        world = load_world(args.world)
        return Obstacles.from_world(world), world.bounds()
    if args.circles is not None:
        text: str = args.circles
        if not text.lstrip().startswith("[") and _is_file(text):
            return Obstacles.from_json_file(text), None
        return Obstacles.from_json(text, "--circles"), None
    raise InvalidInputError("the potential field needs obstacles: give --world or --circles")


def _is_file(text: str) -> bool:
    """Whether ``text`` names an existing file (a name too long for the system is JSON text, not a file)."""
    try:
        return Path(text).is_file()
    except OSError:
        return False


def check_free(
    obstacles: Obstacles, bounds: Bounds | None, what: str, x: float, y: float, *, robot_radius: float = 0.0
) -> None:
    """Raise :class:`InvalidInputError` when ``(x, y)`` is outside ``bounds``, inside an obstacle or, for a
    robot of ``robot_radius`` (m), close enough to one that the robot would overlap it."""
    why = obstacles_refusal(obstacles, x, y, bounds=bounds, clearance_m=robot_radius, clearance_name="--robot-radius")
    if why:
        raise InvalidInputError(f"{what} ({x}, {y}) is {why}")


def plan_with_potential_field(args: argparse.Namespace, start: Pose2D, goal: tuple[float, float]) -> PlanResult:
    obstacles, bounds = load_obstacles(args)
    check_free(obstacles, bounds, "start", start.x, start.y, robot_radius=args.robot_radius)
    check_free(obstacles, bounds, "goal", *goal, robot_radius=args.robot_radius)
    # The field is built around the obstacles grown by the robot's radius, so the planned point stands for the
    # whole robot (the configuration space of a disc).
    grown = obstacles.inflated(args.robot_radius)
    bounds = bounds or workspace_bounds(grown, (start.x, start.y), goal)
    field = PotentialField.build(goal, grown, bounds, goal_fade=args.goal_fade)
    settings = EscapeSettings(max_steps=args.max_steps)
    result = plan_potential_field(field, (start.x, start.y, start.yaw), args.seed, settings)
    if args.png is not None:
        from mrs_nav.figures.potential_field import draw_plan  # noqa: PLC0415 - matplotlib only when drawing

        draw_plan(
            args.png, obstacles, bounds, start=np.array([start.x, start.y]), goal=np.array(goal), path=result.path
        )
    return result


PLANNERS: dict[str, Planner] = {
    "potential_field": plan_with_potential_field,
    **tree_planners.TREE_PLANNERS,
}


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "plan",
        help="one planning query on a map, a world or a list of circles",
        description="Plan from --start to --goal. Exit 0 when the goal is reached, 2 when not, 1 on bad input.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--world", type=Path, help="Gazebo SDF .world file (its boxes and cylinders)")
    source.add_argument("--map", type=Path, help="rrt / rrt_star: map_server map description (.yaml with its .pgm)")
    source.add_argument(
        "--circles", metavar="JSON", help="circular obstacles: JSON text or file, [[x, y, r], ...] in metres"
    )
    parser.add_argument("--planner", choices=sorted(PLANNERS), default="potential_field")
    parser.add_argument("--start", required=True, metavar="X,Y[,YAW]", help="start pose (m, m, rad)")
    parser.add_argument("--goal", required=True, metavar="X,Y", help="goal position (m)")
    parser.add_argument(
        "--robot-radius",
        type=radius_option,
        default=BURGER_RADIUS,
        metavar="R",
        help=f"obstacles are grown by this radius, so the path is one the robot fits along; at most "
        f"{MAX_ROBOT_RADIUS_M:g} m (default {BURGER_RADIUS}, the Burger's; 0 plans for a point)",
    )
    parser.add_argument(
        "--goal-fade",
        type=number_option(0.0, MAX_SIZE_M),
        default=DEFAULT_GOAL_FADE,
        metavar="M",
        help=f"potential field: the obstacles' push fades within about this distance of the goal, so a goal beside "
        f"a wall is reached (Ge and Cui 2000); 0 is the course's field (default {DEFAULT_GOAL_FADE} m)",
    )
    parser.add_argument("--seed", type=seed_option, default=0, help=f"random seed, 0..{MAX_SEED} (default 0)")
    parser.add_argument(
        "--max-steps",
        type=count_option,
        default=EscapeSettings().max_steps,
        help=f"potential field: integration steps, 1..{MAX_ITERATIONS}",
    )
    parser.add_argument("--png", type=Path, default=None, metavar="FILE.png", help="draw the map, plan and path")
    tree_planners.add_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print the result as one JSON object")
    parser.set_defaults(handler=run)


def check_png(args: argparse.Namespace) -> None:
    """Refuse a ``--png`` that cannot be written, is not a .png name or is one of the inputs, before planning."""
    png: Path | None = args.png
    if png is None:
        return
    if png.suffix.lower() != ".png":
        raise InvalidInputError(f"--png {png}: the file name must end in .png (the figure is a PNG image)")
    final_target(png, "--png")
    check_writable(png, "--png")
    map_path: Path | None = getattr(args, "map", None)
    named = [("--world", args.world), ("--map", map_path), ("--circles", Path(args.circles or ""))]
    if map_path is not None and map_path.is_file():
        named.append(("--map's image", map_image(map_path)))
    check_not_inputs([("--png", png)], [(what, path) for what, path in named if path is not None and path.is_file()])


def run(args: argparse.Namespace) -> int:
    check_png(args)
    start_values = parse_floats(args.start, (2, 3), "--start")
    start = Pose2D(*start_values)
    gx, gy = parse_floats(args.goal, 2, "--goal")
    try:
        result = PLANNERS[args.planner](args, start, (gx, gy))
    except NoPathFoundError as err:
        if args.json:
            print_json(no_path_json(err))
        else:
            print(f"{args.planner}: {err.reason} in {err.time_s * 1000:.1f} ms ({err.iterations} iterations)")
        return fail(f"goal not reached: {err.reason}", 2)
    if args.json:
        print_json(result.to_json())
    else:
        print(
            f"{args.planner}: {result.reason}; {result.length_m:.3f} m through {result.path.shape[0]} waypoints "
            f"in {result.time_s * 1000:.1f} ms ({result.iterations} iterations)"
        )
    return 0


def no_path_json(err: NoPathFoundError) -> dict[str, object]:
    """The ``--json`` object of a query that found no path: the keys of :meth:`PlanResult.to_json`, no path."""
    return {
        "success": False,
        "length_m": 0.0,
        "time_s": err.time_s,
        "first_solution_s": None,
        "iterations": err.iterations,
        "nodes": err.nodes,
        "reason": err.reason,
        "path": [],
    }
