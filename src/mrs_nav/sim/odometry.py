"""Wheel odometry: the pose a real base reports, integrated from what its wheels actually turned.

Each step the wheels turned by d_l and d_r radians (read from the hinge joints, so slip and pushing against a
wall show as drift, as on the real robot). Optional extra noise scales each wheel's travel by
(1 + N(0, k^2)), modelling uneven tyres and encoder error; k = 0 gives the exact wheel odometry.
With s_l = r d_l, s_r = r d_r (m), the pose advances along an arc (exact for constant wheel rates)::

    ds = (s_r + s_l) / 2,   dth = (s_r - s_l) / L
    x += ds cos(th + dth/2) sinc(dth/2),  y += ds sin(th + dth/2) sinc(dth/2),  th += dth
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.sim.robot import BurgerParams


@dataclass(frozen=True)
class Odometry:
    """Odometry at sim time ``stamp`` (s): pose in the odom frame and the body twist (m/s, rad/s)."""

    stamp: float
    pose: Pose2D
    v: float
    omega: float


class WheelOdometry:
    """Integrates wheel-angle increments into a pose in the ``odom`` frame.

    The integration starts at ``start``: the simulator passes the robot's start pose in the world, so ``odom``
    coincides with the world frame at time zero (as Gazebo's diff-drive plugin does) and drifts from it after.
    """

    def __init__(self, params: BurgerParams, noise: float, rng: np.random.Generator, start: Pose2D) -> None:
        if not (math.isfinite(noise) and noise >= 0.0):
            raise InvalidInputError(f"odometry noise must be >= 0, got {noise}")
        self._params = params
        self._noise = noise
        self._rng = rng
        self._x = start.x
        self._y = start.y
        self._yaw = start.yaw
        self._v = 0.0
        self._omega = 0.0

    def update(self, d_left: float, d_right: float, dt: float) -> None:
        """Advance by wheel rotations ``d_left``, ``d_right`` (rad) made over ``dt`` seconds."""
        if self._noise > 0.0:
            scale = 1.0 + self._rng.normal(0.0, self._noise, 2)
            d_left, d_right = d_left * float(scale[0]), d_right * float(scale[1])
        r, sep = self._params.wheel_radius, self._params.wheel_separation
        s_l, s_r = r * d_left, r * d_right
        ds, dth = (s_r + s_l) / 2.0, (s_r - s_l) / sep
        half = dth / 2.0
        chord = ds * (math.sin(half) / half if abs(half) > 1e-9 else 1.0)
        self._x += chord * math.cos(self._yaw + half)
        self._y += chord * math.sin(self._yaw + half)
        self._yaw = wrap_angle(self._yaw + dth)
        self._v, self._omega = ds / dt, dth / dt

    def state(self, stamp: float) -> Odometry:
        return Odometry(stamp, Pose2D(self._x, self._y, self._yaw), self._v, self._omega)
