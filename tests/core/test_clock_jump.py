"""The one rule for a clock that jumps back (mrs_nav.clock_jump)."""

from __future__ import annotations

import pytest

from mrs_nav.clock_jump import ClockJump, ClockJumpDetector


def _detector(readings: list[float]) -> ClockJumpDetector:
    return ClockJumpDetector(iter(readings).__next__)


def test_a_clock_that_goes_on_or_stands_still_never_jumps() -> None:
    detector = _detector([0.0, 0.0, 0.01, 0.01, 5.0, 190.0])
    assert [detector.check() for _ in range(6)] == [None] * 6


def test_any_step_back_is_a_jump_reported_once_with_both_readings() -> None:
    detector = _detector([10.0, 20.0, 19.0, 19.5, 19.49, 200.0, 15.0])
    jumps = [detector.check() for _ in range(7)]
    assert jumps == [None, None, ClockJump(20.0, 19.0), None, ClockJump(19.5, 19.49), None, ClockJump(200.0, 15.0)]
    assert [jump.seconds for jump in jumps if jump is not None] == pytest.approx([1.0, 0.01, 185.0])
