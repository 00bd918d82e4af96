"""``mrs-nav bench ros2``'s arithmetic: latency from stamps, loss, the verdict against the floor."""

from __future__ import annotations

import argparse
import os

import pytest

from mrs_nav.bench.pacing import LEAD_S, phase_option, start_on_grid
from mrs_nav.bench.ros2 import FLOOR_PHASE_S, RATES, _latencies, _report, chain_gap_s, descendants


def test_latency_is_arrival_minus_stamp_and_a_missing_message_is_lost() -> None:
    sent = [1_000_000_000, 1_020_000_000, 1_040_000_000]
    got, lost = _latencies(sent, [[1_000_000_000, 1.0015], [1_040_000_000, 1.0425]])
    assert [round(v, 6) for v in got] == [1.5, 2.5]
    assert lost == 1


def _sent(offset: int) -> dict[str, list[int]]:
    return {t: [offset + round(k * 1e9 / rate) for k in range(int(rate))] for t, rate in RATES.items()}


def _arrivals(sent: dict[str, list[int]], delay_s: float, drop: int = 0) -> dict[str, list[list[float]]]:
    return {t: [[s, s * 1e-9 + delay_s] for s in stamps[drop:]] for t, stamps in sent.items()}


def test_the_verdict_needs_the_floor_ratio_and_no_reliable_loss() -> None:
    bridged, floor = _sent(10**18), _sent(10**18 + 10_000_000)
    samples = [(0.0, 100.0, 0.0), (0.5, 100.0, 0.2), (1.0, 100.0, 0.4)]
    fine = _report(
        bridged, floor, {"bridged": _arrivals(bridged, 0.0012), "floor": _arrivals(floor, 0.001)}, samples, 1
    )
    assert "**meets**" in fine
    messages = sum(len(v) for v in bridged.values())
    ros1, ros2 = round(0.4 / messages * 1e6), round(0.6 / messages * 1e6)
    assert f"ROS 1 half {ros1}, ROS 2 half {ros2}" in fine  # the CPU of each half per message
    slow = _report(bridged, floor, {"bridged": _arrivals(bridged, 0.002), "floor": _arrivals(floor, 0.001)}, samples, 1)
    assert "**MISSES**" in slow
    lossy = _report(
        bridged, floor, {"bridged": _arrivals(bridged, 0.001, drop=1), "floor": _arrivals(floor, 0.001)}, samples, 1
    )
    assert "Loss on the reliable topics (/odom, /map): 2." in lossy
    assert "**MISSES**" in lossy


def test_descendants_include_the_process_itself() -> None:
    assert descendants(os.getpid())[0] == os.getpid()


def test_a_start_on_the_grid_is_its_phase_past_a_whole_second_and_far_enough_ahead() -> None:
    for now in (0.0, 12.3, 12.95, 99.999):
        for phase in (0.0, FLOOR_PHASE_S):
            start = start_on_grid(phase, now)
            assert now + LEAD_S <= start < now + LEAD_S + 1.0
            assert abs((start - phase) - round(start - phase)) < 1e-9
    # two processes asking at different times keep the phase apart on the 50 Hz grid
    a, b = start_on_grid(0.0, 5.01), start_on_grid(FLOOR_PHASE_S, 5.73)
    assert abs((b - a) % (1 / RATES["/odom"]) - FLOOR_PHASE_S) < 1e-9


@pytest.mark.parametrize("text", ["nan", "-0.01", "1.5", "inf", "ten"])
def test_a_phase_that_is_not_a_finite_part_of_a_second_is_refused(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        phase_option(text)


def test_chains_sent_at_the_same_instants_are_not_a_valid_comparison() -> None:
    bridged = _sent(10**18)
    assert abs(chain_gap_s(bridged["/odom"], _sent(10**18 + 10_000_000)["/odom"]) - 0.01) < 1e-9
    late = _sent(10**18 + 19_000_000)["/odom"]  # 1 ms before the next one, and one message 6 ms late
    late[3] += 6_000_000
    assert abs(chain_gap_s(bridged["/odom"], late) - 0.001) < 1e-4
    met = _sent(2 * 10**18)  # a whole number of /odom periods apart
    samples = [(0.0, 100.0, 0.0), (1.0, 100.0, 0.4)]
    report = _report(bridged, met, {"bridged": _arrivals(bridged, 0.0012), "floor": _arrivals(met, 0.001)}, samples, 1)
    assert "**NOT VALID (the two chains sent within 4 ms of each other)**" in report
