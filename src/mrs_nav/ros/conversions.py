"""Conversions between the core's plain types and ROS 1 messages (the only place that knows both).

Times: the core counts sim time in float seconds; messages carry ``rospy.Time``. :func:`to_ros_time` rounds to
the nearest nanosecond (``rospy.Time.from_sec`` truncates, which turns 0.2 s into 0.199999999 s).
Poses: planar poses (x, y, yaw) become 3-D poses on z = 0 with a yaw-only quaternion; going back, the yaw of the
quaternion is kept and roll/pitch dropped. Laser scans follow REP 117 (+inf no return, -inf too close).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import rospy
from geometry_msgs.msg import Pose, PoseWithCovarianceStamped, Quaternion, Transform, TransformStamped, Twist
from nav_msgs.msg import Odometry as OdometryMsg
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, LaserScan

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, quaternion_from_yaw, yaw_from_quaternion
from mrs_nav.sim.commands import Twist2D
from mrs_nav.sim.laser import Scan
from mrs_nav.slam.scan import LaserScanData

# -- time ---------------------------------------------------------------------------------------------------------


def to_ros_time(seconds: float) -> rospy.Time:
    """``rospy.Time`` of ``seconds`` (>= 0), rounded to the nanosecond."""
    nanoseconds = round(seconds * 1e9)
    return rospy.Time(nanoseconds // 1_000_000_000, nanoseconds % 1_000_000_000)


def clock_msg(seconds: float) -> Clock:
    return Clock(clock=to_ros_time(seconds))


# -- poses and transforms ---------------------------------------------------------------------------------------


def yaw_quaternion(yaw: float) -> Quaternion:
    x, y, z, w = quaternion_from_yaw(yaw)
    return Quaternion(x=x, y=y, z=z, w=w)


def quaternion_yaw(q: Quaternion) -> float:
    """Yaw (rad) of a quaternion message; raises InvalidInputError for a zero or non-finite quaternion."""
    values = (q.x, q.y, q.z, q.w)
    norm = math.sqrt(sum(v * v for v in values))
    if not (math.isfinite(norm) and norm > 1e-9):
        raise InvalidInputError(f"orientation is not a valid quaternion: {values}")
    return yaw_from_quaternion(*(v / norm for v in values))


def pose_msg(pose: Pose2D) -> Pose:
    """A ``geometry_msgs/Pose`` on the ground plane."""
    msg = Pose()
    msg.position.x, msg.position.y = pose.x, pose.y
    msg.orientation = yaw_quaternion(pose.yaw)
    return msg


def pose_from_msg(msg: Pose) -> Pose2D:
    """The planar part of a ``geometry_msgs/Pose``; raises InvalidInputError for non-finite values."""
    return Pose2D(msg.position.x, msg.position.y, quaternion_yaw(msg.orientation))


def transform_stamped(pose: Pose2D, stamp: float, parent: str, child: str) -> TransformStamped:
    """The transform parent -> child (``child``'s pose in ``parent``) at sim time ``stamp`` (s)."""
    msg = TransformStamped()
    msg.header.stamp = to_ros_time(stamp)
    msg.header.frame_id = parent
    msg.child_frame_id = child
    msg.transform = Transform()
    msg.transform.translation.x, msg.transform.translation.y = pose.x, pose.y
    msg.transform.rotation = yaw_quaternion(pose.yaw)
    return msg


def pose_from_transform(msg: TransformStamped) -> Pose2D:
    """The planar pose of a transform (child in parent)."""
    t = msg.transform
    return Pose2D(t.translation.x, t.translation.y, quaternion_yaw(t.rotation))


# -- velocities and odometry ------------------------------------------------------------------------------------


def twist_msg(twist: Twist2D) -> Twist:
    msg = Twist()
    msg.linear.x, msg.angular.z = twist.v, twist.omega
    return msg


def twist_from_msg(msg: Twist) -> Twist2D:
    """(v, omega) of a ``geometry_msgs/Twist`` for a planar base; raises InvalidInputError when non-finite."""
    v, omega = msg.linear.x, msg.angular.z
    if not (math.isfinite(v) and math.isfinite(omega)):
        raise InvalidInputError(f"twist is not finite: linear.x={v}, angular.z={omega}")
    return Twist2D(v, omega)


def odometry_msg(
    pose: Pose2D,
    twist: Twist2D,
    stamp: float,
    *,
    frame_id: str,
    child_frame_id: str,
    pose_variance: Sequence[float] = (0.0, 0.0, 0.0),
    twist_variance: Sequence[float] = (0.0, 0.0),
) -> OdometryMsg:
    """A ``nav_msgs/Odometry``: pose in ``frame_id``, twist in ``child_frame_id`` (REP 105).

    The variances (x, y, yaw) and (v, omega) go on the diagonals of the 6x6 covariances; the other planar
    degrees of freedom (z, roll, pitch) get zero.
    """
    msg = OdometryMsg()
    msg.header.stamp = to_ros_time(stamp)
    msg.header.frame_id = frame_id
    msg.child_frame_id = child_frame_id
    msg.pose.pose = pose_msg(pose)
    msg.twist.twist = twist_msg(twist)
    pose_cov = [0.0] * 36
    pose_cov[0], pose_cov[7], pose_cov[35] = pose_variance
    twist_cov = [0.0] * 36
    twist_cov[0], twist_cov[35] = twist_variance
    msg.pose.covariance = pose_cov
    msg.twist.covariance = twist_cov
    return msg


def pose_from_odometry(msg: OdometryMsg) -> Pose2D:
    return pose_from_msg(msg.pose.pose)


def twist_from_odometry(msg: OdometryMsg) -> Twist2D:
    return twist_from_msg(msg.twist.twist)


def joint_state_msg(
    names: Sequence[str], positions: Sequence[float], velocities: Sequence[float], stamp: float
) -> JointState:
    msg = JointState()
    msg.header.stamp = to_ros_time(stamp)
    msg.name = list(names)
    msg.position = list(positions)
    msg.velocity = list(velocities)
    return msg


# -- laser scans ------------------------------------------------------------------------------------------------


def laser_scan_msg(scan: Scan, frame_id: str) -> LaserScan:
    """A ``sensor_msgs/LaserScan`` of a simulated scan (all beams at one instant: time_increment 0)."""
    p = scan.params
    msg = LaserScan()
    msg.header.stamp = to_ros_time(scan.stamp)
    msg.header.frame_id = frame_id
    msg.angle_min = p.angle_min
    msg.angle_max = p.angle_max
    msg.angle_increment = p.angle_increment
    msg.time_increment = 0.0
    msg.scan_time = 1.0 / p.rate
    msg.range_min = p.range_min
    msg.range_max = p.range_max
    msg.ranges = scan.ranges.tolist()
    return msg


def laser_scan_arrays(msg: LaserScan) -> tuple[FloatArray, FloatArray]:
    """(angles, ranges) of a ``LaserScan`` as float64 arrays, angles in the scan's frame (rad).

    Ranges are returned as sent (REP 117: +-inf and NaN kept); use ``valid_ranges`` to select usable beams.
    """
    ranges = np.asarray(msg.ranges, dtype=np.float64)
    angles = msg.angle_min + np.arange(ranges.size, dtype=np.float64) * msg.angle_increment
    return angles, ranges


def scan_data(msg: LaserScan) -> LaserScanData:
    """The core scan of a LaserScan message (InvalidInputError if its numbers are not finite, its range limits are
    invalid or its ranges do not fit its angles)."""
    return LaserScanData.from_message_fields(
        angle_min=msg.angle_min,
        angle_max=msg.angle_max,
        angle_increment=msg.angle_increment,
        range_min=msg.range_min,
        range_max=msg.range_max,
        ranges=np.asarray(msg.ranges, dtype=np.float64),
    )


def any_reading(ranges: FloatArray) -> bool:
    """Whether some range is a number >= 0: NaN (an error) and negative ranges are not readings, while +inf is
    "nothing in range" (REP 117) and a real reading. A scan without any is blind, not empty space."""
    return bool(np.any((ranges >= 0.0) & ~np.isnan(ranges)))


def valid_ranges(msg: LaserScan, ranges: FloatArray) -> npt.NDArray[np.bool_]:
    """Boolean mask of the beams with a finite reading within [range_min, range_max]."""
    return np.isfinite(ranges) & (ranges >= float(msg.range_min)) & (ranges <= float(msg.range_max))


COV_INDEX = (0, 1, 5)  # x, y, yaw rows/columns of a 6x6 pose covariance


def covariance_3x3(msg: PoseWithCovarianceStamped) -> FloatArray:
    """The x, y, yaw block of a PoseWithCovarianceStamped's 6x6 covariance (InvalidInputError unless 36 values)."""
    full = np.asarray(msg.pose.covariance, dtype=np.float64)
    if full.size != 36:
        raise InvalidInputError(f"pose covariance has {full.size} values, expected 36")
    return full.reshape(6, 6)[np.ix_(COV_INDEX, COV_INDEX)]
