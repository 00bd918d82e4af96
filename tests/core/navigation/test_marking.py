"""When scans may mark obstacles (navigation.marking): only while the localisation is confident."""

from __future__ import annotations

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
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
