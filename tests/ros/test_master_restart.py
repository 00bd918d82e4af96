"""A roscore stopped and started again on its port during a drive (mrs_nav.ros.master_watch): the running nodes
register again with the new master, and a goal sent afterwards by a new client is reached.

The test runs a roscore of its own (restarting the session's master would cut the pytest process's rospy off) and
talks to the robot through separate processes only, as a user's terminals would: ``python -m
tests.ros.move_base_goal`` as the move_base client, ``rostopic echo`` for the ground truth, ``rosnode list`` and
``rostopic info`` for what the new master knows.
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import AbstractContextManager
from pathlib import Path

import pytest
import yaml

from mrs_nav.ros_processes import process
from tests.rosharness import REPO, RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
START = (-1.5, -1.5)
FIRST_GOAL = (1.5, -1.5)  # along the arena's lower side
SECOND_GOAL = (1.5, 1.0)  # then up its right side, past the cylinder
TOLERANCE = 0.2  # m between the truth and a reached goal (the node's 0.05 m plus SLAM's and odometry's error)
COSTMAP = ("rostopic", "echo", "-n", "1", "--noarr", "/move_base/global_costmap/costmap")
# mrs_nav's nodes in the launch (robot_state_publisher, a C++ node of ROS's, registers only once: docs/ros.md)
NODES = ("/simulator", "/slam", "/rrt_navigation")


@pytest.fixture
def own_master(tmp_path: Path) -> Iterator[RosMaster]:
    master = RosMaster(tmp_path)
    try:
        yield master
    finally:
        master.close()


def _ros(master: RosMaster, *args: str, timeout: float = 20.0) -> str:
    """The output of a ROS command-line tool run against ``master`` ('' when it did not finish in time)."""
    try:
        done = subprocess.run(args, env=master.env, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return ""
    return done.stdout


def _truth(master: RosMaster) -> tuple[float, float] | None:
    """The robot's true position from one ``/ground_truth/odom`` message, None when none came."""
    out = _ros(master, "rostopic", "echo", "-n", "1", "/ground_truth/odom", timeout=15.0)
    if "position" not in out:
        return None
    position = yaml.safe_load(out.split("---")[0])["pose"]["pose"]["position"]
    return float(position["x"]), float(position["y"])


def _away_from(master: RosMaster, x: float, y: float) -> float:
    where = _truth(master)
    return 0.0 if where is None else math.hypot(where[0] - x, where[1] - y)


def _goal(master: RosMaster, goal: tuple[float, float], log: Path) -> AbstractContextManager[subprocess.Popen[bytes]]:
    command = [sys.executable, "-m", "tests.ros.move_base_goal", str(goal[0]), str(goal[1])]
    return process(command, {**master.env, "PYTHONPATH": f"{REPO}:{master.env['PYTHONPATH']}"}, log)


def _drive_and_restart(master: RosMaster, log: Path) -> None:
    """Send the first goal once rrt_navigation has the map, restart the master once the robot is on its way."""
    # a goal before rrt_navigation has SLAM's map is refused: wait for its costmap, which follows the map
    wait_for(lambda: "header" in _ros(master, *COSTMAP), 120.0, "rrt_navigation to have the map")
    with _goal(master, FIRST_GOAL, log):
        try:
            wait_for(lambda: _away_from(master, *START) > 0.3, 90.0, "the robot to set off towards the first goal")
        except AssertionError as err:
            err.add_note(f"the first goal's client: {log.read_text()!r}")
            raise
        master.restart()


def test_nodes_register_again_with_a_restarted_master_and_the_next_goal_is_reached(
    own_master: RosMaster, tmp_path: Path
) -> None:
    master = own_master
    launch = ("rrt_navigation.launch", "rviz:=false", *MAX_RATE, "seed:=5", f"x:={START[0]}", f"y:={START[1]}")
    with master.launch(*launch) as nav:
        _drive_and_restart(master, tmp_path / "first_goal.log")
        restarted = time.monotonic()
        assert nav.poll() is None, "roslaunch exited with the master"
        wait_for(
            lambda: set(NODES) <= set(_ros(master, "rosnode", "list").split()),
            30.0,
            f"{NODES} to register with the new master",
        )
        print(f"nodes listed by the new master {time.monotonic() - restarted:.1f} s after it answered")
        second_log = tmp_path / "second_goal.log"
        with _goal(master, SECOND_GOAL, second_log) as second:
            try:
                second.wait(timeout=120.0)
            except subprocess.TimeoutExpired:
                pytest.fail(f"the goal sent after the restart got no result: {second_log.read_text()!r}")
            assert second.returncode == 0, second_log.read_text()
        where = _truth(master)
        assert where is not None, "no ground truth from the restarted master's graph"
        assert math.hypot(where[0] - SECOND_GOAL[0], where[1] - SECOND_GOAL[1]) <= TOLERANCE, where
        scan = _ros(master, "rostopic", "info", "/scan")
        assert "/simulator" in scan.split("Subscribers:")[0], scan
        assert "/slam" in scan.split("Subscribers:")[1], scan
        status = _ros(master, "rostopic", "info", "/move_base/status")
        assert "/rrt_navigation" in status.split("Subscribers:")[0], status
        services = _ros(master, "rosservice", "list").split()
        assert "/move_base/make_plan" in services, services
        # the parameters the nodes own are back: the launch file's /use_sim_time and robot_description (kept by
        # the simulator) and each node's ~ parameters
        params = set(_ros(master, "rosparam", "list").split())
        owned = {
            "/use_sim_time",
            "/robot_description",
            "/simulator/world",
            "/slam/map_update_interval",
            "/rrt_navigation/planner",
        }
        assert owned <= params, sorted(params)
