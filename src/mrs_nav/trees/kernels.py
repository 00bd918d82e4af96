"""Compiled kernels of the tree planners: the arc algebra of :mod:`mrs_nav.trees.arcs` and its collision check,
one arc at a time, and RRT*'s extend step (steer, choose parent, add, rewire) as one call, so that an RRT*
iteration is one compiled call instead of ~300 numpy calls on a handful of elements (the profile of issue 18:
1,270 iterations/s against OMPL's 13,900) or a dozen compiled calls glued by Python (issue 17: that glue and the
calls' dispatch were ~40 % of a plan).

The formulas and the collision check are those of :mod:`mrs_nav.trees.arcs` (read its docstring); the numpy
versions there stay for batches (drawing, path sampling) and as the reference the tests compare these with.
A tree enters as one tuple of its arrays (:attr:`mrs_nav.trees.tree.ArcTree.arrays`), and a grid as one tuple
(:func:`grid_args`): ``cons`` (conservative free mask), ``free`` (free mask),
``x0, y0`` (origin), ``c, s`` (cos and sin of the origin's yaw) and ``res`` (metres per cell). Kernels take
positional arguments only (explicit signatures), hence the file-wide exemption from ruff's PLR0917.
"""

# ruff: noqa: PLR0917

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types as nt

from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import BoolArray, IntArray, OccupancyGrid

# Chords shorter than this (metres) do not define a direction, so no arc.
MIN_CHORD = 1e-9
# |alpha| must stay below a right angle by this much for the target to be strictly ahead.
FORWARD_MARGIN = 1e-9

_F = nt.float64
_I = nt.intp
_B = nt.boolean
_F1 = nt.Array(_F, 1, "C")
_F2 = nt.Array(_F, 2, "C")
_I1 = nt.Array(_I, 1, "C")
_B1 = nt.Array(_B, 1, "C")
_B2 = nt.Array(_B, 2, "C")
_GRID = nt.Tuple((_B2, _B2, _F, _F, _F, _F, _F))  # type: ignore[no-untyped-call]
_PARENT = nt.Tuple((_I, _F, _F))  # type: ignore[no-untyped-call]
_REWIRES = nt.Tuple((_I1, _F1, _F1))  # type: ignore[no-untyped-call]
_NEAREST = nt.Tuple((_I1, _F1))  # type: ignore[no-untyped-call]
_ARC = nt.UniTuple(_F, 4)  # type: ignore[no-untyped-call]
_XY = nt.UniTuple(_F, 2)  # type: ignore[no-untyped-call]
_LEN_YAW = _XY
_CELL = nt.UniTuple(_I, 2)  # type: ignore[no-untyped-call]
_TREE = nt.Tuple((_F2, _F1, _F1, _I1, _I1, _I1))  # type: ignore[no-untyped-call]

# Costs closer than this (metres) count as equal.
COST_EPS = 1e-9

GridArgs = tuple[BoolArray, BoolArray, float, float, float, float, float]
#: A tree's arrays: position (N, 2), yaw, cost, parent, first child, next sibling (-1: none).
TreeArrays = tuple[FloatArray, FloatArray, FloatArray, IntArray, IntArray, IntArray]
#: The numba types of :data:`GridArgs` and :data:`TreeArrays`, for the signatures of other kernel modules.
GRID_TYPE = _GRID
TREE_TYPE = _TREE


def grid_args(grid: OccupancyGrid) -> GridArgs:
    """The grid as the kernels take it: ``(cons, free, x0, y0, c, s, res)`` (see the module docstring)."""
    x0, y0, yaw = grid.origin
    cons = np.ascontiguousarray(grid.conservative_free_mask)
    free = np.ascontiguousarray(grid.free_mask)
    return cons, free, x0, y0, math.cos(yaw), math.sin(yaw), grid.resolution


@numba.njit(_ARC(_F, _F, _F, _F, _F), cache=True)
def connect_one(x1: float, y1: float, yaw: float, x2: float, y2: float) -> tuple[float, float, float, float]:
    """``(alpha, curvature, length, end_yaw)`` of the arc from pose ``(x1, y1, yaw)`` to ``(x2, y2)``."""
    dx, dy = x2 - x1, y2 - y1
    chord = math.hypot(dx, dy)
    alpha = (math.atan2(dy, dx) - yaw + math.pi) % (2.0 * math.pi) - math.pi
    sin_alpha = math.sin(alpha)
    curvature = 2.0 * sin_alpha / max(chord, MIN_CHORD)
    length = chord * alpha / sin_alpha if sin_alpha != 0.0 else chord
    end_yaw = (yaw + 2.0 * alpha + math.pi) % (2.0 * math.pi) - math.pi
    return alpha, curvature, length, end_yaw


@numba.njit(_B(_F, _F, _F, _F, _F), cache=True)
def feasible_one(chord: float, alpha: float, curvature: float, max_alpha: float, min_turning_radius: float) -> bool:
    """The test of :func:`mrs_nav.trees.arcs.feasible` for one arc (``max_alpha`` already capped below pi/2)."""
    ok = chord > MIN_CHORD and abs(alpha) <= max_alpha
    if min_turning_radius > 0.0:
        ok = ok and abs(curvature) * min_turning_radius <= 1.0
    return ok


@numba.njit(_CELL(_F, _F, _F, _F, _F, _F, _F), cache=True)
def _cell(px: float, py: float, x0: float, y0: float, c: float, s: float, res: float) -> tuple[int, int]:
    """Unclipped ``(row, col)`` of a point, as :meth:`OccupancyGrid.cells` computes it."""
    dx, dy = px - x0, py - y0
    return math.floor((-s * dx + c * dy) / res), math.floor((c * dx + s * dy) / res)


@numba.njit(_B(_B2, _I, _I), cache=True)
def _at(mask: BoolArray, row: int, col: int) -> bool:
    """The mask at a cell; False outside the grid."""
    return 0 <= row < mask.shape[0] and 0 <= col < mask.shape[1] and mask[row, col]


@numba.njit(_I(_F, _F), cache=True)
def _segments(length: float, step: float) -> int:
    return max(math.ceil(length / step - 1e-9), 1)


@numba.njit(_XY(_F, _F, _F, _F, _F), cache=True)
def _point(x1: float, y1: float, yaw: float, curvature: float, s: float) -> tuple[float, float]:
    """The point at arc length ``s`` (the sinc form of arcs.py, exact through the straight case)."""
    half = 0.5 * curvature * s
    chord = s * math.sin(half) / half if half != 0.0 else s
    heading = yaw + half
    return x1 + chord * math.cos(heading), y1 + chord * math.sin(heading)


@numba.njit(_F2(_F2, _F1, _F2, _F), cache=True)
def chain_poses(start: FloatArray, yaw: FloatArray, target: FloatArray, step: float) -> FloatArray:
    """Poses ``(M, 3)`` along the chain of arcs from poses ``(start[i], yaw[i])`` to ``target[i]``, each sampled at
    equal arc-length spacing of at most ``step`` metres as :func:`mrs_nav.trees.arcs.sample` does, with each arc's
    first pose left out after the first arc's (it repeats the previous arc's last one)."""
    count = len(yaw)
    segments = np.empty(count, dtype=np.intp)
    curvature = np.empty(count)
    length = np.empty(count)
    total = 1
    for i in range(count):
        _, curvature[i], length[i], _ = connect_one(start[i, 0], start[i, 1], yaw[i], target[i, 0], target[i, 1])
        segments[i] = _segments(length[i], step)
        total += segments[i]
    out = np.empty((total, 3))
    row = 0
    for i in range(count):
        for k in range(0 if i == 0 else 1, segments[i] + 1):
            s = length[i] * (k / segments[i])
            half = 0.5 * curvature[i] * s
            chord = s * math.sin(half) / half if half != 0.0 else s
            heading = yaw[i] + half
            out[row, 0] = start[i, 0] + chord * math.cos(heading)
            out[row, 1] = start[i, 1] + chord * math.sin(heading)
            out[row, 2] = (heading + half + math.pi) % (2.0 * math.pi) - math.pi
            row += 1
    return out


@numba.njit(_B(_F, _F, _F, _F, _F, _F, _GRID), cache=True)
def _span_free(x1: float, y1: float, yaw: float, curvature: float, s0: float, s1: float, grid: GridArgs) -> bool:
    """The fine check of :func:`arc_free` on the arc's stretch from arc length ``s0`` to ``s1``: samples every
    resolution / 8 or less in ``free``, and the corners they cut."""
    _, free, x0, y0, c, s, res = grid
    n = _segments(s1 - s0, res / 8.0)
    prev_row, prev_col = -1, -1
    for k in range(n + 1):
        px, py = _point(x1, y1, yaw, curvature, s0 + (s1 - s0) * (k / n))
        row, col = _cell(px, py, x0, y0, c, s, res)
        if not _at(free, row, col):
            return False
        # Diagonal neighbours: the segment between the samples crosses one of the corner's other two cells.
        corner = k > 0 and row != prev_row and col != prev_col
        if corner and not (_at(free, prev_row, col) and _at(free, row, prev_col)):
            return False
        prev_row, prev_col = row, col
    return True


@numba.njit(_B(_F, _F, _F, _F, _F, _GRID), cache=True)
def arc_free(x1: float, y1: float, yaw: float, curvature: float, length: float, grid: GridArgs) -> bool:
    """True when every point of the arc lies in a free cell: samples every resolution or less in ``cons``; where
    one is not (but is in ``free``), the stretch from the sample before it to the sample after it is checked
    finely (:func:`_span_free`). Each point of the arc lies within half a step of a sample, so in that sample's
    cell or a neighbour: free around a sample in ``cons``, and checked finely around any other (the check of
    :func:`mrs_nav.trees.arcs.collision_free`)."""
    cons, free, x0, y0, c, s, res = grid
    n = _segments(length, res)
    plain = True
    for k in range(n + 1):
        px, py = _point(x1, y1, yaw, curvature, length * (k / n))
        row, col = _cell(px, py, x0, y0, c, s, res)
        if not _at(cons, row, col):
            plain = False
            if not _at(free, row, col):
                return False
    if plain:
        return True
    # Runs of samples outside ``cons``, each widened by one sample on both sides, are checked finely.
    k = 0
    while k <= n:
        px, py = _point(x1, y1, yaw, curvature, length * (k / n))
        row, col = _cell(px, py, x0, y0, c, s, res)
        if _at(cons, row, col):
            k += 1
            continue
        last = k
        while last < n:
            px, py = _point(x1, y1, yaw, curvature, length * ((last + 1) / n))
            row, col = _cell(px, py, x0, y0, c, s, res)
            if _at(cons, row, col):
                break
            last += 1
        begin, end = max(k - 1, 0), min(last + 1, n)
        if not _span_free(x1, y1, yaw, curvature, length * (begin / n), length * (end / n), grid):
            return False
        k = last + 1
    return True


@numba.njit(_B1(_F2, _F1, _F1, _F1, _B1, _GRID), cache=True)
def arcs_free(
    start: FloatArray, yaw: FloatArray, curvature: FloatArray, length: FloatArray, where: BoolArray, grid: GridArgs
) -> BoolArray:
    """:func:`arc_free` of every arc where ``where`` is True (False elsewhere)."""
    out = np.zeros(len(yaw), dtype=np.bool_)
    for i in range(len(yaw)):
        if where[i]:
            out[i] = arc_free(start[i, 0], start[i, 1], yaw[i], curvature[i], length[i], grid)
    return out


@numba.njit(_PARENT(_I1, _F2, _F1, _F1, _F, _F, _F, _F, _GRID), cache=True)
def best_parent(
    near: IntArray,
    position: FloatArray,
    yaw: FloatArray,
    cost: FloatArray,
    x: float,
    y: float,
    max_alpha: float,
    min_turning_radius: float,
    grid: GridArgs,
) -> tuple[int, float, float]:
    """RRT*'s choose-parent step: of the nodes ``near``, the one whose arc to ``(x, y)`` is feasible and
    collision-free with the least cost through it; ``(node, end yaw, cost)``, node -1 when there is none.

    Collision checks are lazy: candidates are tried in order of cost, and the first free one wins."""
    m = len(near)
    through = np.empty(m)
    end_yaw = np.empty(m)
    curv = np.empty(m)
    arc_len = np.empty(m)
    for k in range(m):
        j = near[k]
        alpha, curv[k], arc_len[k], end_yaw[k] = connect_one(position[j, 0], position[j, 1], yaw[j], x, y)
        chord = math.hypot(x - position[j, 0], y - position[j, 1])
        ok = feasible_one(chord, alpha, curv[k], max_alpha, min_turning_radius)
        through[k] = cost[j] + arc_len[k] if ok else np.inf
    for k in np.argsort(through, kind="mergesort"):
        if not math.isfinite(through[k]):
            break
        j = near[k]
        if arc_free(position[j, 0], position[j, 1], yaw[j], curv[k], arc_len[k], grid):
            return j, end_yaw[k], through[k]
    return -1, 0.0, 0.0


@numba.njit(_REWIRES(_I1, _F2, _F1, _I, _F, _F, _F, _GRID), cache=True)
def rewire_candidates(
    others: IntArray,
    position: FloatArray,
    cost: FloatArray,
    new: int,
    new_yaw: float,
    max_alpha: float,
    min_turning_radius: float,
    grid: GridArgs,
) -> tuple[IntArray, FloatArray, FloatArray]:
    """The nodes of ``others`` that get cheaper through node ``new`` (pose ``position[new]``, ``new_yaw``) by a
    feasible, collision-free arc: their ids, the arcs' end yaws and the costs through ``new``.

    ``max_alpha`` is already capped below pi/2."""
    xn, yn = position[new, 0], position[new, 1]
    ids = np.empty(len(others), dtype=np.intp)
    yaws = np.empty(len(others))
    costs = np.empty(len(others))
    m = 0
    for j in others:
        alpha, curv, arc_len, end_yaw = connect_one(xn, yn, new_yaw, position[j, 0], position[j, 1])
        through = cost[new] + arc_len
        chord = math.hypot(position[j, 0] - xn, position[j, 1] - yn)
        if (
            through < cost[j] - 1e-9
            and feasible_one(chord, alpha, curv, max_alpha, min_turning_radius)
            and arc_free(xn, yn, new_yaw, curv, arc_len, grid)
        ):
            ids[m], yaws[m], costs[m] = j, end_yaw, through
            m += 1
    return ids[:m], yaws[:m], costs[:m]


@numba.njit(_B1(_F2, _B2, _GRID), cache=True)
def lookup(points: FloatArray, mask: BoolArray, grid: GridArgs) -> BoolArray:
    """``mask`` (either of the grid's) at each of the ``(N, 2)`` points; False outside the grid."""
    _, _, x0, y0, c, s, res = grid
    out = np.empty(len(points), dtype=np.bool_)
    for i in range(len(points)):
        row, col = _cell(points[i, 0], points[i, 1], x0, y0, c, s, res)
        out[i] = _at(mask, row, col)
    return out


@numba.njit(_B(_F, _F, _B2, _GRID), cache=True)
def lookup_one(x: float, y: float, mask: BoolArray, grid: GridArgs) -> bool:
    """``mask`` at the point ``(x, y)``; False outside the grid."""
    _, _, x0, y0, c, s, res = grid
    row, col = _cell(x, y, x0, y0, c, s, res)
    return _at(mask, row, col)


@numba.njit(_NEAREST(_F2, _I, _F, _F, _I), cache=True)
def nearest_k(position: FloatArray, n: int, x: float, y: float, k: int) -> tuple[IntArray, FloatArray]:
    """Ids and distances of the ``k`` rows of ``position[:n]`` nearest to ``(x, y)`` (fewer when ``n < k``),
    nearest first, ties by id: one pass keeping the best ``k`` by insertion (``k`` is small)."""
    k = min(k, n)
    ids = np.empty(k, dtype=np.intp)
    dist = np.full(k, np.inf)
    for i in range(n):
        d = math.hypot(position[i, 0] - x, position[i, 1] - y)
        if k == 0 or d >= dist[k - 1]:
            continue
        j = k - 1
        while j > 0 and dist[j - 1] > d:
            dist[j], ids[j] = dist[j - 1], ids[j - 1]
            j -= 1
        dist[j], ids[j] = d, i
    return ids, dist


@numba.njit(_I1(_F2, _I, _F, _F, _F), cache=True)
def within_radius(position: FloatArray, n: int, x: float, y: float, radius: float) -> IntArray:
    """Ids of the rows of ``position[:n]`` within ``radius`` of ``(x, y)``, in id order."""
    ids = np.empty(n, dtype=np.intp)
    m = 0
    r2 = radius * radius
    for i in range(n):
        dx, dy = position[i, 0] - x, position[i, 1] - y
        if dx * dx + dy * dy <= r2:
            ids[m] = i
            m += 1
    return ids[:m]


@numba.njit(_B(_I1, _I, _F, _F, _I1, _F2, _F1, _F1, _F, _F, _GRID), cache=True)
def rederive_subtree(
    ids: IntArray,
    node: int,
    node_yaw: float,
    node_cost: float,
    parent: IntArray,
    position: FloatArray,
    yaw: FloatArray,
    cost: FloatArray,
    max_alpha: float,
    min_turning_radius: float,
    grid: GridArgs,
) -> bool:
    """RRT*'s rewire check: ``node`` takes ``node_yaw`` and ``node_cost``, and its descendants ``ids`` (parents
    before children) the end yaws and costs of the arcs from their parents' new poses. When every such arc is
    feasible and collision-free and no node gets more expensive, the new yaws and costs are written into ``yaw``
    and ``cost`` and True returned; otherwise nothing changes."""
    new_yaw = np.empty(len(yaw))
    new_cost = np.empty(len(cost))
    new_yaw[node], new_cost[node] = node_yaw, node_cost
    for i in ids:
        p = parent[i]
        x1, y1, x2, y2 = position[p, 0], position[p, 1], position[i, 0], position[i, 1]
        alpha, curv, arc_len, end_yaw = connect_one(x1, y1, new_yaw[p], x2, y2)
        through = new_cost[p] + arc_len
        if through > cost[i] + 1e-9 or not feasible_one(
            math.hypot(x2 - x1, y2 - y1), alpha, curv, max_alpha, min_turning_radius
        ):
            return False
        new_yaw[i], new_cost[i] = end_yaw, through
    # Collision checks last: the cost and feasibility tests above are far cheaper and usually decide.
    for i in ids:
        p = parent[i]
        alpha, curv, arc_len, _ = connect_one(
            position[p, 0], position[p, 1], new_yaw[p], position[i, 0], position[i, 1]
        )
        if not arc_free(position[p, 0], position[p, 1], new_yaw[p], curv, arc_len, grid):
            return False
    yaw[node], cost[node] = node_yaw, node_cost
    for i in ids:
        yaw[i], cost[i] = new_yaw[i], new_cost[i]
    return True


@numba.njit(_LEN_YAW(_F, _F, _F, _F, _F, _F, _F, _GRID), cache=True)
def checked_arc(
    x1: float, y1: float, yaw: float, x2: float, y2: float, max_alpha: float, min_turning_radius: float, grid: GridArgs
) -> tuple[float, float]:
    """``(length, end yaw)`` of the arc from pose ``(x1, y1, yaw)`` to ``(x2, y2)``; the length is ``inf`` when
    the arc is not feasible or not collision-free."""
    alpha, curv, arc_len, end_yaw = connect_one(x1, y1, yaw, x2, y2)
    ok = feasible_one(math.hypot(x2 - x1, y2 - y1), alpha, curv, max_alpha, min_turning_radius)
    if not (ok and arc_free(x1, y1, yaw, curv, arc_len, grid)):
        return np.inf, end_yaw
    return arc_len, end_yaw


@numba.njit(_I1(_I1, _I1, _I), cache=True)
def _descendants(first_child: IntArray, next_sibling: IntArray, node: int) -> IntArray:
    """The descendants of ``node`` (itself excluded), breadth first: parents before children."""
    out = np.empty(first_child.size, dtype=np.intp)
    head, tail = 0, 0
    current = node
    while True:
        child = first_child[current]
        while child >= 0:
            out[tail] = child
            tail += 1
            child = next_sibling[child]
        if head == tail:
            return out[:tail]
        current = out[head]
        head += 1


@numba.njit(nt.void(_TREE, _I, _I), cache=True)
def link(tree: TreeArrays, node: int, parent: int) -> None:
    """Make ``node`` the first child of ``parent`` (children's order means nothing to the planners)."""
    _, _, _, parents, first_child, next_sibling = tree
    parents[node] = parent
    next_sibling[node] = first_child[parent]
    first_child[parent] = node


@numba.njit(_I(_TREE, _I, _I, _F2), cache=True)
def add_chain(tree: TreeArrays, size: int, parent: int, way: FloatArray) -> int:
    """Append the chain of arcs ``way`` (rows ``(x, y, end yaw, length)``) below ``parent`` as nodes ``size``,
    ``size + 1``, ...; returns the new size (the arrays must have room)."""
    position, yaw, cost = tree[0], tree[1], tree[2]
    for row in range(len(way)):
        position[size, 0], position[size, 1], yaw[size] = way[row, 0], way[row, 1], way[row, 2]
        cost[size] = cost[parent] + way[row, 3]
        link(tree, size, parent)
        parent = size
        size += 1
    return size


@numba.njit(nt.void(_TREE, _I), cache=True)
def _unlink(tree: TreeArrays, node: int) -> None:
    """Take ``node`` out of its parent's children."""
    _, _, _, parents, first_child, next_sibling = tree
    p = parents[node]
    if first_child[p] == node:
        first_child[p] = next_sibling[node]
        return
    child = first_child[p]
    while next_sibling[child] != node:
        child = next_sibling[child]
    next_sibling[child] = next_sibling[node]


@numba.njit(_I(_TREE, _I, _F, _F, _B, _I, _F, _F, _F, _F, _GRID), cache=True)
def extend_star(
    tree: TreeArrays,
    size: int,
    tx: float,
    ty: float,
    ahead: bool,
    candidates: int,
    step: float,
    gamma: float,
    max_alpha: float,
    min_turning_radius: float,
    grid: GridArgs,
) -> int:
    """RRT*'s steps 2-4 (:mod:`mrs_nav.trees.rrt_star`) towards ``(tx, ty)`` on the first ``size`` nodes of
    ``tree``: steer from the nearest node (with ``ahead``, the nearest of the ``candidates`` nearest that faces the
    target) by at most ``step``, choose the cheapest valid parent among the nodes within
    ``min(step, gamma sqrt(log n / n))``, add the node as number ``size`` (the arrays must have room for it) and
    rewire the other near nodes through it when their subtrees stay valid. Returns the new node's id or -1."""
    position, yaw, cost, parents, first_child, next_sibling = tree
    ids, dist = nearest_k(position, size, tx, ty, candidates)
    k = 0
    if ahead:
        for m in range(ids.size):
            j = ids[m]
            if math.cos(yaw[j]) * (tx - position[j, 0]) + math.sin(yaw[j]) * (ty - position[j, 1]) > 0.0:
                k = m
                break
    nearest, d = ids[k], dist[k]
    if d <= COST_EPS:
        return -1
    xn, yn = tx, ty
    if d > step:
        xn = position[nearest, 0] + (tx - position[nearest, 0]) * (step / d)
        yn = position[nearest, 1] + (ty - position[nearest, 1]) * (step / d)
    if not lookup_one(xn, yn, grid[0], grid):
        return -1
    radius = min(step, gamma * math.sqrt(math.log(size + 1) / (size + 1)))
    near = within_radius(position, size, xn, yn, radius)
    if not np.any(near == nearest):
        near = np.append(near, nearest)
    parent, new_yaw, new_cost = best_parent(near, position, yaw, cost, xn, yn, max_alpha, min_turning_radius, grid)
    if parent < 0:
        return -1
    new = size
    position[new, 0], position[new, 1] = xn, yn
    yaw[new], cost[new] = new_yaw, new_cost
    link(tree, new, parent)
    others = near[near != parent]
    if others.size == 0:
        return new
    rewires, yaws, costs = rewire_candidates(others, position, cost, new, new_yaw, max_alpha, min_turning_radius, grid)
    for m in range(rewires.size):
        j = rewires[m]
        # An earlier rewire of this loop may have made j cheaper already.
        if costs[m] < cost[j] - COST_EPS and rederive_subtree(
            _descendants(first_child, next_sibling, j),
            j,
            yaws[m],
            costs[m],
            parents,
            position,
            yaw,
            cost,
            max_alpha,
            min_turning_radius,
            grid,
        ):
            _unlink(tree, j)
            link(tree, j, new)
    return new
