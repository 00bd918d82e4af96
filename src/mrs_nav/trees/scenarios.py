"""The tree planners' reference query: the course arena map, start (-1.5, -1.5, 0) and goal (1.5, 1.5).

The map is ``worlds/simple.world`` rasterised at 0.05 m, the same grid as the shipped ``maps/simple.yaml``
(a test keeps the two equal). Figures 9-10 and ``mrs-nav bench planners`` use it.
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
