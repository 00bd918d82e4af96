"""Circular-arc motion primitives between a pose and a position (assignment 3b), vectorised over many arcs.

From a pose ``(p1, theta1)`` to a position ``p2`` there is exactly one circular arc leaving ``p1`` tangent to
``theta1`` and passing through ``p2``. With the chord direction ``phi = atan2(y2 - y1, x2 - x1)``, the chord
length ``L = |p2 - p1|`` and the half turn ``alpha = wrap(phi - theta1)``:

- the arc ends with yaw ``theta2 = theta1 + 2 alpha = 2 phi - theta1`` (the chord makes equal angles with the
  tangents at both ends);
- its signed curvature is ``kappa = 2 sin(alpha) / L`` (radius ``r = 1 / |kappa|``, centre ``p1 + r n`` on the
  left normal ``n`` when turning left), ``kappa = 0`` being the straight line;
- its length is ``S = L alpha / sin(alpha)`` (``S = L`` when ``alpha = 0``);
- the point at arc length ``s`` is ``p1 + s sinc(kappa s / 2) (cos(theta1 + kappa s / 2), sin(...))`` with
  ``sinc(x) = sin(x) / x``, which is exact and stable through the straight case, and its yaw is
  ``theta1 + kappa s``.

The robot only drives forward: ``|alpha| < pi / 2`` keeps the target ahead of the start pose, and planners can
tighten this with ``max_alpha``. An optional minimum turning radius (assignment 4b) rejects arcs with
``r < min_turning_radius``.

Collision checks sample every arc at arc-length steps of at most one grid resolution, endpoints included, and
look the samples up in the grid's *conservative* free mask (free cell and free eight neighbours): every point
between two samples is then within half a resolution of a sample and so inside a free cell of the grid. That
costs a margin of one cell, so an arc that fails it while all its samples are in free cells is checked again
finely where it failed: from the sample before each failing run of samples to the sample after it, samples every
resolution / 8 must be in free cells, and where two consecutive samples lie in diagonal cells both cells of the
corner they cut must be free too (the cells a segment between them crosses). The rest of the arc lies within half
a step of a sample whose cell and neighbours are free, so in free cells. Paths may
then pass as close to the inflated obstacles as the grid allows, and a start or goal next to them can be left or
reached.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import BoolArray, IntArray, OccupancyGrid
from mrs_nav.trees import kernels
from mrs_nav.trees.kernels import MIN_CHORD


class Arcs(NamedTuple):
    """A batch of ``N`` arcs: start positions ``(N, 2)``, start yaws, half turns ``alpha``, chord lengths,
    curvatures (1/m), lengths (m) and end yaws (rad, wrapped to [-pi, pi)).

    A NamedTuple rather than a frozen dataclass: planners build several per iteration, and this is cheaper.
    """

    start: FloatArray
    yaw: FloatArray
    alpha: FloatArray
    chord: FloatArray
    curvature: FloatArray
    length: FloatArray
    end_yaw: FloatArray


def connect(start: npt.ArrayLike, yaw: npt.ArrayLike, target: npt.ArrayLike) -> Arcs:
    """The arcs from poses ``(start (N, 2), yaw (N,))`` to positions ``target (N, 2)``.

    Either side may be a single pose or position (``(2,)`` and a scalar yaw), shared by all arcs.
    """
    p2 = np.asarray(target, dtype=np.float64)
    d = p2 - np.asarray(start, dtype=np.float64)
    if d.ndim == 1:
        d = d[None, :]
    # Materialise the start of every arc (cheaper than np.broadcast_to on these small batches).
    p1 = np.empty_like(d)
    p1[:] = start
    theta1 = np.empty(len(d))
    theta1[:] = yaw
    chord = np.hypot(d[:, 0], d[:, 1])
    phi = np.arctan2(d[:, 1], d[:, 0])
    alpha = (phi - theta1 + np.pi) % (2.0 * np.pi) - np.pi
    sin_alpha = np.sin(alpha)
    curvature = 2.0 * sin_alpha / np.maximum(chord, MIN_CHORD)
    # S = L alpha / sin(alpha), and S = L on the straight line (alpha = 0).
    length = chord * np.divide(alpha, sin_alpha, out=np.ones_like(alpha), where=sin_alpha != 0.0)
    end_yaw = (theta1 + 2.0 * alpha + np.pi) % (2.0 * np.pi) - np.pi
    return Arcs(p1, theta1, alpha, chord, curvature, length, end_yaw)


def alpha_limit(max_alpha: float) -> float:
    """The largest ``|alpha|`` allowed: ``max_alpha``, kept strictly below a right angle (the target ahead)."""
    return min(max_alpha, math.pi / 2 - kernels.FORWARD_MARGIN)


def feasible(arcs: Arcs, max_alpha: float = math.pi / 2, min_turning_radius: float = 0.0) -> BoolArray:
    """True for arcs that drive forward with ``|alpha| <= max_alpha`` (< pi/2) and radius >= the minimum."""
    limit = alpha_limit(max_alpha)
    ok: BoolArray = (arcs.chord > MIN_CHORD) & (np.abs(arcs.alpha) <= limit)
    if min_turning_radius > 0.0:
        ok &= np.abs(arcs.curvature) * min_turning_radius <= 1.0
    return ok


def sample(
    arcs: Arcs, step: float, where: BoolArray | None = None, *, with_yaw: bool = True
) -> tuple[FloatArray, IntArray]:
    """Poses ``(M, 3)`` along every arc at equal arc-length spacing of at most ``step`` metres, both ends included,
    and ``first (N + 1,)``: arc ``i``'s poses are rows ``first[i]:first[i + 1]``.

    Arcs where ``where`` is False get only their two end poses (callers ignore them; this keeps infeasible, long
    arcs from costing samples). Without ``with_yaw`` the third column is left unset (collision checks).
    """
    segments = np.maximum(np.ceil(arcs.length / step - 1e-9), 1).astype(np.intp)
    if where is not None:
        segments[~where] = 1
    first = np.zeros(len(segments) + 1, dtype=np.intp)
    np.cumsum(segments + 1, out=first[1:])
    owner = np.repeat(np.arange(len(segments)), segments + 1)
    k = np.arange(first[-1]) - first[owner]
    s = arcs.length[owner] * (k / segments[owner])
    kappa = arcs.curvature[owner]
    half = 0.5 * kappa * s
    # chord to the point at arc length s: s sin(half) / half, = s on the straight line
    chord = s * np.divide(np.sin(half), half, out=np.ones_like(half), where=half != 0.0)
    heading = arcs.yaw[owner] + half
    poses = np.empty((first[-1], 3), dtype=np.float64)
    poses[:, 0] = arcs.start[owner, 0] + chord * np.cos(heading)
    poses[:, 1] = arcs.start[owner, 1] + chord * np.sin(heading)
    if with_yaw:
        poses[:, 2] = (heading + half + np.pi) % (2.0 * np.pi) - np.pi
    return poses, first


def collision_free(arcs: Arcs, grid: OccupancyGrid, where: BoolArray | None = None) -> BoolArray:
    """True for arcs whose every point lies in a free cell of ``grid`` (checked as the module docstring says,
    arc by arc in compiled code: :func:`mrs_nav.trees.kernels.arc_free`).

    With ``where``, only those arcs are checked and the others come back False.
    """
    mask = np.ones(len(arcs.length), dtype=bool) if where is None else np.ascontiguousarray(where, dtype=bool)
    start = np.ascontiguousarray(arcs.start, dtype=np.float64)
    return kernels.arcs_free(start, arcs.yaw, arcs.curvature, arcs.length, mask, kernels.grid_args(grid))


def checked(
    arcs: Arcs, grid: OccupancyGrid, max_alpha: float = math.pi / 2, min_turning_radius: float = 0.0
) -> BoolArray:
    """True for arcs that are :func:`feasible` and :func:`collision_free` (only feasible ones are sampled)."""
    return collision_free(arcs, grid, feasible(arcs, max_alpha, min_turning_radius))


def find_circle(pose: Pose2D, position: npt.ArrayLike) -> tuple[FloatArray, float]:
    """Centre ``(2,)`` and radius (m) of the circle tangent to ``pose`` through ``position``.

    The straight case has no circle: the radius is ``inf`` and the centre ``(nan, nan)``.
    """
    arc = connect(pose.position, pose.yaw, np.asarray(position, dtype=np.float64)[:2])
    kappa = float(arc.curvature[0])
    if kappa == 0.0 or arc.chord[0] <= MIN_CHORD:
        return np.array([math.nan, math.nan]), math.inf
    # The centre lies on the normal to the left of the heading for a left turn (kappa > 0).
    normal = np.array([-math.sin(pose.yaw), math.cos(pose.yaw)])
    return pose.position + normal / kappa, 1.0 / abs(kappa)


def adjust_pose(
    pose: Pose2D,
    position: npt.ArrayLike,
    grid: OccupancyGrid,
    *,
    max_alpha: float = math.pi / 2,
    min_turning_radius: float = 0.0,
) -> Pose2D | None:
    """The pose at ``position`` reached from ``pose`` along the arc (yaw ``2 phi - theta1``), or None when that arc
    drives backwards, turns tighter than ``min_turning_radius`` or leaves the free space of ``grid``."""
    target = np.asarray(position, dtype=np.float64)[:2]
    arc = connect(pose.position, pose.yaw, target)
    if not checked(arc, grid, max_alpha, min_turning_radius)[0]:
        return None
    return Pose2D(float(target[0]), float(target[1]), float(arc.end_yaw[0]))


def take(arcs: Arcs, index: npt.ArrayLike) -> Arcs:
    """The sub-batch of ``arcs`` at ``index`` (an index array or boolean mask)."""
    i = np.asarray(index)
    return Arcs(*(field[i] for field in arcs))
