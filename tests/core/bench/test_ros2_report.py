"""``mrs-nav bench ros2``'s arithmetic: latency from stamps, loss, the verdict against the floor."""

from __future__ import annotations

import os

from mrs_nav.bench.ros2 import RATES, _latencies, _report, descendants


def test_latency_is_arrival_minus_stamp_and_a_missing_message_is_lost() -> None:
    sent = [1_000_000_000, 1_020_000_000, 1_040_000_000]
    got, lost = _latencies(sent, [[1_000_000_000, 1.0015], [1_040_000_000, 1.0425]])
    assert [round(v, 6) for v in got] == [1.5, 2.5]
    assert lost == 1


def _sent(offset: int) -> dict[str, list[int]]:
    return {t: [offset + k * 10_000_000 for k in range(int(rate))] for t, rate in RATES.items()}


def _arrivals(sent: dict[str, list[int]], delay_s: float, drop: int = 0) -> dict[str, list[list[float]]]:
    return {t: [[s, s * 1e-9 + delay_s] for s in stamps[drop:]] for t, stamps in sent.items()}


def test_the_verdict_needs_the_floor_ratio_and_no_reliable_loss() -> None:
    bridged, floor = _sent(10**18), _sent(2 * 10**18)
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
