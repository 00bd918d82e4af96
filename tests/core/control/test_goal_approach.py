"""The last centimetres to a goal pose: position within the xy tolerance, then the heading within the yaw one."""

from __future__ import annotations

import math

import pytest

from mrs_nav.control.goal_approach import ApproachConfig, GoalApproach
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle


def run(approach: GoalApproach, pose: Pose2D, dt: float = 0.1, steps: int = 600) -> tuple[Pose2D, int, float]:
    """Drive a unicycle with the approach until done; the final pose, the steps taken and the top speed."""
    top = 0.0
    for step in range(steps):
        cmd = approach.command(pose, step * dt)
        if cmd.done:
            return pose, step, top
        top = max(top, abs(cmd.u))
        yaw = pose.yaw + cmd.omega * dt
        pose = Pose2D(pose.x + cmd.u * dt * math.cos(pose.yaw), pose.y + cmd.u * dt * math.sin(pose.yaw), yaw)
    raise AssertionError(f"not done after {steps} steps, at {pose}")


@pytest.mark.parametrize(
    ("start", "goal_yaw"),
    [
        (Pose2D(-0.2, 0.05, 0.0), math.pi / 2),
        (Pose2D(0.25, 0.0, 0.0), -math.pi),  # goal behind: turn first, then drive
        (Pose2D(0.0, -0.2, 2.0), 0.3),
        (Pose2D(0.1, 0.1, -1.0), None),
    ],
)
def test_the_robot_ends_on_the_goal_within_both_tolerances(start: Pose2D, goal_yaw: float | None) -> None:
    cfg = ApproachConfig()
    pose, _, top = run(GoalApproach(0.0, 0.0, goal_yaw, cfg), start)
    assert math.hypot(pose.x, pose.y) <= cfg.xy_tolerance_m + 0.01  # the position is latched, then turning only
    if goal_yaw is not None:
        assert abs(wrap_angle(goal_yaw - pose.yaw)) <= cfg.yaw_tolerance_rad
    assert top <= cfg.max_linear


def test_it_slows_down_near_the_goal() -> None:
    approach = GoalApproach(0.0, 0.0, None)
    far = approach.command(Pose2D(-0.3, 0.0, 0.0), 0.0).u
    near = approach.command(Pose2D(-0.08, 0.0, 0.0), 0.1).u
    assert far > 2.0 * near > 0.0


def test_a_robot_already_on_the_goal_only_turns() -> None:
    approach = GoalApproach(1.0, 1.0, math.pi)
    cmd = approach.command(Pose2D(1.0, 1.0, 0.0), 0.0)
    assert cmd.u == 0.0
    assert cmd.omega != 0.0
    assert not cmd.done


def test_bad_tolerances_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="xy_tolerance_m"):
        ApproachConfig(xy_tolerance_m=0.0)
    with pytest.raises(InvalidInputError, match="below pi"):
        ApproachConfig(yaw_tolerance_rad=4.0)


def test_a_robot_still_spinning_inside_the_yaw_tolerance_is_not_done_yet() -> None:
    approach = GoalApproach(0.0, 0.0, 0.0)
    assert not approach.command(Pose2D(0.0, 0.0, -0.3), 0.0).done
    spinning = approach.command(Pose2D(0.0, 0.0, -0.1), 0.1)  # 2 rad/s through the tolerance band
    assert not spinning.done
    assert approach.command(Pose2D(0.0, 0.0, -0.09), 0.2).done  # settled
