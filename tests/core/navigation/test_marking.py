"""When scans may mark obstacles (navigation.marking): only while the localisation is confident."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.navigation.marking import MarkingConfig, MarkingGate

SURE = np.diag([0.01, 0.01, 0.01])  # 0.1 m, 0.1 rad
RVIZ = np.diag([0.25, 0.25, 0.0685])  # rviz's 2D Pose Estimate: 0.5 m, 0.26 rad


def test_without_a_localisation_report_every_scan_marks() -> None:
    assert MarkingGate().may_mark(0.0)


def test_scans_mark_only_while_the_localisation_is_confident() -> None:
    gate = MarkingGate(MarkingConfig(max_xy_stddev_m=0.2, max_yaw_stddev_rad=0.2, settle_s=0.5))
    gate.report(1.0, RVIZ)
    assert not gate.may_mark(1.1)
    gate.report(2.0, SURE)
    assert not gate.may_mark(1.9)  # placed before the localisation was sure
    assert not gate.may_mark(2.4)  # placed partly by the correction before
    assert gate.may_mark(2.5)
    gate.report(3.0, SURE)
    assert gate.may_mark(2.6)  # the same confident spell
    gate.report(4.0, np.diag([0.01, 0.01, 0.09]))  # 0.3 rad: the heading is not sure
    assert not gate.may_mark(4.1)


def test_the_worst_axis_of_the_position_counts() -> None:
    gate = MarkingGate(MarkingConfig(max_xy_stddev_m=0.2))
    stretched = np.array([[0.025, 0.024, 0.0], [0.024, 0.025, 0.0], [0.0, 0.0, 0.001]])  # 0.22 m along x = y
    assert not gate.confident(stretched)
    assert gate.confident(np.diag([0.03, 0.03, 0.001]))
    assert not gate.confident(np.full((3, 3), np.nan))


def test_a_new_initial_pose_stops_marking_until_a_confident_report_after_it() -> None:
    gate = MarkingGate()
    gate.report(1.0, SURE)
    gate.reset(5.0)
    assert not gate.may_mark(5.5)
    gate.report(4.9, SURE)  # computed before the reset, from the old belief
    assert not gate.may_mark(5.5)
    gate.report(5.2, RVIZ)
    assert not gate.may_mark(5.5)
    gate.report(6.0, SURE)
    assert gate.may_mark(6.0 + gate.config.settle_s)


def test_a_reset_without_any_report_before_it_also_stops_marking() -> None:
    gate = MarkingGate()
    gate.reset(1.0)
    assert not gate.may_mark(2.0)


def test_bounds_must_be_positive() -> None:
    with pytest.raises(InvalidInputError, match="max_xy_stddev_m"):
        MarkingConfig(max_xy_stddev_m=0.0)


def test_doubt_says_why_the_pose_is_not_trusted() -> None:
    gate = MarkingGate()
    assert gate.doubt() is None  # no localisation reports (SLAM)
    gate.reset(1.0)
    assert "not reported a confident pose since the last initial pose" in (gate.doubt() or "")
    gate.report(2.0, RVIZ)
    assert "1 sigma 0.50 m, 0.26 rad" in (gate.doubt() or "")
    gate.report(3.0, SURE)
    assert gate.doubt() is None


def test_a_scan_marks_only_once_tf_places_it_by_the_confident_estimate() -> None:
    """The localisation reports the right pose at 6 s but tf still carries its old map->odom (1 m and 30 deg off)
    until its update has finished: scans placed by the old correction do not mark, however late they come."""
    gate = MarkingGate()
    odom = Pose2D(0.5, -0.2, 0.1)  # the robot stands still here in the odometry frame
    right = Pose2D(-5.5, -4.8, -0.1)  # map -> odom of the right pose
    wrong = Pose2D(-4.5, -4.8, -0.1 + math.pi / 6.0)
    gate.reset(5.0)
    gate.report(6.0, SURE, right)
    late = 6.0 + gate.config.settle_s + 5.0
    assert not gate.may_mark(late, wrong, odom)
    assert gate.may_mark(late, right, odom)
    nudged = Pose2D(right.x + 0.03, right.y, right.yaw + 0.01)  # the next update's small correction
    assert gate.may_mark(late, nudged, odom)
    assert not gate.may_mark(late, Pose2D(right.x, right.y, right.yaw + 0.1), odom)  # 0.1 rad off
    gate.report(7.0, SURE)  # a report whose correction is not known: the settle time alone
    assert gate.may_mark(late, wrong, odom)


def test_tf_gap_bounds_must_be_positive() -> None:
    with pytest.raises(InvalidInputError, match="max_tf_gap_m"):
        MarkingConfig(max_tf_gap_m=-1.0)


def test_a_report_stamped_before_the_reset_was_heard_of_counts_only_at_the_pose_given() -> None:
    """The pose is given stamped 5.0 and heard of at 5.3; the localisation took it at once and, the robot standing
    still, sends one report, stamped 5.1: it counts only if it lies at the pose given, not where the old belief
    was."""
    given = Pose2D(-5.0, -5.0, 0.0)
    gate = MarkingGate()
    gate.report(4.0, SURE, pose=Pose2D(-4.0, -5.0, math.pi / 6.0))
    gate.reset(5.3, given, 5.0)
    gate.report(5.1, SURE, pose=Pose2D(-4.0, -5.0, math.pi / 6.0))  # the old belief
    assert not gate.may_mark(9.0)
    gate.report(4.9, SURE, pose=Pose2D(-5.03, -5.05, 0.01))  # before the pose's own stamp
    assert not gate.may_mark(9.0)
    gate.report(5.1, SURE, pose=Pose2D(-5.03, -5.05, 0.01))
    assert gate.may_mark(5.1 + gate.config.settle_s)


def test_after_a_jump_back_in_time_the_next_confident_report_counts_again() -> None:
    """A 2D Pose Estimate at sim time 100 s, then a bag played again from 0 s: every report of the new time line
    lies before the reset. Without forgetting the old stamps, marking would stay off for good."""
    gate = MarkingGate(MarkingConfig(settle_s=0.5))
    gate.reset(100.0, Pose2D(1.0, 1.0, 0.0), 99.5)
    gate.forget_time()
    assert not gate.may_mark(5.0)  # no confident report on the new time line yet
    gate.report(5.0, SURE, pose=Pose2D(-3.0, 2.0, 1.0))  # far from the pose given on the old time line
    assert not gate.may_mark(5.4)
    assert gate.may_mark(5.5)


def test_without_a_localisation_a_jump_back_keeps_every_scan_marking() -> None:
    gate = MarkingGate()
    gate.forget_time()
    assert gate.may_mark(0.0)
