"""The obvious first paths RRT* tries before sampling: turn on a circle, then drive straight to the goal.

From the start pose, a circle of radius ``r`` turning left or right; the point where the line to the goal leaves
it tangentially splits the way into two of the planner's own edges: the arc from the start pose to that point
(the circle itself, since an arc is tangent to the start heading), then a straight arc on to the goal. This is
the turn-straight family of Dubins paths, drawn with the course's arcs: the planner checks both pieces exactly
like any other edge (feasible, within ``max_alpha``, collision-free), so nothing here needs to be exact.
"""

from __future__ import annotations

import math

from mrs_nav.geometry import FloatArray, Pose2D

#: Turning radii (m) of the candidate circles; those below the planner's minimum turning radius are skipped.
TURN_RADII = (0.25, 0.5, 1.0, 2.0)


def turn_points(start: Pose2D, goal: FloatArray, min_turning_radius: float = 0.0) -> list[tuple[float, float, float]]:
    """``(length, x, y)`` of each turn-then-straight way from ``start`` to ``goal`` (x, y): its length (m) and the
    point where the turn ends, shortest first; none for a goal inside a circle."""
    out = []
    gx, gy = float(goal[0]), float(goal[1])
    for r in TURN_RADII:
        if r < min_turning_radius:
            continue
        for side in (1.0, -1.0):  # left (counter-clockwise), right
            cx = start.x - side * r * math.sin(start.yaw)
            cy = start.y + side * r * math.cos(start.yaw)
            d = math.hypot(gx - cx, gy - cy)
            if d <= r:
                continue
            # The tangent point seen from the centre: the goal's bearing turned back by acos(r / d) on this side.
            at = math.atan2(gy - cy, gx - cx) - side * math.acos(r / d)
            begin = math.atan2(start.y - cy, start.x - cx)
            turn = (side * (at - begin)) % (2.0 * math.pi)
            out.append((r * turn + math.sqrt(d * d - r * r), cx + r * math.cos(at), cy + r * math.sin(at)))
    return sorted(out)
