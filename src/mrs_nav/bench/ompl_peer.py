"""OMPL's planners (PyPI ``ompl``, an optional peer) on one of our grids, for the planner benchmark's comparisons.

A state is valid when its cell is free in the same conservative mask our arc checks read; motions are checked
every cell. Times are CPU seconds, like ours.
"""

from __future__ import annotations

import math
from typing import Any

from mrs_nav.bench.planner_runs import CLOCK
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid


class OmplPlanner:
    """An OMPL planner on ``grid``: validity = the cell of the state is free in the conservative mask.

    ``turning_radius`` None plans in R^2 with straight edges; a radius plans in OMPL's Dubins space (forward
    arcs and lines of at least that radius; the goal is the state at ``goal`` heading along start -> goal,
    within 0.05 of OMPL's SE(2) distance, since OMPL needs a goal state where ours leaves the final yaw free).
    ``planner`` names an ``ompl.geometric`` class (RRTstar, InformedRRTstar, BITstar).
    """

    def __init__(
        self, grid: OccupancyGrid, start: Pose2D, goal: Any, *, turning_radius: float | None = None, planner: str
    ) -> None:
        from ompl import base as ob  # noqa: PLC0415 - optional peer, imported only when benchmarking against it
        from ompl import geometric as og  # noqa: PLC0415
        from ompl import util as ou  # noqa: PLC0415

        ou.setLogLevel(ou.LogLevel.LOG_NONE)
        self.ob, self.planner = ob, getattr(og, planner)
        dubins = turning_radius is not None
        space = ob.DubinsStateSpace(turning_radius) if dubins else ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        x0, y0, x1, y1 = grid.extent
        bounds.setLow(0, x0)
        bounds.setLow(1, y0)
        bounds.setHigh(0, x1)
        bounds.setHigh(1, y1)
        space.setBounds(bounds)
        self.setup = og.SimpleSetup(space)
        free = grid.conservative_free_mask.ravel().tolist()
        width, height, inv = grid.width, grid.height, 1.0 / grid.resolution

        def valid(state: Any) -> bool:
            # The same lookup as OccupancyGrid.lookup, scalar: OMPL calls back one state at a time.
            x, y = (state.getX(), state.getY()) if dubins else (state[0], state[1])
            col = math.floor((x - x0) * inv)
            row = math.floor((y - y0) * inv)
            return 0 <= col < width and 0 <= row < height and bool(free[row * width + col])

        self.setup.setStateValidityChecker(valid)
        si = self.setup.getSpaceInformation()
        si.setStateValidityCheckingResolution(grid.resolution / space.getMaximumExtent())
        s, g = space.allocState(), space.allocState()
        if dubins:
            s.setX(start.x)
            s.setY(start.y)
            s.setYaw(start.yaw)
            g.setX(float(goal[0]))
            g.setY(float(goal[1]))
            g.setYaw(math.atan2(float(goal[1]) - start.y, float(goal[0]) - start.x))
        else:
            s[0], s[1], g[0], g[1] = start.x, start.y, float(goal[0]), float(goal[1])
        self.setup.setStartAndGoalStates(s, g, 0.05 if dubins else 0.01)
        self.objective = ob.PathLengthOptimizationObjective(si)
        self.setup.setOptimizationObjective(self.objective)
        self.si = si
        # A start or goal state that fails the cell test: OMPL's planners then wait (BIT* sleeps in nextGoal) for
        # a valid goal until the condition ends, which a CPU-time condition never does. Such a query has no path.
        self.solvable = bool(si.isValid(s) and si.isValid(g))

    def solve(self, seconds: float, threshold: float) -> tuple[float, float]:
        """Plan until a path of at most ``threshold`` m or ``seconds`` of CPU; (CPU seconds, length or inf)."""
        if not self.solvable:
            return math.inf, math.inf
        self.setup.clear()
        self.objective.setCostThreshold(self.ob.Cost(threshold))
        self.setup.setPlanner(self.planner(self.si))
        t0 = CLOCK()
        end = t0 + seconds
        # The budget in CPU seconds too, like ours: OMPL polls this condition between iterations.
        condition = self.ob.PlannerTerminationCondition(lambda: CLOCK() > end)
        self.setup.solve(condition)
        elapsed = CLOCK() - t0
        del condition
        if not self.setup.haveExactSolutionPath():
            return math.inf, math.inf
        return elapsed, float(self.setup.getSolutionPath().length())
