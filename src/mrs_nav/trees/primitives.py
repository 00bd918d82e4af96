"""The obvious first paths RRT* tries before sampling: turn on a circle, then drive straight to the goal.

From the start pose, a circle of radius ``r`` turning left or right; the point where the line to the goal leaves
it tangentially splits the way into the planner's own edges: the turn from the start pose to that point (the
circle itself, since an arc is tangent to the start heading), then a straight arc on to the goal. This is the
turn-straight family of Dubins paths, drawn with the course's arcs: every piece is checked exactly like any other
edge (:func:`mrs_nav.trees.kernels.checked_arc`: feasible, within ``max_alpha``, collision-free), so nothing here
needs to be exact.

An arc turns by twice its ``alpha``, so one edge turns by less than ``2 max_alpha`` (half a turn at most). A
longer turn, as a goal behind the robot needs, is split into equal pieces on the same circle, each one an edge.

The candidates are laid out, ordered and checked in one compiled call: this is the first thing every query
does, and a goal in the open is answered by it alone. A goal round corners is answered by a chain of them along
the guide's corridor (:func:`follow_corridor`): corner to corner, each corner the farthest corridor point in
straight sight of the last. The radii double from 0.1 m: a corner next to an obstacle leaves room only for a tight
turn, and a goal behind the robot by a wall needs a wider one.
"""

# ruff: noqa: PLR0917

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types as nt

from mrs_nav.geometry import FloatArray
from mrs_nav.trees.kernels import GridArgs, arc_free, checked_arc

_F = nt.float64
_B = nt.boolean
_F1 = nt.Array(_F, 1, "C")
_F2 = nt.Array(_F, 2, "C")
_GRID = nt.Tuple((nt.Array(nt.boolean, 2, "C"), nt.Array(nt.boolean, 2, "C"), _F, _F, _F, _F, _F))  # type: ignore[no-untyped-call]

#: Turning radii (m) of the candidate circles; those below the planner's minimum turning radius are skipped.
TURN_RADII = np.array([0.1, 0.2, 0.4, 0.8])
# A piece of a split turn stays this far (rad) below the largest turn one edge allows.
_TURN_MARGIN = 1e-3


@numba.njit(_F2(_F, _F, _F, _F, _F, _F1, _F, _F, _GRID), cache=True)
def turn_then_straight(
    x: float,
    y: float,
    yaw: float,
    gx: float,
    gy: float,
    radii: FloatArray,
    max_alpha: float,
    min_turning_radius: float,
    grid: GridArgs,
) -> FloatArray:
    """The shortest free turn-then-straight way from the pose ``(x, y, yaw)`` to ``(gx, gy)`` over circles of
    ``radii`` on both sides, as rows ``(x, y, end yaw, length)`` of its arcs (the last one ends on the goal), or no
    rows when none is feasible and free. ``max_alpha`` is the planner's cap (below a right angle)."""
    count = 2 * len(radii)
    length = np.full(count, np.inf)
    centre = np.zeros((count, 2))
    begin, turn = np.zeros(count), np.zeros(count)
    for i in range(count):
        r, side = radii[i // 2], 1.0 if i % 2 == 0 else -1.0  # left (counter-clockwise), right
        if r < min_turning_radius:
            continue
        cx, cy = x - side * r * math.sin(yaw), y + side * r * math.cos(yaw)
        d = math.hypot(gx - cx, gy - cy)
        if d <= r:
            continue  # the goal inside the circle
        # The tangent point seen from the centre: the goal's bearing turned back by acos(r / d) on this side.
        at = math.atan2(gy - cy, gx - cx) - side * math.acos(r / d)
        begin[i] = math.atan2(y - cy, x - cx)
        turn[i] = side * ((side * (at - begin[i])) % (2.0 * math.pi))
        centre[i] = cx, cy
        length[i] = r * abs(turn[i]) + math.sqrt(d * d - r * r)
    for i in np.argsort(length, kind="mergesort"):
        if not math.isfinite(length[i]):
            break
        r = radii[i // 2]
        pieces = max(1, math.ceil(abs(turn[i]) / max(2.0 * max_alpha - _TURN_MARGIN, _TURN_MARGIN)))
        out = np.empty((pieces + 1, 4))
        px, py, pyaw = x, y, yaw
        for k in range(pieces + 1):
            if k < pieces:
                a = begin[i] + turn[i] * (k + 1) / pieces
                nx, ny = centre[i, 0] + r * math.cos(a), centre[i, 1] + r * math.sin(a)
            else:
                nx, ny = gx, gy
            piece, pyaw = checked_arc(px, py, pyaw, nx, ny, max_alpha, min_turning_radius, grid)
            if not math.isfinite(piece):
                break
            out[k] = nx, ny, pyaw, piece
            px, py = nx, ny
        else:
            return out
    return np.zeros((0, 4))


@numba.njit(_B(_F, _F, _F, _F, _GRID), cache=True)
def _in_sight(x: float, y: float, tx: float, ty: float, grid: GridArgs) -> bool:
    """Whether the straight segment from ``(x, y)`` to ``(tx, ty)`` is free."""
    return arc_free(x, y, math.atan2(ty - y, tx - x), 0.0, math.hypot(tx - x, ty - y), grid)


@numba.njit(_F2(_F, _F, _F, _F2, _F1, _F, _F, _GRID), cache=True)
def follow_corridor(
    x: float,
    y: float,
    yaw: float,
    path: FloatArray,
    radii: FloatArray,
    max_alpha: float,
    min_turning_radius: float,
    grid: GridArgs,
) -> FloatArray:
    """Turn-then-straight ways from the pose ``(x, y, yaw)`` along the corridor ``path`` ``(K, 2)`` (its first row
    the start, its last the goal), from corner to corner; rows ``(x, y, end yaw, length)`` of their arcs up to the
    last corner reached (the last row on the goal when every corner was).

    From corridor point ``i`` the next corner is the farthest corridor point in straight sight, found by
    bisection between ``i`` and the goal (a point in sight moves the lower end up, one out of sight the upper
    end down: about ``log2 K`` straight checks, against a way of several candidate arcs for each point). When
    no turn-then-straight way reaches that corner, the point halfway to it is tried, and so on."""
    last = len(path) - 1
    out = np.empty((0, 4))
    at = 0
    while at < last:
        lo, hi = at, last
        if _in_sight(x, y, path[hi, 0], path[hi, 1], grid):
            lo = hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if _in_sight(x, y, path[mid, 0], path[mid, 1], grid):
                lo = mid
            else:
                hi = mid
        way = np.zeros((0, 4))
        while lo > at:
            way = turn_then_straight(x, y, yaw, path[lo, 0], path[lo, 1], radii, max_alpha, min_turning_radius, grid)
            if len(way):
                break
            lo = at + (lo - at) // 2
        if not len(way):
            return out
        out = np.concatenate((out, way))
        at = lo
        x, y, yaw = way[-1, 0], way[-1, 1], way[-1, 2]
    return out
