"""``mrs-nav replay``: run SLAM (and the planner) over a recorded bag offline, compare with what was recorded,
and hold the metrics to a golden file."""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mrs_nav.bag.salvage import readable_bag
from mrs_nav.cli.common import fail, print_json
from mrs_nav.replay.golden import dump_json, load_golden, make_golden, regressions
from mrs_nav.replay.session_replay import PlanOptions, SessionReplay, replay_session, write_session_outputs
from mrs_nav.replay.slam_replay import write_outputs
from mrs_nav.slam.config import MAX_COORDINATE_M, SlamConfig
from mrs_nav.slam.relations import load_relations


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "replay",
        help="replay a bag offline: SLAM, re-planning, comparison with the recording, golden metrics",
        description=(
            "Replay a ROS 1 bag without a master. With --slam, run SLAM over its /scan and /odom and write the "
            "map (map_server .yaml + .pgm), the trajectory (CSV), a PNG of map and trajectories and metrics.json "
            "to --out. ATE is computed after an SE(2) alignment, RPE over consecutive processed scans; the "
            "replayed map and poses are compared with the recorded /map and live SLAM pose (/tf map->odom). "
            "With --plan, RRT* is run again (seeded, fixed iterations) to every recorded /move_base_simple/goal "
            "on the replayed and on the recorded map (plans.json). Files in --out are byte-identical for the "
            "same bag and options (timings appear only in the printed summary). A recording that was killed "
            "(.bag.active, no index) is read up to its last whole chunk from a rebuilt copy; the input is never "
            "written."
        ),
    )
    parser.add_argument("bag", type=Path, help="bag with /scan and /odom (and optionally /ground_truth/odom)")
    parser.add_argument("--slam", action="store_true", help="run SLAM over the bag")
    parser.add_argument("--plan", action="store_true", help="re-plan the recorded goals (implies --slam)")
    parser.add_argument(
        "--plan-iterations", type=int, default=1500, help="RRT* iterations per goal with --plan (default: 1500)"
    )
    parser.add_argument(
        "--plan-first", action="store_true", help="stop each re-planning query at its first path (reachability only)"
    )
    parser.add_argument("--seed", type=int, default=0, help="planner seed with --plan (>= 0)")
    parser.add_argument(
        "--against", type=Path, metavar="GOLDEN.json", help="exit 2 naming each metric worse than the golden file"
    )
    parser.add_argument("--write-golden", type=Path, metavar="GOLDEN.json", help="write the metrics as a golden file")
    parser.add_argument("--out", type=Path, default=Path("replay_out"), help="output folder (default: replay_out)")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="SLAM parameter with gmapping's name, e.g. --param maxUrange=30 --param linearUpdate=0 (repeatable)",
    )
    parser.add_argument(
        "--relations",
        type=Path,
        metavar="FILE",
        help=(
            "score the SLAM trajectory on a relations file (Kummerle et al. 2009: 't1 t2 x y z roll pitch yaw' a "
            "line): mean and std of translational (m) and rotational (deg) relation error"
        ),
    )
    parser.add_argument(
        "--relations-offset",
        type=float,
        metavar="S",
        help=(
            "relation stamp minus bag stamp (s); default: found as the most common difference, to 1 ms, between "
            "relation and scan stamps"
        ),
    )
    parser.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    parser.set_defaults(handler=run)


def _options(args: argparse.Namespace) -> list[str]:
    """The options that change the metrics, recorded in a golden file (to replay it the same way)."""
    options = ["--slam", *(f"--param={p}" for p in args.param)]
    if args.plan:
        options += ["--plan", f"--plan-iterations={args.plan_iterations}", f"--seed={args.seed}"]
        options += ["--plan-first"] if args.plan_first else []
    return options


def _replay(args: argparse.Namespace, config: SlamConfig) -> SessionReplay:
    """Replay the bag (a rebuilt copy in a temporary folder when it has no index)."""
    plan = PlanOptions(args.plan_iterations, args.seed, args.plan_first) if args.plan else None
    bar: Any = None
    progress = None
    if sys.stderr.isatty():
        bar = tqdm(desc="replay", unit="scan")
        progress = bar.update
    try:
        with tempfile.TemporaryDirectory(prefix="mrs_nav_replay_") as work:
            bag, note = readable_bag(args.bag, Path(work))
            if note:
                print(f"NOTE: {note}", file=sys.stderr)
            return replay_session(bag, config, plan, progress)
    finally:
        if bar is not None:
            bar.close()


def run(args: argparse.Namespace) -> int:
    if not (args.slam or args.plan):
        return fail("nothing to do: give --slam and/or --plan")
    if args.plan_iterations < 1 or args.seed < 0:
        return fail(f"--plan-iterations must be >= 1 and --seed >= 0, got {args.plan_iterations} and {args.seed}")
    config = SlamConfig.from_assignments(args.param)
    relations = load_relations(args.relations) if args.relations else None
    if args.relations_offset is not None and not math.isfinite(args.relations_offset):
        return fail(f"--relations-offset must be finite, got {args.relations_offset}")
    golden = load_golden(args.against) if args.against else None
    session = _replay(args, config)
    result = session.slam
    if not result.estimate:
        return fail(f"bag {args.bag}: no scan could be paired with odometry ({result.scans_read} scans read)")
    if result.scans_out_of_order or result.scans_rejected:
        print(
            f"NOTE: skipped {result.scans_out_of_order} scans stamped at or before the previous scan and "
            f"{result.scans_rejected} scans without odometry or with bad values, of {result.scans_read}"
            + (f" (first: {result.first_rejection})" if result.first_rejection else ""),
            file=sys.stderr,
        )
    if result.odom_rejected:
        print(
            f"NOTE: skipped {result.odom_rejected} of {result.odom_read} odometry messages farther than "
            f"{MAX_COORDINATE_M:g} m from the origin",
            file=sys.stderr,
        )
    args.out.mkdir(parents=True, exist_ok=True)
    paths = write_outputs(result, args.out)
    paths.update(write_session_outputs(session, args.out))
    if args.write_golden:
        record = make_golden(args.bag.name.removesuffix(".active"), _options(args), session.metrics)
        args.write_golden.write_text(dump_json(record), encoding="utf-8")
    summary = result.summary()
    if relations is not None:
        summary.update(result.relation_errors(relations, args.relations_offset))
    summary["map_yaml"] = str(paths["map_yaml"])
    summary["metrics"] = session.metrics
    found = regressions(session.metrics, golden) if golden is not None else []
    if golden is not None:
        summary["regressions"] = [r.describe() for r in found]
    if args.json:
        print_json(summary)
    else:
        for key, value in summary.items():
            print(f"{key}: {value}")
    if found:
        print(f"REGRESSED against {args.against}: " + "; ".join(r.describe() for r in found), file=sys.stderr)
        return 2
    return 0
