"""Processed scans and keyframes: which processed scans become nodes of the pose graph, and what each keeps.

A processed scan becomes a node, keeping its beams, only where no node is already within
:attr:`KeyframeConfig.radius_m` and :attr:`KeyframeConfig.heading_rad` of its matched pose; a scan in a covered
place keeps its beams with its nearest node only while that node keeps fewer than
:attr:`KeyframeConfig.scans_kept_per_node` (the map is rebuilt from the nodes' scans and these). So memory and work
follow the mapped extent, not the time spent (:mod:`mrs_nav.slam.slam`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.matcher import MatchResult
from mrs_nav.slam.scan import StoredBeams


@dataclass(frozen=True)
class KeyframeConfig:
    """When a processed scan becomes a node (module doc). Internal tuning of the SLAM, not node parameters.

    Why here and not in :class:`mrs_nav.slam.config.SlamConfig`: every field of that is a parameter of the node
    and of ``mrs-nav replay --param``, read from ``config/slam.yaml``; these are set at the update gates' scale
    (``linearUpdate``, ``angularUpdate`` 0.2) from the measurements below, and a user has no reason to change them.
    """

    # m, rad: a node per place and heading, at the update gates' scale: while exploring, every processed scan
    # (0.2 m or 0.2 rad apart) is still a node; the heading tolerance is wider because the laser sees all round,
    # so the same place crossed in another direction rarely needs another node.
    radius_m: float = 0.15
    heading_rad: float = math.radians(30.0)
    # Scans in a covered place kept with their nearest node, for rebuilding the map: rebuilt from the nodes alone,
    # the office loop's map lost 0.013-0.03 of its IoU with the world (360 beams) and 0.05-0.09 (90 beams), 171 of
    # its 410 scans being nodes. Bounded per node, so that memory still follows the mapped extent.
    scans_kept_per_node: int = 2

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if not (isinstance(value, int | float) and value >= 0.0):
                raise InvalidInputError(f"keyframe setting {field.name} must be a number >= 0, got {value!r}")


@dataclass(frozen=True)
class ProcessedScan:
    """One processed scan: its time (s), the corrected base pose in the map, the odometry pose, the match, the
    laser mounting used, its beams and the path length so far."""

    stamp: float
    pose: Pose2D
    odom: Pose2D
    match: MatchResult | None
    laser_pose: Pose2D = dataclasses.field(default_factory=lambda: Pose2D(0.0, 0.0, 0.0))
    beams: StoredBeams | None = None  # kept to rebuild the map after loop closure
    travelled: float = 0.0  # m of path from the first processed scan (by the estimate)


class NodeIndex:
    """The nodes' (x, y, yaw) for :meth:`nearest`, in the first rows of an array, and the node list they are of:
    extended as nodes are appended, taken anew when a loop closure replaces the list.

    Why: made from the whole list for every scan, they cost 1 ms a scan on the Freiburg 079 log, 6 % of its CPU.
    Rows to spare, doubled when full: copied into a new array for every node, they would cost O(nodes^2) over a log.
    """

    def __init__(self, config: KeyframeConfig) -> None:
        self.config = config
        self._poses: FloatArray = np.empty((0, 3))
        self._count = 0
        self._of: Sequence[ProcessedScan] | None = None

    def nearest(self, nodes: Sequence[ProcessedScan], pose: Pose2D) -> int | None:
        """The node of ``nodes`` nearest ``pose`` within the keyframe radius and heading, or None when the place
        is new."""
        if not nodes:
            return None
        if self._of is not nodes:
            self._count, self._of = 0, nodes
        count, size = self._count, len(nodes)
        if count < size:
            if size > len(self._poses):
                grown = np.empty((max(size, 2 * len(self._poses)), 3))
                grown[:count] = self._poses[:count]
                self._poses = grown
            self._poses[count:size] = [(n.pose.x, n.pose.y, n.pose.yaw) for n in nodes[count:]]
            self._count = size
        xy = self._poses[:size]
        distance = np.hypot(xy[:, 0] - pose.x, xy[:, 1] - pose.y)
        turned = np.abs(np.remainder(xy[:, 2] - pose.yaw + math.pi, math.tau) - math.pi)
        distance[(distance >= self.config.radius_m) | (turned >= self.config.heading_rad)] = np.inf
        best = int(np.argmin(distance))
        return best if math.isfinite(distance[best]) else None


def apart(a: Pose2D, b: Pose2D) -> float:
    """Distance (m) between two poses' positions."""
    return math.hypot(a.x - b.x, a.y - b.y)


class NodeTable:
    """The nodes' positions (m) and travel (m), as arrays for vectorised searches over them: extended as nodes are
    appended to the list they are of, taken anew when another list (a loop closure's) replaces it.

    Why: the loop closer looked over every older node in Python at each attempt (the nearest, the submap's, the far
    candidates'), about a microsecond a node: 0.9 ms an attempt on the 736 nodes of the Intel log at its end, a cost
    per scan that grows with the graph where every scan is an attempt (open space, every scan a node).
    """

    def __init__(self) -> None:
        self._xy: FloatArray = np.empty((0, 2))
        self._travel: FloatArray = np.empty(0)
        self._count = 0
        self._of: Sequence[ProcessedScan] | None = None

    def of(self, nodes: Sequence[ProcessedScan]) -> tuple[FloatArray, FloatArray]:
        """Positions (N x 2) and travel (N) of ``nodes``, views valid until the next call."""
        if self._of is not nodes:
            self._count, self._of = 0, nodes
        count, size = self._count, len(nodes)
        if count < size:
            if size > len(self._travel):
                rows = max(size, 2 * len(self._travel))
                xy, travel = np.empty((rows, 2)), np.empty(rows)
                xy[:count], travel[:count] = self._xy[:count], self._travel[:count]
                self._xy, self._travel = xy, travel
            self._xy[count:size] = [(n.pose.x, n.pose.y) for n in nodes[count:]]
            self._travel[count:size] = [n.travelled for n in nodes[count:]]
            self._count = size
        return self._xy[:size], self._travel[:size]
