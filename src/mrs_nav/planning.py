"""The result every planner returns (potential field, RRT, RRT*), and path helpers.

A planner that ends without reaching the goal raises :class:`~mrs_nav.errors.NoPathFoundError` (with the reason
and what it spent) instead of returning: a :class:`PlanResult` always holds a path from the start to the goal.

A path is an ``(N, 3)`` float array of waypoints ``(x, y, yaw)`` in metres and radians, in the frame of the
obstacles or map it was planned on. Its length is the sum of the Euclidean lengths of its segments,
``L = sum_k |p_{k+1} - p_k|`` over the positions ``p_k = (x_k, y_k)``; yaw does not count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def path_length(path: npt.ArrayLike) -> float:
    """Length in metres of a polyline given as ``(N, 2)`` or ``(N, 3)`` rows; 0 for fewer than 2 points."""
    points = np.asarray(path, dtype=np.float64)
    if points.ndim != 2 or points.shape[0] < 2:
        return 0.0
    x, y = points[:, 0], points[:, 1]
    return float(np.hypot(x[1:] - x[:-1], y[1:] - y[:-1]).sum())


def headings_along(points: npt.ArrayLike, final_yaw: float | None = None) -> FloatArray:
    """Give an ``(N, 2)`` polyline a yaw per waypoint: the direction of the segment leaving it.

    The last waypoint keeps the heading of the segment reaching it (or ``final_yaw`` when given). Returns an
    ``(N, 3)`` array ``(x, y, yaw)``.
    """
    xy = np.asarray(points, dtype=np.float64)[:, :2]
    out = np.zeros((xy.shape[0], 3), dtype=np.float64)
    out[:, :2] = xy
    if xy.shape[0] >= 2:
        step = np.diff(xy, axis=0)
        out[:-1, 2] = np.arctan2(step[:, 1], step[:, 0])
        out[-1, 2] = out[-2, 2]
    if final_yaw is not None and xy.shape[0] >= 1:
        out[-1, 2] = final_yaw
    return out


@dataclass(frozen=True)
class PlanResult:
    """Outcome of one planning query.

    ``path`` holds the waypoints ``(x, y, yaw)`` from the start to the goal. ``length_m`` is :func:`path_length`
    of ``path``; ``time_s`` the wall-clock planning time; ``first_solution_s`` the time at which a first path
    reaching the goal was known; ``iterations`` the planner's steps (field integration steps or tree expansions);
    ``nodes`` the vertices kept (trajectory points or tree size); ``reason`` a short human-readable explanation
    (``"goal reached"``, or ``"best path within budget"`` for RRT*, which improves its path until the budget ends).
    """

    path: FloatArray
    length_m: float
    time_s: float
    first_solution_s: float
    iterations: int
    nodes: int
    reason: str

    def to_json(self) -> dict[str, object]:
        """The JSON form printed by ``mrs-nav plan --json`` (``success`` is always true: a failure raises)."""
        return {
            "success": True,
            "length_m": self.length_m,
            "time_s": self.time_s,
            "first_solution_s": self.first_solution_s,
            "iterations": self.iterations,
            "nodes": self.nodes,
            "reason": self.reason,
            "path": [[float(v) for v in row] for row in np.asarray(self.path, dtype=np.float64).reshape(-1, 3)],
        }
