"""Map quality against a known world: the world rasterised on the map's grid, and intersection over union.

A cell is occupied in the world when its square touches an obstacle footprint (box footprints and cylinders
grown by half a cell; exact for axis-aligned boxes). The IoU of occupied cells is taken over the cells the map
has observed (free or occupied), since a map cannot be blamed for what its laser never saw (wall interiors).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.world import World

BoolArray = npt.NDArray[np.bool_]


def rasterise_world(world: World, grid: LogOddsGrid, cells: tuple[npt.NDArray[np.int64], ...]) -> BoolArray:
    """Whether each cell ``(iy, ix)`` of ``grid`` (given as two index arrays) touches an obstacle of ``world``."""
    iy, ix = cells
    half = 0.5 * grid.resolution
    x = grid.origin_x + (ix + 0.5) * grid.resolution
    y = grid.origin_y + (iy + 0.5) * grid.resolution
    hit = np.zeros(x.shape, dtype=bool)
    for box in world.boxes:
        c, s = math.cos(box.yaw), math.sin(box.yaw)
        dx, dy = x - box.x, y - box.y
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        hit |= (np.abs(lx) <= box.size_x / 2 + half) & (np.abs(ly) <= box.size_y / 2 + half)
    for cyl in world.cylinders:
        hit |= np.hypot(x - cyl.x, y - cyl.y) <= cyl.radius + half
    return hit


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
    truth_grid = np.zeros(occupancy.shape, dtype=bool)
    truth_grid[observed] = rasterise_world(_world_in_map(world, world_origin), grid, observed)
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
