"""Contacts: both followers through their whole ROS stack, seeded runs in lockstep at max rate, must never touch.

Each run is its own roscore and ``roslaunch`` of the follower's launch file (``real_time_factor:=0
lockstep:=true seed:=N``) in the course arena, the robot from (-1.5, -1.5) to the goal (1.5, 1.5), whose
diagonal runs past the cylinder: ``potential_field_navigation.launch`` (the potential-field follower with the
world's obstacles) and ``rrt_navigation.launch`` (SLAM and the RRT* path follower). The goal goes out through
:mod:`mrs_nav.ros.navigation_bench_peer`, which counts the simulator's ground-truth contacts and the smallest
clearance of the true footprint. Reported per follower: runs, goals reached, runs with a contact, the contacts
in all, the smallest clearance and the seeds that touched. Seeds run from ``--first-seed`` (0) for each
follower. Each run's outcome, with the times the simulator left lockstep (its free-running warnings), also goes
to stderr as the run ends.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.options import optional_runs_option, runs_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.ros_processes import process, roscore, roslaunch_command, run_peer
from mrs_nav.sim.lockstep import FREE_RUN_LOG
from mrs_nav.tables import markdown_table

# The arena of bench navigation: the diagonal from the start to the goal passes the cylinder at (0.3, 0.2).
WORLD, START, GOAL = "simple.world", Pose2D(-1.5, -1.5, 0.0), (1.5, 1.5)


@dataclass(frozen=True)
class Follower:
    """A follower's launch file, the node the peer talks to and any further launch arguments."""

    launch: str
    navigator: str
    args: tuple[str, ...] = ()


FOLLOWERS = {
    "potential-field": Follower("potential_field_navigation.launch", "potential_field_navigation"),
    "rrt": Follower("rrt_navigation.launch", "rrt_navigation", ("rviz:=false",)),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs", type=runs_option, default=200, help="seeded runs per follower (default 200)")
    parser.add_argument(
        "--first-seed", type=optional_runs_option, default=0, help="seed of the first run (default 0; to split a bench)"
    )
    parser.add_argument("--followers", default=",".join(FOLLOWERS), help="comma-separated: " + ", ".join(FOLLOWERS))


def run_once(follower: Follower, seed: int) -> dict[str, Any]:
    """One goal in the arena through ``follower``'s launch file at max rate in lockstep; the peer's JSON."""
    world = WORLDS_DIR / WORLD
    with tempfile.TemporaryDirectory(prefix="mrs_nav_contacts_") as tmp:
        log_dir = Path(tmp)
        with roscore(log_dir) as env:
            launch = roslaunch_command(
                follower.launch,
                world,
                START,
                "real_time_factor:=0",
                "lockstep:=true",
                f"seed:={seed}",
                *follower.args,
            )
            with process(launch, env, log_dir / "launch.log") as proc:
                goal = ["--goal", *map(str, GOAL)]
                result = dict(
                    run_peer(proc, env, log_dir, [*goal, "--navigator", follower.navigator, "--world", str(world)])
                )
            # the simulator logs to the screen, that is launch.log, once per switch out of lockstep
            log = (log_dir / "launch.log").read_text(errors="replace").splitlines()
            result["free_run_log"] = [line for line in log if FREE_RUN_LOG in line]
            return result


def _run_line(name: str, seed: int, result: dict[str, Any]) -> str:
    """One run's outcome, printed as it ends so that a later failure of the invocation loses no finished run."""
    clearance = result["min_clearance_m"]
    return (
        f"{name} seed {seed}: reached {result['reached']}, final error {result['final_error_m']:.3f} m, "
        f"contacts {result['contacts']}, min clearance {'-' if clearance is None else f'{clearance:.3f}'} m, "
        f"sim {result['sim_s']:.1f} s (goal at {result['sim_start']:.1f} s), "
        f"lockstep free runs {len(result['free_run_log'])}"
    ) + "".join(f"\n  {line}" for line in result["free_run_log"])


def _row(name: str, results: list[dict[str, Any]], first_seed: int = 0) -> list[object]:
    touched = [seed for seed, r in enumerate(results, first_seed) if r["contacts"] > 0]
    clearances = [r["min_clearance_m"] for r in results if r["min_clearance_m"] is not None]
    return [
        name,
        len(results),
        sum(1 for r in results if r["reached"] and r["final_error_m"] <= 0.2),
        len(touched),
        sum(int(r["contacts"]) for r in results),
        min(clearances, default=float("nan")),
        statistics.median(clearances) if clearances else float("nan"),
        statistics.median(r["sim_s"] for r in results),
        ", ".join(map(str, touched)) or "-",
    ]


def run(args: argparse.Namespace) -> str:
    names = [name.strip() for name in args.followers.split(",") if name.strip()]
    unknown = [name for name in names if name not in FOLLOWERS]
    if unknown or not names:
        raise InvalidInputError(
            f"--followers: unknown {unknown or args.followers!r}; expected some of {', '.join(FOLLOWERS)}"
        )
    rows = []
    for name in names:
        seeds = range(args.first_seed, args.first_seed + args.runs)
        results = []
        for seed in tqdm(seeds, desc=name, leave=False):
            results.append(run_once(FOLLOWERS[name], seed))
            tqdm.write(_run_line(name, seed, results[-1]), file=sys.stderr)
        rows.append(_row(name, results, args.first_seed))
    header = [
        "follower",
        "runs",
        "reached",
        "runs with a contact",
        "contacts",
        "min clearance [m]",
        "median of the runs' min clearance [m]",
        "time to goal median (sim s)",
        "seeds that touched",
    ]
    return (
        f"Each follower's whole ROS stack in lockstep at max rate (own roscore, `{FOLLOWERS['potential-field'].launch}`"
        f" / `{FOLLOWERS['rrt'].launch} rviz:=false`, `real_time_factor:=0 lockstep:=true seed:=N`, "
        f"seeds {args.first_seed}..{args.first_seed + args.runs - 1}), "
        f"arena `{WORLD}` from ({START.x}, {START.y}) to {GOAL}: ground-truth contacts "
        "(`/ground_truth/contacts`) and the true footprint's (Burger radius 0.105 m) smallest clearance to the "
        "world over the run. Target: 0 contacts.\n\n" + markdown_table(header, rows)
    )
