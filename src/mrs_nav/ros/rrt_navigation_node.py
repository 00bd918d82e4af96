"""The ``rrt_navigation`` node: RRT* to a goal on the live SLAM map, followed by feedback linearisation (the
course's ``rrt_navigation.py``), around :class:`mrs_nav.navigation.navigator.Navigator`, with move_base's
interface.

Inputs: ``map`` (nav_msgs/OccupancyGrid), ``scan`` (sensor_msgs/LaserScan: obstacles that are not on the map
are marked for planning and a return ahead stops the robot), the robot pose from tf ``map -> odom ->
base_footprint``, and goals (any frame tf can bring into the map frame; an all-zero orientation asks for no
heading) on the ``move_base`` action (move_base_msgs/MoveBaseAction: goal, cancel, preemption by a new goal,
feedback ``base_position`` every control period, result; status SUCCEEDED, ABORTED or REJECTED with a text
reason, PREEMPTED) or on ``move_base_simple/goal`` (geometry_msgs/PoseStamped), which is re-sent as an action
goal (as move_base does) so both take the same path. As move_base's, the action server starts only once the
first map has arrived, so that a client's ``wait_for_server`` means its goal can be planned; an rviz goal before
then is kept and taken once it is up. Service ``move_base/make_plan`` (nav_msgs/GetPlan) plans without
moving (an empty path when it finds none); service ``move_base/clear_costmaps`` (std_srvs/Empty) drops every
obstacle the laser marked, as move_base's. ``amcl_pose`` and ``initialpose`` (geometry_msgs/
PoseWithCovarianceStamped) decide when scans may mark obstacles (:mod:`mrs_nav.navigation.marking`: only while the
localisation is confident; a 2D Pose Estimate drops the marks placed so far), and a goal reached while the
localisation is not confident is never SUCCEEDED on that estimate: the robot is held up to ``~confirm_timeout``
while the node asks the localisation's ``request_nomotion_update`` (std_srvs/Empty, when there is one) for an
update about once a second; it ends SUCCEEDED once the localisation is confident, else ABORTED with the reason.
Before a goal is aborted for failed plans or lack of progress the recoveries of :mod:`mrs_nav.navigation.recovery`
are tried (move_base's parameter names).

Outputs: ``cmd_vel`` (geometry_msgs/Twist) while a goal is active (and a zero Twist when it ends); with
``~heartbeat`` also a zero Twist every control period while idle, which is what paces a simulator in lockstep;
``path`` (nav_msgs/Path, frame map, latched); ``move_base/global_costmap/costmap`` (nav_msgs/OccupancyGrid,
latched, at most once a second while subscribed: the map as planned on, obstacles marked and inflated); ``~status``
(std_msgs/String, latched, one per event: ``"<state>: <message>"``).

The robot stops (the goal kept) when the ``map -> odom`` correction is older than ``~correction_freshness`` or
the last scan older than ``~scan_timeout`` (sim time): a localisation source or laser that died. Such a hold is
logged at info level; a warning comes only once it has lasted ``~stale_periods`` scan periods (the scans' median
interval, :class:`mrs_nav.navigation.quiet.QuietWatch`), so that a loaded machine's late callbacks do not cry
wolf.

When sim time jumps backwards (a bag played again, the simulator restarted) the active goal is aborted with the
reason (``~status`` ``failed: sim time went back ...``) and the robot stopped; the tf buffer and the stamped
inputs are cleared, and the next goal is driven as usual (:mod:`mrs_nav.ros.clock_jump`).

Planning runs in one worker thread, off the control timer: the timer keeps publishing ``cmd_vel`` every period
(following the current path, short of any new obstacle on it, during a periodic replan or one for a path blocked
further on; a zero Twist while there is no usable path), so a lockstep simulator is never held still by a plan,
and adopts the plan on the first tick after it is done.
"""

from __future__ import annotations

import itertools
import math
import sys
import threading
from concurrent.futures import Future, ThreadPoolExecutor

import actionlib
import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import OccupancyGrid as OccupancyGridMsg
from nav_msgs.msg import Path
from nav_msgs.srv import GetPlan, GetPlanRequest, GetPlanResponse
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from std_srvs.srv import Empty, EmptyRequest, EmptyResponse

from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.navigation.marking import MarkingGate
from mrs_nav.navigation.navigator import (
    EventKind,
    GoalState,
    NavCommand,
    NavEvent,
    Navigator,
    PlanOutcome,
    PlanRequest,
    rrt_planner,
)
from mrs_nav.navigation.plan_worker import run_plan
from mrs_nav.navigation.quiet import QuietWatch
from mrs_nav.ros.action_server import RepeatedIdActionServer
from mrs_nav.ros.clock_jump import TimeJumpGuard, keep_status_timer
from mrs_nav.ros.conversions import covariance_3x3, pose_from_msg, pose_msg
from mrs_nav.ros.map_messages import OccupancyGridArrayMsg, occupancy_grid_msg
from mrs_nav.ros.map_odom import lookup_pose
from mrs_nav.ros.navigation_conversions import (
    goal_in_frame,
    grid_from_msg,
    latest_pose,
    path_msg,
    pose_in_frame,
    publish_unless_shutdown,
    scan_in_frame,
)
from mrs_nav.ros.rrt_navigation_config import RrtNavigationConfig

# The status word published with each event (the navigator's goal state after it).
STATUS_OF_EVENT = {
    EventKind.ACCEPTED: "active",
    EventKind.PLANNED: "active",
    EventKind.PLAN_FAILED: "active",
    EventKind.HOLDING: "active",
    EventKind.RESUMED: "active",
    EventKind.RECOVERY: "active",
    EventKind.PREEMPTED: "preempted",
    EventKind.CANCELLED: "preempted",
    EventKind.REFUSED: "refused",
    EventKind.REACHED: "reached",
    EventKind.FAILED: "failed",
}
COSTMAP_PERIOD_S = 1.0  # sim seconds between costmap messages at most (rviz redraws a big grid slowly)
NOMOTION_SERVICE = "request_nomotion_update"  # amcl's (and our localisation's): one update without motion
NOMOTION_PERIOD_S = 1.0  # sim seconds between such requests while a goal waits for a confident localisation
NOMOTION_WAIT_S = 0.5  # wall seconds to wait for the service to show (none under SLAM, which leaves no doubt)


class RrtNavigationNode:
    """Wires a :class:`Navigator` to ROS; :meth:`start` begins the control timer and the action server."""

    def __init__(self, config: RrtNavigationConfig) -> None:
        self.config = config
        self._planner = rrt_planner(config.planner, config.time_budget_s, config.max_iterations)
        self.navigator = Navigator(self._planner, config.navigator, seed=config.seed)
        self._marking = MarkingGate(config.marking)
        self._query_rng = np.random.default_rng(None if config.seed is None else config.seed + 1)
        self._lock = threading.Lock()
        self._tf_buffer = tf2_ros.Buffer()
        # the pose (tf) without Nagle's delay, as cmd_vel: see potential_field_navigation_node
        self._tf_listener = tf2_ros.TransformListener(self._tf_buffer, tcp_nodelay=True)
        self._cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1, tcp_nodelay=True)
        self._path_pub = rospy.Publisher("path", Path, queue_size=1, latch=True)
        self._costmap_pub = rospy.Publisher(
            "move_base/global_costmap/costmap", OccupancyGridArrayMsg, queue_size=1, latch=True
        )
        self._status_pub = rospy.Publisher("~status", String, queue_size=10, latch=True)
        self._action_goal_pub = rospy.Publisher("move_base/goal", MoveBaseActionGoal, queue_size=1)
        self._server = RepeatedIdActionServer(
            "move_base", MoveBaseAction, self._on_action_goal, self._on_action_cancel, auto_start=False
        )
        self._taking_goals = False  # the action server is started (on the first map); set under _early_lock
        self._early_goal: PoseStamped | None = None  # the last rviz goal sent before then, taken once started
        self._early_lock = threading.Lock()  # one of the two happens first: the goal kept, or the server up
        self._goal_ids = itertools.count(1)
        self._active: actionlib.ServerGoalHandle | None = None  # the goal the navigator is driving to
        self._last_scan = -math.inf  # sim time the last usable scan arrived
        # sim times scans arrived (usable or not: one dropped for want of map->odom is the localisation's lateness)
        self._scans = QuietWatch(config.scan_timeout_s, config.stale_periods)
        self._holding_for: str | None = None  # the quiet-input reason the robot is held for, this tick
        self._warned_blind: str | None = None  # the hold warned of, this episode
        self._tf_gap_said: str | None = None  # why tf's placement of the scans keeps them from marking
        self._costmap: tuple[OccupancyGrid | None, float] = (None, -math.inf)  # last published, when
        self._timer: rospy.Timer | None = None
        self._time_jump = TimeJumpGuard("rrt_navigation", self._on_time_jump, self._tf_buffer)
        # one worker: at most one plan runs at a time (the navigator asks for no other while one is in flight)
        self._planner_pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rrt_navigation_plan")
        self._plan: tuple[PlanRequest, Future[PlanOutcome]] | None = None
        self._nomotion: tuple[float, threading.Thread | None] = (-math.inf, None)  # last request: sim time, thread

    def start(self) -> None:
        """Publish the idle status, start the action server, the control loop and the inputs."""
        self._status_pub.publish(String(data="idle: waiting for a goal"))
        rospy.on_shutdown(self._stop)
        self._subs = [
            # numpy_msg: the cells arrive as one int8 array (plain genpy unpacks a tuple of ints, then numpy
            # copies it: most of what a SLAM map update cost this node)
            rospy.Subscriber("map", OccupancyGridArrayMsg, self._on_map, queue_size=1),
            rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=1),
            rospy.Subscriber("move_base_simple/goal", PoseStamped, self._on_simple_goal, queue_size=1),
            rospy.Subscriber("amcl_pose", PoseWithCovarianceStamped, self._on_localisation, queue_size=10),
            rospy.Subscriber("initialpose", PoseWithCovarianceStamped, self._on_initial_pose, queue_size=1),
        ]
        self._plan_service = rospy.Service("move_base/make_plan", GetPlan, self._on_make_plan)
        self._clear_service = rospy.Service("move_base/clear_costmaps", Empty, self._on_clear_costmaps)
        # The planner thread holds the GIL for long stretches; the default 5 ms switch interval would delay each
        # /clock, /tf and timer hand-off of the control loop by up to that, which is what paces a lockstep sim.
        sys.setswitchinterval(0.0005)
        self._timer = self._time_jump.timer(1.0 / self.config.controller_frequency, self._on_timer)

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
        if not self._taking_goals:
            self._start_action_server(grid)

    def _start_action_server(self, grid: OccupancyGrid) -> None:
        """Start the ``move_base`` action on the first map, as move_base starts it once its costmaps have one: a
        client's ``wait_for_server`` then means goals can be taken (the first map arrives on this one thread)."""
        with self._server.lock:
            if rospy.is_shutdown():
                return
            self._server.start()
        keep_status_timer(self._server)
        with self._early_lock:
            self._taking_goals = True
            early, self._early_goal = self._early_goal, None
        rows, cols = grid.values.shape
        rospy.loginfo(
            f"rrt_navigation: received a {cols} x {rows} map at {grid.resolution:g} m/cell: the move_base action is up"
        )
        if early is not None:
            self._send_action_goal(self._action_goal(early))

    def _on_scan(self, msg: LaserScan) -> None:
        self._time_jump.check()
        with self._lock:
            self._scans.arrived(rospy.get_time())
        try:
            origin, ends, hit = scan_in_frame(
                self._tf_buffer, msg, self.config.map_frame, self.config.transform_tolerance_s
            )
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"rrt_navigation: dropping scan: {err}")
            return
        except tf2_ros.TransformException as err:
            rospy.logwarn_throttle(5.0, f"rrt_navigation: dropping scan, no transform to the map: {err}")
            return
        with self._lock:
            checks = self._marking.checks_placement
        # two tf lookups per scan only while there is an amcl_pose to check them against (none under SLAM)
        correction, odom = self._placement(msg.header.stamp) if checks else (None, None)
        with self._lock:
            may_mark = self._marking.may_mark(msg.header.stamp.to_sec(), correction, odom)
            gap = None if may_mark else self._marking.tf_gap(correction, odom)
            self.navigator.set_scan(origin, ends, hit, may_mark)
            self._last_scan = rospy.get_time()
        if (gap is None) != (self._tf_gap_said is None):  # once as it begins, once as it ends
            self._tf_gap_said = gap
            rospy.loginfo(
                f"rrt_navigation: {gap}: scans clear but do not mark"
                if gap
                else "rrt_navigation: tf places the scans by the localisation's estimate again"
            )

    def _placement(self, stamp: rospy.Time) -> tuple[Pose2D | None, Pose2D | None]:
        """The ``map -> odom`` correction and the odometry pose tf gives at ``stamp`` (None, None where it has not
        got them: in SLAM the map frame may be the odometry's own parent, or no odometry frame at all)."""
        cfg = self.config
        try:
            return (
                lookup_pose(self._tf_buffer, cfg.map_frame, cfg.odom_frame, stamp, 0.0),
                lookup_pose(self._tf_buffer, cfg.odom_frame, cfg.base_frame, stamp, 0.0),
            )
        except tf2_ros.TransformException:
            return None, None

    def _on_localisation(self, msg: PoseWithCovarianceStamped) -> None:
        try:
            covariance, pose = covariance_3x3(msg), pose_from_msg(msg.pose.pose)
        except MrsNavError as err:
            rospy.logwarn_throttle(5.0, f"rrt_navigation: ignoring amcl_pose: {err}")
            return
        correction = self._report_correction(msg, pose)
        with self._lock:
            before = self._marking.doubt()
            self._marking.report(msg.header.stamp.to_sec(), covariance, correction, pose)
            after = self._marking.doubt()
        if (before is None) != (after is None):
            rospy.loginfo(
                f"rrt_navigation: {after}: scans clear but do not mark"
                if after
                else "rrt_navigation: the localisation is confident: scans mark obstacles again"
            )

    def _report_correction(self, msg: PoseWithCovarianceStamped, pose: Pose2D) -> Pose2D | None:
        """The ``map -> odom`` correction an ``amcl_pose`` at ``pose`` implies: its pose after the odometry at its
        stamp (None when tf has no odometry there; marking then falls back to the settle time, with a warning)."""
        cfg = self.config
        try:
            odom = lookup_pose(
                self._tf_buffer, cfg.odom_frame, cfg.base_frame, msg.header.stamp, cfg.transform_tolerance_s
            )
            return pose.compose(odom.inverse())
        except tf2_ros.TransformException as err:
            rospy.logwarn_throttle(
                5.0, f"rrt_navigation: amcl_pose at {msg.header.stamp.to_sec():.3f} not checked against tf: {err}"
            )
            return None

    def _on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        """A 2D Pose Estimate: the pose that placed the marks so far was wrong (module docstring). Dated when it
        arrives, not by its stamp: an estimate the localisation made from its old belief after that stamp, before
        it took the new pose, must not count as confidence in the new one (unless it lies at the pose given:
        :meth:`MarkingGate.reset`)."""
        stamp = None if msg.header.stamp.is_zero() else msg.header.stamp.to_sec()
        try:
            given: Pose2D | None = pose_from_msg(msg.pose.pose)
        except MrsNavError:
            given = None  # the localisation ignores it too; the marks go all the same
        with self._lock:
            self._marking.reset(rospy.get_time(), given, stamp)
            cleared = self.navigator.clear_marks()
        rospy.loginfo(
            f"rrt_navigation: new initial pose: dropped {cleared} marked cells; marking resumes once the"
            " localisation is confident"
        )

    def _on_clear_costmaps(self, _req: EmptyRequest) -> EmptyResponse:
        with self._lock:
            cleared = self.navigator.clear_marks()
        rospy.loginfo(f"rrt_navigation: clear_costmaps: dropped {cleared} marked cells")
        return EmptyResponse()

    def _on_simple_goal(self, msg: PoseStamped) -> None:
        """Re-send an rviz goal as an action goal, as move_base does, so that it takes the action's path. One sent
        before the first map (a latched goal, a script quicker than the map) is kept and taken once the action is
        up: actionlib would drop it without a word while its server is not started."""
        with self._early_lock:
            if not self._taking_goals:
                self._early_goal = msg
                where = msg.pose.position
                rospy.loginfo(f"rrt_navigation: goal ({where.x:.2f}, {where.y:.2f}) kept until the first map arrives")
                return
        self._send_action_goal(self._action_goal(msg))

    def _send_action_goal(self, goal: MoveBaseActionGoal) -> None:
        """On ``move_base/goal``, where a bag or ``rostopic echo`` sees it, once the server's own subscriber is
        connected; straight to the server until then (it subscribes as it starts: the goal would be lost)."""
        if self._action_goal_pub.get_num_connections() > 0:
            self._action_goal_pub.publish(goal)
        else:
            self._server.internal_goal_callback(goal)

    def _action_goal(self, target: PoseStamped) -> MoveBaseActionGoal:
        """``target`` as a move_base action goal with an id of this node's."""
        goal = MoveBaseActionGoal()
        goal.header.stamp = rospy.Time.now()
        goal.goal_id.stamp = goal.header.stamp
        goal.goal_id.id = f"move_base_simple-{next(self._goal_ids)}-{goal.header.stamp.to_sec():.3f}"
        goal.goal.target_pose = target
        return goal

    def _on_action_goal(self, handle: actionlib.ServerGoalHandle) -> None:
        """A new goal (called by actionlib with its lock held; ours is taken inside it, never the other way)."""
        target = handle.get_goal().target_pose
        try:
            goal = goal_in_frame(self._tf_buffer, target, self.config.map_frame)
        except (MrsNavError, tf2_ros.TransformException) as err:
            event = NavEvent(EventKind.REFUSED, f"goal refused: {err}")
            self._report([event])
            handle.set_rejected(MoveBaseResult(), event.message)
            return
        with self._lock:
            events = self.navigator.set_goal(goal, rospy.get_time())
            refused = events[-1].kind is EventKind.REFUSED
            previous = None
            if not refused:
                previous, self._active = self._active, handle
        self._report(events)
        if refused:
            handle.set_rejected(MoveBaseResult(), events[-1].message)
            return
        if previous is not None:
            previous.set_canceled(MoveBaseResult(), "preempted by a new goal")
        handle.set_accepted("accepted")

    def _on_action_cancel(self, handle: actionlib.ServerGoalHandle) -> None:
        with self._lock:
            current = self._active is not None and handle.get_goal_id().id == self._active.get_goal_id().id
            events = self.navigator.cancel() if current else []
            if current:
                self._active = None
        self._report(events)
        if current:
            self._cmd_pub.publish(Twist())  # stop now, not at the next tick
        handle.set_canceled(MoveBaseResult(), "cancelled")

    def _on_make_plan(self, req: GetPlanRequest) -> GetPlanResponse:
        """Plan from ``req.start`` (the robot when its frame is empty) to ``req.goal`` without moving."""
        response = GetPlanResponse()
        response.plan.header.frame_id = self.config.map_frame
        response.plan.header.stamp = rospy.Time.now()
        try:
            goal = goal_in_frame(self._tf_buffer, req.goal, self.config.map_frame)
            start = (
                pose_in_frame(self._tf_buffer, req.start, self.config.map_frame)
                if req.start.header.frame_id
                else self._pose()
            )
            if start is None:
                raise InvalidInputError("no start given and no robot pose")
            with self._lock:
                request = self.navigator.plan_query(start, goal)
        except (MrsNavError, tf2_ros.TransformException) as err:
            rospy.logwarn(f"rrt_navigation: make_plan: {err}")
            return response
        cfg = self.config.navigator
        result, why = run_plan(request, self._planner, self._query_rng, cfg.inflation_m, cfg.plan_turned_round)
        if result is None:
            rospy.logwarn(f"rrt_navigation: make_plan found no path: {why}")
            return response
        response.plan = path_msg(result.path, response.plan.header.stamp, self.config.map_frame)
        return response

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

    def _blind(self, now: float) -> tuple[str | None, bool]:
        """Why the robot must stop although it has a pose: its localisation or its laser has gone quiet. Every
        reason that holds is named, so that the status says all of what is wrong, not the first one checked.
        The robot stops past the fixed limits (``~correction_freshness``, ``~scan_timeout``: safety), and the
        second value tells whether a reason has lasted past ``~stale_periods`` scan periods: only that is
        worth a warning, a shorter hold is a loaded machine's late callback, not a dead node."""
        cfg = self.config
        reasons = []
        lasting = False
        with self._lock:
            scan_period = self._scans.period
        if cfg.correction_freshness_s > 0.0:
            try:
                stamp = self._tf_buffer.lookup_transform(cfg.map_frame, cfg.odom_frame, rospy.Time(0)).header.stamp
            except tf2_ros.TransformException:
                return None, False  # no pose at all: the navigator holds for that
            age = now - stamp.to_sec()
            if not stamp.is_zero() and age > cfg.correction_freshness_s:
                freshness = cfg.correction_freshness_s
                reasons.append(
                    f"the {cfg.map_frame}->{cfg.odom_frame} correction is older than {freshness:.2f} s"
                    " (localisation lost?)"
                )
                # map->odom is re-sent far faster than it changes: the localisation's pace is the scans'
                lasting = age > max(freshness, cfg.stale_periods * (scan_period or 0.0))
        with self._lock:
            usable_age, age, scan_timeout = now - self._last_scan, now - self._scans.last, self._scans.timeout_s()
        if cfg.scan_timeout_s > 0.0 and usable_age > cfg.scan_timeout_s:
            reasons.append(f"no laser scan for more than {cfg.scan_timeout_s:.2f} s")
            lasting |= age > scan_timeout
        return "; ".join(reasons) or None, lasting

    def _warn_lasting(self, blind: str | None, lasting: bool) -> None:
        """Warn once per episode when a hold for a quiet input has lasted past ``~stale_periods`` scan periods."""
        if blind is None:
            self._warned_blind = None
        elif lasting and self._warned_blind is None:
            self._warned_blind = blind
            rospy.logwarn(f"rrt_navigation: held for more than {self.config.stale_periods:g} scan periods: {blind}")

    # -- control ----------------------------------------------------------------------------------------------

    def _on_timer(self, event: rospy.timer.TimerEvent) -> None:
        now = rospy.Time.now()
        pose = self._pose()
        blind, lasting = self._blind(now.to_sec())
        self._holding_for = blind
        with self._lock:
            finished = self._finished_plan()
            doubt = self._marking.doubt()
            command = self.navigator.update(pose, now.to_sec(), defer=True, hold=blind, doubt=doubt)
            if command.request is not None:
                self._plan = (command.request, self._planner_pool.submit(self.navigator.run_plan, command.request))
            state = self.navigator.state
            confirming = self.navigator.confirming_since is not None
            handle = self._active
            if state is not GoalState.ACTIVE:
                self._active = None
            costmap = self._due_costmap(now.to_sec())
        twist = Twist()
        twist.linear.x, twist.angular.z = command.u, command.omega
        events = finished.events + command.events
        # the heartbeat (a zero Twist every tick while idle) paces a lockstep simulator at any sim rate
        if self.config.heartbeat or state is GoalState.ACTIVE or events:
            publish_unless_shutdown(self._cmd_pub, twist, "rrt_navigation")
        path = command.path if command.path is not None else finished.path
        if path is not None:
            publish_unless_shutdown(self._path_pub, path_msg(path, now, self.config.map_frame), "rrt_navigation")
        if costmap is not None:
            costmap_msg = occupancy_grid_msg(costmap, now, self.config.map_frame)
            publish_unless_shutdown(self._costmap_pub, costmap_msg, "rrt_navigation")
        self._report(events)
        self._warn_lasting(blind, lasting)
        self._ask_for_update(now.to_sec(), confirming)
        if handle is not None:
            self._action_step(handle, state, pose, now, events)

    def _ask_for_update(self, now: float, confirming: bool) -> None:
        """While a goal reached by the estimate waits for the localisation to be confident (``confirming``), ask it
        for an update without motion about once a second of sim time: a robot standing still gets none otherwise,
        and each request brings one. From a thread of its own: the control timer never waits on the service."""
        asked, thread = self._nomotion
        if not confirming:
            self._nomotion = (-math.inf, None)
            return
        if now - asked < NOMOTION_PERIOD_S or (thread is not None and thread.is_alive()):
            return
        thread = threading.Thread(
            target=_request_nomotion_update, args=(asked == -math.inf,), name="nomotion_update", daemon=True
        )
        self._nomotion = (now, thread)
        thread.start()

    def _on_time_jump(self, seconds: float) -> str:
        """Sim time went back: abort the active goal (its deadlines and progress are of the old time line) and
        forget the stamped inputs."""
        with self._lock:
            dropped = self.navigator.cancel()  # its "goal cancelled" is reported as the failure below
            handle, self._active = self._active, None
            self._last_scan = -math.inf
            self._scans.reset()
            self._costmap = (None, -math.inf)
            self._marking.forget_time()
        if not dropped:
            return "no goal was active"
        text = f"sim time went back {seconds:.1f} s (a bag played again or the simulator restarted?); goal dropped"
        publish_unless_shutdown(self._cmd_pub, Twist(), "rrt_navigation")
        self._report([NavEvent(EventKind.FAILED, text)])
        if handle is not None:
            handle.set_aborted(MoveBaseResult(), text)
        return "active goal aborted, robot stopped"

    def _action_step(
        self,
        handle: actionlib.ServerGoalHandle,
        state: GoalState,
        pose: Pose2D | None,
        now: rospy.Time,
        events: tuple[NavEvent, ...],
    ) -> None:
        """Feedback for the active goal, or its result once it ended (outside our lock: actionlib locks too)."""
        if state is GoalState.ACTIVE:
            if pose is not None:
                feedback = MoveBaseFeedback()
                feedback.base_position.header.stamp = now
                feedback.base_position.header.frame_id = self.config.map_frame
                feedback.base_position.pose = pose_msg(pose)
                handle.publish_feedback(feedback)
            return
        text = next((e.message for e in events if e.kind in {EventKind.REACHED, EventKind.FAILED}), str(state))
        if state is GoalState.REACHED:
            handle.set_succeeded(MoveBaseResult(), text)
        else:
            handle.set_aborted(MoveBaseResult(), text)

    def _due_costmap(self, now: float) -> OccupancyGrid | None:
        """The planning grid when it changed, the last costmap is old enough and someone listens (a big grid
        costs tens of ms to serialise: not on every control tick for nobody; called with the lock held)."""
        last, when = self._costmap
        if now - when < COSTMAP_PERIOD_S or self._costmap_pub.get_num_connections() == 0:
            return None
        grid = self.navigator.inflated_grid
        if grid is None or grid is last:
            return None
        self._costmap = (grid, now)
        return grid

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
            # a hold for a quiet input is told at info level: _warn_lasting warns once it has lasted
            quiet_hold = (
                e.kind is EventKind.HOLDING and self._holding_for is not None and self._holding_for in e.message
            )
            warning = e.kind.warning and not quiet_hold
            (rospy.logwarn if warning else rospy.loginfo)(f"rrt_navigation: {e.message}")
            status = String(data=f"{STATUS_OF_EVENT[e.kind]}: {e.message}")
            publish_unless_shutdown(self._status_pub, status, "rrt_navigation")

    def _stop(self) -> None:
        """On shutdown: stop the loop and the robot (publishing can fail once rospy has closed the topic)."""
        if self._timer is not None:
            self._timer.shutdown()
        # actionlib's status timer checks rospy.is_shutdown() and then publishes, a window in which the topic can
        # close under it (a traceback at Ctrl-C). Its callback takes the server's lock and does nothing for a
        # server not started: mark it so, under that lock, before rospy closes the topics.
        with self._server.lock:
            self._server.started = False
        self._planner_pool.shutdown(wait=False)
        publish_unless_shutdown(self._cmd_pub, Twist(), "rrt_navigation")


def _request_nomotion_update(first: bool) -> None:
    """Call the localisation's ``request_nomotion_update`` if it offers one (logged at info level the ``first`` time
    of a wait)."""
    try:
        rospy.wait_for_service(NOMOTION_SERVICE, timeout=NOMOTION_WAIT_S)
        rospy.ServiceProxy(NOMOTION_SERVICE, Empty)()
    except rospy.ServiceException as err:
        rospy.logwarn(f"rrt_navigation: {NOMOTION_SERVICE} failed: {err}")
        return
    except rospy.ROSException:  # no such service (or shutting down): the wait runs out unasked
        rospy.logdebug(f"rrt_navigation: no {NOMOTION_SERVICE} service to ask for a localisation update")
        return
    (rospy.loginfo if first else rospy.logdebug)(
        f"rrt_navigation: asked the localisation for an update without motion ({NOMOTION_SERVICE})"
    )
