"""Sim time going back under running nodes (mrs_nav.ros.clock_jump): during a drive, and between two plays of a
bag. Every node keeps publishing (map -> odom, /map, /amcl_pose, /cmd_vel) and the next goal is reached.

The jumps are made deterministic by :class:`mrs_nav.ros.clock_jumper.ClockJumper` (the simulator paused around one
/clock message from this process): an offset of -1 s is a jump back by 1 s, one of 10 s or 185 s a jump back by
10 s or 185 s when the simulator resumes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.ros.clock_jumper import Activity, ClockJumper
from tests.ros.navharness import StatusLog, TruthTrack
from tests.ros.test_live_replay import BAGS, _sensor_bag, live_slam, play_bag
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
GOAL = (1.5, -1.5)  # across the arena's lower side from the start at (-1.5, -1.5)


@dataclass(frozen=True)
class Stack:
    """A launch to drive under: its arguments, the navigation node (whose ``~status`` is read), the frame of its
    goals, and what it publishes that must go on after a jump besides a moving ``/cmd_vel``."""

    launch: tuple[str, ...]
    node: str
    frame: str
    published: tuple[str, ...]


SLAM = Stack(("rrt_navigation.launch", "rviz:=false"), "rrt_navigation", "map", ("map->odom", "/map"))
AMCL = Stack(("navigation.launch", "rviz:=false"), "rrt_navigation", "map", ("map->odom", "/amcl_pose"))
FIELD = Stack(("potential_field_navigation.launch", "trajectory_file:=none"), "potential_field_navigation", "odom", ())


@contextmanager
def _subscribers(rospy: Any, stack: Stack) -> Iterator[tuple[Activity, StatusLog, TruthTrack, ClockJumper, Any]]:
    from geometry_msgs.msg import PoseStamped

    activity = Activity()
    status = StatusLog(rospy, f"/{stack.node}/status")
    truth = TruthTrack(rospy, "simple.world")
    jumper = ClockJumper()
    goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
    try:
        yield activity, status, truth, jumper, goal_pub
    finally:
        goal_pub.unregister()
        for closing in (activity, status, truth, jumper):
            closing.close()


def _send_goal(pub: Any, frame: str, x: float, y: float) -> None:
    from geometry_msgs.msg import PoseStamped

    goal = PoseStamped()
    goal.header.frame_id = frame
    goal.pose.position.x, goal.pose.position.y = x, y
    goal.pose.orientation.w = 1.0
    pub.publish(goal)


def _moved_from(truth: TruthTrack, x: float, y: float) -> float:
    last = truth.last()
    return 0.0 if last is None else math.hypot(last[1] - x, last[2] - y)


@pytest.mark.parametrize(
    ("stack", "offset_s"),
    [
        pytest.param(SLAM, -1.0, id="slam-back-1s"),
        pytest.param(SLAM, 10.0, id="slam-back-10s"),
        pytest.param(SLAM, 185.0, id="slam-back-185s"),
        pytest.param(AMCL, 185.0, id="amcl-back-185s"),
        pytest.param(FIELD, 185.0, id="field-back-185s"),
    ],
)
def test_a_clock_jump_during_a_drive_stops_no_node_and_the_next_goal_is_reached(
    ros_master: RosMaster, rospy_node: Any, stack: Stack, offset_s: float
) -> None:
    rospy = rospy_node
    with (
        _subscribers(rospy, stack) as (activity, status, truth, jumper, goal_pub),
        ros_master.launch(*stack.launch, *MAX_RATE, "seed:=5", "x:=-1.5", "y:=-1.5") as proc,
    ):
        wait_for(
            lambda: (
                proc.poll() is not None
                or (goal_pub.get_num_connections() > 0 and all(activity.since(0.0)[w] for w in stack.published))
            ),
            60.0,
            f"the navigation node and {stack.published}",
        )
        assert proc.poll() is None, "roslaunch exited"
        ready = rospy.get_time()
        wait_for(lambda: rospy.get_time() > ready + 2.0, 30.0, "the navigation node to have the map too")
        _send_goal(goal_pub, stack.frame, *GOAL)
        wait_for(lambda: _moved_from(truth, -1.5, -1.5) > 0.3, 60.0, "the robot to set off")
        before = len(status.messages)
        resumed = jumper.jump(offset_s)
        # The goal ends: aborted when the clock goes back (185 s ahead, it may have run out of time before that).
        wait_for(lambda: any(m.startswith("failed:") for m in status.messages[before:]), 30.0, "the goal aborted")
        if offset_s < 0.0:
            assert any("sim time went back" in m for m in status.messages[before:]), status.messages
        heard = len(status.messages)
        _send_goal(goal_pub, stack.frame, *GOAL)
        wait_for(
            lambda: any(m.startswith(("reached:", "failed:")) for m in status.messages[heard:]),
            120.0,
            f"the goal sent after the jump to be reached (status so far: {status.messages})",
        )
        assert any(m.startswith("reached:") for m in status.messages[heard:]), status.messages
        _, x, y = truth.last()
        assert math.hypot(x - GOAL[0], y - GOAL[1]) <= 0.2
        after = activity.since(resumed)
        assert all(after[what] > 0 for what in (*stack.published, "/cmd_vel")), after


def test_a_bag_played_twice_into_slam_gets_map_to_odom_both_times(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    bag = tmp_path / "sensors.bag"
    _sensor_bag(BAGS / "simple.bag", bag)
    seconds = 12.0  # of the bag per play, at 4x
    activity = Activity()
    try:
        with live_slam(ros_master):
            counts = []
            for _ in range(2):
                began = time.monotonic()
                play_bag(ros_master, bag, "-r", "4", "-u", str(seconds))
                counts.append(activity.since(began))
    finally:
        activity.close()
    # At 20 Hz over 12 s of sim time: some 240 broadcasts a play (a loaded machine drops some).
    assert all(count["map->odom"] > 100 for count in counts), counts
    assert all(count["/map"] > 0 for count in counts), counts
