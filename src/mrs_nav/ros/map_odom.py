"""tf for the map-frame nodes (SLAM, localisation): broadcasting their map -> odom correction on a timer, looking
up poses, and naming the frames tf knows when a lookup fails.

The transform is dated ``ahead`` seconds past now, as gmapping and AMCL do, so lookups at the newest odometry
stamp find it. At maximum sim rate a timer can fire twice in one clock tick; tf rejects a repeated stamp, so a
stamp not later than the last one sent is skipped.
"""

from __future__ import annotations

import math

import rospy
import tf2_ros
import yaml

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.ros.conversions import pose_from_transform, transform_stamped

#: The broadcast period's range, s. rospy's timer runs at ``1 / period``: a period of 0 or a denormal kills its
#: thread with ZeroDivisionError and 1e300 with OverflowError, and the node ran on without map -> odom. At most
#: tf's default cache of 10 s, or a listener with that cache loses the transform between two broadcasts; at
#: least 1 ms (1 kHz), past which broadcasts only load the CPU and every listener.
PUBLISH_PERIOD_S = (0.001, 10.0)
#: How far ahead the transform is dated and how long a scan waits for tf, s, at most: tf's default cache of 10 s
#: (a transform dated further ahead leaves such a listener nothing at the current time, and a scan waiting longer
#: is stale), and within what a rospy Duration holds (1e300 s ended the broadcast thread with OverflowError).
MAX_DELAY_S = 10.0


def check_timing(transform_publish_period: float, **delays: float) -> None:
    """Refuse a broadcast period outside :data:`PUBLISH_PERIOD_S` and a delay (by its parameter's name) outside
    [0, :data:`MAX_DELAY_S`] s, with InvalidInputError naming the ``~`` parameter."""
    low, high = PUBLISH_PERIOD_S
    if not low <= transform_publish_period <= high:
        raise InvalidInputError(
            f"~transform_publish_period: must lie in [{low:g}, {high:g}] s, got {transform_publish_period:.3g}"
        )
    for name, value in delays.items():
        if not 0.0 <= value <= MAX_DELAY_S:
            raise InvalidInputError(f"~{name}: must lie in [0, {MAX_DELAY_S:g}] s, got {value:.3g}")


class MapOdomBroadcaster:
    """Sends ``parent -> child`` (map -> odom) with strictly increasing stamps."""

    def __init__(self, parent: str, child: str, ahead: float) -> None:
        self.parent, self.child, self.ahead = parent, child, ahead
        self._broadcaster = tf2_ros.TransformBroadcaster()
        self._last_stamp = -math.inf

    def reset(self) -> None:
        """Forget the last stamp (sim time went back)."""
        self._last_stamp = -math.inf

    def send(self, correction: Pose2D) -> None:
        stamp = (rospy.Time.now() + rospy.Duration(self.ahead)).to_sec()
        if stamp <= self._last_stamp:
            return
        self._last_stamp = stamp
        try:
            self._broadcaster.sendTransform(transform_stamped(correction, stamp, self.parent, self.child))
        except rospy.ROSException as err:  # shutting down
            rospy.logdebug(f"{self.parent}->{self.child} not sent: {err}")


def lookup_pose(buffer: tf2_ros.Buffer, parent: str, child: str, stamp: rospy.Time, wait: float) -> Pose2D:
    """``child`` in ``parent`` at ``stamp``, waiting up to ``wait`` s for the transform to arrive."""
    return pose_from_transform(buffer.lookup_transform(parent, child, stamp, rospy.Duration(wait)))


def tf_state(buffer: tf2_ros.Buffer, listener: tf2_ros.TransformListener) -> str:
    """What tf has given a node, for a warning about a frame it lacks: the frames ``buffer`` has heard of ("none"
    before any tf arrived), and how many ``/tf_static`` publishers ``listener`` is connected to (0: no
    robot_state_publisher or static_transform_publisher runs, or this node has not reached it)."""
    tree = yaml.safe_load(buffer.all_frames_as_yaml()) or {}
    frames = set(tree) | {str(entry.get("parent")) for entry in tree.values()}
    statics = listener.tf_static_sub.get_num_connections()
    return f"frames on tf: {', '.join(sorted(frames)) or 'none'}; /tf_static publishers connected: {statics}"
