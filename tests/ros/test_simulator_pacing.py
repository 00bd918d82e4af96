"""Simulator launches of their own (one /clock publisher at a time): pacing by ~real_time_factor, a bad world."""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.sim.lockstep import FREE_RUN_LOG
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


def test_lockstep_holds_the_sim_within_one_period_of_the_last_command_and_runs_free_without_one(
    ros_master: RosMaster, rospy_node: Any
) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import Twist
    from rosgraph_msgs.msg import Clock

    samples: list[float] = []  # sim time of each /clock message of this launch
    sub = rospy.Subscriber("/clock", Clock, lambda m: samples.append(m.clock.to_sec()), tcp_nodelay=True)
    cmd = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
    try:
        launch_args = ("real_time_factor:=0", "lockstep:=true")
        with ros_master.launch("simulation.launch", *launch_args, name="lockstep") as proc:
            wait_for(lambda: proc.poll() is not None or len(samples) > 10, 60.0, "/clock in lockstep")
            wait_for(lambda: cmd.get_num_connections() > 0, 20.0, "the simulator to subscribe /cmd_vel")
            # no controller yet: flat out
            free0 = samples[-1]
            time.sleep(1.0)
            assert samples[-1] - free0 > 3.0, "without a controller the simulation should run freely"
            # one command: the simulation stops one period (0.1 s) after it, for as long as no other comes
            turn = Twist()
            turn.angular.z = 0.2  # in place: a motion that cannot touch the arena
            cmd.publish(turn)
            time.sleep(0.25)
            held = samples[-1]
            time.sleep(0.3)  # still well inside the 1 s wall-clock silence timeout
            assert samples[-1] == held
            # the next command releases exactly one more period
            cmd.publish(turn)
            wait_for(lambda: samples[-1] > held, 5.0, "the next command to release the simulation")
            time.sleep(0.2)
            assert samples[-1] == pytest.approx(held + 0.1, abs=1e-6)
            # the controller falls silent mid-motion but stays connected (not gone): after the 1 s timeout one period
            # of grace (a rospy timer's tick can fall just past the horizon), then held
            time.sleep(2.0)
            assert samples[-1] == pytest.approx(held + 0.2, abs=1e-6)
            # a stop, then silence from a connected controller (a navigation node idle after its goal): the robot
            # stands still, so the simulation runs on after the 1 s timeout
            cmd.publish(Twist())
            wait_for(lambda: samples[-1] > held + 0.2, 5.0, "the stop to release the simulation")
            stopped = samples[-1]
            time.sleep(2.0)
            assert samples[-1] - stopped > 3.0, "a controller silent after a stop should not hold the simulation"
            # a motion locks it again; then the controller goes away (its connection closes): within the 1 s
            # timeout the simulation runs freely
            cmd.publish(turn)
            time.sleep(0.5)
            relocked = samples[-1]
            time.sleep(0.3)
            assert samples[-1] == relocked, "a motion command should lock the simulation again"
            cmd.unregister()
            released = samples[-1]
            time.sleep(2.0)
            assert samples[-1] - released > 3.0
        log = max(ros_master.log_dir.glob("lockstep-*.log"), key=lambda p: p.stat().st_mtime).read_text()
        assert log.count(FREE_RUN_LOG) == 1, "one warning for the one switch to free running on a motion"
        assert log.count("lockstep released while stopped") == 1
        assert re.search(rf"{FREE_RUN_LOG} [0-9.]+ s: no publisher on /cmd_vel and no command for [0-9.]+ s", log)
    finally:
        sub.unregister()
        cmd.unregister()


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
