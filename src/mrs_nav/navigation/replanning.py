"""When a :class:`~mrs_nav.navigation.navigator.Navigator` plans again, and which new plans it adopts.

A new plan is made when (in order):

* there is none (a new goal, or the last attempt failed: then ``retry_delay_s`` after it);
* the rest of the path comes within the robot's radius of an obstacle of a new map (``blocked``): a plan keeps
  the whole inflation (the radius plus the safety margin) from obstacles, and what enters that margin alone does
  not block it. Without that hysteresis a path hugging the inflated corner of a door jamb in a room the map does
  not know was blocked whenever a mark at the corner moved by a cell (the beams past the corner clear it, the
  next ones mark it again, the estimate shifts by centimetres), replanned every 2 s, and the robot held for each
  plan: it stood at the door until the goal was given up;
* the robot is farther than ``stray_distance_m`` from the rest of the path (``strayed``);
* the distance to the goal has not shrunk by ``progress_m`` for ``progress_timeout_s`` (``stuck``);
* every ``replan_period_s`` once the map has changed since the last plan (``periodic``). Such a plan is only
  an offer: it replaces the current path only if it is clearly shorter than what is left of it (shorter than
  ``improvement_ratio`` times the remaining length and by at least ``improvement_min_m``), so the robot does
  not oscillate between plans of about the same length.

Every failed attempt of the first four kinds counts; ``max_failed_plans`` failures in a row end the goal.
Times are in seconds of the caller's clock, distances in metres.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mrs_nav.control.path_following import PathFollower, cross_track_distance
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.navigation.config import NavigatorConfig


def densify(points: npt.ArrayLike, step: float) -> FloatArray:
    """The polyline ``points`` (``(N, 2+)``) resampled so that consecutive points are at most ``step`` apart
    (``(M, 2)``, every original point kept)."""
    xy = np.asarray(points, dtype=np.float64)[:, :2]
    if xy.shape[0] < 2:
        return xy.copy()
    gaps = np.hypot(*np.diff(xy, axis=0).T)
    counts = np.maximum(np.ceil(gaps / step).astype(np.intp), 1)
    t = np.concatenate([np.arange(c) / c for c in counts])
    starts = np.repeat(np.arange(xy.shape[0] - 1), counts)
    out = xy[starts] + t[:, None] * (xy[starts + 1] - xy[starts])
    return np.vstack((out, xy[-1:]))


def first_blocked_point(
    grid: OccupancyGrid, raw: OccupancyGrid, rest: FloatArray, pose: Pose2D, near_m: float
) -> FloatArray | None:
    """The first point (``(2,)``) of the polyline ``rest`` on an occupied cell of ``grid`` (the map inflated by
    the robot's radius, :attr:`~mrs_nav.navigation.navigator.Navigator.collision_grid`), None when the way is
    clear. Within ``near_m`` of the robot at ``pose`` only ``raw`` (the map before inflation) counts: the robot
    may legitimately be within the inflation of a wall it is leaving."""
    dense = densify(rest, grid.resolution / 2.0)
    near = np.hypot(dense[:, 0] - pose.x, dense[:, 1] - pose.y) <= near_m
    blocked = np.where(near, raw.is_occupied(dense), grid.is_occupied(dense))
    hits = np.flatnonzero(blocked)
    return dense[hits[0]] if hits.size else None


class ReplanPolicy:
    """The replanning bookkeeping of one goal at a time: map versions, failures in a row, progress."""

    def __init__(self, config: NavigatorConfig) -> None:
        self.config = config
        self.map_version = 0
        self._checked_version = 0  # map version the current path was last checked against
        self._planned_version = 0  # map version the current path was planned on
        self.failures = 0
        self.last_plan_time = -math.inf
        self._best_distance = math.inf
        self._progress_time = 0.0

    def new_map(self) -> None:
        self.map_version += 1

    def new_goal(self, now: float) -> None:
        """Start afresh for a goal set at ``now``."""
        self.failures = 0
        self.last_plan_time = -math.inf
        self._best_distance = math.inf
        self._progress_time = now

    def note_distance(self, distance: float, now: float) -> bool:
        """The robot is ``distance`` from the goal at ``now`` (progress is measured against the best so far);
        whether that is progress."""
        if distance < self._best_distance - self.config.progress_m:
            self._best_distance = distance
            self._progress_time = now
            return True
        return False

    def recovered(self, now: float) -> None:
        """A recovery ran at ``now``: plan afresh at once, and count failures and progress from here."""
        self.failures = 0
        self.last_plan_time = -math.inf
        self._progress_time = now

    def reason(
        self, follower: PathFollower | None, pose: Pose2D, now: float, grid: OccupancyGrid, raw: OccupancyGrid
    ) -> str | None:
        """Why to plan now for the robot at ``pose`` following ``follower`` (None: no valid path) on the maps
        ``grid`` (inflated by the robot's radius) and ``raw``; ``None`` when not to."""
        cfg = self.config
        if follower is None:
            if self.failures == 0:
                return "new goal"
            # give the map a moment to change before trying again
            return "retry" if now - self.last_plan_time >= cfg.retry_delay_s else None
        rest = follower.points[follower.segment :]
        if (
            self.map_version != self._checked_version
            and first_blocked_point(grid, raw, rest, pose, cfg.inflation_m + grid.resolution) is not None
        ):
            return "blocked"
        self._checked_version = self.map_version
        if cross_track_distance(follower.holonomic_point(pose), rest) > cfg.stray_distance_m:
            return "strayed"
        if cfg.progress_timeout_s > 0.0 and now - self._progress_time > cfg.progress_timeout_s:
            return "stuck"
        if now - self.last_plan_time >= cfg.replan_period_s and self.map_version != self._planned_version:
            return "periodic"
        return None

    def started(self, now: float) -> None:
        """A plan was started at ``now`` on the current map."""
        self.last_plan_time = now
        self._planned_version = self.map_version
        self._checked_version = self.map_version

    def failed(self) -> bool:
        """Count a failed plan; whether the goal has now failed too often."""
        self.failures += 1
        return self.failures >= self.config.max_failed_plans

    def worth_adopting(self, remaining_m: float, new_m: float) -> bool:
        """Whether an optional plan of ``new_m`` is clearly shorter than the ``remaining_m`` of the current one."""
        cfg = self.config
        return new_m < cfg.improvement_ratio * remaining_m and remaining_m - new_m >= cfg.improvement_min_m

    def adopted(self, reason: str, asked_at: float) -> None:
        """A plan asked at ``asked_at`` for ``reason`` was adopted."""
        self.failures = 0
        if reason == "stuck":
            self._progress_time = asked_at
