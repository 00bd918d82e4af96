"""The TurtleBot3 tutorials' session, typed into real terminals (tmux) as the tutorials type it, with mrs_nav's
package and launch names in place of TurtleBot3's:

1. SLAM (turtlebot3 e-Manual, "SLAM"): ``roslaunch mrs_nav simulation.launch`` (turtlebot3_world.launch),
   ``roslaunch mrs_nav slam.launch sim:=false slam_methods:=gmapping`` (turtlebot3_slam.launch), ``rosrun mrs_nav
   teleop_keyboard`` (turtlebot3_teleop_key.launch) driven by keys, ``rosrun mrs_nav map_saver -f ~/map``.
2. Navigation ("Navigation"): ``roslaunch mrs_nav navigation.launch map_file:=$HOME/map.yaml``, a 2D Pose
   Estimate (``rostopic pub`` to /initialpose), a 2D Nav Goal (``rostopic pub`` to /move_base_simple/goal), the ROS
   wiki's SimpleActionClient (navigation/Tutorials/SendingSimpleGoals) with a ``base_link`` goal, and one cancelled.
3. ``rosbag record`` of the navigation session, then ``rosbag play --clock`` of it into ``slam.launch sim:=false``.

Where a command is not typed exactly as the tutorials do, why:
- ``rosrun map_server map_saver``: Debian 12 has no map_server package; mrs_nav's ``map_saver`` takes the same
  arguments, so the package name is the only change (as for the launch files' package).
- ``open_rviz:=false`` everywhere: the test machine has no display (rviz is tested elsewhere).
- Extra arguments for a bounded run: ``real_time_factor:=3`` while mapping by hand (keys are typed in wall time;
  flat out, a second of typing would be a minute of driving), and ``real_time_factor:=0 lockstep:=true`` for
  navigation (the navigation's commands pace the simulator), and so ``rosbag play --clock -r 10``: until the
  navigation node commands, the simulator runs freely, and the bag starts with the robot standing for 45 to 120 s
  of sim time under load (measured on 14 of this test's bags), for minutes on a quiet machine. Played at the
  recorded rate, SLAM saw only that first view for the whole wait (CI: no map with the walls after 120 s).
- The 2D Pose Estimate and 2D Nav Goal are rviz clicks in the tutorial; here the messages rviz sends, with
  ``rostopic pub``.
- The wiki's action client is C++; the same steps in rospy, with the goal's distance as an argument.
"""

from __future__ import annotations

import math
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.ros.test_teleop_keyboard import Terminal
from tests.rosharness import RosMaster, wait_for

pytestmark = [
    pytest.mark.ros,
    pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux (tools/install.sh installs it)"),
]

START = (-1.5, -1.5)  # the launch files' default start in the course arena
NAV_GOAL = (0.4, -1.3)  # south of the cylinder at (0.3, 0.2)
FORWARD = 0.6  # m ahead in base_link: from NAV_GOAL facing +x, clear of the east wall (x = 2.0)

ACTION_CLIENT = '''\
#!/usr/bin/env python3
"""The ROS wiki's simple navigation goal: DISTANCE m ahead of the robot (frame base_link); "cancel" cancels it."""
import sys

import actionlib
import rospy
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal

rospy.init_node("simple_navigation_goals")
client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
client.wait_for_server()
goal = MoveBaseGoal()
goal.target_pose.header.frame_id = "base_link"
goal.target_pose.header.stamp = rospy.Time.now()
goal.target_pose.pose.position.x = float(sys.argv[1])
goal.target_pose.pose.orientation.w = 1.0
client.send_goal(goal)
if sys.argv[2:] == ["cancel"]:
    rospy.sleep(1.0)
    client.cancel_goal()
client.wait_for_result()
print("RESULT", client.get_state(), client.get_goal_status_text())
'''


class Shell(Terminal):
    """A terminal whose commands each print ``EXIT <n> <code>`` when they end."""

    def __init__(self, env: dict[str, str]) -> None:
        super().__init__(env)
        self._count = 0

    def run(self, command: str) -> str:
        """Type ``command``; returns the marker its end prints."""
        self._count += 1
        marker = f"EXIT {self._count}"
        self.type(f"{command}; echo {marker} $?", "Enter")
        return marker

    def wait(self, text: str, timeout: float, what: str) -> None:
        try:
            wait_for(lambda: text in self.screen(), timeout, what)
        except AssertionError as err:  # the screen as it is when the wait gives up, not as it was when it began
            err.add_note(f"screen: {self.screen()[-1200:]}")
            raise

    def interrupt(self, marker: str, timeout: float = 60.0) -> None:
        """Ctrl-C the running command and wait for its end."""
        self.type("C-c")
        self.wait(f"{marker} ", timeout, "the command's end after Ctrl-C")


class Truth:
    """The latest true pose of the robot (/ground_truth/odom)."""

    def __init__(self, rospy: Any) -> None:
        from nav_msgs.msg import Odometry

        self.lock = threading.Lock()
        self.pose: tuple[float, float] | None = None
        self.sub = rospy.Subscriber("/ground_truth/odom", Odometry, self._on, queue_size=1)

    def _on(self, msg: Any) -> None:
        with self.lock:
            self.pose = (msg.pose.pose.position.x, msg.pose.pose.position.y)


@pytest.fixture
def shells(ros_master: RosMaster, tmp_path: Path) -> Iterator[list[Shell]]:
    """Four terminals, as the tutorials open, with HOME in the test's folder (``~/map``)."""
    env = {**ros_master.env, "HOME": str(tmp_path)}
    opened: list[Shell] = []
    try:
        opened.extend(Shell(env) for _ in range(4))
        yield opened
    finally:
        for shell in opened:
            shell.close()


def _map_by_hand(sim: Shell, slam: Shell, teleop: Shell, saver: Shell, home: Path) -> None:
    """SLAM with keyboard teleop, then map_saver: returns once ~/map.yaml is written and all three are stopped."""
    sim_end = sim.run("roslaunch mrs_nav simulation.launch real_time_factor:=3")
    slam_end = slam.run("roslaunch mrs_nav slam.launch sim:=false slam_methods:=gmapping open_rviz:=false")
    slam.wait("slam: resolution", 120.0, "SLAM started")
    teleop_end = teleop.run("rosrun mrs_nav teleop_keyboard")
    teleop.wait("Control Your TurtleBot3!", 60.0, "the teleop's help")
    teleop.type(*"a" * 10)  # 1.0 rad/s: a turn on the spot shows the arena all round
    time.sleep(3.0)  # wall time of typing: about 9 s of sim time at real_time_factor 3, more than a full turn
    teleop.type("s")
    teleop.wait("angular vel 0.0", 10.0, "the stop")
    teleop.type("q")
    teleop.wait(f"{teleop_end} ", 30.0, "the teleop's end")
    saved = saver.run("rosrun mrs_nav map_saver -f ~/map")
    saver.wait(f"{saved} 0", 60.0, "map_saver")
    assert (home / "map.yaml").exists()
    assert (home / "map.pgm").exists()
    slam.interrupt(slam_end)
    sim.interrupt(sim_end)


def _goal_status(rospy: Any) -> tuple[Any, list[int]]:
    from move_base_msgs.msg import MoveBaseActionResult

    results: list[int] = []
    sub = rospy.Subscriber("/move_base/result", MoveBaseActionResult, lambda m: results.append(m.status.status))
    return sub, results


def _navigate(nav: Shell, client: Shell, shell: Shell, rospy: Any, home: Path) -> str:
    """navigation.launch on the saved map, a 2D Pose Estimate, a 2D Nav Goal, the wiki's action client; returns
    the running navigation.launch's end marker."""
    truth = Truth(rospy)
    result_sub, results = _goal_status(rospy)
    nav_end = nav.run(
        "roslaunch mrs_nav navigation.launch map_file:=$HOME/map.yaml open_rviz:=false real_time_factor:=0 "
        "lockstep:=true"
    )
    try:
        nav.wait("the move_base action is up", 180.0, "the navigation node")
        cov = [0.0] * 36
        cov[0], cov[7], cov[35] = 0.25, 0.25, 0.06853891945200942
        estimate = (
            "rostopic pub -1 /initialpose geometry_msgs/PoseWithCovarianceStamped "
            f"'{{header: {{frame_id: map}}, pose: {{pose: {{position: {{x: {START[0]}, y: {START[1]}}}, "
            f"orientation: {{w: 1.0}}}}, covariance: {cov}}}}}'"
        )
        shell.wait(shell.run(estimate) + " 0", 60.0, "the 2D Pose Estimate published")
        goal = (
            "rostopic pub -1 /move_base_simple/goal geometry_msgs/PoseStamped "
            f"'{{header: {{frame_id: map}}, pose: {{position: {{x: {NAV_GOAL[0]}, y: {NAV_GOAL[1]}}}, "
            "orientation: {w: 1.0}}}'"
        )
        shell.wait(shell.run(goal) + " 0", 60.0, "the 2D Nav Goal published")
        wait_for(lambda: bool(results), 120.0, "the 2D Nav Goal's result")
        assert results == [3], results  # SUCCEEDED
        with truth.lock:
            assert truth.pose is not None
            before = truth.pose
        assert math.dist(before, NAV_GOAL) < 0.25, before
        (home / "simple_goal.py").write_text(ACTION_CLIENT, encoding="utf-8")
        client.wait(client.run(f"python3 ~/simple_goal.py {FORWARD}") + " 0", 120.0, "the base_link goal")
        assert "RESULT 3" in client.screen()  # SUCCEEDED
        with truth.lock:
            after = truth.pose
        assert after is not None
        assert abs(math.dist(before, after) - FORWARD) < 0.15, (before, after)
        assert after[0] > before[0] + FORWARD - 0.15  # ahead: the robot faced +x at the nav goal
        client.wait(client.run("python3 ~/simple_goal.py -1.0 cancel") + " 0", 120.0, "the cancelled goal")
        assert "RESULT 2" in client.screen()  # PREEMPTED
    finally:
        truth.sub.unregister()
        result_sub.unregister()
    return nav_end


def test_the_turtlebot3_tutorial_typed_end_to_end(
    ros_master: RosMaster, rospy_node: Any, shells: list[Shell], tmp_path: Path
) -> None:
    rospy = rospy_node
    from nav_msgs.msg import OccupancyGrid

    first, second, third, fourth = shells
    started = time.monotonic()
    _map_by_hand(first, second, third, fourth, tmp_path)
    recording = fourth.run("rosbag record -O ~/session /scan /tf /tf_static /odom")
    nav_end = _navigate(first, second, third, rospy, tmp_path)
    fourth.interrupt(recording)
    first.interrupt(nav_end)
    assert (tmp_path / "session.bag").stat().st_size > 10_000
    maps: list[Any] = []
    sub = rospy.Subscriber("/map", OccupancyGrid, maps.append, queue_size=1)
    try:
        slam_end = first.run("roslaunch mrs_nav slam.launch sim:=false open_rviz:=false")
        first.wait("slam: resolution", 120.0, "SLAM started")
        play_end = second.run("rosbag play --clock -r 10 ~/session.bag")
        try:
            wait_for(lambda: any(sum(v == 100 for v in m.data) > 200 for m in maps), 120.0, "a map from the played bag")
        except AssertionError as err:  # what rosbag play and SLAM show then (seen once in CI: no map, no warning)
            err.add_note(f"maps received: {len(maps)}")
            err.add_note(f"rosbag play's terminal: {second.screen()[-800:]}")
            err.add_note(f"SLAM's terminal: {first.screen()[-800:]}")
            raise
        second.interrupt(play_end)
        first.interrupt(slam_end)
    finally:
        sub.unregister()
    assert time.monotonic() - started < 240.0, f"the tutorial took {time.monotonic() - started:.0f} s"
