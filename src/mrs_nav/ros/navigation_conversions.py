"""Shared by the navigation nodes: maps in, paths out, poses from tf (basic conversions: mrs_nav.ros.conversions)."""

from __future__ import annotations

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.msg import Path

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.ros.conversions import pose_from_msg, pose_from_transform, pose_msg


def grid_from_msg(msg: OccupancyGridMsg) -> OccupancyGrid:
    """The core grid of a ``nav_msgs/OccupancyGrid``; raises InvalidInputError when it is inconsistent."""
    info = msg.info
    origin = pose_from_msg(info.origin)
    data = np.frombuffer(msg.data, dtype=np.int8) if isinstance(msg.data, bytes) else np.asarray(msg.data)
    return OccupancyGrid.from_message_data(
        data, int(info.width), int(info.height), float(info.resolution), (origin.x, origin.y, origin.yaw)
    )


def path_msg(path: FloatArray, stamp: rospy.Time, frame: str) -> Path:
    """A ``nav_msgs/Path`` of ``(N, 3)`` poses ``(x, y, yaw)``."""
    msg = Path()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    for x, y, yaw in np.asarray(path, dtype=np.float64).reshape(-1, 3):
        pose = PoseStamped()
        pose.header = msg.header
        pose.pose = pose_msg(Pose2D(float(x), float(y), float(yaw)))
        msg.poses.append(pose)
    return msg


def pose_in_frame(buffer: tf2_ros.Buffer, msg: PoseStamped, frame: str) -> Pose2D:
    """The planar pose of ``msg`` expressed in ``frame`` (an empty header frame means ``frame``).

    Raises InvalidInputError for a non-finite pose and ``tf2_ros.TransformException`` when tf cannot
    transform it (waits up to 0.5 s for the transform)."""
    pose = pose_from_msg(msg.pose)
    source = msg.header.frame_id.lstrip("/")
    if source in ("", frame):
        return pose
    transform = buffer.lookup_transform(frame, source, rospy.Time(0), rospy.Duration(0.5))
    return pose_from_transform(transform).compose(pose)


def latest_pose(buffer: tf2_ros.Buffer, frame: str, child: str, timeout_s: float, who: str) -> Pose2D | None:
    """``child``'s latest pose in ``frame`` from tf, or None (with a throttled warning naming ``who``) when tf
    has none or it is older than ``timeout_s`` of the current (sim) time."""
    try:
        transform = buffer.lookup_transform(frame, child, rospy.Time(0))
    except tf2_ros.TransformException as err:
        rospy.logwarn_throttle(5.0, f"{who}: no robot pose: {err}")
        return None
    stamp = transform.header.stamp
    age = 0.0 if stamp.is_zero() else (rospy.Time.now() - stamp).to_sec()  # a static transform has no age
    if age > timeout_s:
        rospy.logwarn_throttle(5.0, f"{who}: the robot pose from tf is {age:.1f} s old")
        return None
    return pose_from_transform(transform)
