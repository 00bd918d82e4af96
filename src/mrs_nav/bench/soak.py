"""Soak: the robot driving between goals for a long run while sim time jumps back; memory and cost per scan must
stay flat in every node.

By default the product's nodes (:mod:`mrs_nav.bench.soak_ros`): ``rrt_navigation.launch`` at max rate in
lockstep in the course arena, sent round the four corners (+-1.5 m) as ``move_base`` action goals for
``--minutes`` of wall time (default 60), with the sim clock jumping back every ``--clock-jump-every`` wall minutes
(default 10; by 1 s, 10 s and 185 s in turn). Measured per node process from /proc: RSS and CPU time (user +
kernel) per simulated scan, start window against end window (:mod:`mrs_nav.bench.soak_rules`); after each jump,
whether the nodes went on publishing and the goal sent after it was reached.

``--in-process`` soaks ``mrs-nav demo``'s stack instead (simulator + SLAM + RRT* navigation in this process, no
ROS and so no clock to jump), measured the same way as one process. In both, RRT* plans a fixed number of
iterations rather than for a wall-clock budget, which would spend more CPU per plan on a quieter machine and so
read a change of load as growth; and CPU time, not wall time, so that other jobs on a shared machine do not count
against the stack.
"""

from __future__ import annotations

import argparse
import itertools
import os
import time
from collections.abc import Sequence

from mrs_nav.bench.soak_ros import NODES, jumps_section, ros_soak
from mrs_nav.bench.soak_rules import CORNERS, MIN_LAPS, TOLERANCE, WINDOW, Lap, Usage, growth, windows
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.options import number_option, seed_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.ros_processes import resident_bytes
from mrs_nav.stack.demo import Demo, DemoConfig
from mrs_nav.tables import markdown_table

START = Pose2D(-1.5, -1.5, 0.0)
#: RRT* samples per plan: about what the demo's 0.25 s budget gives on an idle core.
PLAN_ITERATIONS = 1500
#: The one process of ``--in-process``.
IN_PROCESS = "mrs-nav demo stack (one process)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--minutes",
        type=number_option(0.1, 24 * 60.0),
        default=60.0,
        help=f"wall minutes to run, at least {MIN_LAPS} laps (default 60)",
    )
    parser.add_argument(
        "--clock-jump-every",
        type=number_option(0.0, 24 * 60.0),
        default=10.0,
        metavar="MINUTES",
        help="wall minutes between jumps back of the sim clock (1 s, 10 s, 185 s in turn; default 10, 0 = none)",
    )
    parser.add_argument(
        "--in-process",
        action="store_true",
        help="soak mrs-nav demo's stack in this process instead of the ROS nodes (no clock jumps)",
    )
    parser.add_argument("--seed", type=seed_option, default=0, help="seed of the planner (and in-process, the noise)")


def lap(demo: Demo) -> Lap:
    """Drive round the four corners once."""
    cpu0, sim0 = time.process_time(), demo.sim.time
    reached = sum(demo.go_to(goal).state == "reached" for goal in CORNERS)
    scans = (demo.sim.time - sim0) * demo.sim.config.laser.rate
    return Lap({IN_PROCESS: Usage(resident_bytes(), time.process_time() - cpu0)}, scans, reached)


def in_process_soak(minutes: float, seed: int) -> tuple[list[Lap], float]:
    """Laps of the arena until ``minutes`` of wall time have passed (at least a warm-up and two windows); the laps
    and sim seconds."""
    config = DemoConfig(start=START, goals=CORNERS, seed=seed, plan_time_budget_s=None, plan_iterations=PLAN_ITERATIONS)
    demo = Demo(load_world(WORLDS_DIR / "simple.world"), config)
    deadline = time.monotonic() + 60.0 * minutes
    laps: list[Lap] = []
    for count in itertools.count(1):
        laps.append(lap(demo))
        if count >= MIN_LAPS and time.monotonic() >= deadline:
            return laps, demo.sim.time
    raise AssertionError("unreachable")


def flatness_table(laps: Sequence[Lap]) -> tuple[str, bool]:
    """Markdown: per process, RSS and CPU per scan in the start and end windows and their growth; whether every
    process is flat."""
    start, end = windows(laps)
    grown = growth(start, end)
    rows: list[list[object]] = [
        [
            name,
            start.usage[name].rss / 1e6,
            end.usage[name].rss / 1e6,
            f"{100 * grown[name].rss:+.1f} %",
            start.cpu_per_scan_ms(name),
            end.cpu_per_scan_ms(name),
            f"{100 * grown[name].cpu_per_scan:+.1f} %",
            "flat" if grown[name].flat else "GROWS",
        ]
        for name in start.usage
    ]
    header = ["process", "RSS start (MB)", "RSS end (MB)", "growth", "CPU/scan start (ms)", "end (ms)", "growth", ""]
    windows_line = (
        f"Start window laps 2-{1 + WINDOW} ({round(start.scans)} scans), "
        f"end window laps {len(laps) - WINDOW + 1}-{len(laps)} ({round(end.scans)} scans)."
    )
    return windows_line + "\n\n" + markdown_table(header, rows), all(g.flat for g in grown.values())


def cpu_series(laps: Sequence[Lap]) -> str:
    """CPU ms per scan of each process at about ten laps spread over the run."""
    step = max(1, len(laps) // 10)
    return "; ".join(
        f"{name}: "
        + ", ".join(f"{i + 1}: {lap.cpu_per_scan_ms(name):.1f}" for i, lap in enumerate(laps) if i % step == 0)
        for name in laps[0].usage
    )


def run(args: argparse.Namespace) -> str:
    wall0 = time.monotonic()
    if args.in_process:
        laps, sim_s = in_process_soak(args.minutes, args.seed)
        what = "Whole headless stack in one process (`mrs_nav.stack.demo`: simulator + SLAM + RRT*, no ROS)"
        jumps_part, jumps_ok = "", True
    else:
        soaked = ros_soak(args.minutes, args.clock_jump_every, args.seed, PLAN_ITERATIONS)
        laps, sim_s = soaked.laps, soaked.sim_s
        what = (
            "The ROS nodes as separate processes (own roscore, `rrt_navigation.launch real_time_factor:=0 "
            f"lockstep:=true rviz:=false seed:={args.seed}`; measured from /proc: {', '.join(NODES)}), goals as "
            "`move_base` action goals"
        )
        jumps_part, jumps_ok = jumps_section(soaked.jumps, args.minutes, args.clock_jump_every)
    wall_min = (time.monotonic() - wall0) / 60.0
    table, flat = flatness_table(laps)
    reached = sum(lap.reached for lap in laps)
    verdict = "PASS" if flat and jumps_ok else "FAIL"
    return (
        f"{what}, round the arena's corners (+-1.5 m) for {wall_min:.1f} wall min ({sim_s / 60.0:.1f} sim min, "
        f"{len(laps)} laps, {reached}/{len(CORNERS) * len(laps)} goals reached); requested --minutes "
        f"{args.minutes:g} (the product's soak is 60); RRT* {PLAN_ITERATIONS} iterations per plan. Other jobs "
        f"shared the machine (load average {os.getloadavg()[0]:.1f} at the end); CPU time is each process's own.\n\n"
        f"{table}\n\nCPU ms per scan by lap: {cpu_series(laps)}.\n\n{jumps_part}"
        f"Flat within {100 * TOLERANCE:.0f} % (RSS and CPU per scan of every process, end window against start "
        f"window){' and every goal after a clock jump reached' if jumps_part else ''}: {verdict}."
    )
