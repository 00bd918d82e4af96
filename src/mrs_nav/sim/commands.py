"""Velocity commands as a real base obeys them: clamped to limits, ramped by acceleration, stopped by a watchdog.

A command (v, omega) is clamped to the speed limits when it arrives. Each control step moves the current
command towards it by at most ``a_max * dt`` (a trapezoidal profile), so a step from rest to ``v`` takes
``v / a_max`` seconds and covers ``v^2 / (2 a_max)`` metres; stopping gives the same back, so a command held
for T seconds travels ``v T`` in total. If no command arrives for ``command_timeout`` seconds of sim time the
target becomes zero and the robot brakes at the (harder) watchdog rates, as the Burger's firmware stops its
wheels when its driver node dies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mrs_nav.errors import InvalidInputError
from mrs_nav.sim.robot import BurgerParams


def _approach(current: float, target: float, max_change: float) -> float:
    return current + min(max(target - current, -max_change), max_change)


@dataclass(frozen=True)
class Twist2D:
    """Planar body velocity: forward speed ``v`` in m/s and turn rate ``omega`` in rad/s."""

    v: float = 0.0
    omega: float = 0.0


class CommandLimiter:
    """Turns the last received (v, omega) into the command applied at each control step."""

    def __init__(self, params: BurgerParams) -> None:
        self._params = params
        self._target = Twist2D()
        self._current = Twist2D()
        self._last_time = -math.inf

    @property
    def target(self) -> Twist2D:
        """The clamped command most recently received."""
        return self._target

    @property
    def current(self) -> Twist2D:
        """The command applied at the last control step."""
        return self._current

    def receive(self, v: float, omega: float, now: float) -> Twist2D:
        """Accept a command at sim time ``now`` (s); returns it clamped to the speed limits."""
        if not (math.isfinite(v) and math.isfinite(omega)):
            raise InvalidInputError(f"velocity command must be finite, got v={v}, omega={omega}")
        p = self._params
        self._target = Twist2D(
            min(max(v, -p.max_linear_speed), p.max_linear_speed),
            min(max(omega, -p.max_angular_speed), p.max_angular_speed),
        )
        self._last_time = now
        return self._target

    def timed_out(self, now: float) -> bool:
        """Whether the watchdog has stopped the robot at sim time ``now``."""
        return now - self._last_time > self._params.command_timeout

    def update(self, now: float, dt: float) -> Twist2D:
        """The command to apply for the step of ``dt`` seconds starting at ``now``."""
        p = self._params
        if self.timed_out(now):
            target, linear, angular = Twist2D(), p.watchdog_linear_decel, p.watchdog_angular_decel
        else:
            target, linear, angular = self._target, p.max_linear_accel, p.max_angular_accel
        self._current = Twist2D(
            _approach(self._current.v, target.v, linear * dt),
            _approach(self._current.omega, target.omega, angular * dt),
        )
        return self._current
