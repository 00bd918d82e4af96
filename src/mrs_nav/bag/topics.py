"""The topics a recorded session holds, with their ROS 1 types: one list for every recorder and reader.

``launch/record.launch`` (Debian's ``rosbag record``) and ``mrs-nav demo`` (rosbags) record exactly these, and
``mrs-nav replay`` reads them; a test checks the launch file's list against :data:`RECORDED_TOPICS`.
"""

from __future__ import annotations

SCAN = "/scan"
ODOM = "/odom"
TF = "/tf"
TF_STATIC = "/tf_static"
CLOCK = "/clock"
GROUND_TRUTH = "/ground_truth/odom"
CMD_VEL = "/cmd_vel"
MAP = "/map"
PATH = "/path"
GOAL = "/move_base_simple/goal"

#: topic -> message type (rosbags' names) of everything a session recording holds.
RECORDED_TOPICS: dict[str, str] = {
    SCAN: "sensor_msgs/msg/LaserScan",
    ODOM: "nav_msgs/msg/Odometry",
    TF: "tf2_msgs/msg/TFMessage",
    TF_STATIC: "tf2_msgs/msg/TFMessage",
    CLOCK: "rosgraph_msgs/msg/Clock",
    GROUND_TRUTH: "nav_msgs/msg/Odometry",
    CMD_VEL: "geometry_msgs/msg/Twist",
    MAP: "nav_msgs/msg/OccupancyGrid",
    PATH: "nav_msgs/msg/Path",
    GOAL: "geometry_msgs/msg/PoseStamped",
}
