"""Whether a point may be a start or a goal: a finite point inside the map, not in an obstacle, and not within the
robot's clearance of one.

There is one check per kind of map the planners read: :func:`grid_refusal` on an occupancy grid (the tree planners,
the navigator) and :func:`obstacles_refusal` on circles and boxes (the potential field, the exact shortest path, the
command line's worlds and circles, the potential-field node). Each answers why the point is refused, as a phrase
that completes "the goal (x, y) is ..." (``"outside the map"``), or None when it is admissible; callers name the
point and what it is for.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import UNKNOWN, OccupancyGrid

#: The refusal of a point with a NaN or infinite coordinate.
NOT_FINITE = "not a finite number"


def grid_refusal(
    grid: OccupancyGrid,
    x: float,
    y: float,
    *,
    raw: OccupancyGrid | None = None,
    inflation_m: float | None = None,
    unknown_hint: str = "",
) -> str | None:
    """Why ``(x, y)`` is no admissible start or goal on ``grid``, the map inflated by the robot's clearance
    (``inflation_m`` metres when known, for the message), or None.

    With ``raw`` (the same map before inflation) a point in one of its obstacles is named as such, and a point in
    unknown space that obstacles enclose (the unseen inside of an obstacle) is refused even when ``grid`` made
    unknown space free. ``unknown_hint`` is added to the refusal of a point in unknown space (e.g. the option that
    would allow it).
    """
    if not (math.isfinite(x) and math.isfinite(y)):
        return NOT_FINITE
    point = np.array([[x, y]])
    rows, cols, inside = grid.cells_of(point)
    if not inside[0]:
        return "outside the map"
    if raw is not None and raw.is_occupied(point)[0]:
        return "inside an obstacle"
    if not grid.free_mask[rows[0], cols[0]]:
        if grid.values[rows[0], cols[0]] < 0:
            return f"in unknown space{unknown_hint}"
        if inflation_m is None:
            return "in an obstacle (or within the robot radius of one)"
        return f"within {inflation_m:.3f} m (robot radius + margin) of an obstacle"
    if raw is not None and enclosed_unknown(raw, x, y):
        return "in unknown space enclosed by obstacles (the inside of an obstacle)"
    return None


def enclosed_unknown(raw: OccupancyGrid, x: float, y: float) -> bool:
    """Whether ``(x, y)`` lies in an unknown region of ``raw`` that touches neither a free cell nor the edge of
    the map: the unseen inside of an obstacle, which allowing unknown space must not make a goal."""
    rows, cols, inside = raw.cells_of(np.array([[x, y]]))
    unknown = raw.values == UNKNOWN
    if not inside[0] or not unknown[rows[0], cols[0]]:
        return False
    labels, _ = ndimage.label(unknown)  # 4-connected: a diagonal gap in a wall does not open it
    region = labels == labels[rows[0], cols[0]]
    if region[0, :].any() or region[-1, :].any() or region[:, 0].any() or region[:, -1].any():
        return False
    rim = ndimage.binary_dilation(region) & ~region
    return not bool(np.any(raw.free_mask[rim]))


def obstacles_refusal(
    obstacles: Obstacles,
    x: float,
    y: float,
    *,
    bounds: tuple[float, float, float, float] | None = None,
    clearance_m: float = 0.0,
    clearance_name: str = "the robot radius",
    tolerance_m: float = 0.0,
) -> str | None:
    """Why ``(x, y)`` is no admissible start or goal among ``obstacles``, or None: outside ``bounds``
    ``(xmin, ymin, xmax, ymax)`` when given, inside an obstacle (a point within ``tolerance_m`` of the surface
    counts as outside), or within ``clearance_m`` (called ``clearance_name`` in the message) of one, where a robot
    of that radius would overlap it."""
    if not (math.isfinite(x) and math.isfinite(y)):
        return NOT_FINITE
    if bounds is not None and not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
        return f"outside the world [{bounds[0]:g}, {bounds[2]:g}] x [{bounds[1]:g}, {bounds[3]:g}]"
    if obstacles.contains((x, y), -tolerance_m)[0]:
        return "inside an obstacle"
    if clearance_m > 0.0 and obstacles.inflated(clearance_m).contains((x, y))[0]:
        return f"within {clearance_name} {clearance_m:g} m of an obstacle: the robot would overlap it"
    return None
