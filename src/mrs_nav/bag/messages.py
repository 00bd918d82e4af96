"""Conversions between rosbags message objects and the core's plain types (poses, scans)."""

from __future__ import annotations

from typing import Any

import numpy as np

from mrs_nav.bag.io import typestore
from mrs_nav.geometry import Pose2D, quaternion_from_yaw, yaw_from_quaternion
from mrs_nav.slam.scan import LaserScanData

LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"


def stamp_of(message: Any) -> float:
    """Header stamp of a message in seconds."""
    stamp = message.header.stamp
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def _time(seconds: float) -> Any:
    sec = int(np.floor(seconds))
    return typestore().types["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((seconds - sec) * 1e9) % 10**9)


def _header(seconds: float, frame: str, seq: int = 0) -> Any:
    return typestore().types["std_msgs/msg/Header"](seq=seq, stamp=_time(seconds), frame_id=frame)


def _pose_parts(pose: Pose2D) -> tuple[Any, Any]:
    types = typestore().types
    qx, qy, qz, qw = quaternion_from_yaw(pose.yaw)
    return (
        types["geometry_msgs/msg/Point"](x=pose.x, y=pose.y, z=0.0),
        types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
    )


def laser_scan_message(scan: LaserScanData, seconds: float, frame: str, seq: int = 0) -> Any:
    """A ``sensor_msgs/LaserScan`` holding ``scan``."""
    n = scan.ranges.size
    return typestore().types[LASER_SCAN](
        header=_header(seconds, frame, seq),
        angle_min=scan.angle_min,
        angle_max=scan.angle_min + scan.angle_increment * max(n - 1, 0),
        angle_increment=scan.angle_increment,
        time_increment=0.0,
        scan_time=0.0,
        range_min=scan.range_min,
        range_max=scan.range_max,
        ranges=np.asarray(scan.ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )


def scan_from_message(message: Any) -> LaserScanData:
    """The core scan of a ``sensor_msgs/LaserScan``; raises InvalidInputError when its geometry is inconsistent."""
    return LaserScanData.from_message_fields(
        angle_min=float(message.angle_min),
        angle_max=float(message.angle_max),
        angle_increment=float(message.angle_increment),
        range_min=float(message.range_min),
        range_max=float(message.range_max),
        ranges=np.asarray(message.ranges, dtype=np.float64),
    )


def odometry_message(pose: Pose2D, seconds: float, frame: str, child: str, seq: int = 0) -> Any:
    """A ``nav_msgs/Odometry`` at ``pose`` (no twist, no covariance)."""
    types = typestore().types
    position, orientation = _pose_parts(pose)
    pose_msg = types["geometry_msgs/msg/PoseWithCovariance"](
        pose=types["geometry_msgs/msg/Pose"](position=position, orientation=orientation),
        covariance=np.zeros(36, dtype=np.float64),
    )
    vector = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/TwistWithCovariance"](
        twist=types["geometry_msgs/msg/Twist"](linear=vector(x=0.0, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)),
        covariance=np.zeros(36, dtype=np.float64),
    )
    return types[ODOMETRY](header=_header(seconds, frame, seq), child_frame_id=child, pose=pose_msg, twist=twist)


def pose_from_odometry(message: Any) -> Pose2D:
    """The planar pose of a ``nav_msgs/Odometry``."""
    p, q = message.pose.pose.position, message.pose.pose.orientation
    return Pose2D(float(p.x), float(p.y), yaw_from_quaternion(q.x, q.y, q.z, q.w))


def tf_message(pose: Pose2D, seconds: float, parent: str, child: str) -> Any:
    """A ``tf2_msgs/TFMessage`` with one transform ``parent -> child``."""
    types = typestore().types
    qx, qy, qz, qw = quaternion_from_yaw(pose.yaw)
    transform = types["geometry_msgs/msg/TransformStamped"](
        header=_header(seconds, parent),
        child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](
            translation=types["geometry_msgs/msg/Vector3"](x=pose.x, y=pose.y, z=0.0),
            rotation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
        ),
    )
    return types["tf2_msgs/msg/TFMessage"](transforms=[transform])
