"""Occupancy grid mapping in log-odds with vectorised ray casting.

Each processed scan adds ``loccupied`` to the log-odds of the cells holding beam end points and subtracts
``lfree`` from the cells the beams crossed (Thrun, Burgard, Fox, *Probabilistic Robotics*, ch. 9), clamped to
``[-lmax, lmax]``. A cell crossed by several beams of one scan is updated once, and a cell holding an end
point is never cleared by the same scan, so the update does not depend on the angular density of the laser.

Like gmapping's point accumulator, each cell also keeps the mean of the end points that fell in it, so the scan
matcher can align to where obstacles were seen rather than to cell centres (sub-cell accuracy). The sums are of
offsets from the cell's corner, so float32 keeps them exact to micrometres: 16 bytes a cell in all.

The grid covers the bounding box of what scans have reached (plus a growth margin), never more than
``max_cells`` cells: growth past that raises :class:`InvalidInputError` before anything is allocated.

Cells are indexed ``[row, col] = [iy, ix]``; cell ``(ix, iy)`` covers
``[origin_x + ix * resolution, origin_x + (ix + 1) * resolution)`` and likewise in y.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.scan import BeamSplit

IntArray = npt.NDArray[np.int64]
# A grid as compiled kernels take it (LogOddsGrid.kernel_args): log-odds, hit offset sums, hit counts, origin x,
# origin y and resolution (m); and that as a numba type.
GridArrays = tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32], float, float, float]
GRID_ARRAYS_TYPE = "Tuple((float32[:, ::1], float32[:, :, ::1], float32[:, ::1], float64, float64, float64))"

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
        # Sum of end point offsets from the cell's corner (m) and end point count per cell, for the mean hit.
        self.hit_sum = np.zeros((2, height, width), dtype=np.float32)
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
        self.logodds[:] = 0.0
        self.hit_sum[:] = 0.0
        self.hit_count[:] = 0.0

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
        self.logodds = np.pad(self.logodds, pad)
        self.hit_sum = np.pad(self.hit_sum, [(0, 0), *pad])
        self.hit_count = np.pad(self.hit_count, pad)
        self.origin_x -= pad[1][0] * res
        self.origin_y -= pad[0][0] * res

    def integrate(self, sensor: Pose2D, beams: BeamSplit) -> None:
        """Update the grid with one scan taken from ``sensor`` (laser pose in the map frame)."""
        res = self.resolution
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
        # Sample every beam at half a cell up to half a cell before its end, so no crossed cell is skipped on
        # axis-aligned beams and the end cell is left to the occupied update.
        step = 0.5 * res
        n_hit = beams.hit_ranges.size
        lengths = ranges.copy()
        lengths[:n_hit] -= 0.5 * res
        counts = np.maximum(np.ceil(lengths / step).astype(np.int64), 0)
        total = int(counts.sum())
        beam = np.repeat(np.arange(ranges.size), counts)
        k = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        t = k * step
        free_ix, free_iy = self.cell_of(sensor.x + t * cos[beam], sensor.y + t * sin[beam])
        occ_ix, occ_iy = self.cell_of(ends_x[:n_hit], ends_y[:n_hit])
        keep = (occ_ix >= 0) & (occ_ix < self.width) & (occ_iy >= 0) & (occ_iy < self.height)
        occ_ix, occ_iy = occ_ix[keep], occ_iy[keep]
        corner_x = self.origin_x + occ_ix * res
        corner_y = self.origin_y + occ_iy * res
        np.add.at(self.hit_sum[0], (occ_iy, occ_ix), ends_x[:n_hit][keep] - corner_x)
        np.add.at(self.hit_sum[1], (occ_iy, occ_ix), ends_y[:n_hit][keep] - corner_y)
        np.add.at(self.hit_count, (occ_iy, occ_ix), 1.0)
        self._apply(free_ix, free_iy, occ_ix, occ_iy)

    def _apply(self, free_ix: IntArray, free_iy: IntArray, occ_ix: IntArray, occ_iy: IntArray) -> None:
        keep = (free_ix >= 0) & (free_ix < self.width) & (free_iy >= 0) & (free_iy < self.height)
        free_ix, free_iy = free_ix[keep], free_iy[keep]
        all_x = np.concatenate([free_ix, occ_ix])
        all_y = np.concatenate([free_iy, occ_iy])
        if all_x.size == 0:
            return
        # Work in the scan's bounding window so marking cells costs O(window), not O(map).
        x0, x1 = int(all_x.min()), int(all_x.max()) + 1
        y0, y1 = int(all_y.min()), int(all_y.max()) + 1
        window = self.logodds[y0:y1, x0:x1]
        free = np.zeros(window.shape, dtype=bool)
        free[free_iy - y0, free_ix - x0] = True
        occ = np.zeros(window.shape, dtype=bool)
        occ[occ_iy - y0, occ_ix - x0] = True
        free &= ~occ
        window[free] -= self.lfree
        window[occ] += self.loccupied
        np.clip(window, -self.lmax, self.lmax, out=window)

    def mean_hits(self, iy: IntArray, ix: IntArray) -> tuple[FloatArray, FloatArray]:
        """Mean end point (m) of cells ``(iy, ix)``; the cell centre where nothing was hit."""
        count = self.hit_count[iy, ix].astype(np.float64)
        res = self.resolution
        safe = np.maximum(count, 1.0)
        dx = np.where(count > 0, self.hit_sum[0, iy, ix] / safe, 0.5 * res)
        dy = np.where(count > 0, self.hit_sum[1, iy, ix] / safe, 0.5 * res)
        return self.origin_x + ix * res + dx, self.origin_y + iy * res + dy

    def kernel_args(self) -> GridArrays:
        """The grid's arrays and geometry, for compiled kernels (they see the arrays, not copies)."""
        return self.logodds, self.hit_sum, self.hit_count, self.origin_x, self.origin_y, self.resolution

    def occupied(self) -> npt.NDArray[np.bool_]:
        """Cells that are more likely occupied than free (what the scan matcher aligns to)."""
        return np.asarray(self.logodds > 0.0)

    def to_occupancy(self) -> npt.NDArray[np.int8]:
        """ROS ``OccupancyGrid`` values: 100 occupied (p >= 0.65), 0 free (p < 0.5), -1 unknown."""
        out = np.full(self.logodds.shape, -1, dtype=np.int8)
        out[self.logodds >= OCCUPIED_LOGODDS] = 100
        out[self.logodds < FREE_LOGODDS] = 0
        return out
