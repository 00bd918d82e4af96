"""``mrs-nav carmen2bag``: convert a CARMEN log (FLASER lines) to a ROS 1 bag for SLAM benchmarks."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mrs_nav.bag.from_carmen import carmen_to_bag
from mrs_nav.cli.common import print_json
from mrs_nav.errors import InvalidInputError
from mrs_nav.motion_model import DEFAULT_ALPHAS, OdometryNoise
from mrs_nav.options import parse_floats, seed_option

_DEFAULT_NOISE = ",".join(f"{a:g}" for a in DEFAULT_ALPHAS)


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "carmen2bag",
        help="convert a CARMEN log to a ROS bag (/scan, /odom, /tf, /ground_truth/odom)",
        description=(
            "Convert the FLASER lines of a CARMEN log (plain or .gz) to a ROS 1 bag: sensor_msgs/LaserScan on "
            "/scan (CARMEN's beam angles, frame base_scan), the logged (corrected) poses on /ground_truth/odom, "
            "and odometry on /odom plus tf odom->base_footprint: by default the robot's real odometry from the "
            "log's ODOM lines; with --odom synthetic, the logged poses' increments with the noise of the "
            "odometry motion model (Thrun et al., Probabilistic Robotics, table 5.6), seeded. Scans stamped at or "
            "before their predecessor are restamped (previous + the log's median interval) with a NOTE. A bad "
            "line is one ERROR naming file:line."
        ),
    )
    parser.add_argument("log", type=Path, help="CARMEN log file (.log or .log.gz)")
    parser.add_argument("bag", type=Path, help="bag file to write (replaced if it exists)")
    parser.add_argument(
        "--odom",
        choices=("log", "synthetic"),
        default="log",
        help="odometry: the log's ODOM lines (default) or synthetic noise on the logged poses",
    )
    parser.add_argument("--seed", type=seed_option, default=0, help="seed of the synthetic odometry noise (default: 0)")
    parser.add_argument(
        "--odom-noise",
        default=_DEFAULT_NOISE,
        metavar="A1,A2,A3,A4",
        help=(
            "odometry motion model alphas, as variances: var(rot) = a1*rot^2 + a2*trans^2, "
            "var(trans) = a3*trans^2 + a4*(rot1^2 + rot2^2); units rad^2/rad^2, rad^2/m^2, m^2/m^2, m^2/rad^2 "
            f"(with --odom synthetic; default: {_DEFAULT_NOISE}; 0,0,0,0 gives perfect odometry)"
        ),
    )
    parser.add_argument(
        "--odom-scale",
        default="1,1",
        metavar="LINEAR,ANGULAR",
        help=(
            "multiply the log's odometry increments (distance, turn) by these factors, each in 0.5..2: a wheel "
            "calibration (with --odom log; default: 1,1)"
        ),
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    alphas = parse_floats(args.odom_noise, 4, "--odom-noise")
    try:
        noise = OdometryNoise.of(alphas)
    except InvalidInputError as err:
        raise InvalidInputError(f"--odom-noise: {err}") from None
    if args.odom == "log" and args.odom_noise != _DEFAULT_NOISE:
        raise InvalidInputError("--odom-noise applies to --odom synthetic only")
    linear, angular = parse_floats(args.odom_scale, 2, "--odom-scale")
    progress = None
    bar: Any = None
    if sys.stderr.isatty():
        bar = tqdm(desc="carmen2bag", unit="scan")
        progress = bar.update
    try:
        summary = carmen_to_bag(
            args.log,
            args.bag,
            noise if args.odom == "synthetic" else None,
            args.seed,
            odom_scale=(linear, angular),
            progress=progress,
        )
    finally:
        if bar is not None:
            bar.close()
    for note in summary.notes:
        print(f"NOTE: {note}", file=sys.stderr)
    if args.json:
        payload = {"scans": summary.scans, "duration_s": summary.duration_s, "odometry": summary.odometry}
        print_json({**payload, "bag": str(args.bag)})
    else:
        print(f"wrote {summary.scans} scans ({summary.duration_s:.0f} s of log) to {args.bag}")
    return 0
