"""The simulator node paces sim time by ~real_time_factor (its own module: one /clock publisher at a time)."""

from __future__ import annotations

import time
from typing import Any

import pytest

from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros


def test_real_time_factor_paces_sim_time_against_the_wall_clock(ros_master: RosMaster, rospy_node: Any) -> None:
    rospy = rospy_node
    from rosgraph_msgs.msg import Clock

    samples: list[tuple[float, float]] = []  # (wall, sim) per /clock message of this launch
    sub = rospy.Subscriber("/clock", Clock, lambda m: samples.append((time.monotonic(), m.clock.to_sec())))
    try:
        with ros_master.launch("simulation.launch", "real_time_factor:=2", name="paced") as proc:
            wait_for(lambda: proc.poll() is not None or len(samples) > 10, 60.0, "/clock at rtf 2")
            first = len(samples)
            time.sleep(3.0)
            (wall0, sim0), (wall1, sim1) = samples[first], samples[-1]
    finally:
        sub.unregister()
    assert (sim1 - sim0) / (wall1 - wall0) == pytest.approx(2.0, rel=0.1)
