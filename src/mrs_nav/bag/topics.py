"""The topics a recorded session holds, with their ROS 1 types: one list for every recorder and reader.

``launch/record.launch`` (Debian's ``rosbag record``) and ``mrs-nav demo`` (rosbags) record exactly these, and
``mrs-nav replay`` reads them; a test checks the launch file's list against :data:`RECORDED_TOPICS`. The
localisation's outputs (:data:`LOCALISATION_TOPICS`) are recorded when it runs (navigation on a saved map), so
such a session replays with them; the demo runs SLAM, not the localisation, and writes the others only.
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
AMCL_POSE = "/amcl_pose"
PARTICLECLOUD = "/particlecloud"

#: topic -> message type of the localisation node's outputs (navigation.launch on a saved map).
LOCALISATION_TOPICS: dict[str, str] = {
    AMCL_POSE: "geometry_msgs/msg/PoseWithCovarianceStamped",
    PARTICLECLOUD: "geometry_msgs/msg/PoseArray",
}

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
    **LOCALISATION_TOPICS,
}
