"""Run by tests/ros/test_ros2_cdr.py with the ROS 2 venv's python (and mrs_nav on its path): for several messages
of each type the bridge sends as bytes, the ROS 1 bytes rewritten to CDR (:class:`mrs_nav.bridge.ros1_cdr.Ros1ToCdr`)
beside rclpy's own ``serialize_message`` of the same message. One JSON line per message on stdout.

rclpy (Fast CDR) leaves its alignment padding unwritten, so those bytes hold whatever its buffer held: a byte may
differ only where the rewrite wrote padding (a zero), and rclpy must read the rewrite back as it reads its own bytes
(float32 fields come back rounded both ways).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from typing import Any

from geometry_msgs.msg import Pose, PoseArray, PoseStamped, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from mrs_nav.bridge.ros1_cdr import Ros1ToCdr
from mrs_nav.ros2.messages import codec, fields_of


def odometry(frame: str, child: str) -> Odometry:
    msg = Odometry()
    msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = -3, 999_999_999, frame
    msg.child_frame_id = child
    msg.pose.pose.position.x, msg.pose.pose.orientation.w = 1.25, 1.0
    msg.pose.covariance[0] = msg.twist.covariance[35] = 0.5
    msg.twist.twist.angular.z = -0.75
    return msg


def scan(frame: str, ranges: int, intensities: int) -> LaserScan:
    msg = LaserScan(angle_min=-3.1, angle_max=3.1, range_max=3.5)
    msg.header.frame_id = frame
    msg.ranges = [0.5 + i for i in range(ranges)]
    msg.intensities = [float(i) for i in range(intensities)]
    return msg


def grid(frame: str, width: int, height: int) -> OccupancyGrid:
    msg = OccupancyGrid()
    msg.header.frame_id = frame
    msg.info.width, msg.info.height, msg.info.resolution = width, height, 0.05
    msg.info.origin.position.x = -9.6
    msg.data = [(i % 102) - 1 for i in range(width * height)]
    return msg


def transforms(*children: str) -> TFMessage:
    out = []
    for index, child in enumerate(children):
        t = TransformStamped(child_frame_id=child)
        t.header.frame_id = "odom" * index
        t.header.stamp.sec = index
        t.transform.translation.y, t.transform.rotation.w = 0.1 * index, 1.0
        out.append(t)
    return TFMessage(transforms=out)


def cases() -> Iterator[tuple[str, Any]]:
    for frame, child in (("odom", "base_footprint"), ("", ""), ("o", "ba"), ("abc", "x")):
        yield "nav_msgs/Odometry", odometry(frame, child)
    for frame, ranges, intensities in (("base_scan", 360, 360), ("", 0, 0), ("ab", 3, 0), ("abc", 0, 1), ("l", 5, 2)):
        yield "sensor_msgs/LaserScan", scan(frame, ranges, intensities)
    for frame, width, height in (("map", 384, 384), ("", 0, 0), ("ma", 3, 1), ("m", 7, 3)):
        yield "nav_msgs/OccupancyGrid", grid(frame, width, height)
    for children in ((), ("base_footprint",), ("a", "", "odd_name"), ("tb3_0/base_footprint", "tb3_0/odom")):
        yield "tf2_msgs/TFMessage", transforms(*children)
    pose = PoseWithCovarianceStamped()
    pose.header.frame_id, pose.pose.covariance[7] = "map", 0.25
    yield "geometry_msgs/PoseWithCovarianceStamped", pose
    path = PathMsg(poses=[PoseStamped(), PoseStamped()])
    path.header.frame_id, path.poses[1].header.frame_id = "map", "odd"
    yield "nav_msgs/Path", path
    yield "nav_msgs/Path", PathMsg()
    yield "geometry_msgs/PoseArray", PoseArray(poses=[Pose(), Pose()])


def main() -> int:
    ros1, cdr = codec(), Ros1ToCdr(fields_of)
    for type_name, msg in cases():
        expected = serialize_message(msg)
        got = cdr.transcode(type_name, ros1.encode(type_name, msg))
        differ = [i for i, (a, b) in enumerate(zip(expected, got, strict=False)) if a != b]
        result = {
            "type": type_name,
            "bytes": len(expected),
            "same_length": len(expected) == len(got),
            "differ_where_not_padding": [i for i in differ if got[i] != 0],
            "reads_back": deserialize_message(got, type(msg)) == deserialize_message(expected, type(msg)),
        }
        print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
