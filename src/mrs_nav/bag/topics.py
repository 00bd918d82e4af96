"""The topics a recorded session holds, with their ROS 1 types: one list for every recorder and reader.

``launch/record.launch`` (Debian's ``rosbag record``) records :data:`RECORDED_TOPICS`, a test checks its list
against it: what the robot sensed and was told, which a standard ``rosbag play --clock BAG`` replays into a live
stack (``slam.launch sim:=false``) without fighting it. Left out are the running stack's own outputs
(:data:`STACK_OUTPUTS`): ``/clock`` (``rosbag play --clock`` makes the clock from the bag's time; a second one
made sim time go back and forth), ``/map`` and ``/path`` (the live SLAM and planner publish their own), and the
localisation's ``/amcl_pose`` and ``/particlecloud``. Bags recorded before, and ``mrs-nav demo``'s (which runs
SLAM and the planner in one process and keeps their outputs for ``mrs-nav replay`` to compare with), hold those
too; the replay reads them where they are.
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

#: topic -> message type (rosbags' names) of what record.launch records: the robot's sensors, its transforms,
#: the true pose of a simulation (under a name of its own) and the commands and goals it was given.
RECORDED_TOPICS: dict[str, str] = {
    SCAN: "sensor_msgs/msg/LaserScan",
    ODOM: "nav_msgs/msg/Odometry",
    TF: "tf2_msgs/msg/TFMessage",
    TF_STATIC: "tf2_msgs/msg/TFMessage",
    GROUND_TRUTH: "nav_msgs/msg/Odometry",
    CMD_VEL: "geometry_msgs/msg/Twist",
    GOAL: "geometry_msgs/msg/PoseStamped",
}

#: topic -> message type of what a running stack publishes itself, left out of recordings (module docstring).
STACK_OUTPUTS: dict[str, str] = {
    CLOCK: "rosgraph_msgs/msg/Clock",
    MAP: "nav_msgs/msg/OccupancyGrid",
    PATH: "nav_msgs/msg/Path",
    **LOCALISATION_TOPICS,
}

#: topic -> message type of every session topic the replay knows (recorded now, or by older recordings).
SESSION_TYPES: dict[str, str] = {**RECORDED_TOPICS, **STACK_OUTPUTS}
