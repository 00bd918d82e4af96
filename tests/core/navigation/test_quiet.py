"""QuietWatch: an input is stale after a few of its own periods (sim time), never sooner than its floor."""

from __future__ import annotations

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.navigation.quiet import QuietWatch


def test_a_5_hz_input_late_by_a_period_or_two_is_not_quiet_but_one_that_stops_is() -> None:
    watch = QuietWatch(floor_s=0.4, periods=4.0)
    t = 0.0
    for _ in range(30):
        t += 0.2
        watch.arrived(t)
    assert watch.timeout_s() == pytest.approx(0.8)
    assert not watch.quiet(t + 0.5)  # two scans late on a loaded machine: the fixed 0.4 s limit called it lost
    assert watch.quiet(t + 0.81)  # four periods without a scan: gone


def test_the_floor_holds_for_a_fast_input_and_before_the_period_is_known() -> None:
    watch = QuietWatch(floor_s=0.15, periods=4.0)
    assert watch.quiet(0.0)  # nothing yet
    watch.arrived(1.0)
    assert watch.timeout_s() == 0.15
    for k in range(1, 10):
        watch.arrived(1.0 + 0.02 * k)  # 50 Hz
    assert watch.timeout_s() == 0.15
    watch.arrived(0.5)  # a repeat or older stamp changes nothing
    assert watch.last == pytest.approx(1.18)
    assert watch.timeout_s(period=0.2) == pytest.approx(0.8)  # judged by the rate of what drives it
    assert not watch.quiet(1.18 + 0.5, period=0.2)
    watch.reset()
    assert watch.quiet(100.0)
    assert watch.timeout_s() == 0.15


def test_a_burst_of_late_arrivals_does_not_stretch_the_period() -> None:
    watch = QuietWatch(floor_s=0.0, periods=3.0)
    times = [0.2 * k for k in range(20)] + [3.8 + 1.5, 5.3 + 1.5]  # two long gaps among 19 normal intervals
    for t in times:
        watch.arrived(t)
    assert watch.timeout_s() == pytest.approx(0.6)


def test_periods_below_one_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="stale_periods"):
        QuietWatch(floor_s=0.1, periods=0.5)
