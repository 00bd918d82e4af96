"""The simulator's cmd_vel watchdog and lockstep through the real nodes: the robot drives to a goal under
rrt_navigation, then the navigation node is killed with SIGKILL (no zero command on the way out), and the ground
truth must show the robot standing (speed below 0.01 m/s) within 0.5 s of sim time of the last /cmd_vel; or the
node is frozen (SIGSTOP: its connection stays open, as a node starved of CPU), and the simulation must wait for it
instead of driving the robot blind on its last command."""

from __future__ import annotations

import contextlib
import math
import os
import signal
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from tests.ros.navharness import IdentityCorrection, world_map_msg
from tests.rosharness import RosMaster, node_pid, wait_for

pytestmark = pytest.mark.ros

STOPPED = 0.01  # m/s
WITHIN = 0.5  # s of sim time after the last /cmd_vel
PERIOD = 0.1  # s of sim time: ~lockstep_period, the navigation node's control period


class Speeds:
    """Sim-time stamped samples: the last /cmd_vel's arrival and the ground truth's speed (m/s)."""

    def __init__(self, rospy: Any) -> None:
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry

        self.rospy = rospy
        self._lock = threading.Lock()
        self.last_command = -math.inf
        self.truth: list[tuple[float, float]] = []
        self.subs = [
            rospy.Subscriber("/cmd_vel", Twist, self._on_command, queue_size=100, tcp_nodelay=True),
            rospy.Subscriber("/ground_truth/odom", Odometry, self._on_truth, queue_size=1000, tcp_nodelay=True),
        ]

    def _on_command(self, _msg: Any) -> None:
        now = self.rospy.get_time()
        with self._lock:
            self.last_command = now

    def _on_truth(self, msg: Any) -> None:
        v = msg.twist.twist.linear
        with self._lock:
            self.truth.append((msg.header.stamp.to_sec(), math.hypot(v.x, v.y)))

    def speed(self) -> float:
        with self._lock:
            return self.truth[-1][1] if self.truth else 0.0

    def stopped_after(self, since: float) -> float:
        """Sim time from ``since`` to the first ground-truth sample from which the robot stays below STOPPED."""
        with self._lock:
            samples = [(t, s) for t, s in self.truth if t >= since]
        moving = [t for t, s in samples if s >= STOPPED]
        return (moving[-1] if moving else since) - since

    def close(self) -> None:
        for sub in self.subs:
            sub.unregister()


@contextlib.contextmanager
def driving(ros_master: RosMaster, rospy: Any, speeds: Speeds) -> Iterator[int]:
    """The simulator in lockstep and rrt_navigation on the arena's map, the robot sent 3 m east along the south
    side (seconds at full speed); yields the navigation node's pid once the robot is at cruising speed."""
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import OccupancyGrid

    with (
        ros_master.launch("simulation.launch", "real_time_factor:=0", "lockstep:=true", "x:=-1.5", "y:=-1.5"),
        ros_master.launch("rrt_navigation.launch", "slam:=false", "seed:=3"),
    ):
        correction = IdentityCorrection(rospy)
        map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        try:
            map_pub.publish(world_map_msg(rospy, "simple.world"))
            wait_for(lambda: map_pub.get_num_connections() > 0, 60.0, "the navigation node on /map")
            wait_for(lambda: goal_pub.get_num_connections() > 0, 60.0, "the navigation node on the goal topic")
            goal = PoseStamped()
            goal.header.frame_id = "map"
            goal.pose.position.x, goal.pose.position.y, goal.pose.orientation.w = 1.5, -1.5, 1.0
            goal_pub.publish(goal)
            wait_for(lambda: speeds.speed() > 0.15, 60.0, "the robot at cruising speed")
            yield node_pid(ros_master, "/rrt_navigation")
        finally:
            correction.close()
            map_pub.unregister()
            goal_pub.unregister()


def test_the_robot_stops_within_half_a_second_of_its_command_source_dying(
    ros_master: RosMaster, rospy_node: Any
) -> None:
    rospy = rospy_node
    speeds = Speeds(rospy)
    try:
        with driving(ros_master, rospy, speeds) as pid:
            os.kill(pid, signal.SIGKILL)
            wait_for(lambda: rospy.get_time() > speeds.last_command + 2.0, 60.0, "2 s of sim time without commands")
    finally:
        speeds.close()
    stopped = speeds.stopped_after(speeds.last_command)
    print(f"stopped {stopped:.3f} s of sim time after the last /cmd_vel")
    assert stopped <= WITHIN


def test_a_frozen_navigation_node_holds_the_lockstep_simulation_instead_of_letting_the_robot_run_blind(
    ros_master: RosMaster, rospy_node: Any
) -> None:
    """Before, the simulator ran freely after 1 s of wall-clock silence whoever was connected: the robot drove on
    its last command until the watchdog (0.3 s of sim time, 6.6 cm at full speed), the likely cause of the
    contact bench's one touch on a loaded machine."""
    rospy = rospy_node
    speeds = Speeds(rospy)
    try:
        with driving(ros_master, rospy, speeds) as pid:
            os.kill(pid, signal.SIGSTOP)
            try:
                time.sleep(3.0)  # wall: three times ~lockstep_timeout
                frozen_at = speeds.last_command
                advanced = rospy.get_time() - frozen_at
            finally:
                os.kill(pid, signal.SIGCONT)
            wait_for(lambda: speeds.last_command > frozen_at, 60.0, "the navigation node commanding again")
            wait_for(lambda: speeds.speed() > 0.15, 60.0, "the robot driving on")
    finally:
        speeds.close()
    print(f"sim time advanced {advanced:.3f} s past the frozen node's last /cmd_vel in 3 s of wall time")
    # One period of lockstep and one of grace (a rospy timer's tick can fall just past the horizon): 0.20-0.21 s on a
    # quiet machine. Plus the lag of this process's clock behind the simulator's when it hears the command, which
    # its own /clock queue sets: 0.35 s in all in a CI run at a load of 4-5 on 2 cores. Free running (the old rule)
    # makes this many seconds (23.6 s measured), so a bound of ten periods still tells the two apart.
    assert advanced < 10.0 * PERIOD
