"""Following a planned path with a holonomic point and feedback linearisation (assignment 4c).

The robot is steered through the point ``P = x + epsilon (cos theta, sin theta)`` ahead of its wheel axle;
``P`` can move in any direction, so the path is followed by choosing a velocity for ``P`` and mapping it to
the unicycle commands ``(u, omega)`` with :func:`feedback_linearized`.

The velocity of ``P`` (all lengths in metres, speeds in m/s):

* The segment ``[x_1, x_2]`` of the path beside ``P`` is the one where the projections on its direction
  ``n = (x_2 - x_1) / |x_2 - x_1|`` change sign, ``sign(n . (x_2 - P)) != sign(n . (x_1 - P))``; when
  several segments qualify the closest one wins.
* ``v = v_nom n + k d n_perp`` with ``n_perp`` the left normal of ``n`` and ``d = n_perp . (x_1 - P)`` the
  signed cross-track distance: the first term runs along the path, the second pulls ``P`` back onto it with
  the gain ``k`` (1/s), so the cross-track error decays as ``exp(-k t)``.
* Past the end of the last segment (or closer to the last point than ``v_nom / k``) ``P`` is driven straight at
  the last point with a speed proportional to the distance, and stops within ``goal_tolerance`` of it.

The commands are finally scaled down together (which keeps the direction of ``P``'s motion) to the robot's
limits, by default a TurtleBot3 Burger's 0.22 m/s and 2.84 rad/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.control.feedback_linearization import feedback_linearized, point_ahead
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR

SPEED = 0.2  # m/s, nominal speed of the holonomic point along the path (the course's SPEED)
EPSILON = 0.1  # m, distance of the holonomic point ahead of the axle (the course's EPSILON for RRT navigation)
GAIN = 2.0  # 1/s, cross-track gain k
GOAL_TOLERANCE = 0.05  # m, the holonomic point stops this close to the last path point
MAX_LINEAR = BURGER_MAX_LINEAR
MAX_ANGULAR = BURGER_MAX_ANGULAR


@dataclass(frozen=True)
class PathPoint:
    """Where a point lies beside a path: segment ``segment`` (from point ``segment`` to ``segment + 1``),
    the signed cross-track distance ``cross_track_m`` (positive when the path is to the point's left) and the
    distance ``along_m`` from the segment's start along its direction (may be negative or exceed the segment)."""

    segment: int
    cross_track_m: float
    along_m: float


def as_path_points(path_points: npt.ArrayLike) -> FloatArray:
    """The ``(N, 2)`` positions of a path given as ``(N, 2)`` or ``(N, 3)`` rows, consecutive duplicates removed.

    Raises :class:`InvalidInputError` for an empty, misshapen or non-finite path.
    """
    points = np.asarray(path_points, dtype=np.float64)
    if points.ndim != 2 or points.shape[0] == 0 or points.shape[1] not in (2, 3):
        raise InvalidInputError(f"path must be a non-empty (N, 2) or (N, 3) array, got shape {points.shape}")
    if not np.all(np.isfinite(points)):
        raise InvalidInputError("path has a non-finite coordinate")
    xy = points[:, :2]
    keep = np.ones(xy.shape[0], dtype=bool)
    keep[1:] = np.hypot(*np.diff(xy, axis=0).T) > 1e-9
    return np.ascontiguousarray(xy[keep])


def locate_on_path(
    position: npt.ArrayLike, points: FloatArray, first_segment: int = 0, last_segment: int | None = None
) -> PathPoint:
    """The segment of ``points`` (``(N, 2)``, N >= 2, no repeated points) beside ``position``.

    Only segments ``first_segment`` to ``last_segment`` (inclusive; default the last one) are considered (a
    follower's progress and look-ahead window). A segment qualifies when
    the projections of its ends relative to ``position`` change sign (``position`` lies beside it); the closest
    qualifying segment wins. When none qualifies (``position`` is outside a bend, before the start or past the
    end) the segment with the nearest point wins.
    """
    p = np.asarray(position, dtype=np.float64)[:2]
    first = min(max(first_segment, 0), points.shape[0] - 2)
    last = points.shape[0] - 2 if last_segment is None else min(max(last_segment, first), points.shape[0] - 2)
    starts, ends = points[first : last + 1], points[first + 1 : last + 2]
    step = ends - starts
    length = np.hypot(step[:, 0], step[:, 1])
    n = step / length[:, None]
    n_perp = np.column_stack((-n[:, 1], n[:, 0]))
    to_start, to_end = starts - p, ends - p
    beside = np.sign(np.einsum("ij,ij->i", n, to_end)) != np.sign(np.einsum("ij,ij->i", n, to_start))
    cross = np.einsum("ij,ij->i", n_perp, to_start)
    along = -np.einsum("ij,ij->i", n, to_start)
    if np.any(beside):
        candidates = np.flatnonzero(beside)
        best = int(candidates[np.argmin(np.abs(cross[candidates]))])
    else:
        nearest = np.hypot(*(points[first : last + 2] - p).T)
        vertex = int(np.argmin(nearest))
        best = min(vertex, step.shape[0] - 1)
    return PathPoint(first + best, float(cross[best]), float(along[best]))


def get_velocity(
    position: npt.ArrayLike,
    path_points: npt.ArrayLike,
    *,
    speed: float = SPEED,
    gain: float = GAIN,
    goal_tolerance: float = GOAL_TOLERANCE,
    first_segment: int = 0,
) -> FloatArray:
    """Velocity (m/s, shape ``(2,)``) of the holonomic point at ``position`` that follows ``path_points``.

    ``v = speed n + gain d n_perp`` on the segment beside the point (see the module docstring); near the end
    the point is driven at the last path point and stopped (zero velocity) within ``goal_tolerance`` of it.
    """
    p = np.asarray(position, dtype=np.float64)[:2]
    points = as_path_points(path_points)
    return _velocity(p, points, speed, gain, goal_tolerance, first_segment=first_segment, last_segment=None)[0]


def _velocity(
    p: FloatArray,
    points: FloatArray,
    speed: float,
    gain: float,
    goal_tolerance: float,
    *,
    first_segment: int,
    last_segment: int | None,
) -> tuple[FloatArray, PathPoint | None]:
    to_goal = points[-1] - p
    distance = math.hypot(*to_goal)
    if distance < goal_tolerance:
        return np.zeros(2), None
    # Near the end, aim straight at the last point and slow down in proportion (no overshoot): the same gain
    # that corrects the cross-track error brings the point to rest.
    final_approach = min(speed, gain * distance) * to_goal / distance
    if points.shape[0] < 2:
        return final_approach, None
    where = locate_on_path(p, points, first_segment, last_segment)
    last = where.segment == points.shape[0] - 2
    seg_start, seg_end = points[where.segment], points[where.segment + 1]
    seg_length = math.hypot(*(seg_end - seg_start))
    if last and (where.along_m >= seg_length or distance < speed / gain):
        return final_approach, where
    n = (seg_end - seg_start) / seg_length
    n_perp = np.array([-n[1], n[0]])
    return speed * n + gain * where.cross_track_m * n_perp, where


@dataclass(frozen=True)
class FollowerConfig:
    """Parameters of :class:`PathFollower` (metres, seconds, radians)."""

    speed: float = SPEED
    epsilon: float = EPSILON
    gain: float = GAIN
    goal_tolerance: float = GOAL_TOLERANCE
    max_linear: float = MAX_LINEAR
    max_angular: float = MAX_ANGULAR
    # How far along the path beyond the end of the segment reached the follower looks for the segment beside it:
    # far enough to catch up after a disturbance, short enough not to cut across to a later part of the path.
    lookahead_m: float = 0.6
    # Feedback linearisation backs the robot up when the point's velocity points behind it; without reversing
    # (a forward-looking laser, planners that plan forward arcs) the robot turns on the spot instead.
    allow_reverse: bool = False

    def __post_init__(self) -> None:
        for name in ("speed", "epsilon", "gain", "goal_tolerance", "max_linear", "max_angular", "lookahead_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"follower {name} must be a positive number, got {value}")


@dataclass(frozen=True)
class FollowCommand:
    """One control step: forward speed ``u`` (m/s), turn rate ``omega`` (rad/s), whether the end of the path
    is reached (then both are zero), and the signed cross-track distance of the holonomic point (m)."""

    u: float
    omega: float
    done: bool
    cross_track_m: float


def saturate(u: float, omega: float, max_linear: float, max_angular: float) -> tuple[float, float]:
    """Scale ``(u, omega)`` by one factor so both are within their limits (keeps the direction of ``P``)."""
    scale = max(abs(u) / max_linear, abs(omega) / max_angular, 1.0)
    return u / scale, omega / scale


class PathFollower:
    """Follows one path; remembers the segment reached so that it never goes back to an earlier part of the
    path that passes close by (a loop or a U-turn)."""

    def __init__(self, path_points: npt.ArrayLike, config: FollowerConfig | None = None) -> None:
        self.config = config or FollowerConfig()
        self.points = as_path_points(path_points)
        # cumulative length (m) at each path point, for the look-ahead window
        self._arc = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(self.points, axis=0).T))))
        self.segment = 0

    def holonomic_point(self, pose: Pose2D) -> FloatArray:
        """The point ``epsilon`` ahead of ``pose`` that the follower steers."""
        return point_ahead(pose, self.config.epsilon)

    def command(self, pose: Pose2D) -> FollowCommand:
        """The commands for the robot at ``pose`` (in the path's frame)."""
        cfg = self.config
        p = self.holonomic_point(pose)
        reach = self._arc[min(self.segment + 1, self._arc.shape[0] - 1)] + cfg.lookahead_m
        window_end = int(np.searchsorted(self._arc, reach, side="right"))
        velocity, where = _velocity(
            p,
            self.points,
            cfg.speed,
            cfg.gain,
            cfg.goal_tolerance,
            first_segment=self.segment,
            last_segment=window_end - 1,
        )
        if where is None and not np.any(velocity):
            return FollowCommand(0.0, 0.0, True, 0.0)
        cross = 0.0
        if where is not None:
            self.segment = where.segment
            cross = where.cross_track_m
        u, omega = feedback_linearized(pose, velocity, cfg.epsilon)
        if not cfg.allow_reverse and u < 0.0:
            # the point should move backwards: turn on the spot towards its velocity (left when dead behind)
            u, omega = 0.0, math.copysign(cfg.max_angular, omega) if omega else cfg.max_angular
        u, omega = saturate(u, omega, cfg.max_linear, cfg.max_angular)
        return FollowCommand(u, omega, False, cross)


def cross_track_distance(position: npt.ArrayLike, path_points: npt.ArrayLike) -> float:
    """Unsigned distance (m) from ``position`` to the polyline ``path_points`` (nearest point on any segment)."""
    points = as_path_points(path_points)
    p = np.asarray(position, dtype=np.float64)[:2]
    if points.shape[0] == 1:
        return float(math.hypot(*(points[0] - p)))
    starts, step = points[:-1], np.diff(points, axis=0)
    t = np.clip(np.einsum("ij,ij->i", p - starts, step) / np.einsum("ij,ij->i", step, step), 0.0, 1.0)
    nearest = starts + t[:, None] * step
    return float(np.min(np.hypot(*(nearest - p).T)))
