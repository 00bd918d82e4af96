"""Rasterising a :class:`~mrs_nav.maps.world.World` into an :class:`~mrs_nav.maps.occupancy_grid.OccupancyGrid`.

The grid covers the world's obstacle footprints (plus ``margin``), its origin snapped to a multiple of the
resolution. A cell is occupied when the obstacle footprint reaches into the cell: its centre lies strictly inside
a box grown by half a cell along the box's own axes, or within ``radius + resolution / 2`` of a cylinder's axis. This
errs towards marking a cell occupied (conservative for planning). Every other cell is free: a world file
describes all of its obstacles.

Regenerate the shipped course map with ``python -m mrs_nav.maps.rasterize worlds/simple.world maps/simple.yaml``.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.limits import MAX_GRID_CELLS, check_grid_cells
from mrs_nav.maps.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from mrs_nav.maps.world import World, load_world
from mrs_nav.options import Parser, length_option, number_option

#: The course arena map's cell size in metres.
DEFAULT_RESOLUTION = 0.05
# A cell that only touches a footprint along its border (within rounding) is not occupied.
_TOUCH = 1e-9


def raster_frame(world: World, resolution: float, margin: float = 0.0) -> tuple[float, float, int, int]:
    """The grid :func:`rasterize_world` would make: origin ``(x0, y0)`` and ``(width, height)`` in cells.

    Raises :class:`InvalidInputError` naming the world when that grid exceeds
    :data:`~mrs_nav.limits.MAX_GRID_CELLS`, before anything is allocated.
    """
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise InvalidInputError(f"resolution must be positive and finite, got {resolution}")
    if not (math.isfinite(margin) and margin >= 0.0):
        raise InvalidInputError(f"margin must be finite and >= 0, got {margin}")
    xmin, ymin, xmax, ymax = world.bounds(margin)
    # Snap outwards to the resolution; the small tolerance keeps +-2.1 m from growing by a spurious cell.
    x0 = math.floor(xmin / resolution + 1e-6) * resolution
    y0 = math.floor(ymin / resolution + 1e-6) * resolution
    # Sizes as floats first: a tiny resolution over a large world would overflow math.ceil or ask for terabytes.
    columns, rows = (xmax - x0) / resolution - 1e-6, (ymax - y0) / resolution - 1e-6
    if not columns * rows <= MAX_GRID_CELLS:
        check_grid_cells(math.ceil(min(columns, 1e18)), math.ceil(min(rows, 1e18)), world.source or world.name)
    return x0, y0, max(1, math.ceil(columns)), max(1, math.ceil(rows))


def rasterize_world(world: World, resolution: float = DEFAULT_RESOLUTION, margin: float = 0.0) -> OccupancyGrid:
    """Rasterise ``world`` at ``resolution`` metres per cell over its obstacles' bounds grown by ``margin``."""
    x0, y0, width, height = raster_frame(world, resolution, margin)
    xs = x0 + (np.arange(width) + 0.5) * resolution
    ys = y0 + (np.arange(height) + 0.5) * resolution
    cx, cy = np.meshgrid(xs, ys)  # (height, width): rows are y
    occupied = np.zeros((height, width), dtype=bool)
    half = resolution / 2.0
    for box in world.boxes:
        c, s = math.cos(box.yaw), math.sin(box.yaw)
        dx, dy = cx - box.x, cy - box.y
        u, v = c * dx + s * dy, -s * dx + c * dy
        occupied |= (np.abs(u) < box.size_x / 2.0 + half - _TOUCH) & (np.abs(v) < box.size_y / 2.0 + half - _TOUCH)
    for cyl in world.cylinders:
        occupied |= np.hypot(cx - cyl.x, cy - cyl.y) < cyl.radius + half - _TOUCH
    values = np.where(occupied, OCCUPIED, FREE).astype(np.int8)
    return OccupancyGrid(values, resolution, (round(x0, 9), round(y0, 9), 0.0))


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m mrs_nav.maps.rasterize WORLD OUT.yaml [--resolution R] [--margin M]``: write map_server files."""
    from mrs_nav.maps.map_io import map_targets, save_map  # noqa: PLC0415 - only the command needs file output

    parser = Parser(prog="python -m mrs_nav.maps.rasterize", description=main.__doc__)
    parser.add_argument("world", type=Path)
    parser.add_argument("out", type=Path, help="map description to write (.yaml; the .pgm goes beside it)")
    parser.add_argument(
        "--resolution", type=number_option(1e-3, 10.0), default=DEFAULT_RESOLUTION, help="metres per cell"
    )
    parser.add_argument("--margin", type=length_option, default=0.0, help="free border around the obstacles, metres")
    try:
        args = parser.parse_args(argv)
        map_targets(args.out, "OUT")  # writable before the rasterising, seconds on a large world
        save_map(rasterize_world(load_world(args.world), args.resolution, args.margin), args.out)
    except MrsNavError as err:
        print(f"ERROR: {err}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
