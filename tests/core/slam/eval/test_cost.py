"""The cost along a log (issue 40): growth from the first tenth of the scans to the last, tail, area mapped."""

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.eval.cost import (
    GROWTH_LINE,
    bytes_per_m2,
    cost_along,
    cost_failures,
    mapped_area_m2,
)
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.scan import LaserScanData, split_beams
from mrs_nav.slam.slam import Slam
from tests.core.slam.synthetic import cast


def test_a_last_tenth_twice_the_first_reports_two_and_fails():
    ms = [4.0] * 90 + [8.0] * 10
    cost = cost_along(ms)
    assert cost.scans == 100
    assert cost.first_median_ms == 4.0
    assert cost.last_median_ms == 8.0
    assert cost.growth == pytest.approx(2.0)
    assert not cost.flat


def test_a_flat_series_with_rare_spikes_passes_both_lines():
    rng = np.random.default_rng(3)
    ms = 5.0 + rng.uniform(-0.5, 0.5, 1000)
    ms[::50] = 40.0  # a closure every 50 scans: 2 % of them, above the 95th percentile's reach
    cost = cost_along(ms.tolist())
    assert cost.growth == pytest.approx(1.0, abs=0.1)
    assert cost.flat
    assert cost.tail < 1.2
    assert cost.tail_bounded


def test_spikes_in_more_than_five_percent_of_scans_break_the_tail_line():
    cost = cost_along([5.0 if i % 10 else 20.0 for i in range(100)])  # every tenth scan four times the median
    assert cost.median_ms == 5.0
    assert cost.p95_ms == pytest.approx(20.0)
    assert cost.tail == pytest.approx(4.0)
    assert not cost.tail_bounded
    assert not cost_along([5.0] * 90 + [20.0] * 10).flat  # the same spikes all at the end are growth too


def test_the_growth_line_is_inclusive_and_short_series_take_one_scan_a_share():
    assert cost_along([5.0] * 9 + [5.0 * GROWTH_LINE] * 1).flat
    cost = cost_along([2.0, 3.0, 6.0])
    assert (cost.first_median_ms, cost.last_median_ms, cost.growth) == (2.0, 6.0, 3.0)


def test_a_zero_first_tenth_is_infinite_growth():
    assert math.isinf(cost_along([0.0] * 10 + [1.0] * 90).growth)


@pytest.mark.parametrize(
    ("ms", "share", "match"),
    [
        ([], 0.1, "no processed scans"),
        ([1.0, math.nan], 0.1, "finite"),
        ([1.0, -1.0], 0.1, ">= 0"),
        ([1.0], 0.6, "share"),
    ],
)
def test_bad_input_is_refused(ms, share, match):
    with pytest.raises(InvalidInputError, match=match):
        cost_along(ms, share)


def test_the_area_mapped_is_the_cells_a_scan_observed():
    grid = LogOddsGrid(0.05, (-1.0, -1.0, 1.0, 1.0))
    assert mapped_area_m2(grid) == 0.0
    # One beam straight ahead, 1 m: 20 cells crossed (19 free and the end point's cell), 0.05 m wide each.
    scan = LaserScanData(0.0, 0.1, 0.0, 10.0, np.array([1.0 - 0.025]))
    grid.integrate(Pose2D(0.0125, 0.0125, 0.0), split_beams(scan, 10.0))
    assert mapped_area_m2(grid) == pytest.approx(20 * 0.05**2)
    lo = grid.dense()[0]
    assert mapped_area_m2(grid) == pytest.approx(np.count_nonzero(lo) * 0.05**2)


def test_bytes_per_square_metre():
    assert bytes_per_m2(1000.0, 4.0) == 250.0
    assert math.isnan(bytes_per_m2(1000.0, 0.0))


def test_the_failures_name_each_line_broken():
    assert cost_failures(cost_along([5.0] * 100), 200.0) == []
    grown = cost_along([4.0] * 90 + [8.0] * 10)
    assert cost_failures(grown) == ["last/first tenth 2.00 > 1.2"]  # p95 8 ms is 2x the median 4 ms
    assert cost_failures(grown, 600.0) == ["last/first tenth 2.00 > 1.2", "peak RSS 600 MB > 500 MB"]
    spiky = cost_along([5.0 if i % 10 else 20.0 for i in range(100)])
    assert cost_failures(spiky) == ["p95/median 4.00 > 3.0"]


def test_what_the_slam_holds_follows_the_area_not_the_time():
    slam = Slam(SlamConfig(temporalUpdate=1.0))
    held = []
    for lap in range(6):  # back and forth over the same metre of the room, a scan a second
        for k in range(5):
            x = 0.25 * (k if lap % 2 == 0 else 4 - k)
            pose = Pose2D(-2.0 + x, 0.0, 0.0)
            slam.add_scan(pose, cast(pose), stamp=float(lap * 5 + k))
        held.append(slam.held_bytes)
    assert held[0] >= slam.grid.nbytes > 0
    # After the first laps filled the place's nodes and the scans kept beside them, it holds no more
    assert held[-1] == held[2]
    area = mapped_area_m2(slam.grid)
    assert 10.0 < area < 60.0  # of the 10 m x 6 m room, what 3.5 m beams from a metre of it see
    assert bytes_per_m2(held[-1], area) < 50_000
