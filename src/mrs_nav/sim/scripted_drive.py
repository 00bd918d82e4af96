"""Scripted drives for simulations without a planner: pure pursuit along a polyline of waypoints.

Benchmarks, SLAM scenarios and bag recordings need the robot to drive somewhere sensible without the
navigation stack. :class:`WaypointDriver` projects the robot onto the polyline, aims ``lookahead`` metres
further along it, and turns in proportion to the heading error (rad) towards that point::

    omega = k * e,    v = speed * max(0, cos e)

so it slows down in sharp turns and turns on the spot at corners. The commands respect nothing but the
simulator's own limits (which clamp them); obstacles are not looked at, so the polyline must be free.
"""

from __future__ import annotations

import math

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.sim.commands import Twist2D

# The centre line of the office's ring corridor (worlds/office.world), counter-clockwise from the SW corner.
OFFICE_CORRIDOR_LOOP = ((-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0))


class WaypointDriver:
    """Pure pursuit along waypoints (m); ``loop`` closes the polyline, else the robot stops at its end."""

    def __init__(
        self,
        waypoints: tuple[tuple[float, float], ...] | list[tuple[float, float]],
        *,
        loop: bool = True,
        speed: float = 0.2,
        lookahead: float = 0.6,
        gain: float = 2.0,
    ) -> None:
        points = np.asarray(waypoints, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2 or not np.all(np.isfinite(points)):
            raise InvalidInputError(f"waypoints: need at least two finite (x, y) points, got {waypoints!r}")
        if not (speed > 0.0 and lookahead > 0.0 and gain > 0.0):
            raise InvalidInputError("speed, lookahead and gain must be positive")
        if loop:
            points = np.vstack([points, points[:1]])
        self._starts = points[:-1]
        self._vectors = points[1:] - points[:-1]
        self._lengths = np.hypot(self._vectors[:, 0], self._vectors[:, 1])
        if np.any(self._lengths <= 0.0):
            raise InvalidInputError("waypoints: consecutive points must differ")
        self._offsets = np.concatenate([[0.0], np.cumsum(self._lengths)])
        self.length = float(self._offsets[-1])
        self.loop = loop
        self.speed, self.lookahead, self.gain = speed, lookahead, gain

    def progress(self, x: float, y: float) -> float:
        """Arc length (m) of the polyline point closest to (x, y)."""
        rel = np.array([x, y]) - self._starts
        t = np.clip(np.einsum("ij,ij->i", rel, self._vectors) / self._lengths**2, 0.0, 1.0)
        nearest = self._starts + t[:, None] * self._vectors
        i = int(np.argmin(np.hypot(*(nearest - np.array([x, y])).T)))
        return float(self._offsets[i] + t[i] * self._lengths[i])

    def point_at(self, s: float) -> tuple[float, float]:
        """The polyline point at arc length ``s`` (m): wrapped on a loop, clamped on an open path."""
        s = s % self.length if self.loop else min(max(s, 0.0), self.length)
        i = min(int(np.searchsorted(self._offsets, s, side="right")) - 1, len(self._lengths) - 1)
        t = (s - self._offsets[i]) / self._lengths[i]
        x, y = self._starts[i] + t * self._vectors[i]
        return float(x), float(y)

    def command(self, pose: Pose2D) -> Twist2D:
        """The (v, omega) that steers from ``pose`` along the polyline."""
        s = self.progress(pose.x, pose.y)
        if not self.loop and self.length - s < 0.05:
            return Twist2D()
        tx, ty = self.point_at(s + self.lookahead)
        error = wrap_angle(math.atan2(ty - pose.y, tx - pose.x) - pose.yaw)
        return Twist2D(self.speed * max(0.0, math.cos(error)), self.gain * error)
