"""The last centimetres to a goal pose: drive the wheel axle onto the goal position, then turn on the spot to
the goal heading (what move_base's local planners do within ``xy_goal_tolerance`` / ``yaw_goal_tolerance``).

A path follower steers a point ``epsilon`` ahead of the axle, so it leaves the axle about ``epsilon`` short of
the goal. :class:`GoalApproach` takes over near the goal:

1. **position**: turn towards the goal while the bearing error exceeds ``turn_first_rad``, otherwise drive
   forward at ``k_linear * distance * cos(bearing error)`` (slowing down in proportion to the distance, never
   below ``min_linear`` so the robot does not stall short of it) while turning at ``k_angular * error``;
   the position is reached (and latched, as move_base's ``latch_xy_goal_tolerance``: turning on the spot may
   shift the axle by wheel slip) within ``xy_tolerance_m``;
2. **heading** (when the goal has one): turn on the spot at ``k_angular * error``, at least ``min_angular``,
   until within ``yaw_tolerance_rad`` while turning no faster than ``settled_rate`` (estimated from the
   successive poses): a base still spinning from the position phase would otherwise coast out of the tolerance
   after the goal is declared reached (the Burger decelerates at about 6 rad/s^2: 0.7 rad from 2.84 rad/s).

Speeds in m/s and rad/s, limited to ``max_linear`` / ``max_angular``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR

XY_GOAL_TOLERANCE = 0.05  # m, as TurtleBot3's move_base configuration
YAW_GOAL_TOLERANCE = 0.17  # rad (about 10 deg), as TurtleBot3's move_base configuration


@dataclass(frozen=True)
class ApproachConfig:
    """Parameters of :class:`GoalApproach` (metres, radians, seconds)."""

    xy_tolerance_m: float = XY_GOAL_TOLERANCE
    yaw_tolerance_rad: float = YAW_GOAL_TOLERANCE
    k_linear: float = 1.0  # 1/s
    k_angular: float = 2.0  # 1/s
    min_linear: float = 0.02  # m/s
    min_angular: float = 0.3  # rad/s
    # Above this bearing error the robot turns on the spot before driving (no sideways creep past the goal).
    turn_first_rad: float = 0.5
    settled_rate: float = 0.5  # rad/s
    max_linear: float = BURGER_MAX_LINEAR
    max_angular: float = BURGER_MAX_ANGULAR

    def __post_init__(self) -> None:
        for name in (
            "xy_tolerance_m",
            "yaw_tolerance_rad",
            "k_linear",
            "k_angular",
            "min_linear",
            "min_angular",
            "turn_first_rad",
            "settled_rate",
            "max_linear",
            "max_angular",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"goal approach {name} must be a positive number, got {value}")
        if self.yaw_tolerance_rad >= math.pi:
            raise InvalidInputError(f"yaw goal tolerance must be below pi rad, got {self.yaw_tolerance_rad}")


@dataclass(frozen=True)
class ApproachCommand:
    """Forward speed ``u`` (m/s), turn rate ``omega`` (rad/s), and whether the goal pose is reached (then both
    are zero)."""

    u: float
    omega: float
    done: bool


class GoalApproach:
    """Brings the robot onto one goal position (and heading, unless ``yaw`` is None); see the module docstring."""

    def __init__(self, x: float, y: float, yaw: float | None, config: ApproachConfig | None = None) -> None:
        self.config = config or ApproachConfig()
        self.x, self.y, self.yaw = x, y, yaw
        self.position_reached = False
        self._last: tuple[float, float] | None = None  # (time, yaw) of the previous pose

    def command(self, pose: Pose2D, now: float) -> ApproachCommand:
        """The commands for the robot at ``pose`` (the goal's frame) at time ``now`` (s)."""
        cfg = self.config
        rate = math.inf
        if self._last is not None and now > self._last[0]:
            rate = abs(wrap_angle(pose.yaw - self._last[1])) / (now - self._last[0])
        self._last = (now, pose.yaw)
        distance = math.hypot(self.x - pose.x, self.y - pose.y)
        if distance <= cfg.xy_tolerance_m:
            self.position_reached = True
        if not self.position_reached:
            error = wrap_angle(math.atan2(self.y - pose.y, self.x - pose.x) - pose.yaw)
            omega = _limited(cfg.k_angular * error, cfg.min_angular, cfg.max_angular)
            if abs(error) > cfg.turn_first_rad:
                return ApproachCommand(0.0, omega, False)
            u = min(max(cfg.k_linear * distance, cfg.min_linear), cfg.max_linear) * math.cos(error)
            return ApproachCommand(u, cfg.k_angular * error, False)
        if self.yaw is None:
            return ApproachCommand(0.0, 0.0, True)
        error = wrap_angle(self.yaw - pose.yaw)
        if abs(error) <= cfg.yaw_tolerance_rad and rate <= cfg.settled_rate:
            return ApproachCommand(0.0, 0.0, True)
        return ApproachCommand(0.0, _limited(cfg.k_angular * error, cfg.min_angular, cfg.max_angular), False)


def _limited(omega: float, least: float, most: float) -> float:
    """``omega`` with its magnitude raised to ``least`` and capped at ``most`` (sign kept)."""
    return math.copysign(min(max(abs(omega), least), most), omega)
