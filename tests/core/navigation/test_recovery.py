"""Recoveries before a goal is given up (navigation.recovery), as move_base's, driven through the navigator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.navigation.goal import NavGoal
from mrs_nav.navigation.navigator import EventKind, GoalState, Navigator, NavigatorConfig
from mrs_nav.navigation.recovery import RecoveryBehavior, RecoveryConfig
from mrs_nav.planning import PlanResult
from tests.core.navigation.test_navigator import arena, astar, drive, kinds, with_wall


def never(grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng: np.random.Generator) -> PlanResult:
    raise NoPathFoundError("no path found")


def test_failed_plans_run_conservative_clear_rotation_aggressive_clear_then_abort_naming_them() -> None:
    nav = Navigator(never, NavigatorConfig(max_failed_plans=2, retry_delay_s=0.5))
    nav.set_map(arena(), 0.0)
    nav.set_scan([-1.5, -1.5], [[-1.0, -1.5], [1.5, -1.5]], [True, False])  # one mark 0.5 m from the robot
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose, events = drive(nav, Pose2D(-1.5, -1.5, 0.0), 60.0)
    assert nav.state is GoalState.FAILED
    recoveries = [e.message for e in events if e.kind is EventKind.RECOVERY]
    assert len(recoveries) == 3  # each logged once
    assert "1/3 (conservative_reset)" in recoveries[0]
    assert "cleared 0 marked cells" in recoveries[0]
    assert "2/3 (rotate_recovery)" in recoveries[1]
    assert "3/3 (aggressive_reset)" in recoveries[2]
    assert "cleared all 1 marked cells" in recoveries[2]
    assert kinds(events).count(EventKind.PLAN_FAILED) == 8  # two failed plans before each recovery and after
    failed = events[-1]
    assert failed.kind is EventKind.FAILED
    assert "after recoveries (conservative_reset, rotate_recovery, aggressive_reset)" in failed.message
    assert "last: no path found" in failed.message
    assert (pose.x, pose.y) == (-1.5, -1.5)  # turned on the spot only
    assert abs(pose.yaw) >= 2.0 * math.pi - 0.3  # a full turn (at 0.1 s steps of 2.84 rad/s)


def test_a_goal_blocked_only_by_stale_marks_is_reached_after_a_clear() -> None:
    nav = Navigator(astar, NavigatorConfig(max_failed_plans=1), seed=1)
    room = arena()
    nav.set_map(room, 0.0)
    # a wall of marks right across the room (a scan placed at a wrong pose), 0.5 m ahead and out of view later
    ys = np.arange(-1.95, 1.96, 0.025)
    nav.set_scan([0.5, 0.0], np.column_stack((np.full_like(ys, 0.5), ys)), np.ones(ys.size, dtype=bool))
    nav.set_scan([-1.5, 0.0], [[-1.9, 0.0]], [False])  # the robot's own scan: nothing ahead
    nav.set_goal(NavGoal(1.5, 0.0), 0.0)
    _pose, events = drive(nav, Pose2D(-1.5, 0.0, 0.0), 120.0)
    assert nav.state is GoalState.REACHED, [e.message for e in events]
    assert [e.message.split(" (")[1].split(")")[0] for e in events if e.kind is EventKind.RECOVERY] == [
        "conservative_reset",
        "rotate_recovery",
        "aggressive_reset",
    ]  # the marks are 2 m away: within the conservative reset distance, only the aggressive one clears them


def test_no_progress_runs_the_recoveries_then_aborts() -> None:
    grid = arena()
    nav = Navigator(astar, NavigatorConfig(progress_timeout_s=5.0), seed=1)
    nav.set_map(grid, 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    pose, events, now = Pose2D(-1.5, -1.5, 0.0), [], 0.0
    while now < 60.0 and nav.state is GoalState.ACTIVE:  # the wheels spin but the robot never moves
        cmd = nav.update(pose, now)
        events.extend(cmd.events)
        pose = Pose2D(pose.x, pose.y, pose.yaw + cmd.omega * 0.1)
        now += 0.1
    assert nav.state is GoalState.FAILED
    assert kinds(events).count(EventKind.RECOVERY) == 3
    assert "no progress for 5 s after recoveries" in events[-1].message


def test_recoveries_follow_move_base_switches() -> None:
    def config(enabled: bool, rotation: bool, names: tuple[str, ...] = ("conservative_reset", "rotate_recovery")):
        return RecoveryConfig.from_move_base(
            recovery_behavior_enabled=enabled,
            clearing_rotation_allowed=rotation,
            recovery_behaviors=names,
            conservative_reset_dist=3.0,
            rotation_speed=1.0,
        )

    assert config(True, True).behaviors == (RecoveryBehavior.CONSERVATIVE_RESET, RecoveryBehavior.ROTATE_RECOVERY)
    assert config(True, False).behaviors == (RecoveryBehavior.CONSERVATIVE_RESET,)
    assert config(False, True).behaviors == ()
    with pytest.raises(InvalidInputError, match="unknown"):
        config(True, True, ("clear_everything",))
    with pytest.raises(InvalidInputError, match="conservative_reset_dist"):
        RecoveryConfig(conservative_reset_dist_m=-1.0)


def test_without_recoveries_failed_plans_abort_at_once() -> None:
    nav = Navigator(never, NavigatorConfig(max_failed_plans=1, recovery=RecoveryConfig(behaviors=())))
    nav.set_map(with_wall(arena(), 0.0, 0.0, 0.1, 0.1), 0.0)
    nav.set_goal(NavGoal(1.5, 1.5), 0.0)
    _, events = drive(nav, Pose2D(-1.5, -1.5, 0.0), 5.0)
    assert kinds(events) == [EventKind.PLAN_FAILED, EventKind.FAILED]
    assert "after recoveries" not in events[-1].message
