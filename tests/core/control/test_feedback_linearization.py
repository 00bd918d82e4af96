"""Feedback linearisation (2a-2d): the commanded point velocity is reproduced; both forms agree."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.control.feedback_linearization import (
    feedback_linearized,
    feedback_linearized_relative,
    point_ahead,
    point_velocity,
)
from mrs_nav.errors import InvalidInputError
from mrs_nav.fields.potential_field import PotentialField
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.obstacles import Obstacles

coordinates = st.floats(-10.0, 10.0)
angles = st.floats(-math.pi, math.pi)
epsilons = st.floats(0.01, 0.5)
velocities = st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0))
poses = st.builds(Pose2D, coordinates, coordinates, angles)


@given(pose=poses, eps=epsilons, velocity=velocities)
def test_commands_reproduce_the_wanted_velocity_of_the_point(
    pose: Pose2D, eps: float, velocity: tuple[float, float]
) -> None:
    u, omega = feedback_linearized(pose, velocity, eps)
    np.testing.assert_allclose(point_velocity(pose, u, omega, eps), velocity, atol=1e-9)


@given(pose=poses, eps=epsilons, velocity=velocities)
def test_point_moves_as_commanded_under_the_unicycle_kinematics(
    pose: Pose2D, eps: float, velocity: tuple[float, float]
) -> None:
    # integrate x' = u cos(theta), y' = u sin(theta), theta' = omega over a tiny step and watch P move
    x, y, yaw = pose.x, pose.y, pose.yaw
    u, omega = feedback_linearized(pose, velocity, eps)
    h = 1e-6
    moved = Pose2D(
        x + h * u * math.cos(yaw + h * omega / 2), y + h * u * math.sin(yaw + h * omega / 2), yaw + h * omega
    )
    observed = (point_ahead(moved, eps) - point_ahead(pose, eps)) / h
    np.testing.assert_allclose(observed, velocity, atol=1e-5 * (1 + abs(omega)))


arena = st.floats(-1.8, 1.8)


@given(pose=st.builds(Pose2D, arena, arena, angles), eps=epsilons, goal=st.tuples(arena, arena))
def test_absolute_and_relative_pose_forms_give_the_same_commands(
    pose: Pose2D, eps: float, goal: tuple[float, float]
) -> None:
    # The field evaluated at P in the world (absolute form) and the field built from the goal and obstacles
    # expressed in the robot frame, evaluated at P = (eps, 0) there (relative form, 2d).
    gx, gy = goal
    circles = np.array([[0.3, 0.2, 0.3], [-1.0, 1.0, 0.2]])
    world_field = PotentialField((gx, gy), Obstacles(circles=circles), v_max=8.0)
    absolute = feedback_linearized(pose, world_field.velocity(point_ahead(pose, eps))[0], eps)

    def in_robot_frame(px: float, py: float) -> tuple[float, float]:
        local = Pose2D(px, py).relative_to(pose)
        return local.x, local.y

    local_circles = np.array([(*in_robot_frame(cx, cy), r) for cx, cy, r in circles])
    robot_field = PotentialField(in_robot_frame(gx, gy), Obstacles(circles=local_circles), v_max=8.0)
    relative = feedback_linearized_relative(robot_field.velocity((eps, 0.0))[0], eps)
    np.testing.assert_allclose(relative, absolute, atol=1e-9)


def test_bad_inputs_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="epsilon"):
        feedback_linearized(Pose2D(0, 0, 0), (1.0, 0.0), 0.0)
    with pytest.raises(InvalidInputError, match="velocity"):
        feedback_linearized_relative((math.nan, 0.0), 0.1)
    with pytest.raises(InvalidInputError, match="non-finite"):
        Pose2D(math.inf, 0.0)
