"""Planning off the control loop: the protocol between a :class:`~mrs_nav.navigation.navigator.Navigator` and
a worker thread, and the planners it runs.

``Navigator.update(pose, now, defer=True)`` does not plan but returns a :class:`PlanRequest` in its command;
the caller runs :func:`run_plan` on it (in a worker thread: it reads only the request, the planner and the
random generator) and hands the :data:`PlanOutcome` to ``Navigator.finish_plan`` on a later step, which
applies the same rules as a synchronous plan. Requests are compared by identity, so the navigator recognises
(and ignores) the outcome of a request made stale by a new goal, a cancel or reaching the goal.

Planning (with any :class:`Planner`, RRT* by default in the nodes) happens on the map inflated by the robot
radius plus a safety margin. The cells within the inflation distance of the robot itself are cleared of
inflation before planning (:func:`clear_footprint`), so a robot that has drifted close to a wall can still plan
its way out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.geometry import FloatArray, Pose2D, wrap_angle
from mrs_nav.maps.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from mrs_nav.planning import PlanResult
from mrs_nav.trees.rrt import RRTConfig, rrt
from mrs_nav.trees.rrt_star import RRTStarConfig, rrt_star


class Planner(Protocol):
    """Plans from ``start`` to the position ``goal`` on ``grid`` (already inflated; plan only on free cells).

    Returns a :class:`PlanResult` whose ``path`` is ``(N, 3)`` poses; raises
    :class:`~mrs_nav.errors.NoPathFoundError` when it finds no path and another :class:`MrsNavError` on a bad
    query (e.g. the start or goal is not free). ``rng`` seeds any randomness.
    """

    def __call__(
        self, grid: OccupancyGrid, start: Pose2D, goal: tuple[float, float], rng: np.random.Generator
    ) -> PlanResult: ...


@dataclass(frozen=True, eq=False)
class PlanRequest:
    """One plan to make (see :func:`run_plan`): from ``pose`` to ``goal`` on ``grid`` (inflated) and ``raw`` (the
    same map before inflation), asked at ``now`` for ``reason``; ``remaining_m`` is what was left of the current
    path then (from the robot), which an optional plan must clearly beat. Compared by identity."""

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


def run_plan(
    request: PlanRequest, planner: Planner, rng: np.random.Generator, inflation_m: float, turned_round: bool
) -> PlanOutcome:
    """Plan for ``request`` with ``planner`` from the robot, and (``turned_round``) from it turned round on the
    spot: arcs run forward only, so a goal behind the robot otherwise costs a loop. The shorter plan wins."""
    pose = request.pose
    grid = clear_footprint(request.grid, request.raw, [pose.x, pose.y], inflation_m)
    starts = [pose]
    if turned_round:
        starts.append(Pose2D(pose.x, pose.y, wrap_angle(pose.yaw + math.pi)))
    best: PlanResult | None = None
    why = "no path"
    for start in starts:
        try:
            result = planner(grid, start, request.goal, rng)
        except MrsNavError as err:
            why = str(err)
            continue
        if best is None or result.length_m < best.length_m:
            best = result
    return best, "" if best is not None else why


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
