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
