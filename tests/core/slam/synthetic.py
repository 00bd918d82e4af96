"""A tiny analytic laser simulator for SLAM tests: walls as segments, exact ranges."""

from __future__ import annotations

import itertools
import math

import numpy as np

from mrs_nav.geometry import Pose2D
from mrs_nav.slam.scan import LaserScanData

# A 10 m x 6 m room with an inner wall stub and a pillar (square), so that no pose is ambiguous.
ROOM = np.array(
    [
        [-5.0, -3.0, 5.0, -3.0],
        [5.0, -3.0, 5.0, 3.0],
        [5.0, 3.0, -5.0, 3.0],
        [-5.0, 3.0, -5.0, -3.0],
        [0.0, 3.0, 0.0, 1.0],
        [2.0, -1.5, 2.6, -1.5],
        [2.6, -1.5, 2.6, -0.9],
        [2.6, -0.9, 2.0, -0.9],
        [2.0, -0.9, 2.0, -1.5],
        [-3.0, -3.0, -2.0, -2.0],
    ]
)


def cast(pose: Pose2D, beams: int = 360, max_range: float = 3.5, walls: np.ndarray = ROOM) -> LaserScanData:
    """Exact ranges from ``pose`` over 360 degrees; no hit within ``max_range`` gives +inf."""
    angles = -math.pi + np.arange(beams) * (2.0 * math.pi / beams)
    d = np.stack([np.cos(angles + pose.yaw), np.sin(angles + pose.yaw)], axis=1)  # (B, 2)
    p = np.array([pose.x, pose.y])
    a, b = walls[:, :2], walls[:, 2:]
    e = b - a  # (W, 2)
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]  # (B, W)
    ap = a[None, :, :] - p[None, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ap[..., 0] * e[None, :, 1] - ap[..., 1] * e[None, :, 0]) / denom
        u = (ap[..., 0] * d[:, None, 1] - ap[..., 1] * d[:, None, 0]) / denom
    t = np.where((np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1), t, np.inf)
    ranges = t.min(axis=1)
    ranges[ranges >= max_range] = np.inf
    return LaserScanData(float(angles[0]), 2.0 * math.pi / beams, 0.12, max_range, ranges)


def person(centre: np.ndarray, radius: float = 0.25) -> np.ndarray:
    """Walls (segments) of a person as a laser sees one at ``centre``: a circle ``2 * radius`` m across, as an
    octagon."""
    angles = np.arange(9) * math.pi / 4
    corners = np.stack([centre[0] + radius * np.cos(angles), centre[1] + radius * np.sin(angles)], axis=1)
    return np.array([[*a, *b] for a, b in itertools.pairwise(corners)])


# A room (x -8..0, y -3..3) with a 2 m doorway in its east wall, a pillar and two stubs; outside it nothing is in the
# laser's 3.5 m: there the SLAM has only odometry, which over-reports every turn by 8 % (wheels slipping as they
# turn). The robot leaves the room, drives 21 m out, turns round and comes back: 14 degrees and 4 m off.
ROOM_WITH_DOOR = np.array(
    [
        [-8, -3, 0, -3],
        [0, -3, 0, -1],
        [0, 1, 0, 3],
        [0, 3, -8, 3],
        [-8, 3, -8, -3],
        [-5, -1, -4.6, -1],  # a pillar
        [-4.6, -1, -4.6, -0.6],
        [-4.6, -0.6, -5, -0.6],
        [-5, -0.6, -5, -1],
        [-2, 3, -2, 2],
        [-7, -3, -6, -2],
    ],
    dtype=np.float64,
)


def route(corners: list[tuple[float, float]], step: float = 0.25) -> list[Pose2D]:
    """Poses every ``step`` m along the polyline ``corners``, turning on the spot 0.25 rad a pose at each."""
    poses = [Pose2D(*corners[0], 0.0)]
    for (x0, y0), (x1, y1) in itertools.pairwise(corners):
        heading = math.atan2(y1 - y0, x1 - x0)
        while abs(math.remainder(poses[-1].yaw - heading, math.tau)) > 1e-9:
            turn = math.remainder(heading - poses[-1].yaw, math.tau)
            poses.append(Pose2D(poses[-1].x, poses[-1].y, poses[-1].yaw + math.copysign(min(0.25, abs(turn)), turn)))
        n = round(math.hypot(x1 - x0, y1 - y0) / step)
        poses += [Pose2D(x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * i / n, heading) for i in range(1, n + 1)]
    return poses


def far_drive() -> tuple[list[Pose2D], list[Pose2D]]:
    """The true poses of the drive out of ``ROOM_WITH_DOOR`` and back, and its odometry (turns outside 8 % over)."""
    corners = [(-6.5, 1.0), (-1.5, -1.5), (-1.5, 1.5), (-1, 0), (20, 0), (20, 0.5), (-1, 0.5), (-3, 1.5)]
    truth = route([*corners, (-6.5, -1.5), (-6.5, 1.5), (-3.5, 1.5), (-3.5, -1.5)])
    odom = [truth[0]]
    for a, b in itertools.pairwise(truth):
        step = b.relative_to(a)
        outside = max(a.x, b.x) > 3.5
        odom.append(odom[-1].compose(Pose2D(step.x, step.y, step.yaw * (1.08 if outside else 1.0))))
    return truth, odom
