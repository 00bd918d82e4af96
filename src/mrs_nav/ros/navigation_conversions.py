"""Shared by the navigation nodes: maps in, paths out, poses from tf (basic conversions: mrs_nav.ros.conversions)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.msg import Path
from sensor_msgs.msg import LaserScan

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.navigation.goal import NavGoal
from mrs_nav.navigation.obstacles import beam_ends
from mrs_nav.ros.conversions import laser_scan_arrays, pose_from_msg, pose_from_transform, pose_msg, quaternion_yaw


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


def no_heading(msg: PoseStamped) -> bool:
    """Whether the pose's orientation is the all-zero quaternion: a goal sent without a heading (move_base's
    clients and rviz never send it otherwise)."""
    q = msg.pose.orientation
    return bool(q.x == 0.0 and q.y == 0.0 and q.z == 0.0 and q.w == 0.0)


def pose_in_frame(buffer: tf2_ros.Buffer, msg: PoseStamped, frame: str) -> Pose2D:
    """The planar pose of ``msg`` expressed in ``frame`` (an empty header frame means ``frame``).

    An all-zero orientation is a pose without a heading (:func:`no_heading`): its position is taken with no
    rotation. Raises InvalidInputError for a non-finite pose and ``tf2_ros.TransformException`` when tf cannot
    transform it (waits up to 0.5 s for the transform)."""
    pose = Pose2D(msg.pose.position.x, msg.pose.position.y, 0.0) if no_heading(msg) else pose_from_msg(msg.pose)
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


def goal_in_frame(buffer: tf2_ros.Buffer, msg: PoseStamped, frame: str) -> NavGoal:
    """The goal ``msg`` asks for, in ``frame`` (an empty header frame means ``frame``): its position and heading,
    None when the orientation is the all-zero quaternion (no rotation: a goal sent without one).

    The one conversion of a goal message: raises InvalidInputError for a non-finite position or an invalid
    quaternion, and ``tf2_ros.TransformException`` when tf cannot transform it (waits up to 0.5 s)."""
    q = msg.pose.orientation
    goal = NavGoal(msg.pose.position.x, msg.pose.position.y, None if no_heading(msg) else quaternion_yaw(q))
    source = msg.header.frame_id.lstrip("/")
    if source in ("", frame):
        return goal
    transform = buffer.lookup_transform(frame, source, rospy.Time(0), rospy.Duration(0.5))
    return goal.seen_from(pose_from_transform(transform))


def scan_in_frame(
    buffer: tf2_ros.Buffer, msg: LaserScan, frame: str, wait: float
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """A laser scan in ``frame`` where the laser was at the scan's stamp (waiting up to ``wait`` s for that
    transform; the latest one for a scan stamped 0): the laser's position ``(2,)``, the beam end points ``(N, 2)``
    (at the return, or at ``range_max`` for beams without one) and which beams returned. Not the latest
    transform: a node running late at maximum sim rate while the robot turns (up to 2.8 rad/s) would rotate the
    returns by tens of degrees and mark obstacles in empty rooms.

    Raises InvalidInputError for a scan whose angles or range limits are not finite numbers, and
    ``tf2_ros.TransformException`` when tf cannot place the laser."""
    numbers = (msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max)
    if not all(math.isfinite(v) for v in numbers) or msg.range_max <= 0.0:
        raise InvalidInputError(
            f"scan angle_min {msg.angle_min}, angle_increment {msg.angle_increment}, range_min {msg.range_min},"
            f" range_max {msg.range_max}: not usable numbers"
        )
    angles, ranges = laser_scan_arrays(msg)
    stamp = msg.header.stamp
    laser = pose_from_transform(buffer.lookup_transform(frame, msg.header.frame_id, stamp, rospy.Duration(wait)))
    return beam_ends(laser, angles, ranges, msg.range_min, msg.range_max)


def publish_unless_shutdown(publisher: rospy.Publisher, msg: object, who: str) -> None:
    """Publish ``msg``; a topic closed by a shutdown under a timer tick in flight is no error (Ctrl-C)."""
    try:
        publisher.publish(msg)
    except rospy.ROSException as err:
        if not (rospy.is_shutdown() or rospy.core.is_shutdown_requested()):
            raise
        rospy.logdebug(f"{who}: not sent while shutting down: {err}")
