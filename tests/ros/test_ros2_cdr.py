"""The ROS 2 bridge's CDR rewrite against rclpy's own serialiser (tests/ros/ros2_cdr_check.py in the ROS 2 venv):
Odometry, LaserScan, OccupancyGrid, TFMessage and the other bridged types, with empty and odd-length strings and
arrays so that every alignment case comes up. No ROS 2 node is made (nothing to discover: the domain set is never
used)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from mrs_nav.bridge.ros2_link import package_root
from tests.ros.ros2_harness import ROS2_PYTHON, needs_ros2, ros2_env

pytestmark = [pytest.mark.ros, needs_ros2]

CHECK = Path(__file__).with_name("ros2_cdr_check.py")
BRIDGED = {"nav_msgs/Odometry", "sensor_msgs/LaserScan", "nav_msgs/OccupancyGrid", "tf2_msgs/TFMessage"}


def test_the_rewritten_bytes_are_rclpys_for_every_message() -> None:
    env = ros2_env(0) | {"PYTHONPATH": str(package_root())}
    done = subprocess.run([str(ROS2_PYTHON), str(CHECK)], env=env, capture_output=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    results = [json.loads(line) for line in done.stdout.splitlines()]
    assert {r["type"] for r in results} >= BRIDGED
    assert len(results) >= 20
    for result in results:
        assert result["same_length"], result
        assert result["differ_where_not_padding"] == [], result
        assert result["reads_back"], result
