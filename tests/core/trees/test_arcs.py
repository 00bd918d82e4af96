"""Arc motion primitives: geometry (theta2 = 2 phi - theta1, centre, radius), sampling, forward-only, collisions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid
from mrs_nav.trees import arcs


def _open_grid() -> OccupancyGrid:
    return OccupancyGrid(np.zeros((80, 80), dtype=np.int8), 0.05, (-2.0, -2.0, 0.0))


def test_end_yaw_is_twice_the_chord_direction_minus_the_start_yaw() -> None:
    start = Pose2D(0.0, 0.0, 0.3)
    pose = arcs.adjust_pose(start, [1.0, 1.0], _open_grid())
    assert pose is not None
    assert (pose.x, pose.y) == (1.0, 1.0)
    assert pose.yaw == pytest.approx(2 * math.pi / 4 - 0.3)


def test_find_circle_is_tangent_at_the_start_and_passes_through_the_target() -> None:
    start = Pose2D(0.5, -0.2, 1.0)
    target = np.array([1.2, 0.9])
    centre, radius = arcs.find_circle(start, target)
    assert np.hypot(*(centre - start.position)) == pytest.approx(radius)
    assert np.hypot(*(centre - target)) == pytest.approx(radius)
    # the radius to the start is perpendicular to the heading
    assert np.dot(centre - start.position, [math.cos(1.0), math.sin(1.0)]) == pytest.approx(0.0, abs=1e-12)
    centre, radius = arcs.find_circle(Pose2D(0, 0, 0), [2.0, 0.0])
    assert radius == math.inf
    assert np.isnan(centre).all()


def test_samples_lie_on_the_circle_with_tangent_yaws_and_at_most_one_step_apart() -> None:
    start = Pose2D(0.0, 0.0, -0.4)
    target = np.array([1.0, 0.6])
    centre, radius = arcs.find_circle(start, target)
    batch = arcs.connect(start.position, start.yaw, target)
    poses, first = arcs.sample(batch, 0.05)
    assert first.tolist() == [0, len(poses)]
    assert np.allclose(np.hypot(*(poses[:, :2] - centre).T), radius)
    assert np.allclose(poses[0], [0.0, 0.0, -0.4])
    assert np.allclose(poses[-1, :2], target)
    steps = np.diff(poses[:, :2], axis=0)
    assert np.hypot(*steps.T).max() <= 0.05 + 1e-12
    # the chord between two samples points along the mean of their yaws
    assert np.allclose(np.arctan2(steps[:, 1], steps[:, 0]), (poses[:-1, 2] + poses[1:, 2]) / 2)
    assert batch.length[0] == pytest.approx(radius * abs(2 * batch.alpha[0]))


def test_straight_line_case() -> None:
    batch = arcs.connect([0.0, 0.0], 0.0, [[1.0, 0.0]])
    assert batch.curvature[0] == 0.0
    assert batch.length[0] == 1.0
    assert batch.end_yaw[0] == 0.0
    poses, _ = arcs.sample(batch, 0.3)
    assert np.allclose(poses[:, 1], 0.0)
    assert np.allclose(np.diff(poses[:, 0]), 0.25)


def test_forward_only_and_minimum_turning_radius() -> None:
    grid = _open_grid()
    assert arcs.adjust_pose(Pose2D(0, 0, 0), [-1.0, 0.1], grid) is None  # behind
    assert arcs.adjust_pose(Pose2D(0, 0, 0), [0.0, 1.0], grid) is None  # a half circle: not strictly ahead
    # chord 0.5 at 45 degrees off the heading: radius 0.5 / (2 sin 45) = 0.354 m
    assert arcs.adjust_pose(Pose2D(0, 0, 0), [0.3536, 0.3536], grid, min_turning_radius=0.3) is not None
    assert arcs.adjust_pose(Pose2D(0, 0, 0), [0.3536, 0.3536], grid, min_turning_radius=0.4) is None
    assert arcs.adjust_pose(Pose2D(0, 0, 0), [1.0, 1.0], grid, max_alpha=math.pi / 8) is None


def test_arcs_through_obstacles_are_rejected_even_when_the_ends_are_free() -> None:
    values = np.zeros((80, 80), dtype=np.int8)
    values[38:42, 38:42] = OCCUPIED  # a 0.2 m block at the centre
    grid = OccupancyGrid(values, 0.05, (-2.0, -2.0, 0.0))
    assert arcs.adjust_pose(Pose2D(-1.0, 0.0, 0.0), [1.0, 0.0], grid) is None
    assert arcs.adjust_pose(Pose2D(-1.0, 0.5, 0.0), [1.0, 0.5], grid) is not None


_ARENA = OccupancyGrid(np.zeros((40, 40), dtype=np.int8), 0.05, (-1.0, -1.0, 0.0))
_VALUES = _ARENA.values.copy()
_VALUES[15:25, 18:22] = OCCUPIED
_VALUES[5, 5:30] = OCCUPIED
_CLUTTER = OccupancyGrid(_VALUES, 0.05, (-1.0, -1.0, 0.0))

_coord = st.floats(-0.95, 0.95)


@settings(max_examples=500, deadline=None)
@given(_coord, _coord, st.floats(-math.pi, math.pi), _coord, _coord)
def test_an_arc_accepted_as_free_is_free_everywhere_at_one_centimetre(
    x1: float, y1: float, yaw: float, x2: float, y2: float
) -> None:
    batch = arcs.connect([x1, y1], yaw, [x2, y2])
    if not arcs.checked(batch, _CLUTTER)[0]:
        return
    dense, _ = arcs.sample(batch, 0.01)
    assert _CLUTTER.is_free(dense).all()


def test_arcs_hugging_an_obstacle_pass_the_fine_check_but_not_a_blocked_corner() -> None:
    values = np.zeros((40, 40), dtype=np.int8)
    values[20:, 20:] = OCCUPIED  # the quadrant x, y >= 0 of a grid from -1 to 1 m
    grid = OccupancyGrid(values, 0.05, (-1.0, -1.0, 0.0))
    # a straight line 1 cm below the blocked quadrant: its cells are free, their neighbours are not
    assert arcs.checked(arcs.connect([-0.9, -0.01], 0.0, [0.9, -0.01]), grid)[0]
    # a diagonal cutting 1 mm off the quadrant's corner: no sample lands in the blocked cell, the corner rule sees it
    cutting = arcs.connect([-0.5, 0.501], -math.pi / 4, [0.5, -0.499])
    assert grid.is_free(arcs.sample(cutting, 0.05 / 8)[0]).all()
    assert not arcs.checked(cutting, grid)[0]
    assert arcs.checked(arcs.connect([-0.5, 0.49], -math.pi / 4, [0.5, -0.51]), grid)[0]  # 1 cm clear
