"""SLAM on a scripted drive through a simulated world (the core simulator, no ROS): for tests and benchmarks.

The robot follows waypoints with a simple heading controller on its true pose (the driver is not under test),
SLAM gets the simulator's wheel odometry and scans, and the result is scored against the true trajectory
(ATE after SE(2) alignment) and against the world (map IoU over observed cells).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.maps.world import World
from mrs_nav.sim.simulator import Simulator, SimulatorConfig
from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.eval.map_iou import map_iou
from mrs_nav.slam.eval.metrics import TrajectoryErrors, align_se2, trajectory_errors
from mrs_nav.slam.scan import laser_scan_data
from mrs_nav.slam.slam import Slam

OFFICE_START = Pose2D(-5.0, -5.0, 0.0)
# Along the south corridor, round the south-east corner and up the east corridor: 20 m, about 100 s.
OFFICE_WAYPOINTS = ((5.0, -5.0), (5.0, 5.0))
# Once round the 40 m ring corridor and on along the south corridor past the start (47 m): the loop closes
# when the robot is back in the south corridor, where it set out.
OFFICE_LOOP_WAYPOINTS = ((5.0, -5.0), (5.0, 5.0), (-5.0, 5.0), (-5.0, -5.0), (3.0, -5.0))

# The simulator's wheel odometry errs by 1 % of wheel travel (1 sigma): the matcher's odometry prior is set to
# about twice that, tighter than gmapping's defaults (0.1, 0.2, 0.1, 0.2), which suit a less known robot.
SIM_SLAM_CONFIG = SlamConfig(maxUrange=3.0, srr=0.02, srt=0.05, str=0.02, stt=0.05)

COMMAND_PERIOD = 0.1  # s between driver commands
REACHED = 0.15  # m: a waypoint counts as reached within this distance


@dataclass(frozen=True)
class DriveResult:
    """Errors of the SLAM trajectory, map IoU (strict, and with one cell of tolerance), scans processed and
    the SLAM CPU time per processed scan (ms; process time, so other jobs on the machine do not inflate it)."""

    errors: TrajectoryErrors
    iou: float
    iou_one_cell: float
    scans: int
    slam_ms: tuple[float, ...]
    sim_time_s: float
    slam: Slam

    @property
    def scans_per_second(self) -> float:
        """Processed scans per second of SLAM CPU time."""
        total = sum(self.slam_ms) / 1000.0
        return len(self.slam_ms) / total if total > 0 else math.inf


def drive_with_slam(
    world: World,
    start: Pose2D,
    waypoints: Sequence[tuple[float, float]],
    *,
    slam_config: SlamConfig | None = None,
    sim_config: SimulatorConfig | None = None,
    timeout: float = 300.0,
) -> DriveResult:
    """Drive ``waypoints`` from ``start`` with SLAM running; raises InvalidInputError if they are not reached."""
    sim = Simulator(world, sim_config or SimulatorConfig(odom_noise=0.01, seed=1), start)
    params = sim.config.laser
    slam = Slam(slam_config or SIM_SLAM_CONFIG, Pose2D(params.mount_x, params.mount_y, 0.0))
    truth: list[Pose2D] = []
    slam_ms: list[float] = []
    steps_per_command = max(1, round(COMMAND_PERIOD * sim.config.physics_rate))
    remaining = list(waypoints)
    while remaining:
        if sim.time > timeout:
            raise InvalidInputError(f"scripted drive did not reach {remaining[0]} within {timeout} s of sim time")
        pose = sim.ground_truth()
        gx, gy = remaining[0]
        if math.hypot(gx - pose.x, gy - pose.y) < REACHED:
            remaining.pop(0)
            continue
        error = wrap_angle(math.atan2(gy - pose.y, gx - pose.x) - pose.yaw)
        v = 0.2 * max(0.0, math.cos(error)) ** 4
        sim.set_command(v, max(-1.5, min(1.5, 2.0 * error)))
        for _ in range(steps_per_command):
            scan = sim.step()
            if scan is None:
                continue
            data = laser_scan_data(scan)
            t0 = time.process_time()
            done = slam.add_scan(sim.odometry().pose, data, scan.stamp)
            if done is not None:
                slam_ms.append(1000.0 * (time.process_time() - t0))
                truth.append(sim.ground_truth())
    slam.finish()  # the map from the corrected poses, as after a log's last scan
    estimate = [p.pose for p in slam.processed]
    errors = trajectory_errors(estimate, truth)
    # SLAM fixes its map frame only up to a rigid motion (its first headings come from odometry): the map is
    # compared with the world after the same SE(2) alignment as the ATE, estimate onto ground truth.
    alignment = align_se2(np.array([[p.x, p.y] for p in estimate]), np.array([[p.x, p.y] for p in truth]))
    map_in_world = (alignment.x, alignment.y, alignment.yaw)
    iou = map_iou(slam.grid, world, map_in_world)
    iou_one_cell = map_iou(slam.grid, world, map_in_world, tolerance=1)
    return DriveResult(errors, iou, iou_one_cell, len(estimate), tuple(slam_ms), sim.time, slam)
