"""A goal sent from a machine without ROS, through the Zenoh bridge, drives the simulated robot, and only when
the bridge's configuration allows it: the potential-field follower waits for /move_base_simple/goal.

Without SLAM there is no ``map`` frame, so the open bridge's inbound rule names ``odom`` (the follower's frame,
which starts at the world origin) and the monitor sends the goal in it."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.bridge.session import open_client_session
from tests.ros.navharness import StatusLog, TruthTrack
from tests.ros.zenoh_harness import mrs_nav, start_bridge, wait_bridge_up
from tests.rosharness import RosMaster, free_port, wait_for

pytestmark = pytest.mark.ros

GOAL = (1.5, 1.5)


GOAL_IN_ODOM = {"topic": "/move_base_simple/goal", "type": "geometry_msgs/PoseStamped", "frame": "odom"}


def _bridge(ros_master: RosMaster, tmp: Path, name: str, **config: Any) -> tuple[Any, str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    return start_bridge(ros_master, tmp, name, {"listen": [endpoint], **config}), endpoint


def _send_goal(endpoint: str) -> Any:
    goal = f"{GOAL[0]},{GOAL[1]},0"
    return mrs_nav("monitor", "--connect", endpoint, "--send-goal", goal, "--frame", "odom", "--timeout", "5")


def test_a_remote_goal_drives_the_robot_only_when_allowed(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    rospy = rospy_node
    truth = TruthTrack(rospy, "simple.world")
    status = StatusLog(rospy, "/potential_field_navigation/status")
    try:
        with ros_master.launch(
            "potential_field_navigation.launch",
            # Max rate in lockstep, as the other node tests: at a fixed 10x real time a loaded machine let the
            # follower's commands fall behind sim time, and the robot once touched a wall on the way.
            "real_time_factor:=0",
            "lockstep:=true",
            "seed:=1",
            f"trajectory_file:={tmp_path / 'trajectory.txt'}",
        ) as nav:
            wait_for(lambda: nav.poll() is not None or truth.last() is not None, 60.0, "the simulated robot")
            assert nav.poll() is None, "roslaunch exited"

            closed, endpoint = _bridge(ros_master, tmp_path, "zb_closed")
            with closed as proc:
                session = open_client_session([endpoint])
                wait_bridge_up(session, proc, "the default bridge")
                session.close()
                refused = _send_goal(endpoint)
                assert refused.returncode == 1
                assert "inbound allow-list" in refused.stderr
                start = rospy.get_time()
                wait_for(lambda: rospy.get_time() > start + 5.0, 60.0, "5 s of sim time")
            _, x0, y0 = truth.last()
            assert math.hypot(x0 + 1.5, y0 + 1.5) < 0.02, "the robot moved without an allowed goal"

            opened, endpoint = _bridge(ros_master, tmp_path, "zb_open", inbound=[GOAL_IN_ODOM])
            with opened as proc:
                session = open_client_session([endpoint])
                wait_bridge_up(session, proc, "the bridge that allows goals")
                session.close()
                sent = _send_goal(endpoint)
                assert sent.returncode == 0, sent.stderr
                wait_for(lambda: nav.poll() is not None or status.has("reached"), 120.0, "the goal to be reached")
        _, x, y = truth.last()
        assert math.hypot(x - GOAL[0], y - GOAL[1]) <= 0.2
        assert truth.contacts == 0
    finally:
        truth.close()
        status.close()
