"""Soak: the whole headless stack driving between goals for a long run; memory and cost per scan must stay flat.

The stack is `mrs-nav demo`'s (simulator + SLAM + RRT* navigation in one process, at the simulator's maximum
rate) in the course arena, sent round the four corners (+-1.5 m) for ``--minutes`` of wall time (default 60).
The first lap maps the arena and is a warm-up; the three laps after it are the start window and the last three
laps the end window (a lap's replans vary, so one lap is a noisy sample). In each window the resident set size
(RSS, from /proc, at the window's end) and the process CPU time per simulated scan are taken; the run passes
when both end figures are within 10 % of the start figures. CPU time, not wall time, so that other jobs on a
shared machine do not count against the stack; and RRT* plans a fixed number of iterations rather than for the
demo's wall-clock budget, which would spend more CPU per plan on a quieter machine and so read a change of load
as growth.
"""

from __future__ import annotations

import argparse
import itertools
import os
import time
from dataclasses import dataclass

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.options import number_option, seed_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.stack.demo import Demo, DemoConfig
from mrs_nav.tables import markdown_table

CORNERS = ((1.5, 1.5), (-1.5, 1.5), (1.5, -1.5), (-1.5, -1.5))
START = Pose2D(-1.5, -1.5, 0.0)
#: Largest growth of RSS and of CPU time per scan from the start window to the end window.
TOLERANCE = 0.10
#: RRT* samples per plan: about what the demo's 0.25 s budget gives on an idle core.
PLAN_ITERATIONS = 1500
#: Laps in each of the start and end windows.
WINDOW = 3


@dataclass(frozen=True)
class Lap:
    """One round of the four corners: RSS at its end (bytes), CPU seconds and scans simulated in it."""

    rss: int
    cpu_s: float
    scans: float
    reached: int

    @property
    def cpu_per_scan_ms(self) -> float:
        return 1000.0 * self.cpu_s / self.scans if self.scans else float("nan")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--minutes",
        type=number_option(0.1, 24 * 60.0),
        default=60.0,
        help=f"wall minutes to run, at least {1 + 2 * WINDOW} laps (default 60)",
    )
    parser.add_argument("--seed", type=seed_option, default=0, help="seed of the simulator noise and the planner")


def resident_bytes() -> int:
    """This process's resident set size in bytes (Linux /proc)."""
    with open("/proc/self/statm", encoding="ascii") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def lap(demo: Demo) -> Lap:
    """Drive round the four corners once."""
    cpu0, sim0 = time.process_time(), demo.sim.time
    reached = sum(demo.go_to(goal).state == "reached" for goal in CORNERS)
    scans = (demo.sim.time - sim0) * demo.sim.config.laser.rate
    return Lap(resident_bytes(), time.process_time() - cpu0, scans, reached)


def soak(minutes: float, seed: int) -> tuple[list[Lap], float]:
    """Laps of the arena until ``minutes`` of wall time have passed (at least a warm-up and two windows); the laps
    and sim seconds."""
    config = DemoConfig(start=START, goals=CORNERS, seed=seed, plan_time_budget_s=None, plan_iterations=PLAN_ITERATIONS)
    demo = Demo(load_world(WORLDS_DIR / "simple.world"), config)
    deadline = time.monotonic() + 60.0 * minutes
    laps: list[Lap] = []
    for count in itertools.count(1):
        laps.append(lap(demo))
        if count >= 1 + 2 * WINDOW and time.monotonic() >= deadline:
            return laps, demo.sim.time
    raise AssertionError("unreachable")


def window(laps: list[Lap]) -> Lap:
    """Several consecutive laps as one: RSS at the last, CPU time and scans summed."""
    return Lap(laps[-1].rss, sum(x.cpu_s for x in laps), sum(x.scans for x in laps), sum(x.reached for x in laps))


def run(args: argparse.Namespace) -> str:
    wall0 = time.monotonic()
    laps, sim_s = soak(args.minutes, args.seed)
    wall_min = (time.monotonic() - wall0) / 60.0
    start, end = window(laps[1 : 1 + WINDOW]), window(laps[-WINDOW:])
    rss_growth = end.rss / start.rss - 1.0
    cpu_growth = end.cpu_per_scan_ms / start.cpu_per_scan_ms - 1.0
    passed = rss_growth <= TOLERANCE and cpu_growth <= TOLERANCE
    reached = sum(lap.reached for lap in laps)
    table = markdown_table(
        ["window", "RSS (MB)", "CPU per scan (ms)", "scans in window"],
        [
            [f"start (laps 2-{1 + WINDOW})", start.rss / 1e6, start.cpu_per_scan_ms, round(start.scans)],
            [f"end (laps {len(laps) - WINDOW + 1}-{len(laps)})", end.rss / 1e6, end.cpu_per_scan_ms, round(end.scans)],
            ["growth", f"{100 * rss_growth:+.1f} %", f"{100 * cpu_growth:+.1f} %", ""],
        ],
    )
    step = max(1, len(laps) // 10)
    series = ", ".join(f"{i + 1}: {lap.cpu_per_scan_ms:.1f}" for i, lap in enumerate(laps) if i % step == 0)
    load = os.getloadavg()[0]
    return (
        f"Whole headless stack (simulator + SLAM + RRT*) round the arena's corners for {wall_min:.1f} wall min "
        f"({sim_s / 60.0:.1f} sim min, {len(laps)} laps, {reached}/{4 * len(laps)} goals reached); requested "
        f"--minutes {args.minutes:g} (the product's soak is 60); RRT* {PLAN_ITERATIONS} iterations per plan. "
        f"Other jobs shared the machine (load average {load:.1f} at the end); CPU time is the process's own.\n\n"
        f"{table}\n\n"
        f"CPU ms per scan by lap: {series}.\n\n"
        f"Flat within {100 * TOLERANCE:.0f} % (RSS and CPU per scan, end window against start window): "
        f"{'PASS' if passed else 'FAIL'}."
    )
