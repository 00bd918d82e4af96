"""``mrs-nav plan``: one planning query on a map or world.

Exit status: 0 when the goal is reached, 2 when it is not (the planner's reason on stderr), 1 on bad input.
Planners are looked up in :data:`PLANNERS`: a name on the command line -> a function of the parsed
arguments, the start pose and the goal returning a :class:`~mrs_nav.planning.PlanResult`.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrs_nav.cli import tree_planners
from mrs_nav.cli.common import fail, parse_floats, print_json
from mrs_nav.geometry import Pose2D
from mrs_nav.planning import PlanResult

Planner = Callable[[argparse.Namespace, Pose2D, tuple[float, float]], PlanResult]

PLANNERS: dict[str, Planner] = {
    **tree_planners.TREE_PLANNERS,
}


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "plan",
        help="one planning query on a map or world",
        description="Plan from --start to --goal. Exit 0 when the goal is reached, 2 when not, 1 on bad input.",
    )
    # Let "--start -1.5,-1.5,0" through: argparse takes only plain numbers like "-1.5" for negative values.
    parser._negative_number_matcher = re.compile(r"^-\.?\d")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--world", type=Path, help="Gazebo SDF .world file (its boxes and cylinders)")
    source.add_argument("--map", type=Path, help="map_server map description (.yaml with its .pgm)")
    parser.add_argument("--planner", choices=sorted(PLANNERS), default="rrt_star")
    parser.add_argument("--start", required=True, metavar="X,Y[,YAW]", help="start pose (m, m, rad)")
    parser.add_argument("--goal", required=True, metavar="X,Y", help="goal position (m)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    tree_planners.add_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print the result as one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    start_values = parse_floats(args.start, (2, 3), "--start")
    start = Pose2D(*start_values)
    gx, gy = parse_floats(args.goal, 2, "--goal")
    result = PLANNERS[args.planner](args, start, (gx, gy))
    if args.json:
        print_json(result.to_json())
    else:
        print(
            f"{args.planner}: {result.reason}; {result.length_m:.3f} m through {result.path.shape[0]} waypoints "
            f"in {result.time_s * 1000:.1f} ms ({result.iterations} iterations)"
        )
    if not result.success:
        return fail(f"goal not reached: {result.reason}", 2)
    return 0
