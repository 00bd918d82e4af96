"""nav_msgs/OccupancyGrid and MapMetaData of a core :class:`OccupancyGrid` (map server, saver, localisation)."""

from __future__ import annotations

import rospy
from nav_msgs.msg import MapMetaData
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.ros.conversions import pose_msg


def map_metadata(grid: OccupancyGrid, load_time: rospy.Time) -> MapMetaData:
    info = MapMetaData()
    info.map_load_time = load_time
    info.resolution = grid.resolution
    info.width, info.height = grid.width, grid.height
    info.origin = pose_msg(Pose2D(*grid.origin))
    return info


def occupancy_grid_msg(grid: OccupancyGrid, stamp: rospy.Time, frame_id: str) -> OccupancyGridMsg:
    """The message of ``grid`` (row-major data, row 0 at the origin) in ``frame_id``."""
    msg = OccupancyGridMsg()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.info = map_metadata(grid, stamp)
    msg.data = grid.values.ravel().tolist()
    return msg
