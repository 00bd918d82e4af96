"""``mrs-nav replay``: run SLAM (and the planner) over recorded bags offline, compare with what was recorded,
and hold the metrics to golden files; several bags fan out to worker processes or a Dask cluster."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mrs_nav.atomic_write import check_not_inputs, write_text
from mrs_nav.cli.common import fail, print_json
from mrs_nav.options import number_option, runs_option
from mrs_nav.replay.batch import (
    aggregate,
    find_bags,
    golden_beside,
    job_outputs,
    markdown_report,
    replay_bag,
    run_jobs,
)
from mrs_nav.replay.golden import dump_json, make_golden
from mrs_nav.replay.job_options import add_options, golden_job, job_from_args, name_options
from mrs_nav.slam.eval.consistency import BROKEN_FRACTION, DUPLICATED_LINE
from mrs_nav.slam.eval.relations import load_relations
from mrs_nav.textfiles import check_writable


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "replay",
        help="replay bags offline: SLAM, re-planning, comparison with the recording, golden metrics",
        description=(
            "Replay a ROS 1 bag without a master. With --slam, run SLAM over its /scan and /odom (or, without /odom, "
            "the odometry on /tf; --scan-topic, --odom-topic and gmapping's frame names read other robots' bags, the "
            "laser's mounting comes from the bag's tf) and write the "
            "map (map_server .yaml + .pgm), the trajectory (CSV), a PNG of map and trajectories and metrics.json "
            "to --out. ATE is computed after an SE(2) alignment, RPE over consecutive processed scans; the "
            "replayed map and poses are compared with the recorded /map and live SLAM pose (/tf map->odom). "
            "With --plan, RRT* is run again (seeded, fixed iterations) to every recorded /move_base_simple/goal "
            "on the replayed and on the recorded map (plans.json). Files in --out are byte-identical for the "
            "same bag and options (timings appear only in the printed summary). A recording that was killed "
            "(.bag.active, no index) is read up to its last whole chunk from a rebuilt copy; the input is never "
            "written. Given several bags or a folder, each bag is replayed into --out/NAME/ by --workers local "
            "processes or on the Dask scheduler given by --cluster; a bag with NAME.golden.json beside it is "
            "replayed with that file's options and held to it, the others with this command's options; "
            "--out/report.json and --out/report.md aggregate the verdicts (exit 2 if any bag regressed, 1 if any "
            "failed)."
        ),
    )
    parser.add_argument(
        "bags", type=Path, nargs="+", metavar="BAG", help="bag(s) with /scan and /odom or /tf, or folders of bags"
    )
    add_options(parser)
    parser.add_argument(
        "--against", type=Path, metavar="GOLDEN.json", help="exit 2 naming each metric worse than the golden file"
    )
    parser.add_argument("--write-golden", type=Path, metavar="GOLDEN.json", help="write the metrics as a golden file")
    parser.add_argument("--out", type=Path, default=Path("replay_out"), help="output folder (default: replay_out)")
    parser.add_argument(
        "--workers",
        type=runs_option,
        default=os.cpu_count() or 1,
        help="local worker processes for several bags (default: the number of CPUs; 1 replays them in turn)",
    )
    parser.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="replay several bags on this Dask distributed scheduler (e.g. tcp://127.0.0.1:8786) instead",
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
        type=number_option(-1e10, 1e10),
        metavar="SECONDS",
        help=(
            "relation stamp minus bag stamp (s); default: found by the relations' geometry against the bag's ground "
            "truth (else its odometry) over every offset, refused with an ERROR when no offset stands out"
        ),
    )
    parser.add_argument(
        "--reference",
        action="store_true",
        help=(
            "also the doubled-wall figure of the map the scans make at the bag's /ground_truth/odom poses "
            "(doubled_wall_fraction_at_truth; null without them): how much of the broken-map figure the scene "
            "itself draws, such as things gone on the next pass"
        ),
    )
    parser.add_argument("--json", action="store_true", help="print the metrics (or the report) as one JSON object")
    parser.set_defaults(handler=run)


def _options(args: argparse.Namespace) -> list[str]:
    """The options that change the metrics, recorded in a golden file (to replay it the same way)."""
    options = ["--slam", *(f"--param={p}" for p in args.param), *name_options(args)]
    if args.plan:
        options += ["--plan", f"--plan-iterations={args.plan_iterations}", f"--seed={args.seed}"]
        options += ["--plan-first"] if args.plan_first else []
    return options


def run(args: argparse.Namespace) -> int:
    if len(args.bags) > 1 or args.bags[0].is_dir():
        return _run_batch(args)
    bag = args.bags[0]
    outputs = [("--out file", path) for path in job_outputs(args.out)]
    outputs += [("--write-golden", args.write_golden)] if args.write_golden else []
    named = (("input bag", bag), ("--against", args.against), ("--relations", args.relations))
    check_not_inputs(outputs, [(what, path) for what, path in named if path is not None])
    if args.cluster:
        print(f"NOTE: --cluster fans out several bags; the one bag {bag} is replayed here", file=sys.stderr)
    job = dataclasses.replace(job_from_args(args, bag, args.out, args.against), reference=args.reference)
    relations = load_relations(args.relations) if args.relations else None
    if args.relations_offset is not None and not math.isfinite(args.relations_offset):
        return fail(f"--relations-offset must be finite, got {args.relations_offset}")
    check_writable(args.out, "--out", folder=True)
    if args.write_golden:
        check_writable(args.write_golden, "--write-golden")
    bar: Any = tqdm(desc="replay", unit="scan") if sys.stderr.isatty() else None
    try:
        outcome, session = replay_bag(job, bar.update if bar else None)
    finally:
        if bar is not None:
            bar.close()
    for note in outcome.notes:
        print(f"NOTE: {note}", file=sys.stderr)
    if args.write_golden:
        record = make_golden(bag.name.removesuffix(".active"), _options(args), session.metrics)
        write_text(args.write_golden, dump_json(record), "--write-golden")
    summary = outcome.summary
    if summary["map_broken"]:
        at_truth = summary.get("doubled_wall_fraction_at_truth")
        scene = (
            f" (the map the scans make at the bag's ground-truth poses reads {at_truth:.4f}, past the line too: the "
            "scene itself draws such walls, e.g. things gone on the next pass)"
            if at_truth is not None and at_truth > BROKEN_FRACTION
            else ""
        )
        doubled, duplicated = summary["doubled_wall_fraction"], summary["duplicated_place_fraction"]
        why = []
        if doubled > BROKEN_FRACTION:
            why.append(
                f"{doubled:.4f} of the scan end points draw walls of a metre or more where the final map has free "
                f"space, past the line of {BROKEN_FRACTION}{scene}"
            )
        if duplicated > DUPLICATED_LINE:
            why.append(
                f"{duplicated:.4f} of the places checked are in the map twice (found by place elsewhere, twice in a "
                f"row), past the line of {DUPLICATED_LINE}"
            )
        print(
            f"WARNING: bag {bag}: the SLAM map is likely broken (doubled, turned or repeated walls): "
            f"{'; '.join(why)}; its figures describe a map that does not hold",
            file=sys.stderr,
        )
    if relations is not None:
        scored = session.slam.relation_errors(relations, args.relations_offset)
        summary.update(scored)
        print(_relations_line(scored), file=sys.stderr)
    summary["map_yaml"] = str(args.out / "slam_map.yaml")
    summary["metrics"] = session.metrics
    if args.against is not None:
        summary["regressions"] = list(outcome.regressions)
    if args.json:
        print_json(summary)
    else:
        for key, value in summary.items():
            print(f"{key}: {value}")
    if outcome.regressions:
        print(f"REGRESSED against {args.against}: " + "; ".join(outcome.regressions), file=sys.stderr)
        return 2
    return 0


def _relations_line(scored: dict[str, Any]) -> str:
    """The relations figure with the offset it was scored at, how that offset was found and how many scored."""
    how = (
        "given"
        if scored["relations_offset_rule"] == "given"
        else (
            f"found by the relations' geometry: {scored['relations_offset_support']:.0f} relations' worth of support "
            f"against {scored['relations_offset_runner_up_support']:.0f} at the next best offset, "
            f"{scored['relations_offset_runner_up_s']:.3f} s"
        )
    )
    return (
        f"NOTE: relations {scored['relations_trans_mean_m']:.4f} m, {scored['relations_rot_mean_deg']:.3f} deg over "
        f"{scored['relations_scored']} relations ({scored['relations_skipped']} outside the bag) at clock offset "
        f"{scored['relations_offset_s']:.4f} s ({how})"
    )


def _run_batch(args: argparse.Namespace) -> int:
    if args.against or args.write_golden or args.relations or args.reference:
        return fail(
            "--against, --write-golden, --relations and --reference take one bag; several bags are held to "
            "NAME.golden.json beside them"
        )
    bags = find_bags(args.bags)
    outs = [args.out / bag.name.removesuffix(".active").removesuffix(".bag") for bag in bags]
    goldens = [golden_beside(bag) for bag in bags]
    outputs = [("--out file", args.out / name) for name in ("report.json", "report.md")]
    outputs += [("--out file", path) for out in outs for path in job_outputs(out)]
    inputs = [("input bag", bag) for bag in bags] + [("golden file", g) for g in goldens if g is not None]
    check_not_inputs(outputs, inputs)
    check_writable(args.out, "--out", folder=True)
    jobs = [
        golden_job(bag, out, golden) if golden else job_from_args(args, bag, out, None)
        for bag, out, golden in zip(bags, outs, goldens, strict=True)
    ]
    # No monitor thread: the local workers are forked after the bar exists, and only a single-threaded parent
    # forks them (others start them through a fork server, which costs each its imports).
    tqdm.monitor_interval = 0
    bar: Any = tqdm(total=len(jobs), desc="replay", unit="bag") if sys.stderr.isatty() else None
    try:
        outcomes = run_jobs(jobs, args.workers, args.cluster, (lambda _: bar.update()) if bar else None)
    finally:
        if bar is not None:
            bar.close()
    report = aggregate(outcomes)
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "report.json", dump_json(report), "report")
    table = markdown_report(outcomes)
    write_text(args.out / "report.md", table, "report")
    if args.json:
        print_json(report)
    else:
        print(table, end="")
    failed = [o for o in outcomes if o.error is not None]
    if failed:  # the report has them all; the one line says which and why, as a single bag's failure would
        reasons = "; ".join(f"{o.name}: {o.error}" for o in failed)
        return fail(f"{len(failed)} of {len(outcomes)} bags failed ({reasons}); the report is in {args.out}")
    return 2 if any(o.regressions for o in outcomes) else 0
