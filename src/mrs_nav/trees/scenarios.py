"""The tree planners' reference queries: the course arena, the office world and a building of offices.

The arena is ``worlds/simple.world`` rasterised at 0.05 m, the same grid as the shipped ``maps/simple.yaml``
(a test keeps the two equal), start (-1.5, -1.5, 0), goal (1.5, 1.5); figures 9-10 and ``mrs-nav bench
planners`` use it. The office is ``worlds/office.world`` (20 m square) and the building 5 x 5 offices with doors
between them (about 100 m square), both at 0.05 m.
"""

from __future__ import annotations

import numpy as np

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR

COURSE_START = Pose2D(-1.5, -1.5, 0.0)
COURSE_GOAL = np.array([1.5, 1.5])


def course_grid() -> OccupancyGrid:
    """The course arena rasterised at 0.05 m (not inflated)."""
    return rasterize_world(load_world(WORLDS_DIR / "simple.world"), 0.05)


#: The office world's reference query: start in its south-west room, goals across the building.
OFFICE_START = Pose2D(-5.0, -5.0, 0.0)
OFFICE_GOALS = ((5.0, 5.0), (8.0, -8.0), (-2.0, 8.0), (8.0, 8.0))


def office_grid() -> OccupancyGrid:
    """``worlds/office.world`` (20 m x 20 m) rasterised at 0.05 m (not inflated)."""
    return rasterize_world(load_world(WORLDS_DIR / "office.world"), 0.05)


def building_grid(tiles: int = 5) -> OccupancyGrid:
    """A ``tiles x tiles`` building of offices (about 100 m square for 5): :func:`office_grid` repeated, with a
    1 m door through each pair of facing outer walls (at y = 5 m on east-west walls and x = -7 m on north-south
    ones, local office coordinates, where both sides are open). The origin is the south-west office's."""
    office = office_grid()
    n, res = office.width, office.resolution
    x0, y0, _ = office.origin
    values = np.tile(office.values, (tiles, tiles))
    half_door, band = round(0.5 / res), round(0.4 / res)
    door_row, door_col = round((5.0 - y0) / res), round((-7.0 - x0) / res)
    for k in range(1, tiles):
        edge = k * n
        for t in range(tiles):
            values[t * n + door_row - half_door : t * n + door_row + half_door, edge - band : edge + band] = 0
            values[edge - band : edge + band, t * n + door_col - half_door : t * n + door_col + half_door] = 0
    return OccupancyGrid(values, res, office.origin)
