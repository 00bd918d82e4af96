"""The ``potential_field_navigation`` node: the course's potential-field follower on the robot, around
:class:`mrs_nav.fields.follower.FieldFollower`.

Obstacles come from the world file (``~obstacles: world``) or from each ``scan`` (``~obstacles: scan``); the
pose from ``ground_truth/odom`` (``~pose_source: ground_truth``) or tf ``~frame -> base_footprint``
(``~pose_source: tf``); the goal from ``~goal_x``/``~goal_y`` or ``move_base_simple/goal``. Publishes
``cmd_vel`` and ``~status`` (std_msgs/String, latched, ``"<state>: <message>"``) and writes the robot's
trajectory to ``~trajectory_file`` (default ``$ROS_HOME/potential_field_trajectory.csv``, ``none`` for no file)
as CSV with the header ``t,x,y,yaw`` (sim seconds, metres, radians), which the course's plotting reads with
``np.genfromtxt(path, delimiter=",", names=True)``. With ``~heartbeat`` (default false; the launch file sets it
with ``lockstep:=true``) ``cmd_vel`` goes out every control period even while idle (a zero Twist), which is
what paces a simulator in lockstep. A scan whose angles or range limits are not finite numbers is dropped with
a throttled warning. When sim time jumps backwards (the simulator restarted, a bag played again) the active goal
is dropped (``~status`` ``failed: sim time went back ...``), the robot stopped, and the tf buffer and the last
ground-truth pose are cleared (:mod:`mrs_nav.ros.clock_jump`); the trajectory file goes on with the new times.
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import rospkg
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from mrs_nav.config_files import node_default, node_defaults
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.fields.follower import FieldFollower, FieldFollowerConfig, scan_obstacles
from mrs_nav.geometry import Pose2D, format_point
from mrs_nav.maps.admissible import obstacles_refusal
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world
from mrs_nav.ros.clock_jump import TimeJumpGuard
from mrs_nav.ros.conversions import (
    any_reading,
    pose_from_odometry,
    pose_from_transform,
    scan_data,
    valid_ranges,
)
from mrs_nav.ros.navigation_conversions import latest_pose, pose_in_frame, publish_unless_shutdown
from mrs_nav.ros.params import private_params

NODE = "potential_field_navigation"
_default = functools.partial(node_default, NODE)
OBSTACLE_SOURCES = ("world", "scan")
TRAJECTORY_FILE = "potential_field_trajectory.csv"  # under ROS_HOME unless ~trajectory_file says otherwise
POSE_SOURCES = ("ground_truth", "tf")


# The follower's parameters, named as FieldFollowerConfig's fields.
_FOLLOWER_PARAMS = ("epsilon", "speed", "robot_radius", "safety_margin", "goal_tolerance", "max_linear", "max_angular")


def _follower(values: Mapping[str, Any]) -> FieldFollowerConfig:
    return FieldFollowerConfig(**{name: values[name] for name in _FOLLOWER_PARAMS})


@dataclass(frozen=True)
class PotentialFieldNavigationConfig:
    """The node's private parameters (defaults: config/potential_field_navigation.yaml)."""

    obstacles: str = _default("obstacles")
    world: Path | None = None  # ~world "": none
    pose_source: str = _default("pose_source")
    frame: str = _default("frame")
    base_frame: str = _default("base_frame")
    goal: tuple[float, float] | None = None  # ~goal_x, ~goal_y NaN: wait for move_base_simple/goal
    rate_hz: float = _default("rate")
    pose_timeout_s: float = _default("pose_timeout")
    trajectory_file: Path | None = None
    seed: int | None = None  # ~seed < 0: random
    heartbeat: bool = _default("heartbeat")
    follower: FieldFollowerConfig = field(default_factory=lambda: _follower(node_defaults(NODE)))

    def __post_init__(self) -> None:
        if self.obstacles not in OBSTACLE_SOURCES:
            raise InvalidInputError(f"~obstacles: expected one of {OBSTACLE_SOURCES}, got {self.obstacles!r}")
        if self.pose_source not in POSE_SOURCES:
            raise InvalidInputError(f"~pose_source: expected one of {POSE_SOURCES}, got {self.pose_source!r}")
        if self.obstacles == "world" and self.world is None:
            raise InvalidInputError("~world: a world file is required when ~obstacles is 'world'")
        for name in ("rate_hz", "pose_timeout_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"~{name}: must be a positive number, got {value}")

    @classmethod
    def from_params(cls) -> PotentialFieldNavigationConfig:
        """Read the ``~`` parameters (defaults: config/potential_field_navigation.yaml)."""
        values = private_params(NODE)
        if not values["trajectory_file"]:
            values["trajectory_file"] = str(Path(rospkg.get_ros_home()) / TRAJECTORY_FILE)
        return cls.from_values(values)

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> PotentialFieldNavigationConfig:
        """The config from every parameter of config/potential_field_navigation.yaml by name (an empty
        ``trajectory_file``: no file)."""
        gx, gy, world, seed = values["goal_x"], values["goal_y"], values["world"], values["seed"]
        trajectory = values["trajectory_file"]
        return cls(
            obstacles=values["obstacles"],
            world=Path(world) if world else None,
            pose_source=values["pose_source"],
            frame=values["frame"],
            base_frame=values["base_frame"],
            goal=(gx, gy) if math.isfinite(gx) and math.isfinite(gy) else None,
            rate_hz=values["rate"],
            pose_timeout_s=values["pose_timeout"],
            trajectory_file=None if trajectory in ("none", "") else Path(trajectory).expanduser(),
            seed=None if seed < 0 else seed,
            heartbeat=values["heartbeat"],
            follower=_follower(values),
        )


class PotentialFieldNavigationNode:
    """Wires a :class:`FieldFollower` to ROS; :meth:`start` begins the control timer."""

    def __init__(self, config: PotentialFieldNavigationConfig) -> None:
        self.config = config
        self._rng = np.random.default_rng(config.seed)
        self._world_obstacles = (
            Obstacles.from_world(load_world(config.world)) if config.obstacles == "world" and config.world else None
        )
        self._lock = threading.Lock()
        self._follower: FieldFollower | None = None
        self._scan_obstacles: Obstacles | None = None
        self._truth: tuple[rospy.Time, Pose2D] | None = None
        self._trajectory: TextIO | None = None
        self._tf_buffer = tf2_ros.Buffer()
        # The pose is asked for without Nagle's algorithm (tcp_nodelay), as cmd_vel and the clock are: with it,
        # at max rate in lockstep the clock and the commands ran on while ground_truth/odom waited for a delayed
        # ACK, and the follower acted on the same pose for up to 9 ticks (0.9 s, 11 cm) and once touched.
        self._tf_listener = tf2_ros.TransformListener(self._tf_buffer, tcp_nodelay=True)
        self._cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1, tcp_nodelay=True)
        self._status_pub = rospy.Publisher("~status", String, queue_size=10, latch=True)
        self._goal_sub = rospy.Subscriber("move_base_simple/goal", PoseStamped, self._on_goal, queue_size=1)
        self._truth_sub = (
            rospy.Subscriber("ground_truth/odom", Odometry, self._on_truth, queue_size=1, tcp_nodelay=True)
            if config.pose_source == "ground_truth"
            else None
        )
        self._scan_sub = (
            rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=1) if config.obstacles == "scan" else None
        )
        self._timer: rospy.Timer | None = None
        self._time_jump = TimeJumpGuard("potential_field_navigation", self._on_time_jump, self._tf_buffer)

    def start(self) -> None:
        """Open the trajectory file, take the goal parameter if set, and start the control loop."""
        path = self.config.trajectory_file
        if path is not None:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                self._trajectory = path.open("w", encoding="utf-8")
            except OSError as err:
                rospy.logerr(f"potential_field_navigation: ~trajectory_file {path}: {err}; no trajectory is written")
            else:
                self._trajectory.write("t,x,y,yaw\n")  # sim s, m, m, rad
                rospy.loginfo(f"potential_field_navigation: trajectory to {path}")
        rospy.on_shutdown(self._stop)
        self._status("idle", "waiting for a goal")
        if self.config.goal is not None:
            self._set_goal(*self.config.goal)
        self._timer = self._time_jump.timer(1.0 / self.config.rate_hz, self._on_timer)

    # -- inputs -------------------------------------------------------------------------------------------------

    def _on_truth(self, msg: Odometry) -> None:
        try:
            pose = pose_from_odometry(msg)
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"potential_field_navigation: ignoring ground truth: {err}")
            return
        with self._lock:
            self._truth = (msg.header.stamp, pose)

    def _on_goal(self, msg: PoseStamped) -> None:
        try:
            goal = pose_in_frame(self._tf_buffer, msg, self.config.frame)
        except (MrsNavError, tf2_ros.TransformException) as err:
            rospy.logwarn(f"potential_field_navigation: goal refused: {err}")
            self._status("refused", f"goal refused: {err}")
            return
        self._set_goal(goal.x, goal.y)

    def _set_goal(self, x: float, y: float) -> None:
        obstacles = self._world_obstacles
        why = (
            None
            if obstacles is None
            else obstacles_refusal(obstacles, x, y, clearance_m=self.config.follower.robot_radius)
        )
        if why:
            rospy.logwarn(f"potential_field_navigation: goal {format_point(x, y)} refused: {why}")
            self._status("refused", f"goal {format_point(x, y)} refused: {why}")
            return
        with self._lock:
            current = obstacles or self._scan_obstacles or Obstacles()
            self._follower = FieldFollower((x, y), current, self.config.follower, self._rng)
        rospy.loginfo(f"potential_field_navigation: goal {format_point(x, y)} accepted")
        self._status("active", f"goal {format_point(x, y)} accepted")

    def _on_scan(self, msg: LaserScan) -> None:
        self._time_jump.check()
        pose = self._pose()
        if pose is None:
            return
        try:
            mount = self._tf_buffer.lookup_transform(self.config.base_frame, msg.header.frame_id, rospy.Time(0))
            laser = pose.compose(pose_from_transform(mount))
        except (tf2_ros.TransformException, MrsNavError) as err:
            # Placing the beams at the wrong origin would put obstacles where there are none: drop instead.
            rospy.logwarn_throttle(
                5.0, f"potential_field_navigation: dropping a scan in frame {msg.header.frame_id!r}: {err}"
            )
            return
        try:
            scan = scan_data(msg)
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"potential_field_navigation: dropping scan: {err}")
            return
        if not any_reading(scan.ranges):
            # A blind scan would clear every obstacle the last one saw.
            rospy.logwarn_throttle(5.0, "potential_field_navigation: dropping a scan without a range >= 0")
            return
        ranges = np.where(valid_ranges(msg, scan.ranges), scan.ranges, np.inf)
        try:
            obstacles = scan_obstacles(laser, scan.angles, ranges)
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"potential_field_navigation: dropping scan: {err}")
            return
        with self._lock:
            self._scan_obstacles = obstacles
            if self._follower is not None:
                self._follower.set_obstacles(obstacles)

    def _pose(self) -> Pose2D | None:
        now = rospy.Time.now()
        if self.config.pose_source == "ground_truth":
            with self._lock:
                truth = self._truth
            if truth is None or (now - truth[0]).to_sec() > self.config.pose_timeout_s:
                return None
            return truth[1]
        cfg = self.config
        return latest_pose(self._tf_buffer, cfg.frame, cfg.base_frame, cfg.pose_timeout_s, "potential_field_navigation")

    # -- control ------------------------------------------------------------------------------------------------

    def _on_timer(self, event: rospy.timer.TimerEvent) -> None:
        now = rospy.Time.now().to_sec()
        pose = self._pose()
        with self._lock:
            if pose is not None and self._trajectory is not None:
                self._trajectory.write(f"{now:.3f},{pose.x:.4f},{pose.y:.4f},{pose.yaw:.4f}\n")
            follower = self._follower
            if follower is None:
                if self.config.heartbeat:  # a zero Twist every tick while idle paces a lockstep simulator
                    publish_unless_shutdown(self._cmd_pub, Twist(), "potential_field_navigation")
                return
            if pose is None:
                publish_unless_shutdown(self._cmd_pub, Twist(), "potential_field_navigation")
                rospy.logwarn_throttle(5.0, "potential_field_navigation: no pose; stopped")
                return
            command = follower.command(pose, now)
            if command.done:
                self._follower = None
        twist = Twist()
        twist.linear.x, twist.angular.z = command.u, command.omega
        publish_unless_shutdown(self._cmd_pub, twist, "potential_field_navigation")
        if command.done:
            gx, gy = follower.goal
            message = f"goal {format_point(gx, gy)} reached, {math.hypot(gx - pose.x, gy - pose.y):.3f} m away"
            rospy.loginfo(f"potential_field_navigation: {message}")
            self._status("reached", message)
            with self._lock:
                if self._trajectory is not None:
                    self._trajectory.flush()

    def _on_time_jump(self, seconds: float) -> str:
        """Sim time went back: drop the goal (the follower's stall and escape timers are of the old time line) and
        the ground-truth pose, whose stamp lies ahead of the new time."""
        with self._lock:
            follower, self._follower = self._follower, None
            self._truth = None
        if follower is None:
            return "no goal was active"
        publish_unless_shutdown(self._cmd_pub, Twist(), "potential_field_navigation")
        self._status("failed", f"sim time went back {seconds:.1f} s (the simulator restarted?); goal dropped")
        return "goal dropped, robot stopped"

    def _status(self, state: str, message: str) -> None:
        publish_unless_shutdown(self._status_pub, String(data=f"{state}: {message}"), "potential_field_navigation")

    def _stop(self) -> None:
        if self._timer is not None:
            self._timer.shutdown()
        publish_unless_shutdown(self._cmd_pub, Twist(), "potential_field_navigation")
        with self._lock:  # a timer tick in flight writes under the lock: never to a closed file
            if self._trajectory is not None:
                self._trajectory.close()
                self._trajectory = None
