"""``mrs-nav replay``: run SLAM over a bag offline, with metrics against its ground truth."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mrs_nav.cli.common import fail, print_json
from mrs_nav.errors import InvalidInputError
from mrs_nav.replay.slam_replay import replay_slam, write_outputs
from mrs_nav.slam.config import SlamConfig


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "replay",
        help="run SLAM over a bag offline (metrics against /ground_truth/odom when present)",
        description=(
            "Replay a ROS 1 bag without a master. With --slam, run SLAM over its /scan and /odom and write the "
            "map (map_server .yaml + .pgm), the trajectory (CSV) and a PNG of map and trajectories to --out. "
            "ATE is computed after an SE(2) alignment, RPE over consecutive processed scans."
        ),
    )
    parser.add_argument("bag", type=Path, help="bag with /scan and /odom (and optionally /ground_truth/odom)")
    parser.add_argument("--slam", action="store_true", help="run SLAM over the bag")
    parser.add_argument("--out", type=Path, default=Path("replay_out"), help="output folder (default: replay_out)")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="SLAM parameter with gmapping's name, e.g. --param maxUrange=30 --param linearUpdate=0 (repeatable)",
    )
    parser.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    parser.set_defaults(handler=run)


def parse_params(items: list[str]) -> SlamConfig:
    """``["name=value", ...]`` into a validated :class:`SlamConfig`."""
    values: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InvalidInputError(f"--param: expected NAME=VALUE, got {item!r}")
        values[name.strip()] = value.strip()
    return SlamConfig.from_mapping(values)


def run(args: argparse.Namespace) -> int:
    if not args.slam:
        return fail("nothing to do: give --slam")
    config = parse_params(args.param)
    if not args.bag.is_file():
        return fail(f"bag {args.bag} does not exist")
    bar: Any = None
    progress = None
    if sys.stderr.isatty():
        bar = tqdm(desc="replay --slam", unit="scan")
        progress = bar.update
    try:
        result = replay_slam(args.bag, config, progress)
    finally:
        if bar is not None:
            bar.close()
    if not result.estimate:
        return fail(f"bag {args.bag}: no scan could be paired with odometry ({result.scans_read} scans read)")
    paths = write_outputs(result, args.out)
    summary = result.summary()
    summary["map_yaml"] = str(paths["map_yaml"])
    if args.json:
        print_json(summary)
    else:
        for key, value in summary.items():
            print(f"{key}: {value}")
    return 0
