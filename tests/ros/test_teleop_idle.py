"""Teleoperation beside an idle rrt_navigation node (simulator in real time, no lockstep): the node leaves
/cmd_vel alone while it has no goal, so the robot drives at the commanded speed."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pytest

from tests.ros.navharness import TruthTrack
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

SPEED = 0.15  # m/s, commanded


def test_teleop_speed_is_not_fought_by_the_idle_navigation_node(ros_master: RosMaster, rospy_node: Any) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import Twist

    truth = TruthTrack(rospy, "simple.world")
    with (
        ros_master.launch("simulation.launch", "x:=-1.5", "y:=-1.5", "yaw:=0") as sim,
        ros_master.launch("rrt_navigation.launch", "slam:=false") as nav,
    ):
        wait_for(lambda: truth.last() is not None, 60.0, "ground truth from the simulator")
        wait_for(
            lambda: rospy.get_published_topics() and _has_publisher(rospy, "/rrt_navigation/status"), 60.0, "the node"
        )
        teleop = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
        wait_for(lambda: teleop.get_num_connections() > 0, 30.0, "the simulator's cmd_vel")
        stop = threading.Event()

        def drive() -> None:
            command = Twist()
            command.linear.x = SPEED
            while not stop.wait(0.05):  # 20 Hz of wall time, as a teleop keyboard node
                teleop.publish(command)

        driver = threading.Thread(target=drive, daemon=True)
        driver.start()
        t0 = rospy.get_time()
        wait_for(lambda: rospy.get_time() > t0 + 4.0, 30.0, "4 s of teleoperation")
        stop.set()
        driver.join()
        teleop.unregister()
        assert sim.poll() is None
        assert nav.poll() is None
    samples = truth.since(t0 + 1.0)  # past the acceleration
    samples = samples[samples[:, 0] <= t0 + 4.0]
    truth.close()
    distance = np.hypot(*np.diff(samples[:, 1:], axis=0).T).sum()
    speed = distance / (samples[-1, 0] - samples[0, 0])
    assert abs(speed - SPEED) <= 0.05 * SPEED, speed


def _has_publisher(rospy: Any, topic: str) -> bool:
    return any(name == topic for name, _ in rospy.get_published_topics())
