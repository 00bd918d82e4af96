"""Navigating to a goal on a live occupancy grid: the ROS-free state machine behind ``rrt_navigation``.

A :class:`Navigator` owns one goal at a time. It is fed the latest map (:meth:`Navigator.set_map`), goals
(:meth:`Navigator.set_goal`) and, at the control rate, the robot's pose in the map frame
(:meth:`Navigator.update`, ``None`` when the pose is unknown); it answers with wheel commands, a new path
to publish when it has one, and events (goal accepted, refused, planned, reached, failed, ...).

Planning (with any :class:`Planner`, RRT* by default in the nodes) happens on the map inflated by the robot
radius plus a safety margin. With ``allow_unknown`` (as move_base's option of that name) unknown cells count as
free, so a goal in a room SLAM has not seen yet gets an optimistic plan that is repaired as the map reveals it.
The cells within the inflation distance of the robot itself are cleared of inflation before planning, so a
robot that has drifted close to a wall can still plan its way out.

A new plan is made when (in order):

* there is none (a new goal, or the last attempt failed);
* occupied cells of a new map lie on the rest of the path (``blocked``);
* the robot is farther than ``stray_distance_m`` from the rest of the path (``strayed``);
* the distance to the goal has not shrunk by ``progress_m`` for ``progress_timeout_s`` (``stuck``);
* every ``replan_period_s`` once the map has changed since the last plan (``periodic``). Such a plan is only
  an offer: it replaces the current path only if it is clearly shorter than what is left of it (shorter than
  ``improvement_ratio`` times the remaining length and by at least ``improvement_min_m``), so the robot does
  not oscillate between plans of about the same length.

Every failed attempt of the first four kinds (planner exception or no path) counts; the next attempt comes
``retry_delay_s`` later (the robot waits, stopped) and ``max_failed_plans`` failures in a row end the goal as
failed. The goal is reached when the robot is within ``goal_tolerance_m``
of it and the follower has brought its holonomic point to rest at the end of the path (or the robot is within
half the tolerance). Without a pose, or when the last map is older than ``map_timeout_s``, the robot is
stopped and the goal kept; it resumes when both are back. Times are in seconds of the caller's clock (sim
time in ROS), distances in metres.

Planning can run off the control loop: ``update(pose, now, defer=True)`` does not plan but returns a
:class:`PlanRequest` in its command; the caller runs :meth:`Navigator.run_plan` on it (in a worker thread: it
reads only the request and the planner) and hands the outcome to :meth:`Navigator.finish_plan` on a later step,
which applies the same rules as a synchronous plan. Meanwhile the robot follows the current path when the plan
is only an offer (``periodic``) and stands still otherwise (the path is gone or unusable), and no other plan is
started. A new goal, a cancel or reaching the goal discards the request in flight: its outcome is then ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Protocol

import numpy as np
import numpy.typing as npt

from mrs_nav.control.path_following import FollowerConfig, PathFollower, cross_track_distance
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.geometry import FloatArray, Pose2D, wrap_angle
from mrs_nav.maps.occupancy_grid import FREE, OCCUPIED, OccupancyGrid, planning_grid
from mrs_nav.planning import PlanResult, path_length
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.trees.rrt import RRTConfig, rrt
from mrs_nav.trees.rrt_star import RRTStarConfig, rrt_star


class Planner(Protocol):
    """Plans from ``start`` to the position ``goal`` on ``grid`` (already inflated; plan only on free cells).

    Returns a :class:`PlanResult` whose ``path`` is ``(N, 3)`` poses; may raise :class:`MrsNavError` (e.g. the
    start or goal is not free). ``rng`` seeds any randomness.
    """

    def __call__(
        self, grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng: np.random.Generator
    ) -> PlanResult: ...


class GoalState(Enum):
    """Where the current (or last) goal stands; the values are those of ``actionlib_msgs/GoalStatus``."""

    IDLE = 0  # no goal yet (GoalStatus.PENDING)
    ACTIVE = 1
    PREEMPTED = 2
    REACHED = 3  # GoalStatus.SUCCEEDED
    FAILED = 4  # GoalStatus.ABORTED
    REFUSED = 5  # GoalStatus.REJECTED


class EventKind(Enum):
    """What happened; ``warning`` kinds are those a node logs as warnings."""

    ACCEPTED = "accepted"
    REFUSED = "refused"
    PREEMPTED = "preempted"
    PLANNED = "planned"
    PLAN_FAILED = "plan_failed"
    REACHED = "reached"
    FAILED = "failed"
    HOLDING = "holding"
    RESUMED = "resumed"
    CANCELLED = "cancelled"

    @property
    def warning(self) -> bool:
        return self in {EventKind.REFUSED, EventKind.PLAN_FAILED, EventKind.FAILED, EventKind.HOLDING}


@dataclass(frozen=True)
class NavEvent:
    """One thing worth reporting, with a one-line human-readable ``message``."""

    kind: EventKind
    message: str


@dataclass(frozen=True)
class NavCommand:
    """The answer to :meth:`Navigator.update`: commands (m/s, rad/s), a new path to publish (``(N, 3)``) when
    the plan changed, and the events of this step."""

    u: float
    omega: float
    path: FloatArray | None = None
    events: tuple[NavEvent, ...] = ()
    request: PlanRequest | None = None


@dataclass(frozen=True, eq=False)
class PlanRequest:
    """One plan to make (see :meth:`Navigator.run_plan`): from ``pose`` to ``goal`` on ``grid`` (inflated) and
    ``raw`` (the same map before inflation), asked at ``now`` for ``reason``; ``remaining_m`` is what was left of
    the current path then (from the robot), which an optional plan must clearly beat. Compared by identity."""

    goal: tuple[float, float]
    pose: Pose2D
    now: float
    reason: str
    grid: OccupancyGrid
    raw: OccupancyGrid
    remaining_m: float

    @property
    def optional(self) -> bool:
        """Whether the current path stays usable (the new plan is only an offer)."""
        return self.reason == "periodic"


# What planning answered: the best result (None when none) and, without one, why.
PlanOutcome = tuple[PlanResult | None, str]


@dataclass(frozen=True)
class NavigatorConfig:
    """Parameters of :class:`Navigator` (metres, seconds)."""

    robot_radius: float = BURGER_RADIUS
    # Added to the robot radius when inflating the map: the planners keep exactly the inflated distance from
    # obstacles, and the follower's cross-track error and the SLAM pose error eat into it.
    safety_margin_m: float = 0.1
    goal_tolerance_m: float = 0.2
    allow_unknown: bool = True
    stray_distance_m: float = 0.3
    replan_period_s: float = 5.0
    improvement_ratio: float = 0.85
    improvement_min_m: float = 0.2
    max_failed_plans: int = 5
    # Also plan from the robot turned round on the spot and keep the shorter plan: arcs run forward only, so a
    # goal behind the robot otherwise costs a loop.
    plan_turned_round: bool = True
    retry_delay_s: float = 1.0
    progress_m: float = 0.1
    progress_timeout_s: float = 30.0
    map_timeout_s: float = 0.0  # 0 = off: a static map (published once, latched) never refreshes
    follower: FollowerConfig = field(default_factory=FollowerConfig)

    def __post_init__(self) -> None:
        for name in ("goal_tolerance_m", "stray_distance_m", "replan_period_s", "improvement_ratio", "progress_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"navigator {name} must be a positive number, got {value}")
        for name in (
            "robot_radius",
            "safety_margin_m",
            "improvement_min_m",
            "retry_delay_s",
            "progress_timeout_s",
            "map_timeout_s",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise InvalidInputError(f"navigator {name} must be a number >= 0, got {value}")
        if self.max_failed_plans < 1:
            raise InvalidInputError(f"navigator max_failed_plans must be >= 1, got {self.max_failed_plans}")

    @property
    def inflation_m(self) -> float:
        """How far (m) obstacles are grown for planning: the robot radius plus the safety margin."""
        return self.robot_radius + self.safety_margin_m


def cell_centres(grid: OccupancyGrid, rows: npt.ArrayLike, cols: npt.ArrayLike) -> FloatArray:
    """``(N, 2)`` map coordinates (m) of the centres of the cells ``(rows[i], cols[i])`` of ``grid``."""
    u = (np.asarray(cols, dtype=np.float64) + 0.5) * grid.resolution
    v = (np.asarray(rows, dtype=np.float64) + 0.5) * grid.resolution
    x0, y0, yaw = grid.origin
    c, s = math.cos(yaw), math.sin(yaw)
    return np.stack([x0 + c * u - s * v, y0 + s * u + c * v], axis=-1)


def clear_footprint(grid: OccupancyGrid, raw: OccupancyGrid, position: npt.ArrayLike, radius: float) -> OccupancyGrid:
    """``grid`` with the cells within ``radius`` of ``position`` that are occupied only by inflation (not in
    ``raw``, the same grid before inflation) made free."""
    p = np.asarray(position, dtype=np.float64)[:2]
    reach = radius + grid.resolution
    rows, cols, _ = grid.cells_of(np.array([p - reach, p + reach]))
    r0, r1, c0, c1 = rows[0], rows[1] + 1, cols[0], cols[1] + 1
    rr, cc = np.mgrid[r0:r1, c0:c1]
    centres = cell_centres(grid, rr.ravel(), cc.ravel())
    near = np.hypot(*(centres - p).T) <= reach
    rr, cc = rr.ravel()[near], cc.ravel()[near]
    inflated_only = (grid.values[rr, cc] >= OCCUPIED) & ~raw.occupied_mask[rr, cc]
    if not np.any(inflated_only):
        return grid
    values = grid.values.copy()
    values[rr[inflated_only], cc[inflated_only]] = FREE
    return OccupancyGrid(values, grid.resolution, grid.origin)


class Navigator:
    """The navigation state machine; see the module docstring. Not thread-safe: call it from one thread."""

    def __init__(self, planner: Planner, config: NavigatorConfig | None = None, seed: int | None = None) -> None:
        self.planner = planner
        self.config = config or NavigatorConfig()
        self.rng = np.random.default_rng(seed)
        self.state = GoalState.IDLE
        self.goal: tuple[float, float] | None = None
        self.path: FloatArray | None = None
        self.last_plan: PlanResult | None = None
        self.plans_made = 0
        self._grid: OccupancyGrid | None = None
        self._plan_grid: OccupancyGrid | None = None
        self._map_stamp = -math.inf
        self._map_version = 0
        self._checked_version = 0  # map version the current path was last checked against
        self._planned_version = 0  # map version the current path was planned on
        self._follower: PathFollower | None = None
        self._failures = 0
        self._last_plan_time = -math.inf
        self._best_distance = math.inf
        self._progress_time = 0.0
        self._holding = False
        self._pending: PlanRequest | None = None

    # -- inputs -------------------------------------------------------------------------------------------

    def set_map(self, grid: OccupancyGrid, now: float) -> None:
        """Take a new map (raw occupancy, not inflated) received at time ``now``."""
        self._grid = grid
        self._plan_grid = None
        self._map_stamp = now
        self._map_version += 1

    @property
    def grid(self) -> OccupancyGrid | None:
        """The last map received, raw."""
        return self._grid

    @property
    def inflated_grid(self) -> OccupancyGrid | None:
        """The last map as planned on: inflated, unknown made free when ``allow_unknown``."""
        if self._grid is None:
            return None
        if self._plan_grid is None:
            cfg = self.config
            self._plan_grid = planning_grid(self._grid, cfg.inflation_m, cfg.allow_unknown)
        return self._plan_grid

    def set_goal(self, x: float, y: float, now: float) -> list[NavEvent]:
        """Ask to go to ``(x, y)`` (map frame). A valid goal preempts the current one; a bad one is refused and
        leaves the current goal (if any) running."""
        refusal = self._refusal(x, y)
        if refusal is not None:
            return [NavEvent(EventKind.REFUSED, f"goal ({x:.2f}, {y:.2f}) refused: {refusal}")]
        events = []
        if self.state is GoalState.ACTIVE and self.goal is not None:
            gx, gy = self.goal
            events.append(NavEvent(EventKind.PREEMPTED, f"goal ({gx:.2f}, {gy:.2f}) preempted by a new goal"))
        self._reset_goal()
        self.goal = (float(x), float(y))
        self.state = GoalState.ACTIVE
        self._progress_time = now
        events.append(NavEvent(EventKind.ACCEPTED, f"goal ({x:.2f}, {y:.2f}) accepted"))
        return events

    def cancel(self) -> list[NavEvent]:
        """Drop the current goal (the robot stops at the next update)."""
        if self.state is not GoalState.ACTIVE:
            return []
        self._reset_goal()
        self.state = GoalState.PREEMPTED
        return [NavEvent(EventKind.CANCELLED, "goal cancelled")]

    def _refusal(self, x: float, y: float) -> str | None:
        if not (math.isfinite(x) and math.isfinite(y)):
            return "its position is not a finite number"
        grid = self.inflated_grid
        if grid is None or self._grid is None:
            return "no map received yet"
        goal = np.array([[x, y]])
        _, _, inside = grid.cells_of(goal)
        if not inside[0]:
            return "it lies outside the map"
        if self._grid.is_occupied(goal)[0]:
            return "it lies inside an obstacle"
        if grid.is_occupied(goal)[0]:
            return f"it lies within {self.config.inflation_m:.3f} m (robot radius + margin) of an obstacle"
        if not grid.is_free(goal)[0]:
            return "it lies in unknown space and allow_unknown is off"
        return None

    def _reset_goal(self) -> None:
        self.goal = None
        self.path = None
        self._follower = None
        self._failures = 0
        self._last_plan_time = -math.inf
        self._best_distance = math.inf
        self._holding = False
        self._pending = None  # a plan in flight for this goal is now stale

    @property
    def planning(self) -> bool:
        """Whether a deferred plan is in flight (asked for and not yet finished)."""
        return self._pending is not None

    # -- the control step ---------------------------------------------------------------------------------

    def update(self, pose: Pose2D | None, now: float, defer: bool = False) -> NavCommand:
        """One control step for the robot at ``pose`` (map frame; ``None`` when unknown) at time ``now``. With
        ``defer`` a needed plan is not made here but returned as the command's ``request`` (module docstring)."""
        if self.state is not GoalState.ACTIVE or self.goal is None:
            return NavCommand(0.0, 0.0)
        hold = self._hold_reason(pose, now)
        if hold is not None:
            if self._holding:
                return NavCommand(0.0, 0.0)
            self._holding = True
            return NavCommand(0.0, 0.0, events=(NavEvent(EventKind.HOLDING, f"stopped: {hold}"),))
        assert pose is not None
        events: list[NavEvent] = []
        if self._holding:
            self._holding = False
            events.append(NavEvent(EventKind.RESUMED, "pose and map are back; resuming"))
        distance = math.hypot(self.goal[0] - pose.x, self.goal[1] - pose.y)
        if self._arrived(pose, distance):
            gx, gy = self.goal
            self._reset_goal()
            self.state = GoalState.REACHED
            events.append(NavEvent(EventKind.REACHED, f"goal ({gx:.2f}, {gy:.2f}) reached, {distance:.3f} m away"))
            return NavCommand(0.0, 0.0, events=tuple(events))
        if distance < self._best_distance - self.config.progress_m:
            self._best_distance = distance
            self._progress_time = now

        new_path: FloatArray | None = None
        request: PlanRequest | None = None
        reason = None if self._pending is not None else self.replan_reason(pose, now)
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
        return NavCommand(command.u, command.omega, new_path, tuple(events), request)

    def _hold_reason(self, pose: Pose2D | None, now: float) -> str | None:
        if pose is None:
            return "no robot pose in the map frame"
        if self._grid is None:
            return "no map"
        timeout = self.config.map_timeout_s
        if timeout > 0.0 and now - self._map_stamp > timeout:
            return f"the map is {now - self._map_stamp:.1f} s old"
        return None

    def _arrived(self, pose: Pose2D, distance: float) -> bool:
        tolerance = self.config.goal_tolerance_m
        if distance > tolerance:
            return False
        if distance <= tolerance / 2.0 or self._follower is None:
            return True
        # within the tolerance: stop once the follower has brought its point to the end of the path
        return bool(self._follower.command(pose).done)

    def replan_reason(self, pose: Pose2D, now: float) -> str | None:
        """Why the next :meth:`update` at ``pose`` will plan (``None``: it will not). A node may stop the robot
        first, since planning takes wall-clock time while a simulation runs on."""
        if self.state is not GoalState.ACTIVE:
            return None
        if self._follower is None or self.path is None:
            if self._failures == 0:
                return "new goal"
            # give the map a moment to change before trying again
            return "retry" if now - self._last_plan_time >= self.config.retry_delay_s else None
        if self._map_version != self._checked_version and self._path_blocked(pose):
            return "blocked"
        self._checked_version = self._map_version
        remaining = self._remaining_path()
        if cross_track_distance(self._follower.holonomic_point(pose), remaining) > self.config.stray_distance_m:
            return "strayed"
        if self.config.progress_timeout_s > 0.0 and now - self._progress_time > self.config.progress_timeout_s:
            return "stuck"
        if now - self._last_plan_time >= self.config.replan_period_s and self._map_version != self._planned_version:
            return "periodic"
        return None

    def _maps(self) -> tuple[OccupancyGrid, OccupancyGrid]:
        """The planning grid and the raw map (only called once a map is known)."""
        grid = self.inflated_grid
        if grid is None or self._grid is None:
            raise InvalidInputError("no map received yet")
        return grid, self._grid

    def _remaining_path(self) -> FloatArray:
        assert self._follower is not None
        return self._follower.points[self._follower.segment :]

    def _path_blocked(self, pose: Pose2D) -> bool:
        """Whether occupied cells of the current map lie on the rest of the path. Close to the robot only the
        raw map counts (the robot may legitimately be within the inflation of a wall it is leaving)."""
        grid, raw = self._maps()
        rest = densify(self._remaining_path(), grid.resolution / 2.0)
        near = np.hypot(rest[:, 0] - pose.x, rest[:, 1] - pose.y) <= self.config.inflation_m + grid.resolution
        return bool(np.any(grid.is_occupied(rest[~near])) or np.any(raw.is_occupied(rest[near])))

    def _request(self, pose: Pose2D, now: float, reason: str) -> PlanRequest:
        """Start a plan for ``reason``: the bookkeeping of an attempt, and what the planner needs."""
        assert self.goal is not None
        grid, raw = self._maps()
        remaining = math.inf
        if reason == "periodic" and self._follower is not None:
            remaining = path_length(np.vstack(([pose.x, pose.y], self._remaining_path()[:, :2])))
        else:
            # the current path is unusable: stop following it whatever the outcome
            self._follower = None
            self.path = None
        self._last_plan_time = now
        self._planned_version = self._map_version
        self._checked_version = self._map_version
        return PlanRequest(self.goal, pose, now, reason, grid, raw, remaining)

    def run_plan(self, request: PlanRequest) -> PlanOutcome:
        """Plan for ``request`` (from the robot, and from it turned round when so configured; the shorter
        wins). Reads only the request, the planner and the random generator, so it may run in another thread
        while :meth:`update` runs (with ``defer``: no other plan is made meanwhile)."""
        pose = request.pose
        grid = clear_footprint(request.grid, request.raw, [pose.x, pose.y], self.config.inflation_m)
        starts = [pose]
        if self.config.plan_turned_round:
            starts.append(Pose2D(pose.x, pose.y, wrap_angle(pose.yaw + math.pi)))
        best: PlanResult | None = None
        why = "no path"
        for start in starts:
            try:
                result = self.planner(grid, start, request.goal, self.rng)
            except MrsNavError as err:
                why = str(err)
                continue
            if not result.success or result.path.shape[0] == 0:
                why = result.reason or "no path"
            elif best is None or result.length_m < best.length_m:
                best = result
        return best, "" if best is not None else why

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
        assert self.goal is not None
        result, why = outcome
        reason, optional = request.reason, request.optional
        if result is None:
            if optional:
                return None
            self._failures += 1
            cfg = self.config
            events.append(
                NavEvent(
                    EventKind.PLAN_FAILED,
                    f"planning ({reason}) failed ({self._failures}/{cfg.max_failed_plans}): {why}",
                )
            )
            if self._failures >= cfg.max_failed_plans:
                gx, gy = self.goal
                self._reset_goal()
                self.state = GoalState.FAILED
                events.append(
                    NavEvent(
                        EventKind.FAILED,
                        f"goal ({gx:.2f}, {gy:.2f}) failed: {cfg.max_failed_plans} plans failed; last: {why}",
                    )
                )
            return None
        path = self._with_goal(result.path)
        if optional and self._follower is not None:
            remaining, new = request.remaining_m, path_length(path)
            cfg = self.config
            if not (new < cfg.improvement_ratio * remaining and remaining - new >= cfg.improvement_min_m):
                return None
        self._failures = 0
        if reason == "stuck":
            self._progress_time = request.now
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


def densify(points: npt.ArrayLike, step: float) -> FloatArray:
    """The polyline ``points`` (``(N, 2+)``) resampled so that consecutive points are at most ``step`` apart
    (``(M, 2)``, every original point kept)."""
    xy = np.asarray(points, dtype=np.float64)[:, :2]
    if xy.shape[0] < 2:
        return xy.copy()
    gaps = np.hypot(*np.diff(xy, axis=0).T)
    counts = np.maximum(np.ceil(gaps / step).astype(np.intp), 1)
    t = np.concatenate([np.arange(c) / c for c in counts])
    starts = np.repeat(np.arange(xy.shape[0] - 1), counts)
    out = xy[starts] + t[:, None] * (xy[starts + 1] - xy[starts])
    return np.vstack((out, xy[-1:]))


PLANNERS = ("rrt_star", "rrt")


def rrt_planner(kind: str = "rrt_star", time_budget_s: float | None = 0.3, iterations: int | None = None) -> Planner:
    """A :class:`Planner` running the project's RRT* (``"rrt_star"``) or RRT (``"rrt"``) with circular-arc edges,
    within ``time_budget_s`` wall-clock seconds and/or ``iterations`` samples."""
    if kind == "rrt_star":
        star = RRTStarConfig(iterations=iterations, time_budget=time_budget_s)

        def plan_star(
            grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng: np.random.Generator
        ) -> PlanResult:
            return rrt_star(start, np.asarray(goal, dtype=np.float64), grid, star, rng)

        return plan_star
    if kind == "rrt":
        plain = RRTConfig(iterations=iterations if iterations is not None else 5000, time_budget=time_budget_s)

        def plan_rrt(
            grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng: np.random.Generator
        ) -> PlanResult:
            return rrt(start, np.asarray(goal, dtype=np.float64), grid, plain, rng)

        return plan_rrt
    raise InvalidInputError(f"unknown planner {kind!r}; expected one of {', '.join(PLANNERS)}")
