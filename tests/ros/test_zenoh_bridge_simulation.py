"""The simulator watched from a machine without ROS: simulation + bridge, the monitor sees the robot drive."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

from mrs_nav.bridge.session import open_client_session
from tests.ros.zenoh_harness import Ticker, mrs_nav, start_bridge, wait_bridge_up
from tests.rosharness import RosMaster, free_port, wait_for

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def watched_simulation(
    ros_master: RosMaster, rospy_node: Any, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[str]:
    """The simulator in real time (its /odom at 50 Hz, /scan at 5 Hz) and a bridge; yields the endpoint."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        ros_master.launch("simulation.launch", "real_time_factor:=1", "x:=-1.5", "y:=-1.5", "yaw:=0") as sim,
        start_bridge(ros_master, tmp_path_factory.mktemp("sim"), "zb_sim", {"listen": [endpoint]}) as bridge,
    ):
        wait_for(lambda: sim.poll() is not None or rospy_node.get_time() > 0.5, 60, "/clock from the simulator")
        assert sim.poll() is None, "the simulation's roslaunch exited"
        session = open_client_session([endpoint])
        wait_bridge_up(session, bridge, "the bridge")
        session.close()
        yield endpoint


def test_the_monitor_sees_the_simulated_robot_drive(watched_simulation: str, rospy_node: Any) -> None:
    from geometry_msgs.msg import Twist

    def forward(_: int) -> Any:
        cmd = Twist()
        cmd.linear.x = 0.2
        return cmd

    with Ticker(rospy_node, "/cmd_vel", Twist, forward, 20.0):
        result = mrs_nav("monitor", "--connect", watched_simulation, "--once", "--duration", "3", "--json")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["speed"]["linear"] == pytest.approx(0.2, abs=0.05)  # wheel odometry, with its drift
    topics = summary["topics"]
    assert topics["/odom"]["type"] == "nav_msgs/Odometry"
    assert topics["/scan"]["rate_hz"] == pytest.approx(5.0, rel=0.2)
    assert topics["/odom"]["rate_hz"] == pytest.approx(50.0, rel=0.2)
    assert topics["/odom"]["latency_ms_p50"] < 20.0
    assert "/clock" not in topics  # denied by default
