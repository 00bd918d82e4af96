"""Driving the robot by the potential field in real time, with a random-walk escape (the course's
``potential_field_navigation.py``, assignment 1.1 and 1.2 on the robot).

At every control step the combined field ``V = cap(V_a + w + V_r)`` (:mod:`mrs_nav.fields.potential_field`; ``w`` the
Gaussian noise of fix 1e) is evaluated at the robot's position, around the obstacles grown by the robot radius
plus a margin, and the point ``epsilon`` ahead of the axle is driven with that velocity by feedback
linearisation. (Evaluating the field at the robot rather than at the point ahead makes the robot itself, not a
point 0.2 m in front of it, come to rest on the goal.)

Local minima (1f): when the robot has not moved ``stall_move`` in ``stall_time_s`` while the goal is farther
than ``stall_distance`` (the field is weak there, or it dithers across a saddle), the robot walks at full speed
along a heading that follows the Markov chain ``theta' ~ N(theta, walk_angle_std^2)``, redrawn every
``walk_step_s`` (headings that would run into an obstacle within ``lookahead_m`` are redrawn at once). After
``min_walk_s`` it returns to the field as soon as its last step went down the potential (a positive component
along the field where it arrived).

Chassis guard: feedback linearisation drives the point ahead with the field, so the axle itself moves along the
projection ``(v . h) h`` of the field ``v`` on its heading ``h`` and can close on an obstacle that ``v`` merely
skirts (reversing past the cylinder, or one control period late on a stale pose). The forward speed is scaled
down (to 0, a turn on the spot) until the axle, carried ``guard_horizon_s`` ahead at that speed, keeps out of the
inner half of the safety margin or at least does not go deeper into it.

Units: metres, seconds, radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mrs_nav.control.feedback_linearization import feedback_linearized
from mrs_nav.control.path_following import FollowCommand, saturate
from mrs_nav.errors import InvalidInputError
from mrs_nav.fields.potential_field import DEFAULT_DECAY, PotentialField, workspace_bounds
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR, BURGER_RADIUS

WALK_REDRAWS = 20  # headings tried before giving up for this step
GUARD_SCALES = np.array([1.0, 0.75, 0.5, 0.25])  # forward speeds tried by the chassis guard, then 0


@dataclass(frozen=True)
class FieldFollowerConfig:
    """Parameters of :class:`FieldFollower`."""

    epsilon: float = 0.2
    speed: float = 0.2  # m/s, the field's cap and the walk speed
    robot_radius: float = BURGER_RADIUS
    safety_margin: float = 0.05
    decay: float = DEFAULT_DECAY
    goal_tolerance: float = 0.1
    # Done also when it has come this close and stopped making progress (obstacles near the goal can hold the
    # field's equilibrium a little short of it).
    settle_radius: float = 0.2
    noise_std: float = 0.02
    stall_move: float = 0.1
    stall_time_s: float = 2.0
    stall_distance: float = 0.3
    walk_step_s: float = 0.5
    min_walk_s: float = 2.0
    walk_angle_std: float = math.pi
    lookahead_m: float = 0.3
    # The axle's motion is checked this far ahead: a few control periods, so a command applied one period late
    # (a stale pose) is still covered.
    guard_horizon_s: float = 0.3
    max_linear: float = BURGER_MAX_LINEAR
    max_angular: float = BURGER_MAX_ANGULAR

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value >= 0.0):
                raise InvalidInputError(f"field follower {name} must be a finite number >= 0, got {value}")
        for name in ("epsilon", "speed", "decay", "goal_tolerance", "walk_step_s", "max_linear", "max_angular"):
            if getattr(self, name) <= 0.0:
                raise InvalidInputError(f"field follower {name} must be positive, got {getattr(self, name)}")


@dataclass(frozen=True)
class FieldCommand(FollowCommand):
    """A :class:`FollowCommand` plus whether the robot is on a random walk (``cross_track_m`` is unused, 0)."""

    walking: bool = False


class FieldFollower:
    """Drives towards ``goal`` through the field of ``obstacles`` (replaceable, e.g. from each scan)."""

    def __init__(
        self,
        goal: tuple[float, float],
        obstacles: Obstacles,
        config: FieldFollowerConfig | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        if not all(math.isfinite(v) for v in goal):
            raise InvalidInputError(f"goal ({goal[0]}, {goal[1]}) is not finite")
        self.config = config or FieldFollowerConfig()
        self.goal = (float(goal[0]), float(goal[1]))
        self.rng = rng or np.random.default_rng()
        self.field = self._field(obstacles)
        self.walking = False
        self._anchor: FloatArray | None = None  # where the robot was at _anchor_time
        self._anchor_time = 0.0
        self._walk_started = 0.0
        self._walk_heading = 0.0
        self._walk_step_at = -math.inf
        self._walk_from = np.zeros(2)

    def _field(self, obstacles: Obstacles) -> PotentialField:
        cfg = self.config
        grown = obstacles.inflated(cfg.robot_radius + cfg.safety_margin)
        bounds = workspace_bounds(grown, self.goal)
        return PotentialField.build(self.goal, grown, bounds, decay=cfg.decay, max_speed=cfg.speed)

    def set_obstacles(self, obstacles: Obstacles) -> None:
        """Replace the obstacles (e.g. those seen in the latest scan)."""
        self.field = self._field(obstacles)

    def command(self, pose: Pose2D, now: float) -> FieldCommand:
        """The commands for the robot at ``pose`` at time ``now`` (s)."""
        cfg = self.config
        here = np.array([pose.x, pose.y])
        distance = math.hypot(self.goal[0] - pose.x, self.goal[1] - pose.y)
        if distance <= cfg.goal_tolerance:
            self.walking = False
            return FieldCommand(0.0, 0.0, True, 0.0, False)
        noise = self.rng.normal(0.0, cfg.noise_std, 2) if cfg.noise_std > 0.0 else None
        field = self.field.velocity(here, attractive_noise=noise)[0]
        if self._anchor is None or float(np.hypot(*(here - self._anchor))) >= cfg.stall_move:
            self._anchor, self._anchor_time = here, now
        if distance <= cfg.settle_radius and now - self._anchor_time >= cfg.stall_time_s:
            self.walking = False
            return FieldCommand(0.0, 0.0, True, 0.0, False)
        if self.walking:
            velocity = self._walk(here, field, now)
            if not self.walking:
                self._anchor, self._anchor_time = here, now
        else:
            velocity = field
            if now - self._anchor_time >= cfg.stall_time_s and distance > cfg.stall_distance:
                self.walking, self._walk_started, self._walk_step_at = True, now, -math.inf
                self._walk_heading = pose.yaw
                velocity = self._walk(here, field, now)
        u, omega = feedback_linearized(pose, velocity, cfg.epsilon)
        u, omega = saturate(u, omega, cfg.max_linear, cfg.max_angular)
        return FieldCommand(self._guarded(here, pose.yaw, u), omega, False, 0.0, self.walking)

    def _guarded(self, here: FloatArray, yaw: float, u: float) -> float:
        """The largest of the :data:`GUARD_SCALES` of ``u`` that keeps the axle out of the inner half of the safety
        margin (or no deeper in it than now), else 0."""
        if u == 0.0:
            return u
        travel = GUARD_SCALES * (u * self.config.guard_horizon_s)
        points = np.vstack((here, here + travel[:, None] * np.array([math.cos(yaw), math.sin(yaw)])))
        # the field's obstacles are grown by the radius and the whole margin: -margin/2 is its inner half
        depth = self.field.obstacles.signed_distance(points)
        ok = (depth[1:] >= -0.5 * self.config.safety_margin) | (depth[1:] >= depth[0])
        return float(u * GUARD_SCALES[np.argmax(ok)]) if ok.any() else 0.0

    def _walk(self, here: FloatArray, field: FloatArray, now: float) -> FloatArray:
        cfg = self.config
        if now - self._walk_step_at >= cfg.walk_step_s:
            went = here - self._walk_from
            if now - self._walk_started >= cfg.min_walk_s and float(went @ field) > 0.0:
                self.walking = False  # the last step went downhill: back to the field
                return field
            self._walk_from, self._walk_step_at = here.copy(), now
            self._walk_heading = self._draw_heading(here)
        elif not self._clear(here, self._walk_heading):
            self._walk_heading = self._draw_heading(here)  # an obstacle came up ahead: turn away now
        return cfg.speed * np.array([math.cos(self._walk_heading), math.sin(self._walk_heading)])

    def _draw_heading(self, here: FloatArray) -> float:
        cfg = self.config
        for _ in range(WALK_REDRAWS):
            heading = float(self.rng.normal(self._walk_heading, cfg.walk_angle_std))
            if self._clear(here, heading):
                return heading
        return self._walk_heading + math.pi  # boxed in: back out the way it came

    def _clear(self, here: FloatArray, heading: float) -> bool:
        """Whether the grown obstacles leave the way ahead along ``heading`` free for ``lookahead_m``."""
        steps = np.linspace(0.05, 1.0, 6)[:, None] * self.config.lookahead_m
        ahead = here + steps * np.array([math.cos(heading), math.sin(heading)])
        return bool(np.all(self.field.obstacles.signed_distance(ahead) > 0.0))


def scan_obstacles(
    pose: Pose2D, angles: FloatArray, ranges: FloatArray, sector: float = math.radians(45.0)
) -> Obstacles:
    """Obstacles seen in a scan taken at ``pose`` (the laser's pose in the map frame): per ``sector`` of
    bearing, the nearest return as a small circle (one per sector keeps a wall from adding up to a wall of
    repulsion many times stronger than a post: the repulsion is a sum over obstacles)."""
    ok = np.isfinite(ranges)
    angles, ranges = angles[ok], ranges[ok]
    if ranges.size == 0:
        return Obstacles()
    bins = np.floor((angles % (2 * math.pi)) / sector).astype(np.intp)
    order = np.lexsort((ranges, bins))
    first = order[np.r_[True, np.diff(bins[order]) != 0]]
    world = pose.yaw + angles[first]
    x = pose.x + ranges[first] * np.cos(world)
    y = pose.y + ranges[first] * np.sin(world)
    return Obstacles(circles=np.column_stack((x, y, np.full(x.size, 0.02))))
