"""RRT*'s iterations until its first path, compiled: a block of them is one call.

Until a path exists an iteration of :func:`mrs_nav.trees.rrt_star.grow_rrt_star` is a target (the goal, a guided
target along the corridor of :mod:`mrs_nav.trees.guide`, or a free point of the map), the extend step
(:func:`mrs_nav.trees.kernels.extend_star`), the guide's frontier moved to the new node, and the arc from the new
node onto the goal when it is within a step. Each of those was already one compiled call; glued by Python they
cost about 12 us an iteration, several times the work itself (issue 42: the first path of a query that needs a few
dozen iterations). Here the glue is compiled too, the random numbers of the block are drawn beforehand by the
caller (the mixture's draws, the guided targets' numbers, free points of the map), and the block ends at the first
path, so that everything after it (the informed samples, the improvements) is as before.
"""

# ruff: noqa: PLR0917

from __future__ import annotations

import math

import numba
from numba import types as nt

from mrs_nav.geometry import FloatArray
from mrs_nav.trees.guide_kernels import field_at, guided_target
from mrs_nav.trees.kernels import (
    COST_EPS,
    GRID_TYPE,
    TREE_TYPE,
    GridArgs,
    TreeArrays,
    checked_arc,
    extend_star,
    link,
)

_F, _I = nt.float64, nt.intp
_F1, _F2, _F3 = (nt.Array(_F, dims, "C") for dims in (1, 2, 3))
_MIXTURE = nt.UniTuple(_F, 3)  # type: ignore[no-untyped-call]
_STEER = nt.UniTuple(_F, 4)  # type: ignore[no-untyped-call]
_GUIDE = nt.Tuple((_F, _F1, _F2, _F2, _I))  # type: ignore[no-untyped-call]
_OUT = nt.Tuple((_I, _I, _I, _I, _F))  # type: ignore[no-untyped-call]

#: How many nearest nodes a guided target may be steered from.
AHEAD_CANDIDATES = 8

#: The corridor as the kernel takes it: ``(lookahead, to_go, path, distance, factor)`` (see
#: :class:`mrs_nav.trees.guide.CorridorSampler`); a guide bias of 0 ignores it.
GuideArgs = tuple[float, FloatArray, FloatArray, FloatArray, int]


@numba.njit(_OUT(TREE_TYPE, _I, _F, _F, _F1, _F2, _F3, _F2, _MIXTURE, _STEER, _GUIDE, GRID_TYPE), cache=True)
def grow_until_path(
    tree: TreeArrays,
    size: int,
    gx: float,
    gy: float,
    draws: FloatArray,
    ahead: FloatArray,
    noise: FloatArray,
    free_points: FloatArray,
    mixture: tuple[float, float, float],
    steer: tuple[float, float, float, float],
    guide: GuideArgs,
    grid: GridArgs,
) -> tuple[int, int, int, int, float]:
    """Up to ``len(draws)`` iterations on the first ``size`` nodes of ``tree`` (room for ``len(draws) + 1`` more),
    towards the goal ``(gx, gy)``; returns ``(size, iterations, goal node or -1, free points used, frontier)``.

    Iteration ``i`` takes the goal when ``draws[i] < goal_bias`` (unless the guide is on and its frontier is
    farther than two steps from the goal), a guided target from ``ahead[i]`` and ``noise[i]`` when ``draws[i] <
    goal_bias + guide_bias``, else the next of ``free_points`` (the block ends before an iteration that finds none
    left). ``mixture`` is ``(goal_bias, guide_bias, frontier)``, ``steer`` ``(step, gamma, max_alpha,
    min_turning_radius)``. The block ends at the first node on the goal or connected to it; the frontier
    returned is the one the new nodes moved."""
    goal_bias, guide_bias, frontier = mixture
    step, gamma, max_alpha, mtr = steer
    lookahead, to_go, path, distance, factor = guide
    position, yaw, cost = tree[0], tree[1], tree[2]
    used = 0
    for i in range(len(draws)):
        guided = False
        if draws[i] < goal_bias and not (guide_bias > 0.0 and frontier > 2.0 * step):
            tx, ty = gx, gy
        elif guide_bias > 0.0 and draws[i] < goal_bias + guide_bias:
            tx, ty = guided_target(ahead[i], noise[i], frontier, lookahead, to_go, path, grid)
            guided = True
        elif used < len(free_points):
            tx, ty = free_points[used, 0], free_points[used, 1]
            used += 1
        else:
            return size, i, -1, used, frontier
        candidates = AHEAD_CANDIDATES if guided else 1
        new = extend_star(tree, size, tx, ty, guided, candidates, step, gamma, max_alpha, mtr, grid)
        if new < 0:
            continue
        size += 1
        x, y = position[new, 0], position[new, 1]
        if math.hypot(x - gx, y - gy) <= COST_EPS:
            return size, i + 1, new, used, frontier
        if guide_bias > 0.0:
            frontier = min(frontier, field_at(x, y, distance, factor, grid))
        if math.hypot(gx - x, gy - y) <= step:
            length, end_yaw = checked_arc(x, y, yaw[new], gx, gy, max_alpha, mtr, grid)
            if math.isfinite(length):
                position[size, 0], position[size, 1] = gx, gy
                yaw[size], cost[size] = end_yaw, cost[new] + length
                link(tree, size, new)
                return size + 1, i + 1, size, used, frontier
    return size, len(draws), -1, used, frontier
