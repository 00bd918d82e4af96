"""Sim time going back under running nodes (mrs_nav.ros.clock_jump): during a drive, and between two plays of a
bag. Every node keeps publishing (map -> odom, /map, /amcl_pose, /cmd_vel) and the next goal is reached.

The jumps are made deterministic by pausing the simulator (SIGSTOP) around one /clock message from this process,
published as ``rostopic pub -1 /clock`` does: the clock then stays where that message put it for a wall second,
long enough for every node to see it, instead of racing the simulator's next tick; the simulator then goes on
from its own time. A message 1 s behind the simulator is a jump back by 1 s (and then forward again); a message
10 s or 185 s ahead is, when the simulator resumes, a jump back by 10 s or 185 s (185 s: what a simulator restarted
under the nodes does).
"""

from __future__ import annotations

import math
import os
import signal
import threading
import time
import xmlrpc.client
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests.ros.navharness import StatusLog, TruthTrack
from tests.ros.test_live_replay import BAGS, _sensor_bag, live_slam, play_bag
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
HOLD_S = 1.5  # wall s the paused clock stands at the published time: every node's timer and callbacks see it
GOAL = (1.5, -1.5)  # across the arena's lower side from the start at (-1.5, -1.5)


class Activity:
    """Wall arrival times of what the nodes publish: map -> odom on /tf, /map, /amcl_pose, a moving /cmd_vel."""

    def __init__(self, rospy: Any) -> None:
        from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
        from nav_msgs.msg import OccupancyGrid
        from tf2_msgs.msg import TFMessage

        self._lock = threading.Lock()
        self.arrivals: dict[str, list[float]] = {"map->odom": [], "/map": [], "/amcl_pose": [], "/cmd_vel": []}
        self.subs = [
            rospy.Subscriber("/tf", TFMessage, self._on_tf, queue_size=1000),
            rospy.Subscriber("/map", OccupancyGrid, self._note("/map"), queue_size=1),
            rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, self._note("/amcl_pose"), queue_size=10),
            rospy.Subscriber("/cmd_vel", Twist, self._on_cmd_vel, queue_size=100),
        ]

    def _add(self, what: str) -> None:
        with self._lock:
            self.arrivals[what].append(time.monotonic())

    def _note(self, what: str) -> Callable[[Any], None]:
        return lambda _msg: self._add(what)

    def _on_tf(self, msg: Any) -> None:
        if any(t.header.frame_id.lstrip("/") == "map" and t.child_frame_id == "odom" for t in msg.transforms):
            self._add("map->odom")

    def _on_cmd_vel(self, msg: Any) -> None:
        if msg.linear.x != 0.0 or msg.angular.z != 0.0:
            self._add("/cmd_vel")

    def since(self, wall: float) -> dict[str, int]:
        """How many of each arrived after the monotonic wall time ``wall``."""
        with self._lock:
            return {what: sum(t > wall for t in times) for what, times in self.arrivals.items()}

    def close(self) -> None:
        for sub in self.subs:
            sub.unregister()


def _pid(master: RosMaster, node: str) -> int:
    code, message, uri = xmlrpc.client.ServerProxy(master.uri).lookupNode("/pytest", node)
    assert code == 1, message
    code, message, pid = xmlrpc.client.ServerProxy(uri).getPid("/pytest")
    assert code == 1, message
    return int(pid)


class ClockJumper:
    """Publishes one /clock message while the simulator is paused (see the module's docstring)."""

    def __init__(self, rospy: Any, master: RosMaster) -> None:
        from rosgraph_msgs.msg import Clock

        self.rospy, self.master, self.Clock = rospy, master, Clock
        self.pub = rospy.Publisher("/clock", Clock, queue_size=1)

    def jump(self, offset_s: float) -> float:
        """Pause the simulator, publish its time plus ``offset_s``, hold it, resume; the monotonic wall time of the
        resumption."""
        pid = _pid(self.master, "/simulator")
        wait_for(lambda: self.pub.get_num_connections() >= 3, 10.0, "the nodes to subscribe this /clock")
        os.kill(pid, signal.SIGSTOP)
        try:
            time.sleep(0.2)  # the simulator's last messages arrive
            at = self.rospy.get_time() + offset_s
            self.pub.publish(self.Clock(clock=self.rospy.Time.from_sec(at)))
            time.sleep(HOLD_S)
        finally:
            os.kill(pid, signal.SIGCONT)
        return time.monotonic()

    def close(self) -> None:
        self.pub.unregister()


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
def _subscribers(
    rospy: Any, master: RosMaster, stack: Stack
) -> Iterator[tuple[Activity, StatusLog, TruthTrack, ClockJumper, Any]]:
    from geometry_msgs.msg import PoseStamped

    activity = Activity(rospy)
    status = StatusLog(rospy, f"/{stack.node}/status")
    truth = TruthTrack(rospy, "simple.world")
    jumper = ClockJumper(rospy, master)
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
        _subscribers(rospy, ros_master, stack) as (activity, status, truth, jumper, goal_pub),
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
    activity = Activity(rospy_node)
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
