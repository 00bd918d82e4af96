"""Simulator speed: the core at 100 Hz physics + 5 Hz laser in the office, and the ROS node at maximum rate.

Core: a scripted drive (the robot follows the office's corridor loop by pure pursuit) for ``--duration`` s of
sim time; the real-time factor is sim time over wall time, with the cost split into physics steps and scans.
The product's target is >= 50x real time.

ROS: a roscore on a free port and ``roslaunch mrs_nav simulation.launch real_time_factor:=0`` in the same
world; ``/clock`` is sampled (with Debian's ``rostopic``) at the start and end of a ``--ros-seconds`` wall
window, and the real-time factor is the sim time that passed over the wall time. Every process started is
ended, whatever happens.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

from mrs_nav.bench.results import markdown_table
from mrs_nav.bench.ros_processes import CHECKOUT, RosProcessError, process, read_clock, roscore
from mrs_nav.cli.common import parse_floats
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.sim import Simulator, SimulatorConfig
from mrs_nav.sim.scripted_drive import OFFICE_CORRIDOR_LOOP, WaypointDriver
from mrs_nav.world import load_world

OFFICE = CHECKOUT / "worlds" / "office.world"
OFFICE_START = Pose2D(-5.0, -5.0, 0.0)
TARGET_RTF = 50.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", type=Path, default=OFFICE, help="world file (default: the office)")
    parser.add_argument("--start", default="-5,-5,0", help="start pose x,y,yaw (default: -5,-5,0)")
    parser.add_argument("--duration", type=float, default=120.0, help="sim seconds of the core run (default 120)")
    parser.add_argument("--ros-seconds", type=float, default=20.0, help="wall seconds of the ROS run (default 20)")
    parser.add_argument("--no-ros", action="store_true", help="skip the ROS run")


def bench_core(world_path: Path, start: Pose2D, duration: float) -> dict[str, float]:
    """Run the core for ``duration`` sim seconds; the real-time factor and the cost of a step and of a scan.

    The robot follows the corridor loop of the office (centre line on the square of half-side 5 m).
    """
    world = load_world(world_path)
    sim = Simulator(world, SimulatorConfig(), start)
    driver = WaypointDriver(OFFICE_CORRIDOR_LOOP)
    steps = round(duration * sim.config.physics_rate)
    plain: list[float] = []
    with_scan: list[float] = []
    travelled = 0.0
    previous = start
    t0 = time.perf_counter()
    for _ in range(steps):
        pose = sim.ground_truth()
        travelled += math.hypot(pose.x - previous.x, pose.y - previous.y)
        previous = pose
        command = driver.command(pose)
        sim.set_command(command.v, command.omega)
        t = time.perf_counter()
        scan = sim.step()
        (plain if scan is None else with_scan).append(time.perf_counter() - t)
    wall = time.perf_counter() - t0
    step_cost = sum(plain) / max(len(plain), 1)
    odom, truth = sim.odometry().pose, sim.ground_truth()
    return {
        "sim_seconds": sim.time,
        "wall_seconds": wall,
        "rtf": sim.time / wall,
        "scans": float(len(with_scan)),
        "step_us": step_cost * 1e6,
        "scan_ms": (sum(with_scan) / max(len(with_scan), 1) - step_cost) * 1e3,
        "contacts": float(sim.contacts.events),
        "distance": travelled,
        "odom_error": math.hypot(odom.x - truth.x, odom.y - truth.y),
    }


def bench_ros(world_path: Path, start: Pose2D, wall_seconds: float) -> dict[str, float]:
    """The node at real_time_factor 0: sim seconds per wall second over a window of ``wall_seconds``."""
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_") as tmp:
        log_dir = Path(tmp)
        with roscore(log_dir) as env:
            launch = [
                "roslaunch",
                "--wait",
                "mrs_nav",
                "simulation.launch",
                f"world:={world_path.resolve()}",
                f"x:={start.x}",
                f"y:={start.y}",
                f"yaw:={start.yaw}",
                "real_time_factor:=0",
            ]
            with process(launch, env, log_dir / "launch.log") as proc:
                sim0, wall0 = read_clock(env, timeout=60.0)
                time.sleep(wall_seconds)
                sim1, wall1 = read_clock(env)
                if proc.poll() is not None:
                    raise RosProcessError(f"roslaunch exited early: {(log_dir / 'launch.log').read_text()[-500:]}")
    return {"sim_seconds": sim1 - sim0, "wall_seconds": wall1 - wall0, "rtf": (sim1 - sim0) / (wall1 - wall0)}


def run(args: argparse.Namespace) -> str:
    start = Pose2D(*parse_floats(args.start, 3, "--start"))
    if not (args.duration > 0 and args.ros_seconds > 0):
        raise InvalidInputError("--duration and --ros-seconds must be positive")
    core = bench_core(args.world, start, args.duration)
    verdict = "meets" if core["rtf"] >= TARGET_RTF else "MISSES"
    lines = [
        f"Core simulator (`mrs_nav.sim.Simulator`), world `{args.world.name}`, start {args.start}, 100 Hz physics, "
        "5 Hz 360-beam laser, following the corridor loop (square |x|, |y| = 5 m) at 0.2 m/s. "
        f"Target >= {TARGET_RTF:.0f}x real time: **{verdict}**.",
        "",
        markdown_table(
            [
                "sim s",
                "wall s",
                "real-time factor",
                "physics step (µs)",
                "scan (ms)",
                "scans",
                "contacts",
                "travelled (m)",
            ],
            [
                [
                    core["sim_seconds"],
                    core["wall_seconds"],
                    core["rtf"],
                    core["step_us"],
                    core["scan_ms"],
                    int(core["scans"]),
                    int(core["contacts"]),
                    core["distance"],
                ]
            ],
        ),
    ]
    if not args.no_ros:
        ros = bench_ros(args.world, start, args.ros_seconds)
        lines += [
            "",
            "ROS node at maximum rate (`simulation.launch real_time_factor:=0`, own roscore on a free port; "
            "/clock 100 Hz, /odom + tf + ground truth 50 Hz, joint_states 10 Hz, /scan 5 Hz of sim time; "
            "robot_state_publisher running; nobody else subscribed):",
            "",
            markdown_table(
                ["sim s", "wall s", "achieved real-time factor"],
                [[ros["sim_seconds"], ros["wall_seconds"], ros["rtf"]]],
            ),
        ]
    return "\n".join(lines)
