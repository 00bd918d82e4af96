"""bench soak: the windows compared, the flatness rule, when the clock jumps, and the verdict on the jumps."""

from __future__ import annotations

import pytest

from mrs_nav.bench.soak_ros import jumps_section, laps_from_json
from mrs_nav.bench.soak_rules import MIN_LAPS, Lap, Usage, growth, jump_offset, jumps_due, windows


def _lap(rss_mb: float, cpu_s: float, scans: float = 100.0, node: str = "/slam") -> Lap:
    return Lap({node: Usage(int(rss_mb * 1e6), cpu_s)}, scans, 4)


def test_the_warm_up_lap_is_in_neither_window_and_each_window_sums_its_laps() -> None:
    laps = [_lap(50.0, 99.0), *(_lap(100.0 + i, 1.0 + i) for i in range(MIN_LAPS - 1))]
    start, end = windows(laps)
    assert start.usage["/slam"] == Usage(int(102e6), 1.0 + 2.0 + 3.0)  # laps 2-4: RSS at the last, CPU summed
    assert start.scans == 300.0
    assert start.reached == 12
    assert end.usage["/slam"] == Usage(int(105e6), 4.0 + 5.0 + 6.0)


def test_too_few_laps_for_both_windows_are_refused() -> None:
    with pytest.raises(ValueError, match=f"at least {MIN_LAPS} laps"):
        windows([_lap(100.0, 1.0)] * (MIN_LAPS - 1))


def test_a_process_is_flat_up_to_ten_percent_growth_of_rss_and_of_cpu_per_scan() -> None:
    start = Lap({"a": Usage(100, 10.0), "b": Usage(100, 10.0), "c": Usage(100, 10.0)}, 1000.0, 12)
    # a: 9 % more RSS, 10 % more CPU over 10 % more scans; b: 11 % more RSS; c: 12 % more CPU per scan
    end = Lap({"a": Usage(109, 11.0), "b": Usage(111, 11.0), "c": Usage(100, 12.32)}, 1100.0, 12)
    grown = growth(start, end)
    assert grown["a"].rss == pytest.approx(0.09)
    assert grown["a"].cpu_per_scan == pytest.approx(0.0)
    assert grown["a"].flat
    assert grown["b"].rss == pytest.approx(0.11)
    assert not grown["b"].flat
    assert grown["c"].cpu_per_scan == pytest.approx(0.12)
    assert not grown["c"].flat


def test_less_cpu_per_scan_and_less_memory_are_flat() -> None:
    grown = growth(_lap(100.0, 10.0, scans=1000.0), _lap(90.0, 9.0, scans=1200.0))["/slam"]
    assert grown.flat
    assert grown.cpu_per_scan == pytest.approx(9.0 / 1200.0 / (10.0 / 1000.0) - 1.0)


def test_the_clock_jumps_every_interval_but_never_at_or_after_the_requested_end() -> None:
    assert [jumps_due(60.0 * m, 10.0, 60.0) for m in (0, 9.9, 10, 25, 50, 59.9, 60, 75)] == [0, 0, 1, 2, 5, 5, 5, 5]
    assert jumps_due(3.5 * 60.0, 1.0, 4.0) == 3
    assert jumps_due(600.0, 0.0, 60.0) == 0  # --clock-jump-every 0: none


def test_the_jumps_cycle_through_one_ten_and_185_seconds_back() -> None:
    # 1 s behind the simulator: back 1 s at once; 10 s and 185 s ahead: back by as much when the simulator resumes
    assert [jump_offset(i) for i in range(5)] == [-1.0, 10.0, 185.0, -1.0, 10.0]


def _jump(after: str = "SUCCEEDED", map_odom: int = 50) -> dict[str, object]:
    published = {"map->odom": map_odom, "/map": 3, "/cmd_vel": 80, "/amcl_pose": 0}
    return {"at_min": 1.0, "offset_s": -1.0, "goal": [1.5, 1.5], "first": "ABORTED", "after": after,
            "error_m": 0.04, "published": published}  # fmt: skip


def test_the_jumps_pass_only_when_every_scheduled_one_was_made_and_survived() -> None:
    assert jumps_section([_jump()] * 3, 4.0, 1.0)[1]
    assert not jumps_section([_jump()] * 2, 4.0, 1.0)[1]  # one missing
    assert not jumps_section([_jump(), _jump(after="ABORTED"), _jump()], 4.0, 1.0)[1]
    assert not jumps_section([_jump(), _jump(map_odom=0), _jump()], 4.0, 1.0)[1]  # SLAM went quiet
    text, ok = jumps_section([], 60.0, 0.0)
    assert ok
    assert "No clock jumps" in text


def test_the_peers_laps_become_laps_per_node() -> None:
    data = {"laps": [{"usage": {"/simulator": [2_000_000, 1.5]}, "scans": 400.0, "reached": 4, "wall_s": 20.0}]}
    (lap,) = laps_from_json(data)
    assert lap.usage["/simulator"] == Usage(2_000_000, 1.5)
    assert lap.cpu_per_scan_ms("/simulator") == pytest.approx(3.75)
