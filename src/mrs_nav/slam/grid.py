"""Occupancy grid mapping in log-odds with vectorised ray casting.

Each processed scan adds ``loccupied`` to the log-odds of the cells holding beam end points and subtracts
``lfree`` from the cells the beams crossed (Thrun, Burgard, Fox, *Probabilistic Robotics*, ch. 9), clamped to
``[-lmax, lmax]``. A cell crossed by several beams of one scan is updated once, and a cell holding an end
point is never cleared by the same scan, so the update does not depend on the angular density of the laser.

Like gmapping's point accumulator, each cell also keeps the mean of the end points that fell in it, so the scan
matcher can align to where obstacles were seen rather than to cell centres (sub-cell accuracy). The sums are of
offsets from the cell's corner, so float32 keeps them exact to micrometres: 16 bytes a cell in all, in four
arrays of 4 bytes a cell.

The grid covers the bounding box of what scans have reached (plus a growth margin), never more than
``max_cells`` cells: growth past that raises :class:`InvalidInputError` before anything is allocated. Growing
replaces the arrays one at a time, each old one freed before the next is copied, so a growth holds the old grid
and one new array (4 bytes a cell), not two grids; the new arrays are zeroed lazily (``np.zeros``), so the
margin costs memory only once scans reach it.

Cells are indexed ``[row, col] = [iy, ix]``; cell ``(ix, iy)`` covers
``[origin_x + ix * resolution, origin_x + (ix + 1) * resolution)`` and likewise in y.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.scan import BeamSplit

IntArray = npt.NDArray[np.int64]
Float32Array = npt.NDArray[np.float32]
# A grid as compiled kernels take it (LogOddsGrid.kernel_args): log-odds, hit offset sums in x and in y, hit
# counts, origin x, origin y and resolution (m); and that as a numba type.
GridArrays = tuple[Float32Array, Float32Array, Float32Array, Float32Array, float, float, float]
GRID_ARRAYS_TYPE = (
    "Tuple((float32[:, ::1], float32[:, ::1], float32[:, ::1], float32[:, ::1], float64, float64, float64))"
)

# map_server's default occupied_thresh 0.65 as log-odds; a cell more likely free than occupied is free.
OCCUPIED_LOGODDS = math.log(0.65 / 0.35)
FREE_LOGODDS = 0.0


class LogOddsGrid:
    """A growable log-odds occupancy grid in the map frame."""

    def __init__(
        self,
        resolution: float,
        extent: tuple[float, float, float, float],
        *,
        grows: bool = True,
        lfree: float = 0.4,
        loccupied: float = 0.9,
        lmax: float = 8.0,
        max_cells: int = 25_000_000,
    ) -> None:
        xmin, ymin, xmax, ymax = extent
        if resolution <= 0.0 or xmax <= xmin or ymax <= ymin:
            raise InvalidInputError(f"occupancy grid needs resolution > 0 and a non-empty extent, got {extent}")
        self.resolution = resolution
        self.grows = grows
        self.lfree = lfree
        self.loccupied = loccupied
        self.lmax = lmax
        self.max_cells = max_cells
        self.origin_x = math.floor(xmin / resolution) * resolution
        self.origin_y = math.floor(ymin / resolution) * resolution
        width = math.ceil((xmax - self.origin_x) / resolution)
        height = math.ceil((ymax - self.origin_y) / resolution)
        if width * height > max_cells:
            raise InvalidInputError(f"occupancy grid of {width} x {height} cells exceeds the limit of {max_cells:,}")
        self.logodds = np.zeros((height, width), dtype=np.float32)
        # Sums of end point offsets from the cell's corner in x and in y (m) and end point count per cell, for
        # the mean hit.
        self.hit_x = np.zeros((height, width), dtype=np.float32)
        self.hit_y = np.zeros((height, width), dtype=np.float32)
        self.hit_count = np.zeros((height, width), dtype=np.float32)

    @property
    def width(self) -> int:
        return int(self.logodds.shape[1])

    @property
    def height(self) -> int:
        return int(self.logodds.shape[0])

    def cell_of(self, x: FloatArray, y: FloatArray) -> tuple[IntArray, IntArray]:
        """Cell indices ``(ix, iy)`` of points in metres (may lie outside the grid)."""
        ix = np.floor((x - self.origin_x) / self.resolution).astype(np.int64)
        iy = np.floor((y - self.origin_y) / self.resolution).astype(np.int64)
        return ix, iy

    def clear(self) -> None:
        """Forget everything observed (the extent stays)."""
        # Fresh arrays, not zeros written over the old: the map rebuilt next makes only what it reaches resident.
        shape = self.logodds.shape
        self.logodds = np.zeros(shape, dtype=np.float32)
        self.hit_x = np.zeros(shape, dtype=np.float32)
        self.hit_y = np.zeros(shape, dtype=np.float32)
        self.hit_count = np.zeros(shape, dtype=np.float32)

    def ensure_contains(self, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        """Grow the grid (if allowed) so that the box lies inside, with a margin to avoid growing every scan."""
        if not self.grows:
            return
        res = self.resolution
        left = max(0, math.ceil((self.origin_x - xmin) / res))
        bottom = max(0, math.ceil((self.origin_y - ymin) / res))
        right = max(0, math.ceil((xmax - (self.origin_x + self.width * res)) / res) + 1)
        top = max(0, math.ceil((ymax - (self.origin_y + self.height * res)) / res) + 1)
        if left == bottom == right == top == 0:
            return
        # A margin so that a slowly growing map is not copied every scan; dropped near the cell limit.
        for margin in (max(int(5.0 / res), self.width // 4, self.height // 4), 0):
            pad = [(bottom + margin if bottom else 0, top + margin if top else 0)]
            pad.append((left + margin if left else 0, right + margin if right else 0))
            cells = (self.height + sum(pad[0])) * (self.width + sum(pad[1]))
            if cells <= self.max_cells:
                break
        else:
            raise InvalidInputError(
                f"the map would grow to {cells:.3g} cells to hold x {xmin:.6g}..{xmax:.6g}, "
                f"y {ymin:.6g}..{ymax:.6g} m, more than the limit of {self.max_cells:,}"
            )
        # One array at a time, each assignment freeing the old one (module docstring); nothing else holds them.
        self.logodds = _grown(self.logodds, pad)
        self.hit_x = _grown(self.hit_x, pad)
        self.hit_y = _grown(self.hit_y, pad)
        self.hit_count = _grown(self.hit_count, pad)
        self.origin_x -= pad[1][0] * res
        self.origin_y -= pad[0][0] * res

    def integrate(self, sensor: Pose2D, beams: BeamSplit) -> None:
        """Update the grid with one scan taken from ``sensor`` (laser pose in the map frame)."""
        angles = np.concatenate([beams.hit_angles, beams.free_angles]) + sensor.yaw
        ranges = np.concatenate([beams.hit_ranges, beams.free_ranges])
        if ranges.size == 0:
            return
        cos, sin = np.cos(angles), np.sin(angles)
        ends_x = sensor.x + ranges * cos
        ends_y = sensor.y + ranges * sin
        self.ensure_contains(
            min(sensor.x, float(ends_x.min())),
            min(sensor.y, float(ends_y.min())),
            max(sensor.x, float(ends_x.max())),
            max(sensor.y, float(ends_y.max())),
        )
        # float32 like the log-odds, so that the updates round as the grid's own arithmetic does
        update = np.array([self.lfree, self.loccupied, self.lmax], dtype=np.float32)
        _integrate(self.kernel_args(), (sensor.x, sensor.y), cos, sin, ranges, beams.hit_ranges.size, update)

    def mean_hits(self, iy: IntArray, ix: IntArray) -> tuple[FloatArray, FloatArray]:
        """Mean end point (m) of cells ``(iy, ix)``; the cell centre where nothing was hit."""
        count = self.hit_count[iy, ix].astype(np.float64)
        res = self.resolution
        safe = np.maximum(count, 1.0)
        dx = np.where(count > 0, self.hit_x[iy, ix] / safe, 0.5 * res)
        dy = np.where(count > 0, self.hit_y[iy, ix] / safe, 0.5 * res)
        return self.origin_x + ix * res + dx, self.origin_y + iy * res + dy

    def kernel_args(self) -> GridArrays:
        """The grid's arrays and geometry, for compiled kernels (they see the arrays, not copies)."""
        return self.logodds, self.hit_x, self.hit_y, self.hit_count, self.origin_x, self.origin_y, self.resolution

    def occupied(self) -> npt.NDArray[np.bool_]:
        """Cells that are more likely occupied than free (what the scan matcher aligns to)."""
        return np.asarray(self.logodds > 0.0)

    def to_occupancy(self) -> npt.NDArray[np.int8]:
        """ROS ``OccupancyGrid`` values: 100 occupied (p >= 0.65), 0 free (p < 0.5), -1 unknown."""
        out = np.full(self.logodds.shape, -1, dtype=np.int8)
        out[self.logodds >= OCCUPIED_LOGODDS] = 100
        out[self.logodds < FREE_LOGODDS] = 0
        return out


def _grown(array: Float32Array, pad: list[tuple[int, int]]) -> Float32Array:
    """``array`` with ``pad`` (rows before and after, columns before and after) cells of zeros around it.

    Why not np.pad: it writes the zeros, so the whole margin becomes resident at once; np.zeros' pages are
    mapped only when first written.
    """
    (bottom, top), (left, right) = pad
    height, width = array.shape
    out = np.zeros((height + bottom + top, width + left + right), dtype=array.dtype)
    out[bottom : bottom + height, left : left + width] = array
    return out


_FREE, _HIT = 1, 2  # what one scan says of a cell


@numba.njit(  # type: ignore[misc]
    "void("
    + GRID_ARRAYS_TYPE
    + ", UniTuple(float64, 2), float64[::1], float64[::1], float64[::1], int64, float32[::1])",
    cache=True,
)
def _integrate(  # noqa: PLR0917 - numba kernels take positional arguments
    grid: GridArrays,
    sensor: tuple[float, float],
    cos: FloatArray,
    sin: FloatArray,
    ranges: FloatArray,
    n_hit: int,
    update: npt.NDArray[np.float32],
) -> None:
    """LogOddsGrid.integrate's ray casting: beams from ``sensor`` (m) in directions ``(cos, sin)`` of length
    ``ranges`` (m), the first ``n_hit`` ending on an obstacle; ``update``: lfree, loccupied, lmax."""
    logodds, hit_x, hit_y, hit_count, origin_x, origin_y, res = grid
    height, width = logodds.shape
    sx, sy = sensor
    lfree, loccupied, lmax = update[0], update[1], update[2]
    # Every sample lies between the sensor and a beam's end: their bounding box, clipped to the grid, holds
    # all the cells this scan marks, so marking costs O(that window), not O(map).
    x_lo = x_hi = math.floor((sx - origin_x) / res)
    y_lo = y_hi = math.floor((sy - origin_y) / res)
    for b in range(ranges.size):
        ix = math.floor((sx + ranges[b] * cos[b] - origin_x) / res)
        iy = math.floor((sy + ranges[b] * sin[b] - origin_y) / res)
        x_lo, x_hi, y_lo, y_hi = min(x_lo, ix), max(x_hi, ix), min(y_lo, iy), max(y_hi, iy)
    x_lo, y_lo = max(x_lo, 0), max(y_lo, 0)
    x_hi, y_hi = min(x_hi, width - 1), min(y_hi, height - 1)
    if x_hi < x_lo or y_hi < y_lo:
        return
    mark = np.zeros((y_hi - y_lo + 1, x_hi - x_lo + 1), dtype=np.uint8)
    # End points: the mean hit sums, and marked occupied (a cell holding one is never cleared by this scan).
    for b in range(n_hit):
        ex = sx + ranges[b] * cos[b]
        ey = sy + ranges[b] * sin[b]
        ix = math.floor((ex - origin_x) / res)
        iy = math.floor((ey - origin_y) / res)
        if 0 <= ix < width and 0 <= iy < height:
            hit_x[iy, ix] += ex - (origin_x + ix * res)
            hit_y[iy, ix] += ey - (origin_y + iy * res)
            hit_count[iy, ix] += 1.0
            mark[iy - y_lo, ix - x_lo] = _HIT
    # Every beam sampled at half a cell up to half a cell before its end, so no crossed cell is skipped on
    # axis-aligned beams and the end cell is left to the occupied update.
    step = 0.5 * res
    for b in range(ranges.size):
        length = ranges[b] - 0.5 * res if b < n_hit else ranges[b]
        for k in range(max(math.ceil(length / step), 0)):
            t = k * step
            ix = math.floor((sx + t * cos[b] - origin_x) / res)
            iy = math.floor((sy + t * sin[b] - origin_y) / res)
            if 0 <= ix < width and 0 <= iy < height and mark[iy - y_lo, ix - x_lo] == 0:
                mark[iy - y_lo, ix - x_lo] = _FREE
    # Each marked cell updated once, however many beams crossed it.
    for row in range(mark.shape[0]):
        for col in range(mark.shape[1]):
            if mark[row, col] == 0:
                continue
            cell = logodds[y_lo + row, x_lo + col]
            cell = cell - lfree if mark[row, col] == _FREE else cell + loccupied
            logodds[y_lo + row, x_lo + col] = min(max(cell, -lmax), lmax)
