"""NavigateToPose over ros2_bridge's pipe: the action's frames, Nav2's feedback numbers from move_base's poses,
and how actionlib's end states become a ROS 2 action's."""

from __future__ import annotations

import math

import pytest

from mrs_nav.bridge.ros2_action import (
    ERROR_NONE,
    ERROR_UNKNOWN,
    ActionFrame,
    Feedback,
    FeedbackTracker,
    GoalStatus,
    Kind,
    outcome,
)
from mrs_nav.errors import InvalidInputError

GOAL_ID = bytes(range(16))


def test_action_frames_round_trip_and_broken_ones_are_errors() -> None:
    for kind in Kind:
        frame = ActionFrame(kind, GOAL_ID, b"pose bytes")
        assert ActionFrame.decode(frame.encode()) == frame
    with pytest.raises(InvalidInputError, match="at least 17"):
        ActionFrame.decode(b"\x01short")
    with pytest.raises(InvalidInputError, match="unknown kind 9"):
        ActionFrame.decode(bytes([9]) + GOAL_ID)


def test_feedback_numbers_round_trip_with_the_pose_bytes() -> None:
    sent = Feedback(12.5, 3.25, 1.5, 2)
    numbers, pose = Feedback.decode(sent.encode(b"\x01\x02"))
    assert pose == b"\x01\x02"
    assert numbers == pytest.approx(sent)
    with pytest.raises(InvalidInputError, match="feedback"):
        Feedback.decode(b"\x00" * 5)


def test_feedback_has_nav2s_distance_time_and_time_remaining() -> None:
    tracker = FeedbackTracker(goal_x=3.0, goal_y=4.0, start=10.0)
    first = tracker.update(10.0, 0.0, 0.0)
    assert (first.navigation_time, first.distance_remaining, first.estimated_time_remaining) == (0.0, 5.0, 0.0)
    for k in range(1, 21):  # 0.2 m/s along the x axis, a pose every 0.1 s
        last = tracker.update(10.0 + 0.1 * k, 0.02 * k, 0.0)
    assert last.navigation_time == pytest.approx(2.0)
    assert last.distance_remaining == pytest.approx(math.hypot(3.0 - 0.4, 4.0))
    assert last.estimated_time_remaining == pytest.approx(last.distance_remaining / 0.2, rel=1e-6)
    standing = [tracker.update(12.0 + 0.1 * k, 0.4, 0.0) for k in range(1, 15)]
    assert standing[-1].estimated_time_remaining == 0.0  # no speed, no estimate (as Nav2)
    near = FeedbackTracker(0.05, 0.0, 0.0)
    near.update(0.0, -1.0, 0.0)
    assert near.update(1.0, 0.0, 0.0).estimated_time_remaining == 0.0  # within 0.1 m: none either


def test_actionlib_end_states_map_onto_a_ros2_actions() -> None:
    assert outcome(GoalStatus.SUCCEEDED, "goal reached", False) == outcome(GoalStatus.SUCCEEDED, "", True)
    assert outcome(GoalStatus.SUCCEEDED, "", False).state == "succeed"
    assert outcome(GoalStatus.SUCCEEDED, "", False).error_code == ERROR_NONE
    assert outcome(GoalStatus.PREEMPTED, "", True).state == "canceled"
    assert outcome(GoalStatus.RECALLED, "", True).state == "canceled"
    # preempted on ROS 1 (a newer goal, a ROS 1 client's cancel) without a ROS 2 cancel: aborted, as Nav2 does
    preempted = outcome(GoalStatus.PREEMPTED, "new goal", False)
    assert (preempted.state, preempted.error_code) == ("abort", ERROR_UNKNOWN)
    assert preempted.error_msg == "move_base: PREEMPTED: new goal"
    aborted = outcome(GoalStatus.ABORTED, "no path after 5 failed plans", False)
    assert (aborted.state, aborted.error_msg) == ("abort", "move_base: ABORTED: no path after 5 failed plans")
    assert outcome(GoalStatus.REJECTED, "", True).state == "abort"
    assert outcome(42, "", False).error_msg == "move_base: status 42"
