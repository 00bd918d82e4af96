"""``mrs-nav demo``: headless whole stack: simulate, map, navigate to goals, record a bag."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mrs_nav.atomic_write import check_not_inputs
from mrs_nav.bag.session import SessionBag
from mrs_nav.cli.common import print_json
from mrs_nav.cli.plan import check_free
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.limits import MAX_BUDGET_S, MAX_SEED
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world
from mrs_nav.options import budget_option, parse_floats, seed_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.stack.demo import Demo, DemoConfig, save_figure
from mrs_nav.textfiles import check_writable

# Start pose and goals used when --start / --goals are not given, per shipped world.
DEFAULTS = {
    "simple": ("-1.5,-1.5,0", "1.5,1.5;-1.5,1.5"),
    "office": ("-5,-5,0", "2,-2;-7.5,3.5"),
    "cluttered": ("-4,-4,0.785", "4,4"),
}


def resolve_world(text: str) -> Path:
    """A world file given as a path, or as the name of a shipped world (``simple``, ``office``, ...)."""
    path = Path(text)
    if path.is_file():
        return path
    shipped = WORLDS_DIR / f"{text}.world"
    if shipped.is_file():
        return shipped
    raise InvalidInputError(f"--world: no such file or shipped world: {text}")


def parse_goals(text: str) -> tuple[tuple[float, float], ...]:
    """``"x,y;x,y"`` into goal positions."""
    goals = []
    for part in text.split(";"):
        if part.strip():
            x, y = parse_floats(part.strip(), 2, "--goals")
            goals.append((x, y))
    if not goals:
        raise InvalidInputError(f"--goals: expected 'x,y;x,y...', got {text!r}")
    return tuple(goals)


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "demo",
        help="headless whole stack: simulate, map, navigate to goals, record a bag",
        description=(
            "Simulator + SLAM + RRT* navigation in one process at the simulator's maximum rate, through a "
            "sequence of goals. Writes OUT/session.bag (the topics of a ROS recording), OUT/map.yaml + map.pgm "
            "(the SLAM map) and OUT/demo.png (map, plans and trajectories). Exit 0 only when every goal is "
            "reached without a contact."
        ),
    )
    parser.add_argument("--world", default="simple", help="world file, or a shipped world name (default: simple)")
    parser.add_argument("--start", default=None, help="start pose x,y,yaw in m, m, rad (default per world)")
    parser.add_argument("--goals", default=None, help='goals "x,y;x,y" in m, map frame (default per world)')
    parser.add_argument("--out", type=Path, default=Path("demo_out"), help="output folder (default: demo_out)")
    parser.add_argument(
        "--seed", type=seed_option, default=0, help=f"seed of the simulator noise and the planner, 0..{MAX_SEED}"
    )
    parser.add_argument(
        "--goal-timeout",
        type=budget_option,
        default=240.0,
        help=f"sim seconds allowed per goal, at most {MAX_BUDGET_S:g}",
    )
    parser.add_argument("--planner", choices=("rrt_star", "rrt"), default="rrt_star")
    parser.add_argument(
        "--time-budget",
        type=budget_option,
        default=0.25,
        help=f"planner budget per plan, wall s, at most {MAX_BUDGET_S:g}",
    )
    parser.add_argument("--no-bag", action="store_true", help="do not record the bag")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    world_path = resolve_world(args.world)
    default_start, default_goals = DEFAULTS.get(world_path.stem, ("0,0,0", None))
    if args.goals is None and default_goals is None:
        raise InvalidInputError(f"--goals is needed for {world_path}")
    start = Pose2D(*parse_floats(args.start or default_start, 3, "--start"))
    goals = parse_goals(args.goals or default_goals or "")
    config = DemoConfig(
        start=start,
        goals=goals,
        seed=args.seed,
        goal_timeout_s=args.goal_timeout,
        planner=args.planner,
        plan_time_budget_s=args.time_budget,
    )
    outputs = [("--out file", args.out / name) for name in ("session.bag", "map.yaml", "map.pgm", "demo.png")]
    check_not_inputs(outputs, [("--world", world_path)])
    world = load_world(world_path)
    # A start outside the world or inside an obstacle fails here, before the run, as `plan` fails on it. Goals are
    # the navigator's to refuse on the map SLAM builds, as a click into an obstacle in rviz would be.
    check_free(Obstacles.from_world(world), world.bounds(), "--start", start.x, start.y)
    out: Path = check_writable(args.out, "--out", folder=True)
    bag_path = None if args.no_bag else out / "session.bag"
    demo = Demo(world, config)
    progress = _progress_bar(len(goals))
    if bag_path is None:
        result = demo.run(progress)
    else:
        with SessionBag(bag_path, demo.sim.config.laser) as bag:
            demo.recorder = bag
            result = demo.run(progress)
    map_yaml = save_map(result.grid, out / "map.yaml")
    png = save_figure(result, out / "demo.png", f"{world_path.stem}: {result.goals_reached}/{len(goals)} goals")
    summary = {
        "goals": len(goals),
        "goals_reached": result.goals_reached,
        "collisions": result.collisions,
        "sim_time_s": round(result.sim_time_s, 3),
        "wall_time_s": round(result.wall_time_s, 3),
        "ate_rmse_m": result.ate_rmse_m,
        "map_iou": result.map_iou,
        "map_iou_1cell": result.map_iou_1cell,
        "bag": str(bag_path) if bag_path else None,
        "map": str(map_yaml),
        "png": str(png),
        "outcomes": [
            {"goal": list(o.goal), "state": o.state, "time_s": round(o.time_s, 2), "distance_m": o.distance_m}
            for o in result.outcomes
        ],
    }
    if args.json:
        print_json(summary)
    else:
        for o in result.outcomes:
            print(
                f"goal ({o.goal[0]:.2f}, {o.goal[1]:.2f}): {o.state} after {o.time_s:.1f} s, {o.distance_m:.3f} m away"
            )
        print(
            f"{result.goals_reached}/{len(goals)} goals, {result.collisions} contacts, {result.sim_time_s:.1f} s sim "
            f"in {result.wall_time_s:.1f} s, ATE {result.ate_rmse_m:.3f} m, map IoU {result.map_iou:.2f} "
            f"({result.map_iou_1cell:.2f} within one cell)"
        )
        print(f"wrote {png}, {map_yaml}" + (f", {bag_path}" if bag_path else ""))
    return 0 if result.success else 2


def _progress_bar(total: int) -> Any:
    """A tqdm bar over the goals when stderr is a terminal, else nothing."""
    if not sys.stderr.isatty():
        return None
    bar = tqdm(total=total, unit="goal", file=sys.stderr)

    def update(sim_time: float) -> None:
        bar.update(1)
        bar.set_postfix(sim_s=f"{sim_time:.0f}")
        if bar.n >= total:
            bar.close()

    return update
