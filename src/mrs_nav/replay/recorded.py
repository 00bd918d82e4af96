"""What a recorded session says the live system did: its last ``/map``, its goals, plans and SLAM poses.

The live SLAM pose is ``map->odom`` (from ``/tf``) composed with the odometry pose, as tf gives it to a node.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.bag import topics
from mrs_nav.bag.io import read_messages
from mrs_nav.bag.messages import pose_from_odometry, stamp_of
from mrs_nav.errors import BagError, InvalidInputError
from mrs_nav.geometry import Pose2D, yaw_from_quaternion
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.planning import path_length
from mrs_nav.replay.bag_frames import BagNames
from mrs_nav.replay.pose_track import PoseTrack


@dataclass(frozen=True)
class Goal:
    """A goal sent on ``/move_base_simple/goal``: its stamp (s) and pose (frame of the message, m, rad)."""

    stamp: float
    pose: Pose2D


@dataclass
class RecordedSession:
    """The recorded outputs of the live system (each empty/None when the bag lacks its topic)."""

    final_map: OccupancyGrid | None = None
    goals: list[Goal] = field(default_factory=list)
    paths: list[tuple[float, float]] = field(default_factory=list)  # (stamp s, length m) of each /path
    map_to_odom: PoseTrack = field(default_factory=lambda: PoseTrack(tolerance=float("inf")))
    odom: PoseTrack = field(default_factory=PoseTrack)

    def slam_pose(self, stamp: float) -> Pose2D | None:
        """The live SLAM pose at ``stamp`` (``map->odom * odom``), None without both."""
        correction, odom = self.map_to_odom.at(stamp), self.odom.at(stamp)
        if correction is None or odom is None:
            return None
        return correction.compose(odom)


def _pose(pose: Any) -> Pose2D:
    p, q = pose.position, pose.orientation
    return Pose2D(float(p.x), float(p.y), yaw_from_quaternion(q.x, q.y, q.z, q.w))


def grid_from_message(message: Any) -> OccupancyGrid:
    """A ``nav_msgs/OccupancyGrid`` as an :class:`OccupancyGrid`."""
    info = message.info
    origin = _pose(info.origin)
    return OccupancyGrid.from_message_data(
        np.asarray(message.data),
        int(info.width),
        int(info.height),
        float(info.resolution),
        (origin.x, origin.y, origin.yaw),
    )


def read_recorded(bag: Path, names: BagNames) -> RecordedSession:
    """Read the recorded map (the last one), goals, plan lengths and live SLAM poses of ``bag``."""
    session = RecordedSession()
    map_frame, odom_frame = names.map_frame, names.odom_frame
    wanted = [topics.MAP, topics.GOAL, topics.PATH, topics.TF, names.odom_topic]
    for topic, _, msg in read_messages(bag, wanted):
        if topic == topics.MAP:
            try:
                session.final_map = grid_from_message(msg)
            except InvalidInputError as err:
                raise BagError(f"bag {bag}: a {topics.MAP} message is malformed: {err}") from None
        elif topic == topics.GOAL:
            session.goals.append(Goal(stamp_of(msg), _pose(msg.pose)))
        elif topic == topics.PATH:
            points = [[p.pose.position.x, p.pose.position.y] for p in msg.poses]
            session.paths.append((stamp_of(msg), path_length(np.asarray(points).reshape(-1, 2)) if points else 0.0))
        elif topic == names.odom_topic:
            try:
                session.odom.add(stamp_of(msg), pose_from_odometry(msg))
            except InvalidInputError:  # non-finite values: skipped, and noted by the SLAM replay of the same bag
                continue
        else:
            for tf in msg.transforms:
                if tf.header.frame_id.lstrip("/") == map_frame and tf.child_frame_id.lstrip("/") == odom_frame:
                    t, q = tf.transform.translation, tf.transform.rotation
                    pose = Pose2D(float(t.x), float(t.y), yaw_from_quaternion(q.x, q.y, q.z, q.w))
                    session.map_to_odom.add(stamp_of(tf), pose)
    return session
