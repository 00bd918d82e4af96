"""Navigating to a goal on a live occupancy grid: the ROS-free state machine behind ``rrt_navigation``.

A :class:`Navigator` owns one goal at a time. It is fed the latest map (:meth:`Navigator.set_map`), goals
(:meth:`Navigator.set_goal`) and, at the control rate, the robot's pose in the map frame
(:meth:`Navigator.update`, ``None`` when the pose is unknown); it answers with wheel commands, a new path
to publish when it has one, and events (goal accepted, refused, planned, reached, failed, ...).

It composes three parts, each in its own module: the goal state machine (:mod:`.goal`), the replanning policy
(:mod:`.replanning`) and planning in a worker (:mod:`.plan_worker`); a :class:`PathFollower` drives the path.
With ``allow_unknown`` (as move_base's option of that name) unknown cells count as free, so a goal in a room
SLAM has not seen yet gets an optimistic plan that is repaired as the map reveals it.

Within ``approach_radius_m`` of the goal the path is left to a :class:`GoalApproach`, which drives the axle
onto the goal position (``xy_tolerance_m``) and then turns to the goal heading, if the goal has one
(``yaw_tolerance_rad``): then the goal is reached. Laser scans (:meth:`Navigator.set_scan`) mark obstacles that
are not on the map for planning (:mod:`.obstacles`; a path they block is replanned) and a return ahead closer
than the robot radius plus ``stop_clearance_m`` stops the robot and makes a new plan. Without a pose, when the
caller says why to hold (e.g. a stale localisation), or when the last map is older than ``map_timeout_s``, the
robot is stopped and the goal kept (a ``HOLDING`` event names why, and again whenever the reason changes); it
resumes when all are back. Before a goal is given up for failed plans or lack of progress, the recoveries of
:mod:`.recovery` run (clearing marks, a turn on the spot). A goal reached on a pose the caller doubts (``doubt``:
a localisation not confident) holds the robot (``HOLDING``, :attr:`Navigator.confirming_since`) up to
``confirm_timeout_s`` for the doubt to go: reached then, else FAILED with that reason. Times are in seconds of
the caller's clock (sim time in ROS), distances in metres, angles in radians.

With ``update(pose, now, defer=True)`` a needed plan is returned as a :class:`PlanRequest` for a worker
(:meth:`run_plan`, then :meth:`finish_plan`). Meanwhile the robot follows the current path when the plan is only
an offer (``periodic``) or replaces a path that a new map blocks further on (``blocked``), up to
``inflation_m`` plus a cell short of the first point of it that the robot would touch
(:attr:`Navigator.collision_grid`), and stands still otherwise; no other plan is started. Why: every point of
the path before that one is clear of the walls by the robot's radius, and a planner's time budget is wall-clock
time, which at a high sim rate would be seconds of standing still each time the map grows across the path. A
new goal, a cancel or reaching the goal discards the request in flight: its outcome is then ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.control.goal_approach import GoalApproach
from mrs_nav.control.path_following import PathFollower
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, format_point, wrap_angle
from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.navigation.config import NavigatorConfig
from mrs_nav.navigation.goal import EventKind, GoalState, GoalTracker, NavEvent, NavGoal, goal_refusal
from mrs_nav.navigation.obstacles import ScanObstacles, return_ahead
from mrs_nav.navigation.plan_worker import (
    PLANNERS,
    Planner,
    PlanOutcome,
    PlanRequest,
    cell_centres,
    clear_footprint,
    rrt_planner,
    run_plan,
)
from mrs_nav.navigation.recovery import Recoveries, RecoveryBehavior, Rotation
from mrs_nav.navigation.replanning import ReplanPolicy, densify, first_blocked_point
from mrs_nav.planning import PlanResult, path_length

__all__ = [
    "PLANNERS",
    "EventKind",
    "GoalState",
    "NavCommand",
    "NavEvent",
    "NavGoal",
    "Navigator",
    "NavigatorConfig",
    "PlanOutcome",
    "PlanRequest",
    "Planner",
    "cell_centres",
    "clear_footprint",
    "densify",
    "rrt_planner",
]


@dataclass(frozen=True)
class NavCommand:
    """The answer to :meth:`Navigator.update`: commands (m/s, rad/s), a new path to publish (``(N, 3)``) when
    the plan changed, and the events of this step."""

    u: float
    omega: float
    path: FloatArray | None = None
    events: tuple[NavEvent, ...] = ()
    request: PlanRequest | None = None


class Navigator:
    """The navigation state machine; see the module docstring. Not thread-safe: call it from one thread."""

    def __init__(self, planner: Planner, config: NavigatorConfig | None = None, seed: int | None = None) -> None:
        self.planner = planner
        self.config = config or NavigatorConfig()
        self.rng = np.random.default_rng(seed)
        self._goal = GoalTracker()
        self._policy = ReplanPolicy(self.config)
        self.path: FloatArray | None = None
        self.last_plan: PlanResult | None = None
        self.plans_made = 0
        self._grid: OccupancyGrid | None = None
        cfg = self.config
        self._obstacles = ScanObstacles(
            mark_unknown=cfg.mark_unknown, obstacle_range_m=cfg.obstacle_range_m, raytrace_range_m=cfg.raytrace_range_m
        )
        self._marked_grid: OccupancyGrid | None = None
        self._returns: FloatArray = np.zeros((0, 2))
        self._approach: GoalApproach | None = None
        self._grown: dict[float, OccupancyGrid] = {}  # the marked map's obstacles grown by so much (m)
        self._map_stamp = -math.inf
        self._follower: PathFollower | None = None
        self._holding: str | None = None  # why the robot is held, as last reported
        self._pending: PlanRequest | None = None
        self._recoveries = Recoveries(cfg.recovery)
        self._rotation: Rotation | None = None  # a rotate_recovery under way
        self.confirming_since: float | None = None  # when the wait at a goal reached on a pose in doubt began

    @property
    def state(self) -> GoalState:
        return self._goal.state

    @property
    def goal(self) -> tuple[float, float] | None:
        """The position (m) of the current goal, None without one."""
        return None if self._goal.goal is None else self._goal.goal.position

    # -- inputs -------------------------------------------------------------------------------------------

    def set_map(self, grid: OccupancyGrid, now: float) -> None:
        """Take a new map (raw occupancy, not inflated) received at time ``now``."""
        self._grid = grid
        self._obstacles.set_map(grid)
        self._marked_grid = None
        self._grown = {}
        self._map_stamp = now
        self._policy.new_map()

    def set_scan(self, origin: npt.ArrayLike, ends: npt.ArrayLike, hit: npt.ArrayLike, mark: bool = True) -> None:
        """Take a laser scan in the map frame: the laser's position ``origin`` (``(2,)``), the beam end points
        ``ends`` (``(N, 2)``, at the return or the maximum range) and ``hit`` (``(N,)`` bool, a return). Without
        ``mark`` it only clears (:mod:`.marking`: the pose that placed it is not trusted)."""
        ends = np.asarray(ends, dtype=np.float64).reshape(-1, 2)
        self._returns = ends[np.asarray(hit, dtype=bool)]
        if self._obstacles.add_scan(origin, ends, hit, mark):
            self._marks_changed()

    def clear_marks(self, around: npt.ArrayLike | None = None, beyond_m: float = 0.0) -> int:
        """Drop the marks farther than ``beyond_m`` from ``around`` (None: all; move_base's ``clear_costmaps``);
        how many cells were unmarked."""
        cleared = self._obstacles.clear(around, beyond_m)
        if cleared:
            self._marks_changed()
        return cleared

    def _marks_changed(self) -> None:
        self._marked_grid = None
        self._grown = {}
        self._policy.new_map()

    @property
    def grid(self) -> OccupancyGrid | None:
        """The last map received, raw."""
        return self._grid

    @property
    def marked_grid(self) -> OccupancyGrid | None:
        """The last map with the obstacles seen by the laser marked occupied."""
        if self._grid is None:
            return None
        if self._marked_grid is None:
            self._marked_grid = self._obstacles.apply(self._grid)
        return self._marked_grid

    @property
    def inflated_grid(self) -> OccupancyGrid | None:
        """The last map as planned on: marked, inflated, unknown made free when ``allow_unknown``."""
        return self._grown_grid(self.config.inflation_m)

    @property
    def collision_grid(self) -> OccupancyGrid | None:
        """The last map as the robot itself would touch it: marked, obstacles grown by ``robot_radius`` alone (not
        ``safety_margin_m``), unknown made free when ``allow_unknown``. A path is blocked only where it crosses
        this (:mod:`.replanning`): plans keep the whole inflation from obstacles, and the safety margin between the
        two grids is hysteresis, as the inscribed radius is for move_base (only a lethal or inscribed cell makes a
        path invalid there; the rest of its inflation is cost)."""
        return self._grown_grid(self.config.robot_radius)

    def _grown_grid(self, inflation_m: float) -> OccupancyGrid | None:
        """The marked map with its obstacles grown by ``inflation_m`` (m), unknown made free when ``allow_unknown``
        (kept until the map or the marks change)."""
        marked = self.marked_grid
        if marked is None:
            return None
        grid = self._grown.get(inflation_m)
        if grid is None:
            grid = self._grown[inflation_m] = planning_grid(marked, inflation_m, self.config.allow_unknown)
        return grid

    @property
    def goal_yaw(self) -> float | None:
        """The heading (rad) the current goal asks for, None when any will do (or without a goal)."""
        return None if self._goal.goal is None else self._goal.goal.yaw

    def set_goal(self, goal: NavGoal, now: float) -> list[NavEvent]:
        """Ask to go to ``goal`` (map frame). A goal the map admits preempts the current one; another is refused
        and leaves the current goal (if any) running."""
        refusal = goal_refusal(self.marked_grid, self.inflated_grid, goal, inflation_m=self.config.inflation_m)
        if refusal is not None:
            return [NavEvent(EventKind.REFUSED, f"goal {format_point(goal.x, goal.y)} refused: {refusal}")]
        events = self._goal.accept(goal)
        self._reset_goal()
        self._policy.new_goal(now)
        return events

    def cancel(self) -> list[NavEvent]:
        """Drop the current goal (the robot stops at the next update)."""
        self._reset_goal()
        return self._goal.cancel()

    def _reset_goal(self) -> None:
        self.path = None
        self._follower = None
        self._approach = None
        self._holding = None
        self._pending = None  # a plan in flight for this goal is now stale
        self._rotation = None
        self.confirming_since = None
        self._recoveries.reset()

    def _end(self, state: GoalState) -> None:
        self._reset_goal()
        self._goal.end(state)

    @property
    def planning(self) -> bool:
        """Whether a deferred plan is in flight (asked for and not yet finished)."""
        return self._pending is not None

    # -- the control step ---------------------------------------------------------------------------------

    def update(
        self, pose: Pose2D | None, now: float, defer: bool = False, hold: str | None = None, doubt: str | None = None
    ) -> NavCommand:
        """One control step for the robot at ``pose`` (map frame; ``None`` when unknown) at time ``now``. With
        ``defer`` a needed plan is not made here but returned as the command's ``request`` (module docstring);
        ``hold`` (why; a text that stays the same while the cause lasts) stops the robot and keeps the goal, as a
        lost pose does; ``doubt`` (why the pose is not trusted, e.g. a localisation not confident) keeps a goal
        reached at that pose from being reached: it waits up to ``confirm_timeout_s``, then ends FAILED."""
        if not self._goal.active:
            return NavCommand(0.0, 0.0)
        hold = hold or self._hold_reason(pose, now)
        if hold is not None:
            if hold == self._holding:
                return NavCommand(0.0, 0.0)
            self._holding = hold
            return NavCommand(0.0, 0.0, events=(NavEvent(EventKind.HOLDING, f"stopped: {hold}"),))
        assert pose is not None
        assert self.goal is not None
        events: list[NavEvent] = []
        if self._holding is not None:
            self._holding = None
            events.append(NavEvent(EventKind.RESUMED, "pose and map are back; resuming"))
        distance = math.hypot(self.goal[0] - pose.x, self.goal[1] - pose.y)
        moved_off = self.confirming_since is not None and distance > self.config.approach.xy_tolerance_m  # re-approach
        if (self._approach is None and distance <= self.config.approach_radius_m) or moved_off:
            self._approach = GoalApproach(*self.goal, self.goal_yaw, self.config.approach)
        if self._approach is not None:
            return self._approach_step(pose, now, distance, events, doubt)
        if self._policy.note_distance(distance, now):
            self._recoveries.reset()
        if self._rotation is not None and self._pending is None:
            omega = self._rotation.command(pose, now)
            if omega is not None:
                return NavCommand(0.0, omega, events=tuple(events))
            self._rotation = None

        new_path: FloatArray | None = None
        request: PlanRequest | None = None
        reason = None if self._pending is not None else self.replan_reason(pose, now)
        if reason == "stuck":
            timeout = self.config.progress_timeout_s
            if not self._recover(pose, now, f"no progress for {timeout:.0f} s", events):
                self._end_failed(f"no progress for {timeout:.0f} s", events)
                return NavCommand(0.0, 0.0, events=tuple(events))
            if self._rotation is not None:
                return NavCommand(0.0, self._rotation.command(pose, now) or 0.0, events=tuple(events))
        if reason is None and self._pending is None and self._follower is not None and self._driving_into(pose):
            reason = "obstacle ahead"
        if reason is not None:
            request = self._request(pose, now, reason)
            if defer:
                self._pending = request
            else:
                new_path = self._adopt(request, self.run_plan(request), events)
                request = None
                if self.state is not GoalState.ACTIVE:
                    return NavCommand(0.0, 0.0, new_path, tuple(events))
        if self._follower is None:  # no valid plan: wait for the next attempt (or the plan in flight)
            return NavCommand(0.0, 0.0, new_path, tuple(events), request)
        command = self._follower.command(pose)
        if command.u > 0.0 and (self._driving_into(pose) or self._at_blockage(pose)):  # wait for the plan, stopped
            return NavCommand(0.0, 0.0, new_path, tuple(events), request)
        return NavCommand(command.u, command.omega, new_path, tuple(events), request)

    def _driving_into(self, pose: Pose2D) -> bool:
        """Whether a laser return lies in the robot's way closer than its radius plus the stop clearance."""
        cfg = self.config
        if not return_ahead(pose, self._returns, cfg.robot_radius, cfg.stop_clearance_m):
            return False
        assert self._follower is not None
        return self._follower.command(pose).u > 0.0

    def _at_blockage(self, pose: Pose2D) -> bool:
        """Whether, with a plan in flight, the robot at ``pose`` is as close as it may come to the first point of
        its path that the latest map blocks (module docstring)."""
        if self._pending is None or self._follower is None:
            return False
        grid, raw = self._maps(self.collision_grid)
        rest = self._follower.points[self._follower.segment :]
        # No exception near the robot: one within its radius of an obstacle stands still, as for any other plan.
        point = first_blocked_point(grid, raw, rest, pose, near_m=0.0)
        margin = self.config.inflation_m + grid.resolution
        return point is not None and math.hypot(point[0] - pose.x, point[1] - pose.y) <= margin

    def _approach_step(
        self, pose: Pose2D, now: float, distance: float, events: list[NavEvent], doubt: str | None
    ) -> NavCommand:
        """Drive the last centimetres, turn to the heading: reached when done on a trusted pose (:meth:`_confirm`)."""
        assert self._approach is not None
        step = self._approach.command(pose, now)
        if step.done:
            what = self._goal.describe()
            yaw = self.goal_yaw
            heading = "" if yaw is None else f" and {abs(wrap_angle(yaw - pose.yaw)):.3f} rad"
            where = f"{distance:.3f} m{heading} away"
            if doubt is not None:
                self._confirm(now, f"{what} failed: reached by the estimate ({where}) but {doubt}", events)
            else:
                self._end(GoalState.REACHED)
                events.append(NavEvent(EventKind.REACHED, f"{what} reached, {where}"))
            return NavCommand(0.0, 0.0, events=tuple(events))
        self.confirming_since = None  # the estimate moved off the goal: a new wait when the approach is done again
        cfg = self.config
        u = step.u
        if u > 0.0 and return_ahead(pose, self._returns, cfg.robot_radius, cfg.stop_clearance_m):
            u = 0.0  # turning on the spot is safe for a round robot; driving on is not
        return NavCommand(u, step.omega, events=tuple(events))

    def _confirm(self, now: float, failure: str, events: list[NavEvent]) -> None:
        """Reached on a pose in doubt: hold up to ``confirm_timeout_s`` (a robot standing still gets no new estimate
        unless the caller asks for one while :attr:`confirming_since`), then fail with ``failure``."""
        timeout = self.config.confirm_timeout_s
        if self.confirming_since is None:
            self.confirming_since = now
            if timeout > 0.0:
                wait = f"waiting up to {timeout:.1f} s for the localisation to be confident"
                events.append(NavEvent(EventKind.HOLDING, f"{self._goal.describe()} reached by the estimate; {wait}"))
        if now - self.confirming_since >= timeout:
            waited = f" (waited {now - self.confirming_since:.1f} s for it to be confident)" if timeout > 0.0 else ""
            self._end(GoalState.FAILED)
            events.append(NavEvent(EventKind.FAILED, failure + waited))

    def _hold_reason(self, pose: Pose2D | None, now: float) -> str | None:
        if pose is None:
            return "no robot pose in the map frame"
        if self._grid is None:
            return "no map"
        timeout = self.config.map_timeout_s
        if timeout > 0.0 and now - self._map_stamp > timeout:
            return f"the map is older than {timeout:.1f} s"
        return None

    def replan_reason(self, pose: Pose2D, now: float) -> str | None:
        """Why the next :meth:`update` at ``pose`` will plan (``None``: it will not)."""
        if not self._goal.active:
            return None
        grid, raw = self._maps(self.collision_grid)
        return self._policy.reason(self._follower, pose, now, grid, raw)

    def _maps(self, grid: OccupancyGrid | None = None) -> tuple[OccupancyGrid, OccupancyGrid]:
        """``grid`` (default: the planning grid) and the raw map (only called once a map is known)."""
        grid, raw = grid or self.inflated_grid, self.marked_grid
        if grid is None or raw is None:
            raise InvalidInputError("no map received yet")
        return grid, raw

    def _request(self, pose: Pose2D, now: float, reason: str) -> PlanRequest:
        """Start a plan for ``reason``: the bookkeeping of an attempt, and what the planner needs."""
        assert self.goal is not None
        grid, raw = self._maps()
        remaining = math.inf
        if reason == "periodic" and self._follower is not None:
            rest = self._follower.points[self._follower.segment :]
            remaining = path_length(np.vstack(([pose.x, pose.y], rest[:, :2])))
        elif reason != "blocked":
            # the current path is unusable: stop following it whatever the outcome
            self._follower = None
            self.path = None
        self._policy.started(now)
        return PlanRequest(self.goal, pose, now, reason, grid, raw, remaining)

    def plan_query(self, start: Pose2D, goal: NavGoal) -> PlanRequest:
        """A request to plan from ``start`` to ``goal`` on the current map that leaves the navigator's own goal
        alone (move_base's ``make_plan``); run it with :func:`~mrs_nav.navigation.plan_worker.run_plan` and a
        generator of its own. Raises :class:`InvalidInputError` for a goal :meth:`set_goal` would refuse."""
        refusal = goal_refusal(self.marked_grid, self.inflated_grid, goal, inflation_m=self.config.inflation_m)
        if refusal is not None:
            raise InvalidInputError(f"goal {format_point(goal.x, goal.y)}: {refusal}")
        grid, raw = self._maps()
        return PlanRequest(goal.position, start, math.nan, "make_plan", grid, raw, math.inf)

    def run_plan(self, request: PlanRequest) -> PlanOutcome:
        """Plan for ``request`` (:func:`~mrs_nav.navigation.plan_worker.run_plan`). Reads only the request, the
        planner and the random generator, so it may run in another thread while :meth:`update` runs (with
        ``defer``: no other plan is made meanwhile)."""
        cfg = self.config
        return run_plan(request, self.planner, self.rng, cfg.inflation_m, cfg.plan_turned_round)

    def finish_plan(self, request: PlanRequest, outcome: PlanOutcome) -> NavCommand:
        """Take the ``outcome`` of the deferred ``request``: the new path (``path``, when adopted) and the events;
        the commands are zero (the next :meth:`update` gives them). A stale request is ignored."""
        if request is not self._pending:
            return NavCommand(0.0, 0.0)
        self._pending = None
        events: list[NavEvent] = []
        path = self._adopt(request, outcome, events)
        return NavCommand(0.0, 0.0, path, tuple(events))

    def _adopt(self, request: PlanRequest, outcome: PlanOutcome, events: list[NavEvent]) -> FloatArray | None:
        """Apply the outcome of ``request``: count a failure (and fail the goal after too many), or adopt the
        path (an optional plan only when clearly shorter than the rest of the current path)."""
        result, why = outcome
        reason, optional = request.reason, request.optional
        if result is None:
            if optional:
                return None
            self._follower = None  # a blocked path is not followed on after its replacement failed
            self.path = None
            failed = self._policy.failed()
            limit = self.config.max_failed_plans
            events.append(
                NavEvent(EventKind.PLAN_FAILED, f"planning ({reason}) failed ({self._policy.failures}/{limit}): {why}")
            )
            if failed and not self._recover(request.pose, request.now, f"{limit} failed plans", events):
                self._end_failed(f"{limit} plans failed", events, f"; last: {why}")
            return None
        path = self._with_goal(result.path)
        if (
            optional
            and self._follower is not None
            and not self._policy.worth_adopting(request.remaining_m, path_length(path))
        ):
            return None
        self._policy.adopted(reason, request.now)
        self.path = path
        self.last_plan = result
        self.plans_made += 1
        self._follower = PathFollower(path, self.config.follower)
        events.append(
            NavEvent(
                EventKind.PLANNED, f"planned ({reason}): {path_length(path):.2f} m in {result.time_s * 1e3:.0f} ms"
            )
        )
        return path

    def _recover(self, pose: Pose2D, now: float, why: str, events: list[NavEvent]) -> bool:
        """Start the next recovery behaviour (:mod:`.recovery`) for the robot at ``pose``; False when none is
        left."""
        behavior = self._recoveries.next()
        if behavior is None:
            return False
        cfg = self.config.recovery
        if behavior is RecoveryBehavior.CONSERVATIVE_RESET:
            count = self.clear_marks((pose.x, pose.y), cfg.conservative_reset_dist_m)
            what = f"cleared {count} marked cells farther than {cfg.conservative_reset_dist_m:.2f} m"
        elif behavior is RecoveryBehavior.AGGRESSIVE_RESET:
            what = f"cleared all {self.clear_marks()} marked cells"
        else:
            self._rotation = Rotation(cfg, now)
            what = "turning a full circle on the spot"
        self._follower = None
        self.path = None
        self._policy.recovered(now)
        step = self._recoveries.describe()
        events.append(NavEvent(EventKind.RECOVERY, f"recovery {step} ({behavior.value}) after {why}: {what}"))
        return True

    def _end_failed(self, why: str, events: list[NavEvent], last: str = "") -> None:
        """Abort the goal for ``why``, naming the recoveries tried in vain."""
        tried = ", ".join(b.value for b in self._recoveries.tried)
        after = f" after recoveries ({tried})" if tried else ""
        what = self._goal.describe()
        self._end(GoalState.FAILED)
        events.append(NavEvent(EventKind.FAILED, f"{what} failed: {why}{after}{last}"))

    def _with_goal(self, path: FloatArray) -> FloatArray:
        """The planned path, ending exactly at the goal (planners stop within their own tolerance of it)."""
        assert self.goal is not None
        path = np.asarray(path, dtype=np.float64).reshape(-1, 3)
        gx, gy = self.goal
        end = path[-1]
        gap = math.hypot(gx - end[0], gy - end[1])
        if gap < 0.01:
            return path
        yaw = math.atan2(gy - end[1], gx - end[0])
        return np.vstack((path, [[gx, gy, yaw]]))
