"""Path following (assignment 4c): the segment search, the velocity law and closed-loop tracking."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrs_nav.control.path_following import (
    FollowerConfig,
    PathFollower,
    cross_track_distance,
    get_velocity,
    locate_on_path,
    saturate,
)
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D

STRAIGHT = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])


def arc(cx: float, cy: float, radius: float, a0: float, a1: float, *, step: float = 0.05) -> np.ndarray:
    count = max(2, math.ceil(abs(a1 - a0) * radius / step) + 1)
    angles = np.linspace(a0, a1, count)
    return np.column_stack((cx + radius * np.cos(angles), cy + radius * np.sin(angles)))


def simulate(follower: PathFollower, pose: Pose2D, dt: float = 0.02, seconds: float = 60.0) -> tuple[np.ndarray, bool]:
    """Integrate a kinematic unicycle under the follower; returns the robot positions and whether it finished."""
    trace = [(pose.x, pose.y)]
    x, y, yaw = pose.x, pose.y, pose.yaw
    for _ in range(int(seconds / dt)):
        cmd = follower.command(Pose2D(x, y, yaw))
        if cmd.done:
            return np.array(trace), True
        assert abs(cmd.u) <= follower.config.max_linear + 1e-9
        assert abs(cmd.omega) <= follower.config.max_angular + 1e-9
        if abs(cmd.omega) > 1e-9:  # exact unicycle integration along an arc
            x += cmd.u / cmd.omega * (math.sin(yaw + cmd.omega * dt) - math.sin(yaw))
            y -= cmd.u / cmd.omega * (math.cos(yaw + cmd.omega * dt) - math.cos(yaw))
        else:
            x += cmd.u * dt * math.cos(yaw)
            y += cmd.u * dt * math.sin(yaw)
        yaw += cmd.omega * dt
        trace.append((x, y))
    return np.array(trace), False


def settled_error(trace: np.ndarray, path: np.ndarray, settle_m: float = 0.5) -> float:
    """Largest distance to the path of the robot positions after it has travelled ``settle_m``."""
    travelled = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(trace, axis=0).T))))
    after = trace[travelled >= settle_m]
    return max(cross_track_distance(p, path) for p in after)


def test_velocity_on_the_path_runs_along_it_at_the_nominal_speed() -> None:
    v = get_velocity([0.5, 0.0], STRAIGHT, speed=0.2)
    np.testing.assert_allclose(v, [0.2, 0.0], atol=1e-12)


def test_velocity_off_the_path_pulls_back_in_proportion_to_the_distance() -> None:
    above = get_velocity([1.5, 0.1], STRAIGHT, speed=0.2, gain=2.0)
    below = get_velocity([1.5, -0.05], STRAIGHT, speed=0.2, gain=2.0)
    np.testing.assert_allclose(above, [0.2, -0.2], atol=1e-12)
    np.testing.assert_allclose(below, [0.2, 0.1], atol=1e-12)


def test_segment_is_the_one_whose_end_projections_change_sign() -> None:
    corner = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    assert locate_on_path([0.4, 0.1], corner).segment == 0
    where = locate_on_path([0.9, 0.6], corner)
    assert where.segment == 1
    assert where.cross_track_m == pytest.approx(-0.1)  # the path lies to the right of the point
    assert where.along_m == pytest.approx(0.6)


def test_stops_within_the_tolerance_of_the_last_point_and_approaches_it_slowly() -> None:
    np.testing.assert_array_equal(get_velocity([2.97, 0.0], STRAIGHT, goal_tolerance=0.05), [0.0, 0.0])
    near = get_velocity([2.9, 0.0], STRAIGHT, speed=0.2, gain=2.0, goal_tolerance=0.05)
    assert near[0] > 0.0
    assert np.linalg.norm(near) == pytest.approx(0.2)  # 2.0 * 0.1 m
    past = get_velocity([3.2, 0.05], STRAIGHT, goal_tolerance=0.05)
    assert past[0] < 0.0  # beyond the end it comes back rather than running on


def test_bad_paths_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="non-empty"):
        get_velocity([0.0, 0.0], np.zeros((0, 2)))
    with pytest.raises(InvalidInputError, match="non-finite"):
        get_velocity([0.0, 0.0], [[0.0, 0.0], [math.nan, 1.0]])
    with pytest.raises(InvalidInputError, match="epsilon"):
        FollowerConfig(epsilon=0.0)


@given(st.floats(-5.0, 5.0), st.floats(-50.0, 50.0))
def test_saturation_keeps_the_ratio_and_the_limits(u: float, omega: float) -> None:
    su, so = saturate(u, omega, 0.22, 2.84)
    assert abs(su) <= 0.22 + 1e-12
    assert abs(so) <= 2.84 + 1e-12
    assert su * omega == pytest.approx(so * u, abs=1e-9)


def test_straight_path_from_an_offset_start_settles_below_3_cm() -> None:
    follower = PathFollower(STRAIGHT)
    trace, done = simulate(follower, Pose2D(0.0, 0.3, 0.6))
    assert done
    assert settled_error(trace, STRAIGHT) < 0.03
    assert math.hypot(*(trace[-1] - STRAIGHT[-1])) < 0.2


def test_curved_path_settles_below_3_cm() -> None:
    # an S: a quarter circle to the left then a half circle to the right, radius 0.5 m (RRT-like arcs)
    path = np.vstack((arc(0.0, 0.5, 0.5, -math.pi / 2, 0.0), arc(1.0, 0.5, 0.5, math.pi, 0.0)[1:], [[1.5, -0.5]]))
    follower = PathFollower(path)
    trace, done = simulate(follower, Pose2D(0.0, -0.1, 0.0))
    assert done
    assert settled_error(trace, path) < 0.03
    assert math.hypot(*(trace[-1] - path[-1])) < 0.2


@settings(max_examples=15, deadline=None)
@given(
    st.floats(0.4, 1.5),
    st.floats(-math.pi, math.pi),
    st.floats(-0.2, 0.2),
)
def test_circles_of_any_radius_are_tracked(radius: float, start_yaw_error: float, offset: float) -> None:
    path = arc(0.0, radius, radius, -math.pi / 2, math.pi / 2)
    follower = PathFollower(path)
    trace, done = simulate(follower, Pose2D(0.0, offset, start_yaw_error / 3.0))
    assert done
    assert settled_error(trace, path, settle_m=0.8) < 0.03


def test_the_follower_does_not_cut_across_to_a_later_part_of_a_u_turn() -> None:
    # out along y = 0, round, and back along y = 0.3; the start is nearer the return leg than the outbound one
    path = np.vstack((STRAIGHT[:3], arc(2.0, 0.15, 0.15, -math.pi / 2, math.pi / 2)[1:], [[0.0, 0.3]]))
    start = Pose2D(0.3, 0.17, 0.0)
    assert get_velocity([0.4, 0.17], path)[0] < 0.0  # the memoryless law would take the return leg
    trace, done = simulate(PathFollower(path), start)
    assert done
    assert trace[:, 0].max() > 1.95  # the follower went round the end of the U
