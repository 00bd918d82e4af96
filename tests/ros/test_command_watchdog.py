"""The simulator's cmd_vel watchdog through the real nodes: the robot drives to a goal under rrt_navigation, the
navigation node is killed with SIGKILL (no zero command on the way out), and the ground truth must show the robot
standing (speed below 0.01 m/s) within 0.5 s of sim time of the last /cmd_vel."""

from __future__ import annotations

import math
import os
import signal
import threading
from typing import Any

import pytest

from tests.ros.navharness import IdentityCorrection, world_map_msg
from tests.rosharness import RosMaster, node_pid, wait_for

pytestmark = pytest.mark.ros

STOPPED = 0.01  # m/s
WITHIN = 0.5  # s of sim time after the last /cmd_vel


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


def test_the_robot_stops_within_half_a_second_of_its_command_source_dying(
    ros_master: RosMaster, rospy_node: Any
) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import OccupancyGrid

    speeds = Speeds(rospy)
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
            goal_pub.publish(goal)  # 3 m east along the south side: seconds at full speed
            wait_for(lambda: speeds.speed() > 0.15, 60.0, "the robot at cruising speed")
            os.kill(node_pid(ros_master, "/rrt_navigation"), signal.SIGKILL)
            wait_for(lambda: rospy.get_time() > speeds.last_command + 2.0, 60.0, "2 s of sim time without commands")
        finally:
            correction.close()
            map_pub.unregister()
            goal_pub.unregister()
            speeds.close()
    stopped = speeds.stopped_after(speeds.last_command)
    print(f"stopped {stopped:.3f} s of sim time after the last /cmd_vel")
    assert stopped <= WITHIN
