"""Two robots on ROS 2: `multi_robot.launch robots:=2 ros2:=true` puts a ros2_bridge in each robot's namespace,
and plain rclpy processes (no mrs_nav), one per namespace, see each robot under /tb3_i/ and send one of them a
NavigateToPose goal: that robot drives there (ground truth), the other stays where it is."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest

from tests.ros.navharness import TruthTrack
from tests.ros.ros2_harness import Ros2Peer, high_domain, needs_ros2
from tests.rosharness import RosMaster, wait_for

pytestmark = [pytest.mark.ros, needs_ros2]

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
# test_multi_robot's start poses in the office's east core room, both facing north
STARTS = {"tb3_0": (1.0, -3.0, math.pi / 2.0), "tb3_1": (3.0, -1.0, math.pi / 2.0)}
GOAL = (3.0, 0.5)  # for tb3_1, 1.5 m ahead of it
STATUS_SUCCEEDED = 4  # action_msgs/GoalStatus


def test_each_robot_is_under_its_namespace_on_ros2_and_takes_its_own_goal(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    rospy = rospy_node
    domain = high_domain()
    truths = {name: TruthTrack(rospy, "office.world", name) for name in STARTS}
    poses = [f"pose{i}:={x} {y} {yaw}" for i, (x, y, yaw) in enumerate(STARTS.values())]
    peers: dict[str, Ros2Peer] = {}
    try:
        with ros_master.launch(
            "multi_robot.launch", "robots:=2", *poses, *MAX_RATE, "rviz:=false", "planner_seed:=5", "ros2:=true",
            f"ros2_domain_id:={domain}", "ros2_allow_inbound:=[/navigate_to_pose]",
        ) as proc:  # fmt: skip
            peers = {name: Ros2Peer(domain, tmp_path / f"{name}.log", namespace=name) for name in STARTS}
            wanted = ("odom", "scan", "map", "/tf")
            for name, peer in peers.items():
                wait_for(
                    lambda p=peer: proc.poll() is not None or all(t in p.last for t in wanted),  # type: ignore[misc]
                    120.0,
                    f"{name}'s topics on ROS 2 (has {list(peer.last)})",
                )
                assert proc.poll() is None, "roslaunch exited"
                odom = peer.last["odom"]
                assert (odom["frame"], odom["child"]) == (f"{name}/odom", f"{name}/base_footprint")
                assert peer.last["scan"]["beams"] == 360
                assert peer.last["map"]["frame"] == "map"

            # one /tf for both robots, each bridge sending its own robot's transforms
            def pairs() -> set[tuple[str, ...]]:
                lines = [line for line in list(peers["tb3_0"].lines) if line.get("topic") == "/tf"]
                return {tuple(pair) for line in lines for pair in line["pairs"]}

            both = {("tb3_0/odom", "tb3_0/base_footprint"), ("tb3_1/odom", "tb3_1/base_footprint")}
            wait_for(lambda: both <= pairs(), 30.0, "both robots' odometry on /tf")
            wait_for(lambda: all(t.last() is not None for t in truths.values()), 30.0, "ground truth")
            _navigate(peers["tb3_1"], truths)
    finally:
        for peer in peers.values():
            peer.close()
        for track in truths.values():
            track.close()


def _navigate(peer: Ros2Peer, truths: dict[str, TruthTrack]) -> None:
    """A NavigateToPose goal on /tb3_1/navigate_to_pose moves tb3_1 there and leaves tb3_0 where it was."""

    def server_ready() -> bool:
        peer.send("server")
        time.sleep(0.2)
        return any(line.get("server") for line in list(peer.lines))

    wait_for(server_ready, 60.0, "tb3_1's navigate_to_pose action server")
    still = truths["tb3_0"].last()
    peer.send(f"navigate short {GOAL[0]} {GOAL[1]}")

    def result() -> list[dict[str, Any]]:
        return [line for line in list(peer.lines) if line.get("action") == "short" and "status" in line]

    wait_for(result, 240.0, "tb3_1's NavigateToPose result")
    assert result()[0]["status"] == STATUS_SUCCEEDED, result()
    end = truths["tb3_1"].last()
    assert math.hypot(end[1] - GOAL[0], end[2] - GOAL[1]) <= 0.3  # SLAM's error on top of the 0.05 m tolerance
    other = truths["tb3_0"].last()
    assert math.hypot(other[1] - still[1], other[2] - still[2]) < 0.05
