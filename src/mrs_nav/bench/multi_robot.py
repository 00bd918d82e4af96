"""Several robots at once: simulator + SLAM + RRT* navigation for 3 robots in the office, max rate, lockstep.

A roscore on a free port and ``roslaunch mrs_nav multi_robot.launch robots:=3 real_time_factor:=0
lockstep:=true`` (one simulator node hosting every robot, per robot a SLAM and a navigation node, 7 processes)
with :mod:`mrs_nav.ros.navigation_bench_peer` sending every robot its goal at once. Two robots cross the east
core room (their straight lines cross), the third crosses the west core room. Reported per run: the
real-time factor from the goals to the last outcome, per robot goal reached, true distance to the goal and
contacts (walls and other robots alike), and the CPU time all the stack's processes used per second of sim
time while driving (sampled every 0.25 s, read off at the goals and the last outcome) and over the whole run
(start-up included).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.ros_processes import (
    TAG_VARIABLE,
    RosProcessError,
    process,
    read_clock,
    roscore,
    run_peer,
    tagged_pids,
)
from mrs_nav.tables import markdown_table

TARGET_RTF = 3.0  # 3 robots, whole stack, max rate in lockstep on a 2-core machine (issue 17)
GOAL_TOLERANCE_M = 0.3  # true distance: the SLAM estimate is within 0.05 m, the SLAM error adds to it
# name: (start, goal) in the office, world frame. tb3_0 and tb3_1 cross in the east core room (as in
# tests/ros/test_multi_robot.py), tb3_2 crosses the west core room on its own.
ROBOTS = {
    "tb3_0": (Pose2D(1.0, -3.0, 1.5708), (3.0, 3.0)),
    "tb3_1": (Pose2D(3.0, -1.0, 1.5708), (1.0, 3.0)),
    "tb3_2": (Pose2D(-3.0, -3.0, 1.5708), (-1.0, 3.0)),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs", type=int, default=1, help="runs, seeds 0.. (default 1)")


def _stack_cpu_seconds(launch_pid: int) -> dict[str, float]:
    """User + system CPU seconds so far of the launch and every node it started, summed per node type
    (``simulator``, ``slam``, ``rrt_navigation``, ...; ``roslaunch`` for the rest). roslaunch puts its nodes in
    sessions of their own, so they are found by the tag :func:`mrs_nav.ros_processes.process` gave them."""
    environ = Path(f"/proc/{launch_pid}/environ").read_bytes().split(b"\0")
    tag = next(v.split(b"=", 1)[1].decode() for v in environ if v.startswith(f"{TAG_VARIABLE}=".encode()))
    seconds: dict[str, float] = {}
    for pid in tagged_pids(tag):
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            argv = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace").split("\0")
        except (OSError, IndexError):
            continue  # ended meanwhile
        name = next((a.split(":=", 1)[1] for a in argv if a.startswith("__name:=")), "roslaunch")
        ticks = int(fields[11]) + int(fields[12])  # utime, stime: fields 14 and 15 of stat
        seconds[name] = seconds.get(name, 0.0) + ticks / os.sysconf("SC_CLK_TCK")
    return seconds


class _CpuSampler:
    """Samples the stack's CPU seconds by node every ``period`` wall seconds in a thread, so the CPU spent between
    two instants another process names (the peer's goals and last outcome) can be read off afterwards."""

    def __init__(self, launch_pid: int, period: float = 0.25) -> None:
        self._pid, self._period = launch_pid, period
        self.samples: list[tuple[float, dict[str, float]]] = []  # (time.monotonic(), CPU s by node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> _CpuSampler:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        while True:
            try:
                self.samples.append((time.monotonic(), _stack_cpu_seconds(self._pid)))
            except OSError:
                return  # the launch ended
            if self._stop.wait(self._period):
                return

    def wait_past(self, instant: float) -> None:
        """Until a sample at or after ``instant`` (monotonic s) is taken (or sampling ended)."""
        while self._thread.is_alive() and (not self.samples or self.samples[-1][0] < instant):
            time.sleep(0.05)

    def between(self, start: float, end: float) -> dict[str, float]:
        """CPU s by node from the last sample at or before ``start`` to the first at or after ``end`` (so the
        window is covered, widened by at most one period each side)."""
        before = [cpu for t, cpu in self.samples if t <= start]
        after = [cpu for t, cpu in self.samples if t >= end]
        if not before or not after:
            raise RosProcessError("the CPU samples do not cover the driving window")
        return {name: after[0][name] - before[-1].get(name, 0.0) for name in after[0]}


def run_once(seed: int) -> dict[str, Any]:
    """One run; the peer's JSON plus the stack's CPU s by node while driving (``cpu_by_node``, from the goals to
    the last outcome) and over the whole launch (``cpu_run_s``, start-up included, with ``total_sim_s``)."""
    poses = [f"pose{i}:={s.x} {s.y} {s.yaw}" for i, (s, _) in enumerate(ROBOTS.values())]
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_") as tmp:
        log_dir = Path(tmp)
        with roscore(log_dir) as env:
            launch = ["roslaunch", "--wait", "mrs_nav", "multi_robot.launch", f"robots:={len(ROBOTS)}", *poses]
            launch += [f"world:={(WORLDS_DIR / 'office.world').resolve()}", "real_time_factor:=0"]
            launch += ["lockstep:=true", "rviz:=false", f"seed:={seed}", f"planner_seed:={seed}"]
            peer = [arg for name, (_, goal) in ROBOTS.items() for arg in ("--robot", name, *map(str, goal))]
            with process(launch, env, log_dir / "launch.log") as proc, _CpuSampler(proc.pid) as sampler:
                result: dict[str, Any] = run_peer(proc, env, log_dir, peer)
                end = result["wall_start"] + result["wall_s"]
                sampler.wait_past(end)
                # rostopic's start-up alone took over 20 s at load average 19 on this 2-core machine
                total_sim, _ = read_clock(env, timeout=60.0)
                run_cpu = sum(sampler.samples[-1][1].values())  # sampled at most 0.25 s before the clock was read
    cpu = sampler.between(result["wall_start"], end)
    return {**result, "cpu_s": sum(cpu.values()), "cpu_by_node": cpu, "cpu_run_s": run_cpu, "total_sim_s": total_sim}


def run(args: argparse.Namespace) -> str:
    if args.runs < 1:
        raise InvalidInputError(f"--runs must be >= 1, got {args.runs}")
    load = os.getloadavg()
    rows, factors, all_ok = [], [], True
    for seed in range(args.runs):
        r = run_once(seed)
        rtf = r["sim_s"] / r["wall_s"]
        factors.append(rtf)
        for name, robot in r["robots"].items():
            ok = robot["reached"] and robot["final_error_m"] <= GOAL_TOLERANCE_M and robot["contacts"] == 0
            all_ok = all_ok and ok
            rows.append(
                [
                    seed,
                    name,
                    "reached" if robot["reached"] else "FAILED",
                    robot["final_error_m"],
                    int(robot["contacts"]),
                    robot["sim_s"],
                    rtf,
                    r["cpu_s"] / r["sim_s"],
                    r["cpu_run_s"] / r["total_sim_s"],
                ]
            )
    verdict = "meets" if min(factors) >= TARGET_RTF else "MISSES"
    split = ", ".join(f"{name} {cpu / r['sim_s']:.3f}" for name, cpu in sorted(r["cpu_by_node"].items()))
    header = [
        "seed",
        "robot",
        "goal",
        "true error (m)",
        "contacts",
        "time to goal (sim s)",
        "real-time factor",
        "stack CPU s per sim s (driving)",
        "stack CPU s per sim s (whole run)",
    ]
    starts = ", ".join(f"{n} ({s.x:g}, {s.y:g}) -> ({g[0]:g}, {g[1]:g})" for n, (s, g) in ROBOTS.items())
    return (
        f"{len(ROBOTS)} robots in `office.world` (`multi_robot.launch robots:={len(ROBOTS)} real_time_factor:=0 "
        "lockstep:=true`: one simulator node, per robot SLAM and RRT* navigation, own roscore on a free port), "
        f"every goal sent at once: {starts}. Real-time factor from the goals to the last outcome (wall clock, "
        f"while other jobs shared the machine: load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} "
        f"(1/5/15 min) on {os.cpu_count()} cores at the start); CPU s of all the stack's processes per sim s while "
        "driving (goals to last outcome, what the real-time factor is measured over) and over the whole run "
        "(start-up and the idle time until the clock is read included). "
        f"Target >= {TARGET_RTF:.0f}x real time: **{verdict}**; every goal reached within "
        f"{GOAL_TOLERANCE_M} m (true pose) without contact: **{'yes' if all_ok else 'NO'}**.\n\n"
        + markdown_table(header, rows)
        + f"\n\nCPU s per sim s by node while driving (all robots together, last run): {split}."
    )
