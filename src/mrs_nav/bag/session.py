"""Recording a headless session (``mrs-nav demo``): what ``launch/record.launch`` records of the same run, and
the outputs of its SLAM and planner for ``mrs-nav replay`` to compare with.

Topics and frames are those of the live system (DESIGN.md): ``/scan`` (``base_scan``), ``/odom`` and tf
``odom -> base_footprint``, ``/ground_truth/odom`` (frame ``world``), tf ``map -> odom`` from SLAM,
``/tf_static`` (``base_footprint -> base_link -> base_scan``), ``/cmd_vel`` and ``/move_base_simple/goal``
(frame ``map``); and the stack's outputs ``/clock``, ``/map`` (latched) and ``/path``, which a recording leaves
out (:mod:`mrs_nav.bag.topics`): play such a bag into a live stack with ``slam.launch sim:=false play:=BAG``,
which takes its sensor topics only. Bag time is sim time.
"""

from __future__ import annotations

from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from mrs_nav.bag.io import TF_MESSAGE, BagWriter, typestore
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, _header, _pose_parts, _time, laser_scan_message
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.sim import LaserParams, Scan
from mrs_nav.slam.scan import laser_scan_data

CLOCK = "rosgraph_msgs/msg/Clock"
TWIST = "geometry_msgs/msg/Twist"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
PATH = "nav_msgs/msg/Path"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"

#: Topics a session bag holds, with their types.
SESSION_TOPICS = {
    "/scan": LASER_SCAN,
    "/odom": ODOMETRY,
    "/ground_truth/odom": ODOMETRY,
    "/tf": TF_MESSAGE,
    "/tf_static": TF_MESSAGE,
    "/clock": CLOCK,
    "/cmd_vel": TWIST,
    "/map": OCCUPANCY_GRID,
    "/path": PATH,
    "/move_base_simple/goal": POSE_STAMPED,
}


def _ns(seconds: float) -> int:
    return round(seconds * 1e9)


def _vector(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
    return typestore().types["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def transform(pose: Pose2D, seconds: float, parent: str, child: str, *, z: float = 0.0) -> Any:
    """A ``geometry_msgs/TransformStamped`` ``parent -> child`` (``child``'s planar pose in ``parent``, height z)."""
    types = typestore().types
    _, rotation = _pose_parts(pose)
    return types["geometry_msgs/msg/TransformStamped"](
        header=_header(seconds, parent),
        child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](translation=_vector(pose.x, pose.y, z), rotation=rotation),
    )


def odometry(pose: Pose2D, twist: tuple[float, float], seconds: float, frame: str, child: str) -> Any:
    """A ``nav_msgs/Odometry`` with the pose and the body twist ``(v, omega)`` (m/s, rad/s)."""
    types = typestore().types
    position, orientation = _pose_parts(pose)
    return types[ODOMETRY](
        header=_header(seconds, frame),
        child_frame_id=child,
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=types["geometry_msgs/msg/Pose"](position=position, orientation=orientation),
            covariance=np.zeros(36, dtype=np.float64),
        ),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](
            twist=types[TWIST](linear=_vector(twist[0]), angular=_vector(z=twist[1])),
            covariance=np.zeros(36, dtype=np.float64),
        ),
    )


def occupancy_grid(grid: OccupancyGrid, seconds: float, frame: str = "map") -> Any:
    """A ``nav_msgs/OccupancyGrid`` of ``grid`` (row-major data, row 0 at the origin)."""
    types = typestore().types
    x0, y0, yaw = grid.origin
    position, orientation = _pose_parts(Pose2D(x0, y0, yaw))
    info = types["nav_msgs/msg/MapMetaData"](
        map_load_time=_time(seconds),
        resolution=grid.resolution,
        width=grid.width,
        height=grid.height,
        origin=types["geometry_msgs/msg/Pose"](position=position, orientation=orientation),
    )
    return types[OCCUPANCY_GRID](header=_header(seconds, frame), info=info, data=grid.values.ravel().copy())


def pose_stamped(pose: Pose2D, seconds: float, frame: str = "map") -> Any:
    types = typestore().types
    position, orientation = _pose_parts(pose)
    return types[POSE_STAMPED](
        header=_header(seconds, frame),
        pose=types["geometry_msgs/msg/Pose"](position=position, orientation=orientation),
    )


def path_message(path: FloatArray, seconds: float, frame: str = "map") -> Any:
    """A ``nav_msgs/Path`` of ``(N, 3)`` poses."""
    poses = [pose_stamped(Pose2D(float(x), float(y), float(yaw)), seconds, frame) for x, y, yaw in path]
    return typestore().types[PATH](header=_header(seconds, frame), poses=poses)


class SessionBag:
    """A :class:`mrs_nav.stack.demo.Recorder` writing the session into a bag; use as a context manager."""

    # Compressed as BagWriter does (BZ2 chunks), which Debian's rosbag reads as it reads a recorded bag.
    def __init__(self, path: Path, laser: LaserParams, *, compress: bool = True) -> None:
        self.bag_path = path
        self.laser = laser
        self._writer = BagWriter(path, compress=compress)
        self._last_clock = -1.0

    def __enter__(self) -> SessionBag:
        self._writer.__enter__()
        # base_footprint -> base_link -> base_scan, as the simulator's URDF places them
        base_link_z = 0.010
        static = typestore().types[TF_MESSAGE](
            transforms=[
                transform(Pose2D(0.0, 0.0, 0.0), 0.0, "base_footprint", "base_link", z=base_link_z),
                transform(
                    Pose2D(self.laser.mount_x, self.laser.mount_y, 0.0),
                    0.0,
                    "base_link",
                    "base_scan",
                    z=self.laser.mount_z - base_link_z,
                ),
            ]
        )
        self._writer.write("/tf_static", TF_MESSAGE, 0, static, latching=True)
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self._writer.__exit__(exc_type, exc, tb)

    def _clock(self, seconds: float) -> None:
        if seconds > self._last_clock:
            self._last_clock = seconds
            self._writer.write("/clock", CLOCK, _ns(seconds), typestore().types[CLOCK](clock=_time(seconds)))

    def scan(self, scan: Scan) -> None:
        message = laser_scan_message(laser_scan_data(scan), scan.stamp, "base_scan")
        self._writer.write("/scan", LASER_SCAN, _ns(scan.stamp), message)

    def odometry(self, stamp: float, odom: Pose2D, v: float, omega: float, truth: Pose2D) -> None:
        self._clock(stamp)
        ns = _ns(stamp)
        self._writer.write("/odom", ODOMETRY, ns, odometry(odom, (v, omega), stamp, "odom", "base_footprint"))
        tf = typestore().types[TF_MESSAGE](transforms=[transform(odom, stamp, "odom", "base_footprint")])
        self._writer.write("/tf", TF_MESSAGE, ns, tf)
        self._writer.write(
            "/ground_truth/odom", ODOMETRY, ns, odometry(truth, (v, omega), stamp, "world", "base_footprint")
        )

    def map_to_odom(self, stamp: float, correction: Pose2D) -> None:
        tf = typestore().types[TF_MESSAGE](transforms=[transform(correction, stamp, "map", "odom")])
        self._writer.write("/tf", TF_MESSAGE, _ns(stamp), tf)

    def command(self, stamp: float, u: float, omega: float) -> None:
        twist = typestore().types[TWIST](linear=_vector(u), angular=_vector(z=omega))
        self._writer.write("/cmd_vel", TWIST, _ns(stamp), twist)

    def map(self, stamp: float, grid: OccupancyGrid) -> None:
        self._writer.write("/map", OCCUPANCY_GRID, _ns(stamp), occupancy_grid(grid, stamp), latching=True)

    def path(self, stamp: float, path: FloatArray) -> None:
        self._writer.write("/path", PATH, _ns(stamp), path_message(path, stamp))

    def goal(self, stamp: float, x: float, y: float) -> None:
        self._writer.write("/move_base_simple/goal", POSE_STAMPED, _ns(stamp), pose_stamped(Pose2D(x, y, 0.0), stamp))
