"""Map quality against a known world: the world rasterised on the map's grid, and intersection over union.

A cell is occupied in the world when its square reaches into an obstacle footprint
(:func:`mrs_nav.maps.rasterize.rasterize_world`, the rule the planners use). The IoU of occupied cells is taken over
the cells the map has observed (free or occupied), since a map cannot be blamed for what its laser never saw
(wall interiors).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import World
from mrs_nav.slam.grid import LogOddsGrid

BoolArray = npt.NDArray[np.bool_]


def world_cells(world: World, grid: LogOddsGrid) -> BoolArray:
    """Whether each cell of ``grid`` touches an obstacle of ``world`` (rasterised with the planners' rules)."""
    raster = rasterize_world(world, grid.resolution)
    out = np.zeros((grid.height, grid.width), dtype=bool)
    # Both grids have origins on multiples of the resolution, so one is a shifted window of the other.
    dx = round((raster.origin[0] - grid.origin_x) / grid.resolution)
    dy = round((raster.origin[1] - grid.origin_y) / grid.resolution)
    occupied = raster.occupied_mask
    x0, y0 = max(dx, 0), max(dy, 0)
    x1, y1 = min(dx + raster.width, grid.width), min(dy + raster.height, grid.height)
    if x1 > x0 and y1 > y0:
        out[y0:y1, x0:x1] = occupied[y0 - dy : y1 - dy, x0 - dx : x1 - dx]
    return out


def map_iou(
    grid: LogOddsGrid,
    world: World,
    world_origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    tolerance: int = 0,
) -> float:
    """IoU of the occupied cells of ``grid`` and of ``world`` over the observed cells.

    ``world_origin`` is the pose (x, y, yaw) of the map frame in the world frame (where SLAM started).
    With ``tolerance`` > 0 cells, an occupied cell of either side counts as matched when the other side has an
    occupied cell within that many cells (Chebyshev distance): IoU = matched / (matched + unmatched of both).
    """
    occupancy = grid.to_occupancy()
    observed = np.nonzero(occupancy >= 0)
    if observed[0].size == 0:
        return 0.0
    truth_grid = world_cells(_world_in_map(world, world_origin), grid)
    truth_grid[occupancy < 0] = False
    mapped_grid = occupancy == 100
    if tolerance <= 0:
        union = int(np.sum(mapped_grid | truth_grid))
        return float(np.sum(mapped_grid & truth_grid)) / union if union else 1.0
    size = 2 * tolerance + 1
    near_truth = ndimage.binary_dilation(truth_grid, np.ones((size, size), dtype=bool))
    near_mapped = ndimage.binary_dilation(mapped_grid, np.ones((size, size), dtype=bool))
    matched = int(np.sum(mapped_grid & near_truth))
    false_pos = int(np.sum(mapped_grid & ~near_truth))
    missed = int(np.sum(truth_grid & ~near_mapped))
    total = matched + false_pos + missed
    return matched / total if total else 1.0


def _world_in_map(world: World, origin: tuple[float, float, float]) -> World:
    """``world`` with its obstacles expressed in the map frame whose pose in the world is ``origin``."""
    ox, oy, oyaw = origin
    c, s = math.cos(-oyaw), math.sin(-oyaw)

    def to_map(x: float, y: float) -> tuple[float, float]:
        dx, dy = x - ox, y - oy
        return c * dx - s * dy, s * dx + c * dy

    boxes = tuple(replace(b, x=to_map(b.x, b.y)[0], y=to_map(b.x, b.y)[1], yaw=b.yaw - oyaw) for b in world.boxes)
    cylinders = tuple(replace(k, x=to_map(k.x, k.y)[0], y=to_map(k.x, k.y)[1]) for k in world.cylinders)
    return replace(world, boxes=boxes, cylinders=cylinders)
