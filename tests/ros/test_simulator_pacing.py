"""Simulator launches of their own (one /clock publisher at a time): pacing by ~real_time_factor, a bad world."""

from __future__ import annotations

import re
import time
from pathlib import Path
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
        # a bare world name is one of the package's worlds
        launch_args = ("world:=office", "x:=-5", "y:=-5", "real_time_factor:=2")
        with ros_master.launch("simulation.launch", *launch_args, name="paced") as proc:
            wait_for(lambda: proc.poll() is not None or len(samples) > 10, 60.0, "/clock at rtf 2")
            first = len(samples)
            time.sleep(3.0)
            (wall0, sim0), (wall1, sim1) = samples[first], samples[-1]
    finally:
        sub.unregister()
    assert (sim1 - sim0) / (wall1 - wall0) == pytest.approx(2.0, rel=0.1)


def test_a_bad_world_ends_the_launch_with_one_clear_line(ros_master: RosMaster, tmp_path: Path) -> None:
    bad = tmp_path / "ball.world"
    bad.write_text(
        '<sdf version="1.6"><world name="w"><model name="ball"><static>true</static><link name="l">'
        '<collision name="c"><geometry><sphere><radius>1</radius></sphere></geometry></collision>'
        "</link></model></world></sdf>"
    )
    with ros_master.launch("simulation.launch", f"world:={bad}", name="bad_world") as proc:
        wait_for(lambda: proc.poll() is not None, 60.0, "roslaunch to end (the simulator is required)")
    log = max(ros_master.log_dir.glob("bad_world-*.log"), key=lambda p: p.stat().st_mtime).read_text()
    assert re.search(r"simulator: .*ball\.world: <model\[ball\]/link\[l\]/collision\[c\]/geometry/sphere>", log)
    assert "Traceback" not in log
