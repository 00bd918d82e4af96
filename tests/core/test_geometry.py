"""Pose2D: transforming point sets agrees with composing poses, and undoes the inverse."""

import math

import numpy as np
import pytest

from mrs_nav.geometry import Pose2D


@pytest.mark.parametrize("pose", [Pose2D(0.0, 0.0, 0.0), Pose2D(1.5, -2.0, 0.7), Pose2D(-3.0, 4.0, -2.9)])
def test_apply_maps_points_as_compose_maps_positions(pose: Pose2D) -> None:
    points = np.random.default_rng(3).uniform(-5.0, 5.0, (50, 2))
    composed = np.array([[q.x, q.y] for q in (pose.compose(Pose2D(x, y)) for x, y in points)])
    np.testing.assert_allclose(pose.apply(points), composed, atol=1e-12)
    np.testing.assert_allclose(pose.inverse().apply(pose.apply(points)), points, atol=1e-12)


def test_apply_turns_the_x_axis_by_the_yaw() -> None:
    moved = Pose2D(1.0, 2.0, math.pi / 2).apply(np.array([[1.0, 0.0], [0.0, 0.0]]))
    np.testing.assert_allclose(moved, [[1.0, 3.0], [1.0, 2.0]], atol=1e-12)
