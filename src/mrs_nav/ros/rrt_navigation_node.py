"""The ``rrt_navigation`` node: RRT* to an rviz 2D Nav Goal on the live SLAM map, followed by feedback
linearisation (the course's ``rrt_navigation.py``), around :class:`mrs_nav.navigation.navigator.Navigator`.

Subscribes ``map`` (nav_msgs/OccupancyGrid) and ``move_base_simple/goal`` (geometry_msgs/PoseStamped, any frame
tf can bring into the map frame); reads the robot pose from tf ``map -> base_footprint``; publishes ``path``
(nav_msgs/Path, frame map, latched), ``cmd_vel`` (geometry_msgs/Twist) and ``~status`` (std_msgs/String,
latched, one message per event: ``"<state>: <message>"`` with state one of idle, active, preempted, reached,
failed, refused). Every event is also logged (warnings for refusals and failures). With ``~heartbeat`` (default
true) ``cmd_vel`` goes out every control period even while idle (a zero Twist), which is what paces a simulator
in lockstep; false leaves ``cmd_vel`` silent while idle (e.g. for teleoperation).

Planning runs in one worker thread, off the control timer: the timer keeps publishing ``cmd_vel`` every period
(following the current path during a periodic replan, a zero Twist while there is no usable path), so a lockstep
simulator is never held still by a plan, and adopts the plan on the first tick after it is done.
"""

from __future__ import annotations

import math
import sys
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field

import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.msg import Path
from std_msgs.msg import String

from mrs_nav.control.path_following import FollowerConfig
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.geometry import Pose2D
from mrs_nav.navigation.navigator import (
    PLANNERS,
    EventKind,
    GoalState,
    NavCommand,
    NavEvent,
    Navigator,
    NavigatorConfig,
    PlanOutcome,
    PlanRequest,
    rrt_planner,
)
from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR, BURGER_RADIUS
from mrs_nav.ros.navigation_conversions import grid_from_msg, latest_pose, path_msg, pose_in_frame
from mrs_nav.ros.params import private_param

# The status word published with each event (the navigator's goal state after it).
STATUS_OF_EVENT = {
    EventKind.ACCEPTED: "active",
    EventKind.PLANNED: "active",
    EventKind.PLAN_FAILED: "active",
    EventKind.HOLDING: "active",
    EventKind.RESUMED: "active",
    EventKind.PREEMPTED: "preempted",
    EventKind.CANCELLED: "preempted",
    EventKind.REFUSED: "refused",
    EventKind.REACHED: "reached",
    EventKind.FAILED: "failed",
}


@dataclass(frozen=True)
class RrtNavigationConfig:
    """The node's private parameters (defaults as in config/rrt_navigation.yaml)."""

    planner: str = "rrt_star"
    time_budget_s: float = 0.3
    rate_hz: float = 10.0
    pose_timeout_s: float = 1.0
    correction_timeout_s: float = 5.0
    map_frame: str = "map"
    odom_frame: str = "odom"
    base_frame: str = "base_footprint"
    seed: int | None = None
    heartbeat: bool = True
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise InvalidInputError(f"~planner: expected one of {', '.join(PLANNERS)}, got {self.planner!r}")
        for name in ("time_budget_s", "rate_hz", "pose_timeout_s", "correction_timeout_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"~{name}: must be a positive number, got {value}")

    @classmethod
    def from_params(cls) -> RrtNavigationConfig:
        follower = FollowerConfig(
            speed=private_param("speed", 0.2),
            epsilon=private_param("epsilon", 0.1),
            gain=private_param("gain", 2.0),
            max_linear=private_param("max_linear", BURGER_MAX_LINEAR),
            max_angular=private_param("max_angular", BURGER_MAX_ANGULAR),
        )
        navigator = NavigatorConfig(
            robot_radius=private_param("robot_radius", BURGER_RADIUS),
            safety_margin_m=private_param("safety_margin", 0.1),
            goal_tolerance_m=private_param("goal_tolerance", 0.2),
            allow_unknown=private_param("allow_unknown", True),
            stray_distance_m=private_param("stray_distance", 0.3),
            replan_period_s=private_param("replan_period", 5.0),
            improvement_ratio=private_param("improvement_ratio", 0.85),
            max_failed_plans=private_param("max_failed_plans", 5),
            retry_delay_s=private_param("retry_delay", 1.0),
            progress_timeout_s=private_param("progress_timeout", 30.0),
            map_timeout_s=private_param("map_timeout", 0.0),
            follower=follower,
        )
        seed = private_param("seed", -1)
        return cls(
            planner=private_param("planner", "rrt_star"),
            time_budget_s=private_param("time_budget", 0.3),
            rate_hz=private_param("rate", 10.0),
            pose_timeout_s=private_param("pose_timeout", 1.0),
            correction_timeout_s=private_param("correction_timeout", 5.0),
            map_frame=private_param("map_frame", "map"),
            odom_frame=private_param("odom_frame", "odom"),
            base_frame=private_param("base_frame", "base_footprint"),
            seed=None if seed < 0 else seed,
            heartbeat=private_param("heartbeat", True),
            navigator=navigator,
        )


class RrtNavigationNode:
    """Wires a :class:`Navigator` to ROS; :meth:`start` begins the control timer."""

    def __init__(self, config: RrtNavigationConfig) -> None:
        self.config = config
        planner = rrt_planner(config.planner, config.time_budget_s)
        self.navigator = Navigator(planner, config.navigator, seed=config.seed)
        self._lock = threading.Lock()
        self._tf_buffer = tf2_ros.Buffer()
        self._tf_listener = tf2_ros.TransformListener(self._tf_buffer)
        self._cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1, tcp_nodelay=True)
        self._path_pub = rospy.Publisher("path", Path, queue_size=1, latch=True)
        self._status_pub = rospy.Publisher("~status", String, queue_size=10, latch=True)
        self._map_sub = rospy.Subscriber("map", OccupancyGridMsg, self._on_map, queue_size=1)
        self._goal_sub = rospy.Subscriber("move_base_simple/goal", PoseStamped, self._on_goal, queue_size=1)
        self._timer: rospy.Timer | None = None
        self._last_time = rospy.Time(0)
        # one worker: at most one plan runs at a time (the navigator asks for no other while one is in flight)
        self._planner_pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rrt_navigation_plan")
        self._plan: tuple[PlanRequest, Future[PlanOutcome]] | None = None

    def start(self) -> None:
        """Publish the idle status, start the control loop and stop the robot on shutdown."""
        self._status_pub.publish(String(data="idle: waiting for a goal"))
        rospy.on_shutdown(self._stop)
        # The planner thread holds the GIL for long stretches; the default 5 ms switch interval would delay each
        # /clock, /tf and timer hand-off of the control loop by up to that, which is what paces a lockstep sim.
        sys.setswitchinterval(0.0005)
        self._timer = rospy.Timer(rospy.Duration(1.0 / self.config.rate_hz), self._on_timer)

    # -- inputs ---------------------------------------------------------------------------------------------

    def _on_map(self, msg: OccupancyGridMsg) -> None:
        try:
            grid = grid_from_msg(msg)
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"rrt_navigation: ignoring map: {err}")
            return
        if msg.header.frame_id and msg.header.frame_id.lstrip("/") != self.config.map_frame:
            rospy.logwarn_throttle(
                5.0,
                f"rrt_navigation: ignoring map in frame {msg.header.frame_id!r}, expected {self.config.map_frame!r}",
            )
            return
        with self._lock:
            self.navigator.set_map(grid, rospy.get_time())

    def _on_goal(self, msg: PoseStamped) -> None:
        try:
            goal = pose_in_frame(self._tf_buffer, msg, self.config.map_frame)
        except (MrsNavError, tf2_ros.TransformException) as err:
            self._report([NavEvent(EventKind.REFUSED, f"goal refused: {err}")])
            return
        with self._lock:
            events = self.navigator.set_goal(goal.x, goal.y, rospy.get_time())
        self._report(events)

    def _pose(self) -> Pose2D | None:
        """The robot pose in the map frame: the latest ``map -> odom`` correction (SLAM publishes it at its own
        pace; no older than ``correction_timeout``) composed with the latest odometry ``odom -> base`` (no older
        than ``pose_timeout``); None when either is missing or too old."""
        cfg, who = self.config, "rrt_navigation"
        odom = latest_pose(self._tf_buffer, cfg.odom_frame, cfg.base_frame, cfg.pose_timeout_s, who)
        if odom is None:
            return None
        correction = latest_pose(self._tf_buffer, cfg.map_frame, cfg.odom_frame, cfg.correction_timeout_s, who)
        return None if correction is None else correction.compose(odom)

    # -- control ----------------------------------------------------------------------------------------------

    def _on_timer(self, event: rospy.timer.TimerEvent) -> None:
        now = rospy.Time.now()
        if now < self._last_time:  # sim time jumped back (a bag restarted): forget the goal
            rospy.logwarn("rrt_navigation: time jumped backwards; dropping the goal")
            with self._lock:
                self._report(self.navigator.cancel())
            self._tf_buffer.clear()
        self._last_time = now
        pose = self._pose()
        with self._lock:
            finished = self._finished_plan()
            command = self.navigator.update(pose, now.to_sec(), defer=True)
            if command.request is not None:
                self._plan = (command.request, self._planner_pool.submit(self.navigator.run_plan, command.request))
            state = self.navigator.state
        twist = Twist()
        twist.linear.x, twist.angular.z = command.u, command.omega
        events = finished.events + command.events
        # the heartbeat (a zero Twist every tick while idle) paces a lockstep simulator at any sim rate
        if self.config.heartbeat or state is GoalState.ACTIVE or events:
            self._cmd_pub.publish(twist)
        path = command.path if command.path is not None else finished.path
        if path is not None:
            self._path_pub.publish(path_msg(path, now, self.config.map_frame))
        self._report(events)

    def _finished_plan(self) -> NavCommand:
        """Hand a finished plan (if any) to the navigator (called with the lock held); its path and events."""
        if self._plan is None or not self._plan[1].done():
            return NavCommand(0.0, 0.0)
        request, future = self._plan
        self._plan = None
        try:
            outcome = future.result()
        except Exception as err:  # a planner bug must not kill the control loop: count it as a failed plan
            outcome = (None, f"planner error: {err!r}")
        return self.navigator.finish_plan(request, outcome)

    def _report(self, events: list[NavEvent] | tuple[NavEvent, ...]) -> None:
        """Log each event and publish it on ``~status``."""
        for e in events:
            (rospy.logwarn if e.kind.warning else rospy.loginfo)(f"rrt_navigation: {e.message}")
            self._status_pub.publish(String(data=f"{STATUS_OF_EVENT[e.kind]}: {e.message}"))

    def _stop(self) -> None:
        if self._timer is not None:
            self._timer.shutdown()
        self._planner_pool.shutdown(wait=False)
        self._cmd_pub.publish(Twist())
