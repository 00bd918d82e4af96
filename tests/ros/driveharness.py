"""Driving the simulated robot from a test by pure pursuit on /ground_truth/odom, and scoring /amcl_pose."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np

from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.sim.commands import Twist2D
from mrs_nav.sim.scripted_drive import OFFICE_CORRIDOR_LOOP, WaypointDriver
from tests.rosharness import wait_for

COMMAND_PERIOD = 0.1  # s of sim time between commands, the simulator's lockstep period
_SLACK = 1e-6  # s


class Spin:
    """A driver for :class:`Drive` that turns in place, counter-clockwise at ``rate`` rad/s."""

    def __init__(self, rate: float) -> None:
        self.rate = rate

    def command(self, pose: Pose2D) -> Twist2D:
        return Twist2D(0.0, self.rate)


class Drive:
    """Drives ``waypoints`` (by default the office's corridor loop; or ``driver``'s commands) from
    /ground_truth/odom, a command every 0.1 s of sim time while ``on``, and pairs each /amcl_pose with the true
    pose of the same stamp."""

    def __init__(
        self,
        rospy: Any,
        waypoints: tuple[tuple[float, float], ...] = OFFICE_CORRIDOR_LOOP,
        *,
        loop: bool = True,
        driver: Spin | None = None,
    ) -> None:
        from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
        from nav_msgs.msg import Odometry
        from tf2_msgs.msg import TFMessage

        from mrs_nav.ros.conversions import pose_from_msg

        self.rospy, self.pose_from_msg, self.Twist = rospy, pose_from_msg, Twist
        self.lock = threading.Lock()
        self.driver: WaypointDriver | Spin = driver or WaypointDriver(waypoints, loop=loop)
        self.on = False
        self.next_command = 0.0
        self.now = 0.0
        self.truth: dict[int, Pose2D] = {}
        self.pairs: list[tuple[float, float, float]] = []  # (stamp, position error m, heading error rad)
        self.tf_stamps: list[float] = []
        self.cmd = rospy.Publisher("/cmd_vel", Twist, queue_size=10, tcp_nodelay=True)
        self.subs = [
            rospy.Subscriber("/ground_truth/odom", Odometry, self._on_truth, queue_size=100, tcp_nodelay=True),
            rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, self._on_estimate, queue_size=100),
            rospy.Subscriber("/tf", TFMessage, self._on_tf, queue_size=1000),
        ]

    def _on_truth(self, msg: Any) -> None:
        stamp = msg.header.stamp
        pose = self.pose_from_msg(msg.pose.pose)
        with self.lock:
            self.truth[round(stamp.to_sec() * 100)] = pose
            self.now = stamp.to_sec()
            # A stamp rounds to the nanosecond and now + 0.1 to the float: without the slack the command due at
            # t + 0.1 can wait for the next ground truth, past the lockstep horizon, and the simulator then waits a
            # whole lockstep_timeout of wall time for it (the loop ran at half real time instead of 3x).
            due = self.on and self.now >= self.next_command - _SLACK
            if due:
                self.next_command = self.now + COMMAND_PERIOD
        if due:
            command = self.driver.command(pose)
            twist = self.Twist()
            twist.linear.x, twist.angular.z = command.v, command.omega
            self.cmd.publish(twist)

    def _on_estimate(self, msg: Any) -> None:
        stamp = msg.header.stamp.to_sec()
        est = self.pose_from_msg(msg.pose.pose)
        with self.lock:
            truth = self.truth.get(round(stamp * 100))
            if truth is not None:
                error = math.hypot(est.x - truth.x, est.y - truth.y)
                self.pairs.append((stamp, error, abs(wrap_angle(est.yaw - truth.yaw))))

    def _on_tf(self, msg: Any) -> None:
        with self.lock:
            self.tf_stamps += [t.header.stamp.to_sec() for t in msg.transforms if t.child_frame_id == "odom"]

    def drive(self, seconds: float, timeout: float) -> None:
        """Drive for ``seconds`` of sim time (at most ``timeout`` wall seconds), then stop."""
        with self.lock:
            end = self.now + seconds
            self.next_command = self.now
        self.on = True
        try:
            wait_for(lambda: self.now >= end, timeout, f"{seconds} s of sim time driving")
        finally:
            self.on = False
            self.cmd.publish(self.Twist())

    def since(self, t0: float) -> np.ndarray:
        with self.lock:
            return np.array([p for p in self.pairs if p[0] >= t0]).reshape(-1, 3)

    def close(self) -> None:
        self.cmd.unregister()
        for sub in self.subs:
            sub.unregister()
