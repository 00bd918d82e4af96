"""The simulator node under a real roslaunch: topic rates in sim time, /cmd_vel drives it, the watchdog stops it."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros


class Recorder:
    """Keeps the sim-time stamps (s) of every message of one topic, and the latest message."""

    def __init__(self, rospy: Any, topic: str, msg_type: Any, stamp: Any) -> None:
        self._stamp = stamp
        self._lock = threading.Lock()
        self.stamps: list[float] = []
        self.last: Any = None
        self.sub = rospy.Subscriber(topic, msg_type, self._on_msg, queue_size=10000, tcp_nodelay=True)

    def _on_msg(self, msg: Any) -> None:
        with self._lock:
            self.stamps.extend(self._stamp(msg))
            self.last = msg

    def period(self) -> float:
        """Median spacing (s) of consecutive distinct stamps."""
        with self._lock:
            stamps = np.unique(self.stamps)
        return float(np.median(np.diff(stamps)))

    def count_between(self, t0: float, t1: float) -> int:
        with self._lock:
            return sum(t0 < s <= t1 for s in self.stamps)


@pytest.fixture(scope="module")
def simulation(ros_master: RosMaster, rospy_node: Any) -> Iterator[Any]:
    """The simulator at maximum rate in the course arena, for the whole module."""
    with ros_master.launch("simulation.launch", "real_time_factor:=0", "x:=-1.5", "y:=-1.5", "yaw:=0") as proc:
        wait_for(lambda: proc.poll() is not None or rospy_node.get_time() > 1.0, 60.0, "/clock from the simulator")
        assert proc.poll() is None, "roslaunch exited"
        yield rospy_node


def test_scan_odom_tf_and_clock_arrive_at_their_rates_in_sim_time(simulation: Any) -> None:
    rospy = simulation
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage

    def header(msg: Any) -> list[float]:
        return [msg.header.stamp.to_sec()]

    recorders = {
        "/clock": Recorder(rospy, "/clock", Clock, lambda m: [m.clock.to_sec()]),
        "/scan": Recorder(rospy, "/scan", LaserScan, header),
        "/odom": Recorder(rospy, "/odom", Odometry, header),
        "/tf": Recorder(
            rospy,
            "/tf",
            TFMessage,
            lambda m: [t.header.stamp.to_sec() for t in m.transforms if t.child_frame_id == "base_footprint"],
        ),
    }
    try:
        wait_for(lambda: all(rec.stamps for rec in recorders.values()), 60.0, "every topic")
        t0 = max(rec.stamps[0] for rec in recorders.values())  # every subscription is connected from here
        wait_for(lambda: rospy.get_time() > t0 + 6.0, 120.0, "6 s of sim time")
        t1 = t0 + 5.0
        expected = {"/clock": 100.0, "/scan": 5.0, "/odom": 50.0, "/tf": 50.0}
        for topic, rate in expected.items():
            rec = recorders[topic]
            assert rec.period() == pytest.approx(1.0 / rate, rel=1e-6), topic
            # At maximum rate a busy subscriber loses some messages (the publishers' queues are short on
            # purpose: a late clock tick is worth less than the next one), never most of them.
            assert rec.count_between(t0, t1) >= 0.5 * rate * (t1 - t0), topic
        scan = recorders["/scan"].last
        assert scan.header.frame_id == "base_scan"
        assert len(scan.ranges) == 360
        assert (scan.range_min, scan.range_max) == pytest.approx((0.12, 3.5))
        odom = recorders["/odom"].last
        assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    finally:
        for rec in recorders.values():
            rec.sub.unregister()


def test_static_frames_from_the_urdf_reach_tf(simulation: Any) -> None:
    rospy = simulation
    import tf2_ros

    buffer = tf2_ros.Buffer()
    listener = tf2_ros.TransformListener(buffer)
    try:
        latest = rospy.Time(0)
        wait_for(lambda: buffer.can_transform("base_footprint", "base_scan", latest), 30.0, "base_footprint->base_scan")
        t = buffer.lookup_transform("base_footprint", "base_scan", rospy.Time(0)).transform.translation
        assert (t.x, t.y, t.z) == pytest.approx((-0.032, 0.0, 0.182))
        wait_for(lambda: buffer.can_transform("odom", "base_scan", rospy.Time(0)), 30.0, "odom->base_scan")
    finally:
        listener.unregister()


def test_cmd_vel_moves_the_robot_and_the_watchdog_stops_it(simulation: Any) -> None:
    rospy = simulation
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Odometry

    truth = Recorder(rospy, "/ground_truth/odom", Odometry, lambda m: [m.header.stamp.to_sec()])
    odom = Recorder(rospy, "/odom", Odometry, lambda m: [m.header.stamp.to_sec()])
    # queue_size=1: on a loaded machine a backlog of queued commands would keep the robot driving after the
    # last one was sent, and the distance below would measure the backlog, not the watchdog.
    pub = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
    try:
        wait_for(lambda: truth.last is not None and odom.last is not None, 30.0, "/ground_truth/odom and /odom")
        start_x = truth.last.pose.pose.position.x
        broken = Twist()
        broken.linear.x = math.nan
        for _ in range(5):
            pub.publish(broken)  # logged and ignored: the node must live on and obey the next good command
            time.sleep(0.01)  # one at a time through the queue of 1
        forward = Twist()
        forward.linear.x = 0.2

        def moved() -> bool:
            pub.publish(forward)  # re-sent every few wall ms: well within the 0.3 s watchdog at any sim speed
            time.sleep(0.002)
            return bool(truth.last.pose.pose.position.x > start_x + 0.3)

        wait_for(moved, 60.0, "the robot to drive 0.3 m", period=0.0)
        last_command = rospy.get_time()
        x_at_last_command = truth.last.pose.pose.position.x
        assert odom.last.pose.pose.position.x > start_x + 0.25  # odometry saw it too
        wait_for(lambda: rospy.get_time() > last_command + 2.0, 60.0, "2 s of sim time without commands")
        final = truth.last
        assert abs(final.twist.twist.linear.x) < 0.01  # stopped
        # at most the 0.3 s watchdog at 0.2 m/s and its brake, plus the message's flight time at maximum sim speed
        assert final.pose.pose.position.x - x_at_last_command < 0.2
    finally:
        pub.unregister()
        truth.sub.unregister()
        odom.sub.unregister()


def test_running_into_a_wall_is_counted_and_the_body_stays_out(simulation: Any) -> None:
    rospy = simulation
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Odometry
    from std_msgs.msg import UInt32

    truth = Recorder(rospy, "/ground_truth/odom", Odometry, lambda m: [m.header.stamp.to_sec()])
    contacts = Recorder(rospy, "/ground_truth/contacts", UInt32, lambda m: [])
    pub = rospy.Publisher("/cmd_vel", Twist, queue_size=10)
    forward = Twist()
    forward.linear.x = 0.22
    deepest = -1.0
    try:
        wait_for(lambda: contacts.last is not None and truth.last is not None, 30.0, "latched contact count")
        assert contacts.last.data == 0  # the earlier tests drove in the open

        def pushed_for_a_while() -> bool:
            nonlocal deepest
            pub.publish(forward)
            time.sleep(0.002)
            deepest = max(deepest, truth.last.pose.pose.position.x + 0.105 - 2.0)  # east wall's face at x = 2
            return bool(contacts.last.data > 0 and abs(truth.last.twist.twist.linear.x) < 0.01)

        wait_for(pushed_for_a_while, 60.0, "the robot to hit the east wall and stall there", period=0.0)
        assert contacts.last.data == 1
        assert deepest < 0.005
    finally:
        pub.unregister()
        truth.sub.unregister()
        contacts.sub.unregister()
