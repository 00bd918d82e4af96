"""Re-running the planner on a session's recorded goals against a map (the replayed one, or the recorded one).

Each goal is planned from the robot's pose when the goal was sent, and from that pose turned round (a
differential drive turns in place; the navigator tries both too), keeping the shorter path, with RRT* (arc
edges) on the map with its unknown cells counted as free (as the navigator's ``allow_unknown``) and obstacles
grown by the robot's radius. The budget is a number of iterations, never wall-clock time, and each query uses a
generator seeded with ``(seed, goal index, heading index)``: the same map and goals give the same plans on any
machine.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import NoPathFoundError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.planning import PlanResult
from mrs_nav.replay.recorded import Goal
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.trees.rrt_star import RRTStarConfig, rrt_star


@dataclass(frozen=True)
class GoalPlan:
    """One re-planned goal: where from and to (m, rad), and the planner's result, or (``result`` None) the
    planner's :class:`NoPathFoundError`."""

    start: Pose2D
    goal: Goal
    result: PlanResult | None
    no_path: NoPathFoundError | None = None

    @property
    def iterations(self) -> int:
        """The planner's iterations, whether it found a path or not."""
        if self.result is not None:
            return self.result.iterations
        return self.no_path.iterations if self.no_path is not None else 0


def replan_goals(
    grid: OccupancyGrid,
    goals: Sequence[Goal],
    start_at: Callable[[float], Pose2D | None],
    *,
    iterations: int = 1500,
    seed: int = 0,
    first_path: bool = False,
) -> list[GoalPlan]:
    """Plan to every goal from ``start_at(goal stamp)`` (goals with no known start are skipped); ``seed`` >= 0.

    With ``first_path`` each query stops at its first path to the goal (reachability at a fraction of the cost).
    """
    plan_grid = planning_grid(grid, BURGER_RADIUS, allow_unknown=True)
    config = RRTStarConfig(iterations=iterations, time_budget=None, stop_at_first=first_path)
    plans = []
    for i, goal in enumerate(goals):
        start = start_at(goal.stamp)
        if start is None:
            continue
        target = np.array([goal.pose.x, goal.pose.y], dtype=np.float64)
        best: GoalPlan | None = None
        for k, heading in enumerate((start.yaw, wrap_angle(start.yaw + math.pi))):
            from_pose = Pose2D(start.x, start.y, heading)
            try:
                result = rrt_star(from_pose, target, plan_grid, config, np.random.default_rng([seed, i, k]))
            except NoPathFoundError as err:
                best = best or GoalPlan(from_pose, goal, None, err)
                continue
            if best is None or best.result is None or result.length_m < best.result.length_m:
                best = GoalPlan(from_pose, goal, result)
        assert best is not None
        plans.append(best)
    return plans
