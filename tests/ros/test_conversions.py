"""Message conversions (no master needed, but Debian's rospy and message packages)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.sim import LaserParams, Scan, Twist2D

pytestmark = pytest.mark.ros

conv = pytest.importorskip("mrs_nav.ros.conversions")

coords = st.floats(-1e3, 1e3, allow_nan=False)
angles = st.floats(-math.pi + 1e-9, math.pi - 1e-9)


@given(coords, coords, angles)
def test_pose_and_transform_round_trip(x: float, y: float, yaw: float) -> None:
    pose = Pose2D(x, y, yaw)
    back = conv.pose_from_msg(conv.pose_msg(pose))
    assert (back.x, back.y) == (x, y)
    assert math.isclose(back.yaw, yaw, abs_tol=1e-9)
    tf = conv.transform_stamped(pose, 12.5, "odom", "base_footprint")
    assert (tf.header.frame_id, tf.child_frame_id) == ("odom", "base_footprint")
    assert conv.pose_from_transform(tf).yaw == pytest.approx(yaw, abs=1e-9)


@given(st.integers(0, 10**7))
def test_sim_times_become_exact_stamps(steps: int) -> None:
    seconds = steps / 100.0
    stamp = conv.to_ros_time(seconds)
    assert stamp.secs == steps // 100
    assert stamp.nsecs == (steps % 100) * 10_000_000  # from_sec would truncate 0.29 s to 289999999 ns


def test_odometry_carries_frames_twist_and_variances() -> None:
    msg = conv.odometry_msg(
        Pose2D(1.0, 2.0, 0.5),
        Twist2D(0.2, -0.3),
        3.0,
        frame_id="odom",
        child_frame_id="base_footprint",
        pose_variance=(0.01, 0.02, 0.03),
        twist_variance=(0.1, 0.2),
    )
    assert (msg.header.frame_id, msg.child_frame_id) == ("odom", "base_footprint")
    assert msg.header.stamp.to_sec() == 3.0
    pose = conv.pose_from_odometry(msg)
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((1.0, 2.0, 0.5))
    assert conv.twist_from_odometry(msg) == Twist2D(0.2, -0.3)
    assert (msg.pose.covariance[0], msg.pose.covariance[7], msg.pose.covariance[35]) == (0.01, 0.02, 0.03)
    assert (msg.twist.covariance[0], msg.twist.covariance[35]) == (0.1, 0.2)


def test_bad_twists_and_quaternions_raise_input_errors() -> None:
    twist = conv.twist_msg(Twist2D(0.1, 0.0))
    twist.angular.z = math.nan
    with pytest.raises(InvalidInputError, match="not finite"):
        conv.twist_from_msg(twist)
    pose = conv.pose_msg(Pose2D(0.0, 0.0))
    pose.orientation.w = 0.0
    with pytest.raises(InvalidInputError, match="quaternion"):
        conv.pose_from_msg(pose)


def test_laser_scan_keeps_rep_117_readings_and_geometry() -> None:
    params = LaserParams()
    ranges = np.full(params.beams, 1.0)
    ranges[0], ranges[1] = math.inf, -math.inf
    msg = conv.laser_scan_msg(Scan(0.2, ranges, params), "base_scan")
    assert msg.header.frame_id == "base_scan"
    assert msg.header.stamp.nsecs == 200_000_000
    assert msg.angle_increment == pytest.approx(2 * math.pi / 360)
    assert msg.scan_time == pytest.approx(0.2)
    beam_angles, back = conv.laser_scan_arrays(msg)
    assert beam_angles[90] == pytest.approx(math.pi / 2)
    assert back[0] == math.inf
    assert back[1] == -math.inf
    assert conv.valid_ranges(msg, back).sum() == params.beams - 2


def test_a_goal_message_is_converted_once_into_a_finite_goal_with_or_without_a_heading() -> None:
    tf2_ros = pytest.importorskip("tf2_ros")
    from geometry_msgs.msg import PoseStamped

    nav = pytest.importorskip("mrs_nav.ros.navigation_conversions")
    buffer = tf2_ros.Buffer(debug=False)  # no tf2_frames service: no master needed
    msg = PoseStamped()
    msg.header.frame_id = "map"
    msg.pose = conv.pose_msg(Pose2D(1.0, -2.0, 0.5))
    goal = nav.goal_in_frame(buffer, msg, "map")
    assert (goal.x, goal.y, goal.yaw) == pytest.approx((1.0, -2.0, 0.5))
    msg.pose.orientation.z = msg.pose.orientation.w = 0.0  # the all-zero quaternion: a goal sent without a heading
    assert nav.goal_in_frame(buffer, msg, "map").yaw is None
    msg.pose.position.x = math.nan
    with pytest.raises(InvalidInputError, match="its position is not a finite number"):
        nav.goal_in_frame(buffer, msg, "map")


# Debian's generated nav_msgs code serialises the array with numpy's deprecated tostring(): its warning, not ours.
@pytest.mark.filterwarnings("ignore:tostring:DeprecationWarning")
def test_a_map_goes_out_as_one_int8_array_with_the_bytes_of_the_plain_message() -> None:
    import io

    import rospy
    from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
    from nav_msgs.srv import GetMapResponse

    from mrs_nav.maps.occupancy_grid import OccupancyGrid
    from mrs_nav.ros.map_messages import occupancy_grid_msg

    values = np.array([[-1, 0, 100], [50, 0, -1]], dtype=np.int8)
    msg = occupancy_grid_msg(OccupancyGrid(values, 0.05, (1.0, -2.0, 0.5)), rospy.Time(3, 4), "map")
    assert isinstance(msg.data, np.ndarray)
    assert msg.data.dtype == np.int8
    plain = OccupancyGridMsg()
    plain.header, plain.info, plain.data = msg.header, msg.info, values.ravel().tolist()
    for wrap in (lambda m: m, lambda m: GetMapResponse(map=m)):  # the topic, and the map services' response
        ours, theirs = io.BytesIO(), io.BytesIO()
        wrap(msg).serialize(ours)
        wrap(plain).serialize(theirs)
        assert ours.getvalue() == theirs.getvalue()
