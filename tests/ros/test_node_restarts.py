"""SLAM and the navigation killed with SIGKILL mid-drive and started again by hand, as a user at a terminal does:
the whole stack (rrt_navigation.launch with SLAM, max rate, lockstep), a goal, ``kill -9`` of ``/slam`` and then of
``/rrt_navigation`` while the robot drives, ``rosrun mrs_nav slam`` and ``rosrun mrs_nav rrt_navigation`` under the
same names (their parameters are still on the master, as roslaunch set them). The robot stops with the
navigation gone, the launch goes on, and the next goal is reached at the truth without touching anything.

A restarted SLAM begins a new map with map->odom at identity, which is where the first one began (the simulator's
odometry starts at the robot's start), so goals in the map frame keep meaning the same place.
"""

from __future__ import annotations

import math
import os
import signal
import sys
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.ros_processes import process
from tests.ros.navharness import StatusLog, TruthTrack
from tests.rosharness import REPO, RosMaster, node_pid, wait_for

pytestmark = pytest.mark.ros

START = (-1.5, -1.5)
FIRST_GOAL = (1.5, -1.5)  # along the arena's lower side: the robot is driving when the nodes are killed
NEXT_GOAL = (1.5, 1.5)
REACHED_WITHIN = 0.2  # m, the truth from the goal


def _goal(x: float, y: float) -> Any:
    from geometry_msgs.msg import PoseStamped

    goal = PoseStamped()
    goal.header.frame_id = "map"
    goal.pose.position.x, goal.pose.position.y = x, y
    goal.pose.orientation.w = 1.0
    return goal


def _moved_from(truth: TruthTrack, x: float, y: float) -> float:
    last = truth.last()
    return 0.0 if last is None else math.hypot(last[1] - x, last[2] - y)


def _send_until_taken(goal_pub: Any, status: StatusLog, goal: tuple[float, float]) -> int:
    """Publish ``goal`` once a second until the navigation says it is active (the simulator listens on the topic
    too, so a connection does not mean the navigation's); the index in ``status`` before it."""
    heard = len(status.messages)

    def taken() -> bool:
        goal_pub.publish(_goal(*goal))
        return any(m.startswith("active:") for m in status.messages[heard:])

    wait_for(taken, 120.0, f"the navigation to take the goal {goal}", period=1.0)
    return heard


def _restart(master: RosMaster, node: str, script: str, log: Path) -> Any:
    os.kill(node_pid(master, f"/{node}"), signal.SIGKILL)
    return process([sys.executable, str(REPO / "scripts" / script), f"__name:={node}"], master.env, log)


def test_slam_and_navigation_killed_mid_drive_and_started_again_reach_the_next_goal(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import PoseStamped

    truth = TruthTrack(rospy, "simple.world")
    status = StatusLog(rospy, "/rrt_navigation/status")
    # Not latched: a restarted navigation must not pick up the goal it was driving to before.
    goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1)
    launch = ("real_time_factor:=0", "lockstep:=true", "seed:=5", "rviz:=false", "x:=-1.5", "y:=-1.5")
    try:
        with ros_master.launch("rrt_navigation.launch", *launch) as proc:
            wait_for(lambda: proc.poll() is not None or rospy.get_time() > 2.0, 120.0, "2 s of sim time")
            _send_until_taken(goal_pub, status, FIRST_GOAL)
            wait_for(lambda: _moved_from(truth, *START) > 0.3, 60.0, "the robot to set off")
            with _restart(ros_master, "slam", "slam", tmp_path / "slam.log"):
                # the navigation holds while map->odom is stale and drives on with the new SLAM's
                wait_for(lambda: _moved_from(truth, *START) > 0.8, 120.0, "the robot driving on with the new SLAM")
                with _restart(ros_master, "rrt_navigation", "rrt_navigation", tmp_path / "nav.log"):
                    killed_at = truth.last()
                    assert killed_at is not None
                    # with its command source gone, the simulator's watchdog stops the robot
                    wait_for(lambda: truth.since(killed_at[0] + 1.0).size > 0, 60.0, "1 s of sim time")
                    settled = truth.last()
                    assert settled is not None
                    wait_for(lambda: truth.since(settled[0] + 1.0).size > 0, 60.0, "1 more s of sim time")
                    assert _moved_from(truth, settled[1], settled[2]) < 0.01, "the robot drives with no navigation"
                    heard = _send_until_taken(goal_pub, status, NEXT_GOAL)
                    wait_for(
                        lambda: any(m.startswith(("reached:", "failed:")) for m in status.messages[heard:]),
                        120.0,
                        "the goal after the restarts to end",
                    )
                    assert proc.poll() is None, "roslaunch ended when its nodes were killed"
    finally:
        goal_pub.unregister()
        status.close()
        truth.close()
    assert any(m.startswith("reached:") for m in status.messages[heard:]), status.messages
    last = truth.last()
    assert last is not None
    error = math.hypot(last[1] - NEXT_GOAL[0], last[2] - NEXT_GOAL[1])
    assert error <= REACHED_WITHIN, f"reached by the estimate but {error:.2f} m from the goal in truth"
    assert truth.contacts == 0, f"{truth.contacts} contacts"
