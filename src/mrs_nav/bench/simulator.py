"""Simulator speed: the core at 100 Hz physics + 5 Hz laser in the office, and the ROS node at maximum rate.

Core: a scripted drive (the robot follows the office's corridor loop by pure pursuit) for ``--duration`` s of
sim time, best of ``--repeats`` runs; the real-time factor is sim time over wall time and over the process's
CPU time (on a shared machine the wall figure says what other processes left, the CPU figure what the
simulator costs), with median costs of a physics step and of a scan. The product's target is >= 50x.

ROS: a roscore on a free port and ``roslaunch mrs_nav simulation.launch real_time_factor:=0`` in the same
world; ``/clock`` is sampled (with Debian's ``rostopic``) at the start and end of a ``--ros-seconds`` wall
window, and the real-time factor is the sim time that passed over the wall time. Every process started is
ended, whatever happens.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.options import duration_option, parse_floats, runs_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.ros_processes import RosProcessError, process, read_clock, roscore, roslaunch_command
from mrs_nav.sim import Simulator, SimulatorConfig
from mrs_nav.sim.scripted_drive import OFFICE_CORRIDOR_LOOP, WaypointDriver
from mrs_nav.tables import markdown_table

OFFICE = WORLDS_DIR / "office.world"
OFFICE_START = Pose2D(-5.0, -5.0, 0.0)
TARGET_RTF = 50.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", type=Path, default=OFFICE, help="world file (default: the office)")
    parser.add_argument("--start", default="-5,-5,0", help="start pose x,y,yaw (default: -5,-5,0)")
    parser.add_argument(
        "--duration", type=duration_option, default=120.0, help="sim seconds of the core run (default 120)"
    )
    parser.add_argument(
        "--ros-seconds", type=duration_option, default=20.0, help="wall seconds of the ROS run (default 20)"
    )
    parser.add_argument("--repeats", type=runs_option, default=3, help="core runs; the best is reported (default 3)")
    parser.add_argument("--no-ros", action="store_true", help="skip the ROS run")


def bench_core(world_path: Path, start: Pose2D, duration: float) -> dict[str, float]:
    """Run the core for ``duration`` sim seconds; real-time factors (wall and CPU) and the cost of a step and a scan.

    The robot follows the corridor loop of the office (centre line on the square of half-side 5 m), with the
    pure-pursuit command recomputed at 20 Hz as a controller node would.
    """
    world = load_world(world_path)
    sim = Simulator(world, SimulatorConfig(), start)
    driver = WaypointDriver(OFFICE_CORRIDOR_LOOP)
    control_every = round(sim.config.physics_rate / 20.0)
    steps = round(duration * sim.config.physics_rate)
    plain: list[float] = []
    with_scan: list[float] = []
    travelled = 0.0
    previous = start
    t0, cpu0 = time.perf_counter(), time.process_time()
    for i in range(steps):
        if i % control_every == 0:
            pose = sim.ground_truth()
            travelled += math.hypot(pose.x - previous.x, pose.y - previous.y)
            previous = pose
            command = driver.command(pose)
            sim.set_command(command.v, command.omega)
        t = time.perf_counter()
        scan = sim.step()
        (plain if scan is None else with_scan).append(time.perf_counter() - t)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    step_cost = sorted(plain)[len(plain) // 2]  # medians: robust to the other processes on the machine
    scan_cost = sorted(with_scan)[len(with_scan) // 2] - step_cost if with_scan else 0.0
    return {
        "sim_seconds": sim.time,
        "wall_seconds": wall,
        "cpu_seconds": cpu,
        "rtf": sim.time / wall,
        "cpu_rtf": sim.time / cpu,
        "scans": float(len(with_scan)),
        "step_us": step_cost * 1e6,
        "scan_ms": scan_cost * 1e3,
        "contacts": float(sim.contacts.events),
        "distance": travelled,
    }


def bench_ros(world_path: Path, start: Pose2D, wall_seconds: float) -> dict[str, float]:
    """The node at real_time_factor 0: sim seconds per wall second over a window of ``wall_seconds``."""
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_") as tmp:
        log_dir = Path(tmp)
        with roscore(log_dir) as env:
            launch = roslaunch_command("simulation.launch", world_path, start, "real_time_factor:=0")
            with process(launch, env, log_dir / "launch.log") as proc:
                sim0, wall0 = read_clock(env, timeout=60.0)
                time.sleep(wall_seconds)
                sim1, wall1 = read_clock(env)
                if proc.poll() is not None:
                    raise RosProcessError(f"roslaunch exited early: {(log_dir / 'launch.log').read_text()[-500:]}")
    return {"sim_seconds": sim1 - sim0, "wall_seconds": wall1 - wall0, "rtf": (sim1 - sim0) / (wall1 - wall0)}


def run(args: argparse.Namespace) -> str:
    start = Pose2D(*parse_floats(args.start, 3, "--start"))
    if not (args.duration > 0 and args.ros_seconds > 0 and args.repeats > 0):
        raise InvalidInputError("--duration, --ros-seconds and --repeats must be positive")
    load = os.getloadavg()[0]
    runs = [bench_core(args.world, start, args.duration) for _ in range(args.repeats)]
    core = max(runs, key=lambda r: r["rtf"])
    verdict = "meets" if core["cpu_rtf"] >= TARGET_RTF else "MISSES"
    lines = [
        f"Core simulator (`mrs_nav.sim.Simulator`), world `{args.world.name}`, start {args.start}, 100 Hz physics, "
        "5 Hz 360-beam laser, following the corridor loop (square |x|, |y| = 5 m) at up to 0.2 m/s, best of "
        f"{args.repeats} runs; load average {load:.1f} on {os.cpu_count()} cores when it started. The real-time "
        "factor is given against wall time (what other processes leave) and against the process's CPU time (the "
        f"simulator's own cost). Target >= {TARGET_RTF:.0f}x real time (CPU): **{verdict}**.",
        "",
        markdown_table(
            [
                "sim s",
                "wall s",
                "RTF (wall)",
                "RTF (CPU)",
                "physics step (µs)",
                "scan (ms)",
                "contacts",
                "travelled (m)",
            ],
            [
                [
                    core["sim_seconds"],
                    core["wall_seconds"],
                    core["rtf"],
                    core["cpu_rtf"],
                    core["step_us"],
                    core["scan_ms"],
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
