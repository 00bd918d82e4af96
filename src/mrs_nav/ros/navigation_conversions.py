"""Message conversions of the navigation nodes: maps in, paths out (poses and times: mrs_nav.ros.conversions)."""

from __future__ import annotations

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.msg import Path

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.occupancy_grid import OccupancyGrid
from mrs_nav.ros.conversions import pose_from_msg, pose_msg


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
