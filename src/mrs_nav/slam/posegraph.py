"""A 2-D pose graph optimised with scipy's sparse nonlinear least squares, with wrong loop edges pruned.

Nodes are poses ``(x, y, yaw)``; an edge ``(i, j, z)`` says that pose ``j`` seen from pose ``i`` is ``z``. The
residual of an edge is ``z^-1 (x_i^-1 x_j)`` as ``(dx, dy, dyaw)`` scaled by the edge's standard deviations.
The first pose is held fixed (the map frame); ``scipy.optimize.least_squares`` solves with a sparse Jacobian.

Robustness to false loop closures (:func:`close_loop`): loop edges are added one at a time to a graph that is
consistent. A true closure agrees with the rest once its drift is spread over the trajectory, so after the solve
every edge stays within :data:`GATE` standard deviations; a false one strains some edge past it and is rejected,
the graph kept as it was. (A robust kernel such as Cauchy's was tried first: it also discounts the true closure
of a long drift, whose residual starts large, and least squares spreads a false one thin enough to pass a gate
on the loop edge's own residual.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from mrs_nav.geometry import FloatArray, Pose2D, wrap_angles


@dataclass(frozen=True)
class Edge:
    """Pose ``j`` in the frame of pose ``i`` is ``measured``, with standard deviations (m, rad)."""

    i: int
    j: int
    measured: Pose2D
    sigma_xy: float
    sigma_yaw: float


GATE = 4.0  # standard deviations (norm of an edge's three scaled residuals) any edge may keep after a solve


def _residuals(flat: FloatArray, first: FloatArray, edges: Sequence[Edge], z: FloatArray, w: FloatArray) -> FloatArray:
    poses = np.vstack([first, flat.reshape(-1, 3)])
    i = np.array([e.i for e in edges])
    j = np.array([e.j for e in edges])
    xi, xj = poses[i], poses[j]
    c, s = np.cos(xi[:, 2]), np.sin(xi[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    # x_i^-1 x_j
    rx, ry, ryaw = c * dx + s * dy, -s * dx + c * dy, xj[:, 2] - xi[:, 2]
    # z^-1 (x_i^-1 x_j)
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    ex, ey = rx - z[:, 0], ry - z[:, 1]
    res = np.stack([cz * ex + sz * ey, -sz * ex + cz * ey, wrap_angles(ryaw - z[:, 2])], axis=1)
    return np.asarray((res * w).ravel(), dtype=np.float64)


def optimise(poses: Sequence[Pose2D], edges: Sequence[Edge], *, max_evaluations: int = 50) -> OptimisedGraph:
    """The poses that best satisfy ``edges`` from the initial ``poses`` (the first stays where it is) and the
    largest normalised edge residual there."""
    if len(poses) < 2 or not edges:
        return OptimisedGraph(list(poses), 0.0)
    start = np.array([[p.x, p.y, p.yaw] for p in poses], dtype=np.float64)
    flat, residuals = _solve(start[1:].ravel(), start[0], edges, max_evaluations)
    worst = float(np.linalg.norm(residuals.reshape(-1, 3), axis=1).max())
    out = flat.reshape(-1, 3)
    optimised = [poses[0], *(Pose2D(float(x), float(y), float(np.arctan2(np.sin(t), np.cos(t)))) for x, y, t in out)]
    return OptimisedGraph(optimised, worst)


def close_loop(poses: Sequence[Pose2D], edges: Sequence[Edge], loop: Edge) -> OptimisedGraph | None:
    """The graph optimised with ``loop`` added, or None when that leaves an edge past :data:`GATE`."""
    result = optimise(poses, [*edges, loop])
    return result if result.worst_residual <= GATE else None


@dataclass(frozen=True)
class OptimisedGraph:
    """Optimised poses and the largest normalised edge residual (standard deviations) they leave."""

    poses: list[Pose2D]
    worst_residual: float


def _solve(
    flat: FloatArray, first: FloatArray, edges: Sequence[Edge], max_evaluations: int
) -> tuple[FloatArray, FloatArray]:
    z = np.array([[e.measured.x, e.measured.y, e.measured.yaw] for e in edges], dtype=np.float64)
    w = np.array([[1.0 / e.sigma_xy, 1.0 / e.sigma_xy, 1.0 / e.sigma_yaw] for e in edges], dtype=np.float64)
    n = flat.size
    sparsity = lil_matrix((3 * len(edges), n), dtype=np.int8)
    for k, edge in enumerate(edges):
        for node in (edge.i, edge.j):
            if node > 0:
                sparsity[3 * k : 3 * k + 3, 3 * (node - 1) : 3 * node] = 1
    solution = least_squares(
        _residuals,
        flat,
        jac_sparsity=sparsity,
        method="trf",
        x_scale="jac",
        max_nfev=max_evaluations,
        args=(first, edges, z, w),
    )
    return np.asarray(solution.x, dtype=np.float64), np.asarray(solution.fun, dtype=np.float64)
