"""Occupancy grids: cell values, resolution and origin, with vectorised free-space queries and inflation.

Cell values follow ``nav_msgs/OccupancyGrid``: ``-1`` unknown, ``0..100`` occupancy probability in percent.
``values[row, col]`` is the cell whose lower-left corner is ``origin + R(yaw) (col, row) * resolution``, so
``row`` grows with y and ``values.ravel()`` is the message's row-major ``data`` (width = columns).

A cell is *occupied* when its value is at least :data:`OCCUPIED_MIN` (65, map_server's ``occupied_thresh``)
and *free* when ``0 <= value <= FREE_MAX`` (19, below map_server's ``free_thresh`` 0.196). Anything else,
unknown cells and cells of uncertain occupancy, is neither: planners treat "not free" as blocked, so unknown
space is never entered. Points outside the grid are neither free nor occupied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.errors import InvalidInputError
from mrs_nav.robot import BURGER_RADIUS

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]

UNKNOWN = -1
FREE = 0
OCCUPIED = 100
OCCUPIED_MIN = 65
FREE_MAX = 19


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """A 2-D occupancy grid.

    ``values``: ``(height, width)`` int8 array as described in the module docstring. ``resolution``: cell side
    in metres. ``origin``: ``(x, y, yaw)`` of the lower-left corner of cell ``(0, 0)`` in metres / radians.
    """

    values: npt.NDArray[np.int8]
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        values = np.asarray(self.values)
        if values.ndim != 2 or values.shape[0] < 1 or values.shape[1] < 1:
            raise InvalidInputError(f"occupancy grid values must be a non-empty 2-D array, got shape {values.shape}")
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise InvalidInputError(f"occupancy grid resolution must be positive and finite, got {self.resolution}")
        if len(self.origin) != 3 or not all(math.isfinite(v) for v in self.origin):
            raise InvalidInputError(f"occupancy grid origin must be three finite numbers, got {self.origin}")
        if np.any((values < UNKNOWN) | (values > OCCUPIED)):
            raise InvalidInputError("occupancy grid values must lie in -1..100")
        object.__setattr__(self, "values", np.ascontiguousarray(values, dtype=np.int8))
        object.__setattr__(self, "origin", tuple(float(v) for v in self.origin))

    @classmethod
    def from_message_data(
        cls, data: npt.ArrayLike, width: int, height: int, resolution: float, origin: tuple[float, float, float]
    ) -> OccupancyGrid:
        """Build from ``nav_msgs/OccupancyGrid`` fields: row-major ``data`` of ``width * height`` int8 values."""
        flat = np.asarray(data, dtype=np.int16).ravel()
        if width < 1 or height < 1 or flat.size != width * height:
            raise InvalidInputError(f"occupancy grid data has {flat.size} cells, expected {width} x {height}")
        return cls(flat.reshape(height, width).astype(np.int8), resolution, origin)

    @property
    def height(self) -> int:
        return int(self.values.shape[0])

    @property
    def width(self) -> int:
        return int(self.values.shape[1])

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of the grid in its own (unrotated) frame shifted to the origin."""
        x0, y0, _ = self.origin
        return (x0, y0, x0 + self.width * self.resolution, y0 + self.height * self.resolution)

    @cached_property
    def free_mask(self) -> BoolArray:
        """``(height, width)``: True where the cell is free."""
        return (self.values >= 0) & (self.values <= FREE_MAX)

    @cached_property
    def occupied_mask(self) -> BoolArray:
        """``(height, width)``: True where the cell is occupied."""
        return self.values >= OCCUPIED_MIN

    def cells(self, points: npt.ArrayLike) -> tuple[IntArray, IntArray, BoolArray]:
        """Unclipped rows, columns and inside mask of ``(N, 2)`` points in metres (the hot path of every lookup).

        Outside cells are caught by one unsigned compare per axis (negative indices wrap to huge values).
        """
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim == 1:
            pts = pts[None, :]
        x0, y0, yaw = self.origin
        if yaw == 0.0:
            u = (pts[:, 0] - x0) / self.resolution
            v = (pts[:, 1] - y0) / self.resolution
        else:
            c, s = math.cos(yaw), math.sin(yaw)
            dx, dy = pts[:, 0] - x0, pts[:, 1] - y0
            u = (c * dx + s * dy) / self.resolution
            v = (-s * dx + c * dy) / self.resolution
        # A point a googol away has no integer cell: clipped one cell past the border, it is simply outside
        # (minimum and maximum rather than np.clip, whose argument checks cost more than the work on a few points).
        col = np.floor(np.minimum(np.maximum(u, -1.0), self.width)).astype(np.intp)
        row = np.floor(np.minimum(np.maximum(v, -1.0), self.height)).astype(np.intp)
        inside = (col.view(np.uintp) < self.width) & (row.view(np.uintp) < self.height)
        return row, col, inside

    def cell(self, x: float, y: float) -> tuple[int, int] | None:
        """``(row, col)`` of one point in metres, None outside the grid (or not finite): what :meth:`cells` gives
        for it, in plain arithmetic (numpy's cost per call is most of a one-point lookup)."""
        x0, y0, yaw = self.origin
        if yaw == 0.0:
            u, v = (x - x0) / self.resolution, (y - y0) / self.resolution
        else:
            c, s = math.cos(yaw), math.sin(yaw)
            dx, dy = x - x0, y - y0
            u, v = (c * dx + s * dy) / self.resolution, (-s * dx + c * dy) / self.resolution
        if not (0.0 <= u < self.width and 0.0 <= v < self.height):  # NaN fails both
            return None
        return math.floor(v), math.floor(u)

    def cells_of(self, points: npt.ArrayLike) -> tuple[IntArray, IntArray, BoolArray]:
        """Rows, columns and an inside-the-grid mask of ``(N, 2)`` points (or one ``(2,)`` point) in metres.

        Rows and columns of points outside the grid are clipped to the border (use the mask).
        """
        row, col, inside = self.cells(points)
        return np.minimum(np.maximum(row, 0), self.height - 1), np.minimum(np.maximum(col, 0), self.width - 1), inside

    def lookup(self, mask: BoolArray, points: npt.ArrayLike) -> BoolArray:
        """Vectorised lookup of a ``(height, width)`` boolean ``mask`` at points; outside the grid is False."""
        row, col, inside = self.cells(points)
        flat = row * self.width + col
        flat *= inside  # outside points read cell 0, then are masked out
        out: BoolArray = mask.reshape(-1).take(flat) & inside
        return out

    def is_free(self, points: npt.ArrayLike) -> BoolArray:
        """``(N,)`` True where a point lies in a free cell (unknown and outside are not free)."""
        return self.lookup(self.free_mask, points)

    def is_occupied(self, points: npt.ArrayLike) -> BoolArray:
        """``(N,)`` True where a point lies in an occupied cell."""
        return self.lookup(self.occupied_mask, points)

    def inflate(self, radius: float = BURGER_RADIUS) -> OccupancyGrid:
        """A copy where every cell from which a disc of ``radius`` metres could overlap an occupied cell is occupied.

        The test is exact for the cells' squares: a disc centred anywhere in cell ``a`` overlaps the square of
        cell ``b`` at offset ``(i, j)`` cells exactly when the two squares are closer than ``radius``, and the
        squares are ``res * hypot(max(|i| - 1, 0), max(|j| - 1, 0))`` apart. So a robot of that radius centred
        *anywhere* in a free cell of the result (not only at its centre) stays clear of every occupied cell's
        square; touching counts as overlap. Unknown cells stay unknown (still not free); a radius of 0 returns an
        identical grid.
        """
        if not (math.isfinite(radius) and radius >= 0.0):
            raise InvalidInputError(f"inflation radius must be finite and >= 0, got {radius}")
        occupied = self.occupied_mask
        if radius == 0.0 or not occupied.any():
            return OccupancyGrid(self.values.copy(), self.resolution, self.origin)
        # Squares offset by (i, j) cells are res * hypot(max(|i| - 1, 0), max(|j| - 1, 0)) apart: exactly the
        # centre distance to the occupied set grown by one cell each way. The Euclidean distance transform of
        # that set gives it in time independent of the radius (a dilation by a 10 m disc kernel at 5 cm took 20 s
        # on a small map); the same cells as a dilation by the kernel of those square gaps (tests/core/maps).
        touching = ndimage.binary_dilation(occupied, structure=np.ones((3, 3), dtype=bool))
        grown = ndimage.distance_transform_edt(~touching) * self.resolution < radius + 1e-9
        values = self.values.copy()
        values[grown] = OCCUPIED
        return OccupancyGrid(values, self.resolution, self.origin)

    def free_area(self) -> float:
        """Area of the free cells in square metres."""
        return self._free_cells * self.resolution**2

    @cached_property
    def _free_cells(self) -> int:
        # Counted once: every RRT* query reads it (its gamma), and a 200 m map has 16 million cells.
        return int(np.count_nonzero(self.free_mask))

    @cached_property
    def conservative_free_mask(self) -> BoolArray:
        """The free mask eroded by one cell (3 x 3): True where a cell and its eight neighbours are all free.

        Checking points spaced at most one resolution apart against this mask proves every point between them
        free in :attr:`free_mask`: a point within ``resolution / 2`` of a sample lies in the sample's cell or one
        of its eight neighbours.
        """
        eroded: BoolArray = ndimage.binary_erosion(self.free_mask, structure=np.ones((3, 3), bool), border_value=0)
        return eroded


def planning_grid(grid: OccupancyGrid, inflation_m: float = BURGER_RADIUS, allow_unknown: bool = True) -> OccupancyGrid:
    """The grid a planner searches: ``grid`` with obstacles grown by ``inflation_m`` (m), and with its unknown
    cells counted as free first when ``allow_unknown`` (move_base's option of that name)."""
    if allow_unknown:
        values = grid.values.copy()
        values[values == UNKNOWN] = FREE
        grid = OccupancyGrid(values, grid.resolution, grid.origin)
    return grid.inflate(inflation_m)
