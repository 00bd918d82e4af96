"""Feedback linearisation of a differential-drive robot (assignment 1.2, parts 2a-2d).

A point ``P`` a distance ``epsilon`` (m) ahead of the wheel axle, ``x_p = x + epsilon (cos theta, sin theta)``,
moves with::

    d x_p / dt = J(theta) (u, omega),   J = [[cos theta, -epsilon sin theta],
                                             [sin theta,  epsilon cos theta]]

``J`` is invertible for ``epsilon != 0``, so any wanted velocity ``v`` (m/s) of ``P`` (holonomic) is produced by
the forward speed ``u`` (m/s) and turn rate ``omega`` (rad/s)::

    u     =  cos theta v_x + sin theta v_y
    omega = (-sin theta v_x + cos theta v_y) / epsilon

In the robot's own frame (2d), where ``theta = 0``, this reduces to ``u = v_x'`` and ``omega = v_y' / epsilon``
with ``v' = R(theta)^T v`` the wanted velocity expressed in the robot frame.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D


def _check(velocity: npt.ArrayLike, epsilon: float) -> tuple[float, float]:
    vx, vy = (float(v) for v in np.asarray(velocity, dtype=np.float64).reshape(2))
    if not (math.isfinite(vx) and math.isfinite(vy)):
        raise InvalidInputError(f"velocity must be finite, got ({vx}, {vy})")
    if not math.isfinite(epsilon) or epsilon <= 0.0:
        raise InvalidInputError(f"epsilon must be a finite distance > 0 m, got {epsilon}")
    return vx, vy


def point_ahead(pose: Pose2D, epsilon: float) -> FloatArray:
    """The holonomic point ``P = x + epsilon (cos theta, sin theta)`` (m) that feedback linearisation steers."""
    return np.array([pose.x + epsilon * math.cos(pose.yaw), pose.y + epsilon * math.sin(pose.yaw)])


def feedback_linearized(pose: Pose2D, velocity: npt.ArrayLike, epsilon: float) -> tuple[float, float]:
    """``(u, omega)`` that move the point ``epsilon`` ahead of ``pose`` with ``velocity`` (world frame, m/s)."""
    vx, vy = _check(velocity, epsilon)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return c * vx + s * vy, (-s * vx + c * vy) / epsilon


def feedback_linearized_relative(velocity_in_robot_frame: npt.ArrayLike, epsilon: float) -> tuple[float, float]:
    """``(u, omega)`` from the wanted velocity of ``P`` expressed in the robot frame: ``(v_x', v_y' / epsilon)``."""
    vx, vy = _check(velocity_in_robot_frame, epsilon)
    return vx, vy / epsilon


def point_velocity(pose: Pose2D, u: float, omega: float, epsilon: float) -> FloatArray:
    """The forward kinematics ``J(theta) (u, omega)``: velocity (m/s, world frame) of the point ``epsilon`` ahead."""
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return np.array([c * u - epsilon * s * omega, s * u + epsilon * c * omega])
