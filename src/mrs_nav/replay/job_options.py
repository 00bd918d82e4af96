"""The options that decide what a replay computes: ``mrs-nav replay``'s, and those a golden file records.

One definition serves the command line, the jobs of bags held to their golden files (replayed with the options
the file recorded) and ``bench replay-batch``, so that a bench replays exactly what ``mrs-nav replay`` would.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from mrs_nav.errors import InvalidInputError
from mrs_nav.limits import MAX_ITERATIONS, MAX_SEED
from mrs_nav.options import count_option, seed_option
from mrs_nav.replay.bag_frames import BagNames
from mrs_nav.replay.batch import BagJob
from mrs_nav.replay.golden import read_golden
from mrs_nav.replay.session_replay import PlanOptions


def add_options(parser: argparse.ArgumentParser) -> None:
    """The options that decide what a replay computes (also those a golden file records)."""
    parser.add_argument("--slam", action="store_true", help="run SLAM over the bag")
    parser.add_argument("--plan", action="store_true", help="re-plan the recorded goals (implies --slam)")
    parser.add_argument(
        "--plan-iterations",
        type=count_option,
        default=1500,
        help=f"RRT* iterations per goal with --plan, 1..{MAX_ITERATIONS} (default: 1500)",
    )
    parser.add_argument(
        "--plan-first", action="store_true", help="stop each re-planning query at its first path (reachability only)"
    )
    parser.add_argument("--seed", type=seed_option, default=0, help=f"planner seed with --plan, 0..{MAX_SEED}")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="SLAM parameter with gmapping's name, e.g. --param maxUrange=30 --param linearUpdate=0 (repeatable)",
    )
    defaults = dataclasses.asdict(BagNames())
    for field, meaning in _NAME_OPTIONS.items():
        default = defaults[field]
        parser.add_argument(
            f"--{field.replace('_', '-')}",
            default=default,
            metavar=field.split("_")[1].upper(),
            help=f"{meaning} (default: {default})" if default else meaning,
        )


# BagNames field -> help, with gmapping's parameter name where it has one
_NAME_OPTIONS = {
    "scan_topic": "topic of the laser scans (gmapping's scan)",
    "odom_topic": "nav_msgs/Odometry topic; without it in the bag, odometry comes from tf odom frame -> base frame",
    "base_frame": (
        "robot frame whose trajectory is mapped (gmapping's base_frame); by default the frame the odometry moves: "
        "the odometry topic's child_frame_id, or the odom frame's child in tf"
    ),
    "odom_frame": "odometry frame (gmapping's odom_frame)",
    "map_frame": "frame of the recorded map and map->odom correction (gmapping's map_frame)",
}


def names_from_args(args: argparse.Namespace) -> BagNames:
    """The topics and frames ``args`` name."""
    return BagNames(**{field: getattr(args, field) for field in _NAME_OPTIONS})


def name_options(args: argparse.Namespace) -> list[str]:
    """The topic and frame options of ``args`` that differ from the defaults (a golden file records them)."""
    given, defaults = dataclasses.asdict(names_from_args(args)), dataclasses.asdict(BagNames())
    return [f"--{key.replace('_', '-')}={value}" for key, value in given.items() if value != defaults[key]]


def job_from_args(args: argparse.Namespace, bag: Path, out: Path, golden: Path | None) -> BagJob:
    """The job ``args`` describe for ``bag`` (budgets and seeds are checked by the option types)."""
    if not (args.slam or args.plan):
        raise InvalidInputError(f"nothing to do: give --slam and/or --plan (for {bag})")
    plan = PlanOptions(args.plan_iterations, args.seed, args.plan_first) if args.plan else None
    return BagJob(bag, out, tuple(args.param), plan, golden, names_from_args(args))


def golden_job(bag: Path, out: Path, golden: Path) -> BagJob:
    """The job of a bag held to ``golden``, with the options the golden file recorded."""
    options = read_golden(golden)["options"]
    parser = argparse.ArgumentParser(prog=f"options of {golden}", add_help=False, exit_on_error=False)
    add_options(parser)
    try:
        recorded, unknown = parser.parse_known_args([str(o) for o in options])
    except argparse.ArgumentError as err:
        raise InvalidInputError(f"golden file {golden}: bad options: {err}") from None
    if unknown:
        raise InvalidInputError(f"golden file {golden}: unknown options {unknown}")
    return job_from_args(recorded, bag, out, golden)
