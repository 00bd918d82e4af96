"""The simulated robot: a TurtleBot3-Burger-like differential drive, its dimensions, limits and kinematics.

Frames follow the Burger's URDF (``urdf/burger.urdf`` holds the same numbers): ``base_footprint`` on the
ground under the wheel axle centre, ``base_link`` 0.010 m above it, the wheel axle at height = wheel radius,
and the laser (``base_scan``) 0.032 m behind the axle and 0.182 m above the ground.

Differential-drive kinematics, with wheel radius r and separation L (metres), wheel rates in rad/s::

    v     = r (w_right + w_left) / 2          [m/s]
    omega = r (w_right - w_left) / L          [rad/s]
    w_left  = (v - omega L / 2) / r
    w_right = (v + omega L / 2) / r
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from mrs_nav.errors import InvalidInputError
from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR, BURGER_RADIUS


@dataclass(frozen=True)
class BurgerParams:
    """Dimensions (m), masses (kg), limits and contact friction of the simulated Burger."""

    wheel_radius: float = 0.033
    wheel_separation: float = 0.160
    wheel_width: float = 0.018
    footprint_radius: float = BURGER_RADIUS
    # The chassis is a vertical cylinder of the footprint radius around base_footprint, clear of the ground
    # so that only the wheels and the caster touch it.
    chassis_clearance: float = 0.015
    chassis_height: float = 0.175
    chassis_mass: float = 0.9
    # Centre of mass behind the axle (as the Burger's, whose body centre is 0.032 m back): the robot rests on
    # its wheels and caster instead of balancing on the axle and pitching forward.
    com_x: float = -0.032
    wheel_mass: float = 0.05
    caster_x: float = -0.081
    caster_radius: float = 0.01
    max_linear_speed: float = BURGER_MAX_LINEAR
    max_angular_speed: float = BURGER_MAX_ANGULAR
    max_linear_accel: float = 1.0
    max_angular_accel: float = 6.0
    # Torque limit of each wheel's velocity motor (N m): ample for 1 m/s^2 on 1 kg, bounded so that pushing
    # against a wall cannot force the body through it.
    wheel_torque_limit: float = 0.5
    wheel_friction: float = 1.0
    caster_friction: float = 0.0
    body_friction: float = 0.3
    # The cmd_vel watchdog: after command_timeout s of sim time without a command (three periods of the 10 Hz
    # navigation nodes, so one late or lost command never trips it) the robot brakes at the watchdog rates, harder
    # than the drive's ramp (the Burger's firmware zeroes its wheel velocities), so that it stands still within
    # 0.5 s of its command source dying: 0.3 s + 0.22 m/s / 2.5 m/s^2 (0.09 s) or 2.84 rad/s / 25 rad/s^2 (0.11 s).
    command_timeout: float = 0.3
    watchdog_linear_decel: float = 2.5
    watchdog_angular_decel: float = 25.0

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if not math.isfinite(value):
                raise InvalidInputError(f"robot parameter {field.name}: must be finite, got {value}")
            if value < 0.0 and field.name not in ("caster_x", "com_x"):
                raise InvalidInputError(f"robot parameter {field.name}: must not be negative, got {value}")
        for name in ("wheel_radius", "wheel_separation", "footprint_radius", "chassis_mass", "wheel_mass"):
            if getattr(self, name) <= 0.0:
                raise InvalidInputError(f"robot parameter {name}: must be positive")
        if not self.caster_x < self.com_x < 0.0:
            raise InvalidInputError("robot parameters: the centre of mass must lie between the caster and the axle")
        if self.wheel_separation / 2.0 + self.wheel_width / 2.0 > self.footprint_radius:
            raise InvalidInputError("robot parameters: the wheels must lie inside the footprint")

    @property
    def total_mass(self) -> float:
        return self.chassis_mass + 2.0 * self.wheel_mass

    def wheel_rates(self, v: float, omega: float) -> tuple[float, float]:
        """(left, right) wheel rates in rad/s for body speeds ``v`` (m/s) and ``omega`` (rad/s)."""
        half = omega * self.wheel_separation / 2.0
        return ((v - half) / self.wheel_radius, (v + half) / self.wheel_radius)

    def body_twist(self, left: float, right: float) -> tuple[float, float]:
        """(v, omega) in m/s and rad/s for wheel rates ``left`` and ``right`` in rad/s."""
        r = self.wheel_radius
        return (r * (right + left) / 2.0, r * (right - left) / self.wheel_separation)


BURGER = BurgerParams()
