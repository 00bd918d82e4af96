"""One simulated drive written twice: as mrs_nav records it and as another robot's user has it.

``package`` bag: ``/scan`` in ``base_scan`` (angles increasing, no return as ``+inf``), ``/odom`` and tf
``odom -> base_footprint``, ``/tf_static`` ``base_footprint -> base_link -> base_scan``.

``foreign`` bag (a gmapping tutorial's recording of a robot with a Hokuyo UTM-30LX-like scanner): ``/scan`` and
``/tf`` only; frames ``odom -> base_link -> laser``, the laser's mounting republished on ``/tf`` at 10 Hz (as
tf's ``static_transform_publisher`` does), angles decreasing (``angle_increment < 0``), no return as readings
outside ``[range_min, range_max]`` (65.533 m beyond, 0 m too close), as the driver reports them.

Both hold the same 270-degree, 1080-beam scans, taken from a 1440-beam full circle of the simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrs_nav.bag.io import TF_MESSAGE, BagWriter, typestore
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, laser_scan_message, odometry_message, tf_message
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.sim import LaserParams
from mrs_nav.sim.scripted_drive import WaypointDriver
from mrs_nav.sim.simulator import Simulator, SimulatorConfig
from mrs_nav.slam.scan import LaserScanData
from tests.rosharness import REPO

FULL_BEAMS = 1440  # 0.25 degree steps around the circle
FOV_BEAMS = 1080  # the middle 270 degrees
RANGE_MIN, RANGE_MAX = 0.1, 10.0
MOUNT = Pose2D(-0.032, 0.0, 0.0)  # the laser in the robot frame (m)
ODOM_PERIOD_STEPS = 5  # odometry at 20 Hz with the 100 Hz physics
NO_RETURN_FAR, NO_RETURN_NEAR = 65.533, 0.0


@dataclass(frozen=True)
class Drive:
    """Scans (stamp s, ranges of the 270-degree field, beams from -135 degrees on) and odometry (stamp s, pose)."""

    scans: list[tuple[float, FloatArray]]
    odometry: list[tuple[float, Pose2D]]


def simulate(duration: float = 30.0) -> Drive:
    """A drive around the course arena's cylinder (worlds/simple.world) for ``duration`` s of sim time."""
    laser = LaserParams(
        beams=FULL_BEAMS, angle_min=-math.pi, range_min=RANGE_MIN, range_max=RANGE_MAX, mount_x=MOUNT.x, mount_y=MOUNT.y
    )
    sim = Simulator(load_world(REPO / "worlds" / "simple.world"), SimulatorConfig(laser=laser), Pose2D(-1.5, -1.5, 0))
    driver = WaypointDriver([(-1.5, -1.5), (1.5, -1.5), (1.5, 1.2), (-1.5, 1.2)], loop=True, speed=0.2)
    first = (FULL_BEAMS - FOV_BEAMS) // 2
    drive = Drive([], [])
    for step in range(round(duration * sim.config.physics_rate)):
        command = driver.command(sim.ground_truth())
        sim.set_command(command.v, command.omega)
        scan = sim.step()
        if scan is not None:
            drive.scans.append((scan.stamp, scan.ranges[first : first + FOV_BEAMS].copy()))
        if step % ODOM_PERIOD_STEPS == 0:
            odom = sim.odometry()
            drive.odometry.append((odom.stamp, odom.pose))
    return drive


def _ns(seconds: float) -> int:
    return round(seconds * 1e9)


def _scan(ranges: FloatArray, *, decreasing: bool) -> LaserScanData:
    step = 2.0 * math.pi / FULL_BEAMS
    angle_min = -FOV_BEAMS / 2 * step
    if not decreasing:
        return LaserScanData(angle_min, step, RANGE_MIN, RANGE_MAX, ranges)
    hokuyo = ranges[::-1].copy()
    hokuyo[hokuyo == math.inf] = NO_RETURN_FAR
    hokuyo[hokuyo == -math.inf] = NO_RETURN_NEAR
    return LaserScanData(angle_min + (FOV_BEAMS - 1) * step, -step, RANGE_MIN, RANGE_MAX, hokuyo)


def write_package_bag(drive: Drive, path: Path) -> Path:
    """The drive in mrs_nav's frames and conventions."""
    with BagWriter(path) as writer:
        writer.write("/tf_static", TF_MESSAGE, 0, tf_message(Pose2D(0, 0, 0), 0.0, "base_footprint", "base_link"))
        writer.write("/tf_static", TF_MESSAGE, 0, tf_message(MOUNT, 0.0, "base_link", "base_scan"))
        for stamp, pose in drive.odometry:
            writer.write("/odom", ODOMETRY, _ns(stamp), odometry_message(pose, stamp, "odom", "base_footprint"))
            writer.write("/tf", TF_MESSAGE, _ns(stamp), tf_message(pose, stamp, "odom", "base_footprint"))
        for stamp, ranges in drive.scans:
            message = laser_scan_message(_scan(ranges, decreasing=False), stamp, "base_scan")
            writer.write("/scan", LASER_SCAN, _ns(stamp), message)
    return path


def write_foreign_bag(
    drive: Drive,
    path: Path,
    *,
    scan_topic: str = "/scan",
    odom_frame: str = "odom",
    mount_frame: str = "laser",
    upside_down: bool = False,
) -> Path:
    """The drive as a gmapping tutorial records another robot: ``/scan`` and ``/tf`` only (module docstring).

    ``mount_frame`` other than ``laser`` puts the mounting on a frame the scans do not name (tf never links them);
    ``upside_down`` mounts the laser rolled by 180 degrees, so its angles run the other way round.
    """
    next_mount = 0.0
    with BagWriter(path) as writer:
        for stamp, pose in drive.odometry:
            writer.write("/tf", TF_MESSAGE, _ns(stamp), tf_message(pose, stamp, odom_frame, "base_link"))
            if stamp >= next_mount:
                mount = tf_message(MOUNT, stamp, "base_link", mount_frame)
                if upside_down:
                    mount.transforms[0].transform.rotation = typestore().types["geometry_msgs/msg/Quaternion"](
                        x=1.0, y=0.0, z=0.0, w=0.0
                    )
                writer.write("/tf", TF_MESSAGE, _ns(stamp), mount)
                next_mount = stamp + 0.1
        for stamp, ranges in drive.scans:
            scan = _scan(ranges, decreasing=True)
            if upside_down:
                scan = LaserScanData(-scan.angle_min, -scan.angle_increment, RANGE_MIN, RANGE_MAX, scan.ranges)
            writer.write(scan_topic, LASER_SCAN, _ns(stamp), laser_scan_message(scan, stamp, "laser"))
    return path


def trajectory(out: Path) -> FloatArray:
    """The (stamp, x, y, yaw) rows of a replay's trajectory.csv."""
    rows = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2, 3), ndmin=2)
    return np.asarray(rows, dtype=np.float64)
