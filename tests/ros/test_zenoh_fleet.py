"""A fleet over Zenoh: one bridge per robot namespace (tb3_0, tb3_1, tb3_2) on a real master, each a client of
one Zenoh router; ``mrs-nav monitor --fleet`` (ROS imports blocked) finds all three behind the router, shows
each robot's own odometry, draws one snapshot, and sends a goal to the robot it names and no other."""

from __future__ import annotations

import contextlib
import json
import math
from pathlib import Path
from typing import Any

import pytest

from tests.ros.zenoh_harness import Router, Ticker, mrs_nav, start_bridge
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

ROBOTS = ("tb3_0", "tb3_1", "tb3_2")
GOAL = "/move_base_simple/goal"


def test_monitor_finds_every_robot_behind_the_router_and_commands_the_one_it_names(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Odometry

    rospy = rospy_node
    goals: dict[str, list[Any]] = {name: [] for name in ROBOTS}

    def odom(index: int) -> Any:
        def make(_: int) -> Any:
            msg = Odometry()
            msg.header.frame_id, msg.child_frame_id = f"{ROBOTS[index]}/odom", f"{ROBOTS[index]}/base_footprint"
            msg.pose.pose.position.x, msg.pose.pose.orientation.w = float(index), 1.0
            return msg

        return make

    with contextlib.ExitStack() as stack:
        router = Router()
        router.start()
        stack.callback(router.kill)
        for name in ROBOTS:
            sub = rospy.Subscriber(f"/{name}{GOAL}", PoseStamped, goals[name].append, queue_size=10)
            stack.callback(sub.unregister)
            config = {
                "mode": "client",
                "listen": [],
                "connect": [router.endpoint],
                "namespace": name,
                "inbound": [{"topic": GOAL, "type": "geometry_msgs/PoseStamped", "frame": "map"}],
            }
            stack.enter_context(start_bridge(ros_master, tmp_path, f"bridge_{name}", config))
        for i, name in enumerate(ROBOTS):
            stack.enter_context(Ticker(rospy, f"/{name}/odom", Odometry, odom(i), 20.0))

        snapshot = tmp_path / "fleet.png"
        connect = ("--connect", router.endpoint, "--mode", "client", "--timeout", "10")
        result = mrs_nav("monitor", *connect, "--fleet", "--once", "--duration", "3", "--json", "--snapshot",
                         str(snapshot))  # fmt: skip
        assert result.returncode == 0, result.stderr
        robots = json.loads(result.stdout)["robots"]
        assert sorted(robots) == list(ROBOTS)
        for i, name in enumerate(ROBOTS):
            # Each robot's own odometry under its own name: /odom, not /tb3_i/odom, and nobody else's.
            assert robots[name]["pose"]["x"] == pytest.approx(float(i)), name
            assert list(robots[name]["topics"]) == ["/odom"], name
            assert robots[name]["topics"]["/odom"]["rate_hz"] > 5.0
        assert snapshot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

        ambiguous = mrs_nav("monitor", *connect, "--fleet", "--send-goal", "1,2,0")
        assert ambiguous.returncode == 1
        assert "add --robot NAME (tb3_0, tb3_1, tb3_2)" in ambiguous.stderr

        sent = mrs_nav("monitor", *connect, "--fleet", "--robot", "tb3_1", "--send-goal", "1.5,-2,0")
        assert sent.returncode == 0, sent.stderr
        assert "sent to mrs_nav/tb3_1" in sent.stdout
        wait_for(lambda: bool(goals["tb3_1"]), 15, "the goal on /tb3_1/move_base_simple/goal")
        goal = goals["tb3_1"][0]
        assert (goal.pose.position.x, goal.pose.position.y, goal.header.frame_id) == (1.5, -2.0, "map")
        assert not goals["tb3_0"]
        assert not goals["tb3_2"]

        unknown = mrs_nav("monitor", *connect, "--fleet", "--robot", "tb3_9", "--send-goal", "1,2,0")
        assert unknown.returncode == 1
        assert unknown.stderr.strip() == "ERROR: robot 'tb3_9' is not in the fleet (found: tb3_0, tb3_1, tb3_2)"


def test_multi_robot_launch_with_a_router_is_one_fleet(ros_master: RosMaster, rospy_node: Any) -> None:
    """``multi_robot.launch robots:=2 zenoh_router:=...``: a bridge per robot; the monitor finds both robots with
    their own pose and map, and a goal sent to tb3_1 reaches tb3_1's navigation and no other."""
    from nav_msgs.msg import OccupancyGrid
    from std_msgs.msg import String

    rospy = rospy_node
    statuses: dict[str, list[str]] = {"tb3_0": [], "tb3_1": []}
    with contextlib.ExitStack() as stack:
        router = Router()
        router.start()
        stack.callback(router.kill)
        for name, log in statuses.items():
            sub = rospy.Subscriber(f"/{name}/rrt_navigation/status", String, lambda m, log=log: log.append(m.data))
            stack.callback(sub.unregister)
        args = ("robots:=2", "rviz:=false", "real_time_factor:=0", "lockstep:=true", "allow_goal:=true")
        proc = stack.enter_context(ros_master.launch("multi_robot.launch", *args, f"zenoh_router:={router.endpoint}"))
        maps: list[Any] = []
        sub = rospy.Subscriber("/tb3_1/map", OccupancyGrid, maps.append, queue_size=1)
        stack.callback(sub.unregister)
        wait_for(lambda: proc.poll() is not None or bool(maps), 90.0, "tb3_1's first map")
        assert proc.poll() is None, "roslaunch exited"

        connect = ("--connect", router.endpoint, "--mode", "client", "--timeout", "10")
        result = mrs_nav("monitor", *connect, "--fleet", "--once", "--duration", "3", "--json")
        assert result.returncode == 0, result.stderr
        robots = json.loads(result.stdout)["robots"]
        assert sorted(robots) == ["tb3_0", "tb3_1"]
        # multi_robot.launch's default starts; each robot's odometry starts at its true pose
        for name, (x, y) in (("tb3_0", (-5.0, -5.0)), ("tb3_1", (5.0, -5.0))):
            pose = robots[name]["pose"]
            assert math.hypot(pose["x"] - x, pose["y"] - y) < 0.3, (name, pose)
            assert robots[name]["map"] is not None, name

        sent = mrs_nav("monitor", *connect, "--fleet", "--robot", "tb3_1", "--send-goal", "4,-5,3.14")
        assert sent.returncode == 0, sent.stderr
        wait_for(
            lambda: any("goal (4.00, -5.00" in s for s in statuses["tb3_1"]), 30, "tb3_1's navigation taking the goal"
        )
        assert not any("goal (4.00, -5.00" in s for s in statuses["tb3_0"])
