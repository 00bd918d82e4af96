"""The navigation state machine, driven directly with occupancy grids and a kinematic robot."""

from __future__ import annotations

import heapq
import math
import time

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid
from mrs_nav.navigation.navigator import (
    EventKind,
    GoalState,
    NavCommand,
    NavGoal,
    Navigator,
    NavigatorConfig,
    cell_centres,
    densify,
)
from mrs_nav.navigation.obstacles import return_ahead
from mrs_nav.navigation.recovery import RecoveryConfig
from mrs_nav.planning import PlanResult, headings_along, path_length
from mrs_nav.robot import BURGER_RADIUS

RES = 0.05


def arena(unknown: bool = False) -> OccupancyGrid:
    """A 4 m x 4 m room (walls one cell thick at the border), free inside, or unknown inside but for the 0.5 m
    around (-1.5, -1.5) that the robot has seen."""
    values = np.full((80, 80), UNKNOWN if unknown else 0, dtype=np.int8)
    values[5:15, 5:15] = 0
    values[0, :] = values[-1, :] = values[:, 0] = values[:, -1] = OCCUPIED
    return OccupancyGrid(values, RES, (-2.0, -2.0, 0.0))


def with_wall(grid: OccupancyGrid, x0: float, y0: float, x1: float, y1: float) -> OccupancyGrid:
    """``grid`` with the rectangle [x0, x1] x [y0, y1] occupied."""
    values = grid.values.copy()
    (r0, r1), (c0, c1), _ = grid.cells_of(np.array([[x0, y0], [x1, y1]]))
    values[r0 : r1 + 1, c0 : c1 + 1] = OCCUPIED
    return OccupancyGrid(values, grid.resolution, grid.origin)


def astar(grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng: np.random.Generator) -> PlanResult:
    """An 8-connected A* on the free cells: a deterministic stand-in for RRT* in these tests."""
    t0 = time.perf_counter()
    free = grid.free_mask
    (sr, gr), (sc, gc), _ = grid.cells_of(np.array([[start.x, start.y], goal]))
    if not free[gr, gc]:
        raise InvalidInputError("goal is not free")
    if not free[sr, sc]:
        raise InvalidInputError("start is not free")
    steps = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    cost = {(sr, sc): 0.0}
    queue = [(0.0, (sr, sc))]
    while queue:
        _, cell = heapq.heappop(queue)
        if cell == (gr, gc):
            break
        for dr, dc in steps:
            nxt = (cell[0] + dr, cell[1] + dc)
            if not (0 <= nxt[0] < grid.height and 0 <= nxt[1] < grid.width) or not free[nxt]:
                continue
            new = cost[cell] + math.hypot(dr, dc)
            if new < cost.get(nxt, math.inf):
                cost[nxt], parent[nxt] = new, cell
                heapq.heappush(queue, (new + math.hypot(gr - nxt[0], gc - nxt[1]), nxt))
    else:
        raise NoPathFoundError("no path")
    cells = [(gr, gc)]
    while cells[-1] != (sr, sc):
        cells.append(parent[cells[-1]])
    rows, cols = np.array(cells[::-1]).T
    points = cell_centres(grid, rows, cols)
    points[0] = (start.x, start.y)
    points[-1] = goal
    path = headings_along(points)
    return PlanResult(path, path_length(path), time.perf_counter() - t0, 0.0, len(cost), len(cost), "found")


def drive(nav: Navigator, pose: Pose2D, seconds: float, dt: float = 0.1, t0: float = 0.0) -> tuple[Pose2D, list]:
    """Run the navigator on a kinematic unicycle until the goal ends or time runs out."""
    events = []
    now = t0
    while now < t0 + seconds and nav.state is GoalState.ACTIVE:
        cmd = nav.update(pose, now)
        events.extend(cmd.events)
        yaw = pose.yaw + cmd.omega * dt
        pose = Pose2D(pose.x + cmd.u * dt * math.cos(pose.yaw), pose.y + cmd.u * dt * math.sin(pose.yaw), yaw)
        now += dt
    return pose, events


def kinds(events) -> list[EventKind]:
    return [e.kind for e in events]


def test_goal_across_the_room_is_reached_within_tolerance_and_the_robot_stops() -> None:
    nav = Navigator(astar, seed=1)
    grid = with_wall(arena(), -0.2, -0.2, 0.2, 0.2)
    nav.set_map(grid, 0.0)
    assert kinds(nav.set_goal(NavGoal(1.5, 1.5), 0.0)) == [EventKind.ACCEPTED]
    pose, events = drive(nav, Pose2D(-1.5, -1.5, 0.0), 120.0)
    assert nav.state is GoalState.REACHED
    assert math.hypot(pose.x - 1.5, pose.y - 1.5) <= 0.2
    assert EventKind.PLANNED in kinds(events)
    assert kinds(events)[-1] is EventKind.REACHED
    assert nav.update(pose, 200.0) == NavCommand(0.0, 0.0)


@pytest.mark.parametrize(
    ("goal", "reason"),
    [
        ((0.0, 0.0), "inside an obstacle"),
        ((0.27, 0.0), "robot radius + margin"),
        ((5.0, 0.0), "outside the map"),
    ],
)
def test_bad_goals_are_refused_and_cause_no_motion(goal: tuple[float, float], reason: str) -> None:
    nav = Navigator(astar)
    nav.set_map(with_wall(arena(), -0.2, -0.2, 0.2, 0.2), 0.0)
    (event,) = nav.set_goal(NavGoal(*goal), 0.0)
    assert event.kind is EventKind.REFUSED
    assert reason in event.message
    assert nav.state is GoalState.IDLE
    assert nav.update(Pose2D(-1.5, -1.5, 0.0), 0.1) == NavCommand(0.0, 0.0)


def test_a_goal_a_googol_away_is_refused_in_a_line_of_readable_length() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    (event,) = nav.set_goal(NavGoal(1e300, -1e300), 0.0)
    assert event.kind is EventKind.REFUSED
    assert event.message == "goal (1e+300, -1e+300) refused: it lies outside the map"


@pytest.mark.parametrize(
    ("x", "y", "yaw", "message"),
    [
        (math.nan, 0.0, None, r"goal \(nan, 0.0\): its position is not a finite number"),
        (0.0, math.inf, None, "its position is not a finite number"),
        (1.0, 2.0, math.nan, r"goal \(1.00, 2.00\): its heading is not a finite number"),
    ],
)
def test_a_goal_is_finite_from_the_moment_it_is_made(x: float, y: float, yaw: float | None, message: str) -> None:
    with pytest.raises(InvalidInputError, match=message):
        NavGoal(x, y, yaw)


def test_a_goal_before_any_map_is_refused() -> None:
    (event,) = Navigator(astar).set_goal(NavGoal(1.0, 1.0), 0.0)
    assert event.kind is EventKind.REFUSED
    assert "no map" in event.message


def test_unknown_space_is_planned_through_only_when_allowed() -> None:
    grid = arena(unknown=True)
    nav = Navigator(astar)
    nav.set_map(grid, 0.0)
    assert kinds(nav.set_goal(NavGoal(1.5, 1.5), 0.0)) == [EventKind.ACCEPTED]
    cmd = nav.update(Pose2D(-1.5, -1.5, 0.0), 0.0)
    assert cmd.path is not None
    assert cmd.u > 0.0
    strict = Navigator(astar, NavigatorConfig(allow_unknown=False))
    strict.set_map(grid, 0.0)
    (event,) = strict.set_goal(NavGoal(1.5, 1.5), 0.0)
    assert event.kind is EventKind.REFUSED
    assert "unknown" in event.message


def test_a_bad_goal_does_not_cancel_the_running_one() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    assert kinds(nav.set_goal(NavGoal(5.0, 0.0), 0.0)) == [EventKind.REFUSED]
    assert nav.state is GoalState.ACTIVE
    assert nav.goal == (1.5, 1.5)


def test_a_map_revealing_a_wall_on_the_path_makes_a_new_plan_around_it() -> None:
    nav = Navigator(astar, NavigatorConfig(replan_period_s=1e9))
    nav.set_map(arena(unknown=True), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    first = nav.update(pose, 0.0).path
    assert first is not None
    assert nav.update(pose, 0.1).path is None  # nothing new: keep the plan
    wall = with_wall(arena(unknown=True), 0.0, -1.95, 0.1, 0.5)  # across the straight line
    nav.set_map(wall, 0.2)
    cmd = nav.update(pose, 0.2)
    assert cmd.path is not None
    assert "blocked" in cmd.events[0].message
    assert not np.any(wall.inflate(0.105).is_occupied(densify(cmd.path, 0.01)))
    assert cmd.path[:, 1].max() > 0.5  # around the top of the wall


def test_a_new_map_that_leaves_the_path_clear_keeps_it() -> None:
    nav = Navigator(astar, NavigatorConfig(replan_period_s=1e9))
    nav.set_map(arena(unknown=True), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    assert nav.update(pose, 0.0).path is not None
    nav.set_map(with_wall(arena(unknown=True), 0.0, 1.0, 0.1, 1.5), 0.5)  # far from the path
    assert nav.update(pose, 0.5).path is None


def test_straying_from_the_path_triggers_a_new_plan() -> None:
    nav = Navigator(astar, NavigatorConfig(replan_period_s=1e9, stray_distance_m=0.3))
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    assert nav.update(Pose2D(-1.5, -1.5, 0.0), 0.0).path is not None
    assert nav.update(Pose2D(-1.0, -1.3, 0.0), 0.1).path is None  # 0.2 m off: tolerated
    cmd = nav.update(Pose2D(-1.0, -1.0, 0.0), 0.2)
    assert cmd.path is not None
    assert "strayed" in cmd.events[0].message
    np.testing.assert_allclose(cmd.path[0, :2], [-1.0, -1.0])


class ScriptedPlanner:
    """Returns straight paths whose length is inflated by the scripted factors, one per call."""

    def __init__(self, factors: list[float]) -> None:
        self.factors = factors
        self.calls = 0

    def __call__(self, grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng) -> PlanResult:
        factor = self.factors[min(self.calls, len(self.factors) - 1)]
        self.calls += 1
        # a detour through a point to the side, making the path `factor` times the straight line
        mid = np.add([start.x, start.y], goal) / 2.0
        half = math.hypot(goal[0] - start.x, goal[1] - start.y) / 2.0
        side = half * math.sqrt(max(factor**2 - 1.0, 0.0))
        direction = np.subtract(goal, [start.x, start.y]) / (2.0 * half)
        mid = mid + side * np.array([-direction[1], direction[0]])
        path = headings_along(np.array([[start.x, start.y], mid, goal]))
        return PlanResult(path, path_length(path), 0.001, 0.001, 1, 3, "found")


def test_periodic_plans_replace_the_path_only_when_clearly_shorter() -> None:
    planner = ScriptedPlanner([1.3, 1.25, 1.0])
    config = NavigatorConfig(replan_period_s=2.0, improvement_ratio=0.85, stray_distance_m=1.0, plan_turned_round=False)
    nav = Navigator(planner, config)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    assert nav.update(pose, 0.0).path is not None
    assert nav.update(pose, 2.5).path is None  # period over but the map did not change: no plan
    assert planner.calls == 1
    nav.set_map(arena(), 2.6)
    assert nav.update(pose, 2.6).path is None  # planned (1.25x), not clearly shorter than 1.3x: kept
    assert planner.calls == 2
    assert nav.update(pose, 3.0).path is None  # within the period: no plan
    nav.set_map(arena(), 4.7)
    cmd = nav.update(pose, 4.7)
    assert planner.calls == 3
    assert cmd.path is not None  # the straight line is clearly shorter
    assert path_length(cmd.path) == pytest.approx(3.0)


@pytest.mark.parametrize("deferred", [False, True])
def test_repeated_planning_failures_end_the_goal_as_failed(deferred: bool) -> None:
    def never(grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng) -> PlanResult:
        raise NoPathFoundError("time budget used up")

    # without recoveries (test_recovery: with them)
    config = NavigatorConfig(max_failed_plans=3, retry_delay_s=1.0, recovery=RecoveryConfig(behaviors=()))
    nav = Navigator(never, config)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    start = Pose2D(-1.5, -1.5, 0.0)
    pose, events = drive_deferred(nav, start, 10.0, latency=3) if deferred else drive(nav, start, 10.0)
    assert nav.state is GoalState.FAILED
    assert kinds(events) == [EventKind.PLAN_FAILED] * 3 + [EventKind.FAILED]
    assert "time budget" in events[-1].message
    assert (pose.x, pose.y) == (-1.5, -1.5)


def test_a_goal_walled_off_is_reported_failed_not_chased() -> None:
    grid = with_wall(arena(), -2.0, 0.9, 2.0, 1.0)  # a wall right across the room
    nav = Navigator(astar, NavigatorConfig(max_failed_plans=2, recovery=RecoveryConfig(behaviors=())))
    nav.set_map(grid, 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    drive(nav, Pose2D(-1.5, -1.5, 0.0), 10.0)
    assert nav.state is GoalState.FAILED


def test_a_new_goal_preempts_the_current_one() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose, _ = drive(nav, Pose2D(-1.5, -1.5, 0.0), 3.0)
    assert nav.state is GoalState.ACTIVE
    events = nav.set_goal(NavGoal(-1.5, 1.5), 3.0)
    assert kinds(events) == [EventKind.PREEMPTED, EventKind.ACCEPTED]
    cmd = nav.update(pose, 3.0)
    assert cmd.path is not None
    np.testing.assert_allclose(cmd.path[-1, :2], [-1.5, 1.5])
    pose, _ = drive(nav, pose, 120.0, t0=3.0)
    assert nav.state is GoalState.REACHED
    assert math.hypot(pose.x + 1.5, pose.y - 1.5) <= 0.2


def test_lost_pose_or_stale_map_stops_the_robot_and_it_resumes() -> None:
    nav = Navigator(astar, NavigatorConfig(map_timeout_s=5.0))
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    assert nav.update(pose, 0.0).u > 0.0
    lost = nav.update(None, 0.1)
    assert (lost.u, lost.omega) == (0.0, 0.0)
    assert kinds(lost.events) == [EventKind.HOLDING]
    assert nav.update(None, 0.2) == NavCommand(0.0, 0.0)  # reported once
    resumed = nav.update(pose, 0.3)
    assert kinds(resumed.events) == [EventKind.RESUMED]
    assert resumed.u > 0.0
    stale = nav.update(pose, 6.0)
    assert (stale.u, stale.omega) == (0.0, 0.0)
    assert "map" in stale.events[0].message
    nav.set_map(arena(), 6.1)
    assert nav.update(pose, 6.1).u > 0.0
    assert nav.state is GoalState.ACTIVE


def test_a_robot_inside_the_inflation_of_a_wall_can_still_plan_out() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(0.0, 0.0), 0.0)
    cmd = nav.update(Pose2D(-1.88, 0.0, 0.0), 0.0)  # 0.07 m from the wall face, inside the 0.105 m inflation
    assert cmd.path is not None
    assert cmd.u > 0.0


def test_bad_configuration_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="approach_radius_m"):
        NavigatorConfig(approach_radius_m=0.0)
    with pytest.raises(InvalidInputError, match="max_failed_plans"):
        NavigatorConfig(max_failed_plans=0)


def test_a_goal_behind_the_robot_is_planned_from_the_robot_turned_round() -> None:
    def forward_only(grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng) -> PlanResult:
        # a straight path, plus a loop of radius 0.3 m when the goal is behind the start heading
        ahead = math.cos(start.yaw) * (goal[0] - start.x) + math.sin(start.yaw) * (goal[1] - start.y)
        path = headings_along(np.array([[start.x, start.y], goal]))
        path[0, 2] = start.yaw
        extra = 0.0 if ahead > 0.0 else 2.0 * math.pi * 0.3
        return PlanResult(path, path_length(path) + extra, 0.001, 0.001, 1, 2, "found")

    nav = Navigator(forward_only)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(-1.0, 0.0), 0.0)
    cmd = nav.update(Pose2D(1.0, 0.0, 0.0), 0.0)
    assert cmd.path is not None
    assert abs(cmd.path[0, 2]) == pytest.approx(math.pi)
    assert cmd.u == 0.0  # it turns on the spot rather than backing up
    assert abs(cmd.omega) > 0.0


def drive_deferred(nav: Navigator, pose: Pose2D, seconds: float, latency: int, dt: float = 0.1) -> tuple[Pose2D, list]:
    """:func:`drive` with planning deferred, each plan finishing ``latency`` control steps after it is asked."""
    events: list = []
    now, in_flight = 0.0, []
    while now < seconds and nav.state is GoalState.ACTIVE:
        if in_flight and in_flight[0][0] <= now:
            _, request, outcome = in_flight.pop(0)
            events.extend(nav.finish_plan(request, outcome).events)
        cmd = nav.update(pose, now, defer=True)
        events.extend(cmd.events)
        if cmd.request is not None:
            in_flight.append((now + latency * dt - 1e-9, cmd.request, nav.run_plan(cmd.request)))
        yaw = pose.yaw + cmd.omega * dt
        pose = Pose2D(pose.x + cmd.u * dt * math.cos(pose.yaw), pose.y + cmd.u * dt * math.sin(pose.yaw), yaw)
        now += dt
    return pose, events


def test_deferred_planning_reaches_the_goal_like_synchronous_planning() -> None:
    nav = Navigator(astar, NavigatorConfig(replan_period_s=2.0), seed=1)
    nav.set_map(with_wall(arena(), -0.2, -0.2, 0.2, 0.2), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose, events = drive_deferred(nav, Pose2D(-1.5, -1.5, 0.0), 120.0, latency=5)
    assert nav.state is GoalState.REACHED
    assert math.hypot(pose.x - 1.5, pose.y - 1.5) <= 0.2
    assert kinds(events)[0] is EventKind.PLANNED


def test_a_deferred_plan_keeps_the_robot_following_its_path_until_adopted() -> None:
    planner = ScriptedPlanner([1.3, 1.0])
    config = NavigatorConfig(replan_period_s=2.0, stray_distance_m=1.0, plan_turned_round=False)
    nav = Navigator(planner, config)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    first = nav.update(pose, 0.0, defer=True)
    assert first.request is not None
    assert (first.u, first.omega) == (0.0, 0.0)
    assert nav.update(pose, 0.1, defer=True).request is None  # one plan at a time
    done = nav.finish_plan(first.request, nav.run_plan(first.request))
    assert done.path is not None
    assert kinds(done.events) == [EventKind.PLANNED]
    nav.set_map(arena(), 2.5)
    periodic = nav.update(pose, 2.5, defer=True)
    assert periodic.request is not None
    assert periodic.request.reason == "periodic"
    assert periodic.u > 0.0  # the current path is still followed while the offer is planned
    following = nav.update(pose, 2.6, defer=True)
    assert following.request is None
    assert following.u > 0.0
    assert nav.path is done.path
    adopted = nav.finish_plan(periodic.request, nav.run_plan(periodic.request))
    assert adopted.path is not None
    assert path_length(adopted.path) == pytest.approx(3.0)
    assert planner.calls == 2


def blocked_ahead(planner) -> tuple[Navigator, NavCommand, float]:
    """A navigator on its way from (-1.5, -1.5) to (1.5, -1.5) whose straight path a new map blocks with a wall
    across it at x = 0.5; the command of the step that asks for the replacement plan, and the x where the path
    first comes within the robot's radius of the wall."""
    nav = Navigator(planner, NavigatorConfig(replan_period_s=1e9, plan_turned_round=False))
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    first = nav.update(Pose2D(-1.5, -1.5, 0.0), 0.0, defer=True).request
    assert first is not None
    assert nav.finish_plan(first, nav.run_plan(first)).path is not None
    nav.set_map(with_wall(arena(), 0.5, -1.95, 0.6, 0.5), 0.5)
    xs = np.arange(-1.5, 1.5, 0.01)
    blocked = nav.collision_grid.is_occupied(np.column_stack((xs, np.full_like(xs, -1.5))))
    return nav, nav.update(Pose2D(-1.5, -1.5, 0.0), 0.5, defer=True), float(xs[np.argmax(blocked)])


def test_a_path_blocked_further_on_is_followed_short_of_the_blockage_until_replaced() -> None:
    nav, asked, edge = blocked_ahead(astar)
    assert asked.request is not None
    assert asked.request.reason == "blocked"
    assert asked.u > 0.0  # 1.8 m of the path are clear: the robot drives on while the new plan is made
    margin = nav.config.inflation_m + RES
    assert nav.update(Pose2D(edge - margin - 0.1, -1.5, 0.0), 0.6, defer=True).u > 0.0
    assert nav.update(Pose2D(edge - margin + 0.05, -1.5, 0.0), 0.7, defer=True).u == 0.0  # no nearer
    adopted = nav.finish_plan(asked.request, nav.run_plan(asked.request))
    assert adopted.path is not None
    assert kinds(adopted.events) == [EventKind.PLANNED]
    assert adopted.path[:, 1].max() > 0.5  # around the top of the wall
    assert not np.any(nav.inflated_grid.is_occupied(densify(adopted.path[1:], 0.01)))


def test_a_mark_in_the_safety_margin_of_a_path_does_not_block_it() -> None:
    """Plans keep the robot's radius plus the safety margin from obstacles; a mark that comes within the margin
    but not within the radius (a door jamb's mark moving by a cell) leaves the path and the robot's drive alone,
    as move_base's inscribed radius does; one within the radius blocks it."""
    nav = Navigator(astar, NavigatorConfig(replan_period_s=1e9, plan_turned_round=False))
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, -1.5), 0.0)
    first = nav.update(Pose2D(-1.5, -1.5, 0.0), 0.0, defer=True).request
    assert first is not None
    path = nav.finish_plan(first, nav.run_plan(first)).path
    assert path is not None
    line = float(np.median(path[:, 1]))  # the path runs along a row of cell centres
    cfg = nav.config
    in_margin = cfg.robot_radius + cfg.safety_margin_m / 2.0  # from the path's line to the mark's edge
    nav.set_map(with_wall(arena(), 0.3, line + in_margin + RES / 2.0, 0.4, line + in_margin + 0.2), 0.5)
    assert nav.inflated_grid.is_occupied(np.array([[0.35, line]]))[0]  # a new plan would keep off it
    assert not nav.collision_grid.is_occupied(np.array([[0.35, line]]))[0]
    step = nav.update(Pose2D(-1.0, line, 0.0), 0.5, defer=True)
    assert step.request is None
    assert step.u > 0.0
    nav.set_map(with_wall(arena(), 0.3, line + cfg.robot_radius / 2.0, 0.4, line + 0.3), 1.0)
    step = nav.update(Pose2D(-1.0, line, 0.0), 1.0, defer=True)
    assert step.request is not None
    assert step.request.reason == "blocked"


def test_a_blocked_path_whose_replacement_fails_is_not_followed_on() -> None:
    def once(grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng) -> PlanResult:
        if calls:
            raise NoPathFoundError("time budget used up")
        calls.append(start)
        return astar(grid, start, goal, rng)

    calls: list[Pose2D] = []
    nav, asked, edge = blocked_ahead(once)
    assert asked.request is not None
    failed = nav.finish_plan(asked.request, nav.run_plan(asked.request))
    assert kinds(failed.events) == [EventKind.PLAN_FAILED]
    assert nav.path is None
    assert nav.update(Pose2D(edge - 1.0, -1.5, 0.0), 0.6, defer=True).u == 0.0


def test_a_new_goal_discards_the_plan_in_flight_for_the_old_one() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    old = nav.update(pose, 0.0, defer=True).request
    assert old is not None
    assert nav.planning
    nav.set_goal(NavGoal(-1.5, 1.5), 0.5)
    assert not nav.planning
    stale = nav.finish_plan(old, nav.run_plan(old))
    assert stale == NavCommand(0.0, 0.0)
    assert nav.path is None
    new = nav.update(pose, 0.6, defer=True).request
    assert new is not None
    assert new.goal == (-1.5, 1.5)
    adopted = nav.finish_plan(new, nav.run_plan(new))
    assert adopted.path is not None
    np.testing.assert_allclose(adopted.path[-1, :2], [-1.5, 1.5])


def test_a_goal_with_a_heading_ends_within_the_move_base_tolerances() -> None:
    nav = Navigator(astar, seed=1)
    nav.set_map(with_wall(arena(), -0.2, -0.2, 0.2, 0.2), 0.0)
    assert kinds(nav.set_goal(NavGoal(1.5, 1.5, math.pi / 2), 0.0)) == [EventKind.ACCEPTED]
    pose, events = drive(nav, Pose2D(-1.5, -1.5, 0.0), 120.0)
    assert nav.state is GoalState.REACHED
    tolerances = nav.config.approach
    assert math.hypot(pose.x - 1.5, pose.y - 1.5) <= tolerances.xy_tolerance_m + 0.01
    assert abs(pose.yaw - math.pi / 2) <= tolerances.yaw_tolerance_rad
    assert "rad away" in events[-1].message


def test_a_goal_inside_an_unseen_obstacle_is_refused() -> None:
    values = arena().values.copy()
    values[30:50, 30:50] = OCCUPIED  # a box whose walls were seen ...
    values[31:49, 31:49] = UNKNOWN  # ... and its inside never
    nav = Navigator(astar)
    nav.set_map(OccupancyGrid(values, RES, (-2.0, -2.0, 0.0)), 0.0)
    (event,) = nav.set_goal(NavGoal(0.0, 0.0), 0.0)
    assert event.kind is EventKind.REFUSED
    assert "inside of an obstacle" in event.message
    assert kinds(nav.set_goal(NavGoal(1.5, 1.5), 0.0)) == [EventKind.ACCEPTED]


def scan(world: OccupancyGrid, pose: Pose2D, beams: int = 180, max_range: float = 3.5):
    """A laser scan of ``world`` from ``pose``: origin, end points and the hit mask (ray marched)."""
    angles = pose.yaw + np.linspace(-math.pi, math.pi, beams, endpoint=False)
    steps = np.arange(1, int(max_range / (RES / 4))) * (RES / 4)
    xy = np.array([pose.x, pose.y])
    ends = np.empty((beams, 2))
    hit = np.zeros(beams, dtype=bool)
    for i, a in enumerate(angles):
        points = xy + steps[:, None] * [math.cos(a), math.sin(a)]
        occupied = np.flatnonzero(world.is_occupied(points))
        hit[i] = occupied.size > 0
        ends[i] = points[occupied[0]] if hit[i] else points[-1]
    return xy, ends, hit


def drive_with_scans(nav: Navigator, world: OccupancyGrid, pose: Pose2D, seconds: float) -> tuple[Pose2D, float]:
    """Drive as :func:`drive`, with a scan of ``world`` every 0.2 s; the final pose and the least clearance (m)
    between the robot's centre and an obstacle of ``world``."""
    occupied = cell_centres(world, *np.nonzero(world.occupied_mask))
    now, least = 0.0, math.inf
    while now < seconds and nav.state is GoalState.ACTIVE:
        if round(now / 0.1) % 2 == 0:
            nav.set_scan(*scan(world, pose))
        cmd = nav.update(pose, now)
        pose = Pose2D(
            pose.x + cmd.u * 0.1 * math.cos(pose.yaw),
            pose.y + cmd.u * 0.1 * math.sin(pose.yaw),
            pose.yaw + cmd.omega * 0.1,
        )
        least = min(least, float(np.min(np.hypot(*(occupied - [pose.x, pose.y]).T))))
        now += 0.1
    return pose, least


def test_an_obstacle_seen_but_not_on_the_map_is_planned_around_without_contact() -> None:
    room = with_wall(arena(), -0.05, -2.0, 0.05, 0.9)  # a wall with a gap at the top ...
    world = with_wall(with_wall(room, -0.05, 1.3, 0.05, 2.0), -1.0, -1.4, -0.8, -1.0)  # ... and a box in the way
    mapped = with_wall(room, -0.05, 1.3, 0.05, 2.0)
    nav = Navigator(astar, seed=2)
    nav.set_map(mapped, 0.0)
    nav.set_goal(NavGoal(-0.5, -1.2), 0.0)
    first = nav.update(Pose2D(-1.6, -1.2, 0.0), 0.0).path
    assert first is not None
    assert mapped.is_free(densify(first, RES)).all()
    pose, least = drive_with_scans(nav, world, Pose2D(-1.6, -1.2, 0.0), 120.0)
    assert nav.state is GoalState.REACHED
    assert least > BURGER_RADIUS
    assert math.hypot(pose.x + 0.5, pose.y + 1.2) <= nav.config.approach.xy_tolerance_m + 0.01


def test_marks_are_cleared_when_the_laser_sees_through() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    box = with_wall(arena(), 0.5, -0.1, 0.7, 0.1)
    nav.set_scan(*scan(box, Pose2D(-1.0, 0.0, 0.0)))
    marked = nav.marked_grid
    assert marked is not None
    assert marked.is_occupied(np.array([[0.52, 0.0]]))[0]
    new = cell_centres(arena(), *np.nonzero(marked.occupied_mask & ~arena().occupied_mask))
    assert np.all(np.abs(new - [0.6, 0.0]) <= [0.15, 0.15])  # only the box's face: range noise marks nothing
    nav.set_scan(*scan(arena(), Pose2D(-1.0, 0.0, 0.0)))  # the box is gone
    cleared = nav.marked_grid
    assert cleared is not None
    assert not cleared.occupied_mask[30:50, 40:60].any()


def test_returns_in_unknown_cells_are_marked_only_with_mark_unknown() -> None:
    # A saved map that only knows the 0.5 m the robot has seen: the wall at x = 0 is unknown on it.
    world = with_wall(arena(), -0.05, -2.0, 0.05, 0.9)
    pose = Pose2D(-1.0, -1.0, 0.0)
    slam = Navigator(astar)
    slam.set_map(arena(unknown=True), 0.0)
    slam.set_scan(*scan(world, pose))
    assert slam.marked_grid is not None
    assert not slam.marked_grid.is_occupied(np.array([[0.0, -1.0]]))[0]  # left to SLAM, which maps it
    static = Navigator(astar, NavigatorConfig(mark_unknown=True))
    static.set_map(arena(unknown=True), 0.0)
    static.set_scan(*scan(world, pose))
    assert static.marked_grid is not None
    assert static.marked_grid.is_occupied(np.array([[-0.04, -1.0]]))[0]


def test_on_a_static_map_a_wall_in_unknown_space_is_driven_around_without_contact() -> None:
    world = with_wall(arena(), -0.05, -2.0, 0.05, 0.9)  # a wall with a gap at the top, unknown on the map
    nav = Navigator(astar, NavigatorConfig(mark_unknown=True), seed=2)
    nav.set_map(arena(unknown=True), 0.0)
    nav.set_goal(NavGoal(1.0, -1.2), 0.0)
    pose, least = drive_with_scans(nav, world, Pose2D(-1.6, -1.2, 0.0), 300.0)
    assert nav.state is GoalState.REACHED
    assert least > BURGER_RADIUS
    assert math.hypot(pose.x - 1.0, pose.y + 1.2) <= nav.config.approach.xy_tolerance_m + 0.01


def test_a_return_right_ahead_stops_the_robot_and_makes_a_new_plan() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 0.0), 0.0)
    pose = Pose2D(-1.5, 0.0, 0.0)
    assert nav.update(pose, 0.0).u > 0.0
    nav.set_scan(*scan(with_wall(arena(), -1.36, -0.1, -1.3, 0.1), pose))  # 0.14 m ahead of the centre
    cmd = nav.update(pose, 0.1)
    assert cmd.path is not None
    assert "(blocked)" in cmd.events[0].message  # marked: the path through it is blocked
    for now in (0.1, 0.2, 0.3):
        assert nav.update(pose, now).u <= 0.0  # never forward into the return


def test_return_ahead_looks_only_into_the_robots_way() -> None:
    pose = Pose2D(0.0, 0.0, math.pi / 2)
    assert return_ahead(pose, np.array([[0.0, 0.15]]), 0.105, 0.05)
    assert not return_ahead(pose, np.array([[0.0, 0.2]]), 0.105, 0.05)  # farther than radius + clearance
    assert not return_ahead(pose, np.array([[0.0, -0.12]]), 0.105, 0.05)  # behind
    assert not return_ahead(pose, np.array([[0.14, 0.02]]), 0.105, 0.05)  # beside, passing a wall


def test_a_hold_from_the_caller_stops_the_robot_and_it_resumes() -> None:
    nav = Navigator(astar)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose = Pose2D(-1.5, -1.5, 0.0)
    assert nav.update(pose, 0.0).u > 0.0
    stale = "the map->odom correction is older than 0.30 s"
    held = nav.update(pose, 0.1, hold=stale)
    assert (held.u, held.omega) == (0.0, 0.0)
    assert stale in held.events[0].message
    assert nav.update(pose, 0.15, hold=stale).events == ()  # said once while the cause lasts
    both = nav.update(pose, 0.17, hold=f"{stale}; no laser scan for more than 0.40 s")
    assert (both.u, both.omega) == (0.0, 0.0)
    assert "no laser scan" in both.events[0].message  # a changed reason is said again
    assert nav.update(pose, 0.2).u > 0.0


def test_a_goal_reached_on_a_pose_in_doubt_fails_with_the_reason() -> None:
    nav = Navigator(astar, seed=1)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(-1.3, -1.5), 0.0)
    pose, now, events = Pose2D(-1.5, -1.5, 0.0), 0.0, []
    while now < 20.0 and nav.state is GoalState.ACTIVE:
        cmd = nav.update(pose, now, doubt="the localisation is not confident")
        events.extend(cmd.events)
        pose = Pose2D(pose.x + cmd.u * 0.1 * math.cos(pose.yaw), pose.y + cmd.u * 0.1 * math.sin(pose.yaw), pose.yaw)
        now += 0.1
    assert nav.state is GoalState.FAILED
    assert events[-1].kind is EventKind.FAILED
    assert "reached by the estimate" in events[-1].message
    assert "the localisation is not confident" in events[-1].message


def _drive_in_doubt(nav: Navigator, doubt_until: float) -> tuple[list[EventKind], list[tuple[float, float]]]:
    """Drive to the goal of ``nav`` (arena, from (-1.5, -1.5)) while the pose is in doubt until ``doubt_until``
    (s after the navigator said it waits); the events and the commands given from then on."""
    pose, now, kinds, waiting = Pose2D(-1.5, -1.5, 0.0), 0.0, [], []
    arrived: float | None = None
    while now < 30.0 and nav.state is GoalState.ACTIVE:
        unsure = arrived is None or now < arrived + doubt_until
        cmd = nav.update(pose, now, doubt="the localisation is not confident" if unsure else None)
        kinds.extend(e.kind for e in cmd.events)
        if arrived is None and EventKind.HOLDING in kinds:
            arrived = now
        if arrived is not None:
            waiting.append((cmd.u, cmd.omega))
        pose = Pose2D(pose.x + cmd.u * 0.1 * math.cos(pose.yaw), pose.y + cmd.u * 0.1 * math.sin(pose.yaw), pose.yaw)
        now += 0.1
    return kinds, waiting


def test_a_goal_reached_in_doubt_is_reached_once_the_localisation_is_confident_the_robot_held_meanwhile() -> None:
    nav = Navigator(astar, seed=1)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(-1.3, -1.5), 0.0)
    kinds, waiting = _drive_in_doubt(nav, doubt_until=2.0)
    assert nav.state is GoalState.REACHED
    assert kinds[-2:] == [EventKind.HOLDING, EventKind.REACHED]
    assert len(waiting) >= 20
    assert all(command == (0.0, 0.0) for command in waiting)


def test_a_goal_reached_in_doubt_fails_at_once_without_a_confirm_timeout() -> None:
    nav = Navigator(astar, NavigatorConfig(confirm_timeout_s=0.0), seed=1)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(-1.3, -1.5), 0.0)
    kinds, waiting = _drive_in_doubt(nav, doubt_until=2.0)
    assert nav.state is GoalState.FAILED
    assert kinds[-1] is EventKind.FAILED
    assert EventKind.HOLDING not in kinds
    assert waiting == []  # failed the tick it arrived


def test_a_goal_reached_in_doubt_is_approached_again_when_the_estimate_moves_off_it() -> None:
    nav = Navigator(astar, seed=1)
    nav.set_map(arena(), 0.0)
    nav.set_goal(NavGoal(-1.3, -1.5), 0.0)
    pose, now = Pose2D(-1.3, -1.5, 0.0), 0.0
    while nav.confirming_since is None:
        nav.update(pose, now, doubt="unsure")
        now += 0.1
    cmd = nav.update(Pose2D(-1.45, -1.5, 0.0), now)  # a confident estimate 0.15 m short of the goal
    assert nav.state is GoalState.ACTIVE
    assert nav.confirming_since is None
    assert cmd.u > 0.0
