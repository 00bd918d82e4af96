"""Occupancy grid mapping in log-odds with vectorised ray casting.

Each processed scan adds ``loccupied`` to the log-odds of the cells holding beam end points and subtracts
``lfree`` from the cells the beams crossed (Thrun, Burgard, Fox, *Probabilistic Robotics*, ch. 9), clamped to
``[-lmax, lmax]``. A cell crossed by several beams of one scan is updated once, and a cell holding an end
point is never cleared by the same scan, so the update does not depend on the angular density of the laser.

Like gmapping's point accumulator, each cell also keeps the mean of the end points that fell in it, so the scan
matcher can align to where obstacles were seen rather than to cell centres (sub-cell accuracy). The sums are of
offsets from the cell's corner, so float32 keeps them exact to micrometres.

Storage is in tiles of :data:`TILE` x :data:`TILE` cells, allocated when a scan first reaches them: log-odds
(4 bytes a cell) in every tile a beam crossed, the hit sums and counts (12 bytes a cell) only in tiles holding
an end point. Why: the map spans the bounding box of what scans reached, and a long corridor or a campus leaves
most of that box unseen: a dense 16-byte grid of the box took 0.8-0.9 GB on the MIT Infinite Corridor and
Freiburg campus logs and refused scans past its 25 M-cell limit (242 of campus's 2008), where the tiles take
0.1-0.2 GB and the whole replay stays under 0.5 GB with every scan processed.
Tiles are pooled in arrays that grow by half when full (one array at a time, old copies freed before the next
grows), so compiled kernels index them directly: with ``(gy, gx) = (iy + shift_y, ix + shift_x)``, cell
``(iy, ix)`` is at ``pool[table[gy // TILE, gx // TILE], gy % TILE, gx % TILE]``, and a cell of no tile is unknown
(log-odds 0, no hits). The shift (less than a tile) lets the grid grow by whole cells as before tiling, so its
origin, and every coordinate computed from it, stays what it was: the same scans give the same map and poses.
Every tile holding a cell of log-odds above 0 (an occupied cell) has hit sums and counts: only end points raise
a cell's log-odds, and :meth:`LogOddsGrid.assign` gives such tiles hit tiles too, of zero sums if need be (read as
no hits). So a search for occupied cells reads only the tiles that have hit tiles (mrs_nav.slam.matcher_kernels).

Redrawing after a loop closure is lazy (:meth:`LogOddsGrid.invalidate`, :meth:`LogOddsGrid.redraw`): every
tile is marked out of date, and the tiles of a region are drawn again from the rebuild's scans only when a reader
needs that region. Why: with 30 m rays every scan reaches far, and a full rebuild of the Freiburg campus map
re-cast some 1670 scans over the whole campus, 130 s of its 190 s of CPU for 29 closures; the matcher needs only
the tiles round the robot, and the next closure often comes before the robot reaches the rest. A tile redrawn
from the same scans, in the same order, holds what a rebuild of the whole grid would put there, to the bit: its
cells see the same beams' samples (each beam is cast only where it crosses the region, the same samples) and the
same updates in the same order, and the grid grows as that rebuild would (the caller grows it first, scan by scan
in the rebuild's order). Out-of-date tiles are neither read nor written: the caller draws them first.

The grid covers the bounding box of what scans have reached (plus a growth margin), never more than
``max_cells`` cells: growth past that raises :class:`InvalidInputError` before anything is allocated.

Cells are indexed ``[row, col] = [iy, ix]``; cell ``(ix, iy)`` covers
``[origin_x + ix * resolution, origin_x + (ix + 1) * resolution)`` and likewise in y.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.grid_kernels import (
    TILE,
    Float32Array,
    GridArrays,
    GridCells,
    IntArray,
    TileTable,
    _cells,
    _integrate,
    _occupancy,
    _redraw,
    _window,
)
from mrs_nav.slam.scan import BeamSplit

# Rectangles of out-of-date tiles drawn in one pass at most (stale_regions): every beam is clipped to each
REDRAW_RECTANGLES = 8
REDRAW_CHUNK = 64  # scans whose rays redraw() casts at a time
GROWTH_MARGIN_MAX_M = 20.0  # m, the widest margin a growing grid adds (ensure_contains)
# map_server's default occupied_thresh 0.65 as log-odds; a cell more likely free than occupied is free.
OCCUPIED_LOGODDS = math.log(0.65 / 0.35)
FREE_LOGODDS = 0.0


class LogOddsGrid:
    """A growable log-odds occupancy grid in the map frame, stored in tiles (module docstring)."""

    def __init__(
        self,
        resolution: float,
        extent: tuple[float, float, float, float],
        *,
        grows: bool = True,
        lfree: float = 0.4,
        loccupied: float = 0.9,
        lmax: float = 8.0,
        max_cells: int = 50_000_000,
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
        self.width = math.ceil((xmax - self.origin_x) / resolution)
        self.height = math.ceil((ymax - self.origin_y) / resolution)
        if self.width * self.height > max_cells:
            raise InvalidInputError(
                f"occupancy grid of {self.width} x {self.height} cells exceeds the limit of {max_cells:,}"
            )
        self.shift_y = self.shift_x = 0  # of cell (0, 0) into its tile (module docstring)
        # Pool slot of each tile's log-odds and of its hit sums and counts; -1: none yet.
        shape = (-(-self.height // TILE), -(-self.width // TILE))
        self.table = np.full(shape, -1, dtype=np.int32)
        self.hit_table = np.full(shape, -1, dtype=np.int32)
        self.tiles = np.zeros(2, dtype=np.int64)  # pool slots in use: log-odds, hits
        # Tiles out of date since the last invalidate(), to be drawn again by redraw() before they are read
        self.stale = np.zeros(shape, dtype=np.bool_)
        self.stale_tiles = 0  # how many
        self.logodds = _pool(0)
        # Sums of end point offsets from the cell's corner in x and in y (m) and end point count per cell, for
        # the mean hit.
        self.hit_x = _pool(0)
        self.hit_y = _pool(0)
        self.hit_count = _pool(0)

    @property
    def cells(self) -> GridCells:
        """Height, width and the shift of cell (0, 0) into its tile (rows, columns), for the kernels."""
        return self.height, self.width, self.shift_y, self.shift_x

    @property
    def nbytes(self) -> int:
        """Bytes of the grid's arrays as allocated: tile tables, out-of-date marks and tile pools (with their room
        to grow, zeroed lazily: resident only where tiles were taken)."""
        arrays = (self.table, self.hit_table, self.stale, self.logodds, self.hit_x, self.hit_y, self.hit_count)
        return sum(int(a.nbytes) for a in arrays)

    def cell_of(self, x: FloatArray, y: FloatArray) -> tuple[IntArray, IntArray]:
        """Cell indices ``(ix, iy)`` of points in metres (may lie outside the grid)."""
        ix = np.floor((x - self.origin_x) / self.resolution).astype(np.int64)
        iy = np.floor((y - self.origin_y) / self.resolution).astype(np.int64)
        return ix, iy

    def clear(self) -> None:
        """Forget everything observed (the extent stays)."""
        self.table[:] = -1
        self.hit_table[:] = -1
        self.tiles[:] = 0
        self.stale[:] = False
        self.stale_tiles = 0
        # Fresh pools (zeroed lazily), not zeros written over the old ones: tiles are taken from them as zeros.
        self.logodds = _pool(len(self.logodds))
        self.hit_x = _pool(len(self.hit_x))
        self.hit_y = _pool(len(self.hit_y))
        self.hit_count = _pool(len(self.hit_count))

    def ensure_contains(self, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        """Grow the grid (if allowed) so that the box lies inside, with a margin to avoid growing every scan.

        Growing copies only the tile tables (4 bytes a tile); the tiles stay where they are."""
        if not self.grows:
            return
        res = self.resolution
        left = max(0, math.ceil((self.origin_x - xmin) / res))
        bottom = max(0, math.ceil((self.origin_y - ymin) / res))
        right = max(0, math.ceil((xmax - (self.origin_x + self.width * res)) / res) + 1)
        top = max(0, math.ceil((ymax - (self.origin_y + self.height * res)) / res) + 1)
        if left == bottom == right == top == 0:
            return
        # A margin so that a slowly growing map does not grow every scan, at most GROWTH_MARGIN_MAX_M (a quarter
        # of a 300 m map on each side it grew to reached the cell limit on the MIT Infinite Corridor log, little of
        # it ever seen); dropped near the cell limit.
        cap = int(GROWTH_MARGIN_MAX_M / res)
        for margin in (max(int(5.0 / res), min(max(self.width // 4, self.height // 4), cap)), 0):
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
        # Whole tiles before the old ones for the cells added before them, the rest taken up by the shift.
        (before_y, after_y), (before_x, after_x) = pad
        tiles_before_y = max(0, -(-(before_y - self.shift_y) // TILE))
        tiles_before_x = max(0, -(-(before_x - self.shift_x) // TILE))
        self.shift_y += tiles_before_y * TILE - before_y
        self.shift_x += tiles_before_x * TILE - before_x
        self.height += before_y + after_y
        self.width += before_x + after_x
        tiles_y, tiles_x = self.table.shape
        table_pad = [
            (tiles_before_y, -(-(self.height + self.shift_y) // TILE) - tiles_before_y - tiles_y),
            (tiles_before_x, -(-(self.width + self.shift_x) // TILE) - tiles_before_x - tiles_x),
        ]
        self.table = np.pad(self.table, table_pad, constant_values=-1)
        self.hit_table = np.pad(self.hit_table, table_pad, constant_values=-1)
        # Tiles beyond the old extent hold nothing to redraw: invalidate()'s caller grew the grid first to hold
        # every scan of the redraw.
        self.stale = np.pad(self.stale, table_pad, constant_values=False)
        self.origin_x -= before_x * res
        self.origin_y -= before_y * res

    def integrate(self, sensor: Pose2D, beams: BeamSplit) -> None:
        """Update the grid with one scan taken from ``sensor`` (laser pose in the map frame)."""
        cos, sin, ranges = _rays(sensor, beams)
        if ranges.size == 0:
            return
        box = _box(sensor, cos, sin, ranges)
        self.ensure_contains(*box)
        # Room for every tile the scan can reach (its box, clipped to the grid) and one hit tile per end point:
        # the kernel takes its new tiles from the pools' spare slots.
        ix, iy = self.cell_of(np.array([box[0], box[2]]), np.array([box[1], box[3]]))
        tx0, tx1 = ((min(max(int(i), 0), self.width - 1) + self.shift_x) // TILE for i in ix)
        ty0, ty1 = ((min(max(int(i), 0), self.height - 1) + self.shift_y) // TILE for i in iy)
        # A tile more each side: the kernel's cell arithmetic may round across a tile edge this one did not.
        reach = (tx1 - tx0 + 3) * (ty1 - ty0 + 3)
        self._reserve(reach, beams.hit_ranges.size)
        # float32 like the log-odds, so that the updates round as the grid's own arithmetic does
        update = np.array([self.lfree, self.loccupied, self.lmax], dtype=np.float32)
        args = self.kernel_args()
        _integrate(args, self.tiles, (sensor.x, sensor.y), cos, sin, ranges, beams.hit_ranges.size, update)

    def scan_box(self, sensor: Pose2D, beams: BeamSplit) -> tuple[float, float, float, float] | None:
        """The box (m) that :meth:`integrate` grows the grid to hold for this scan; None for a scan of no beams."""
        cos, sin, ranges = _rays(sensor, beams)
        return _box(sensor, cos, sin, ranges) if ranges.size else None

    def tiles_box(self, rect: tuple[int, int, int, int]) -> tuple[float, float, float, float]:
        """The box (m) of tile rows ``[ty0, ty1)`` and columns ``[tx0, tx1)`` (``rect``), a cell wider each side."""
        ty0, ty1, tx0, tx1 = rect
        res = self.resolution
        x0 = self.origin_x + (tx0 * TILE - self.shift_x - 1) * res
        y0 = self.origin_y + (ty0 * TILE - self.shift_y - 1) * res
        x1 = self.origin_x + (tx1 * TILE - self.shift_x + 1) * res
        y1 = self.origin_y + (ty1 * TILE - self.shift_y + 1) * res
        return x0, y0, x1, y1

    def invalidate(self) -> None:
        """Forget everything observed (:meth:`clear`) and mark every tile out of date (module docstring): the map
        is to be drawn again by :meth:`redraw` from scans at new poses. The caller grows the grid first to hold
        all those scans. Cleared, not kept until drawn: an out-of-date tile is never read, and tiles the new
        poses no longer reach would stay allocated (on the MIT Infinite Corridor log, 0.04 GB more at the end)."""
        self.clear()
        self.stale[:] = True
        self.stale_tiles = self.stale.size

    def stale_regions(self, box: tuple[float, float, float, float] | None = None) -> list[tuple[int, int, int, int]]:
        """Disjoint tile rectangles (rows ``[ty0, ty1)``, columns ``[tx0, tx1)``) holding exactly the out-of-date
        tiles that cells of ``box`` (m; None: the whole grid) lie in: runs of them along rows, runs of equal
        columns in consecutive rows merged (the robot's reach less the region drawn before is a few of these).
        At most :data:`REDRAW_RECTANGLES`: more are merged into their bounding rectangle."""
        if self.stale_tiles == 0:
            return []
        ty0, tx0 = 0, 0
        ty1, tx1 = self.stale.shape
        if box is not None:
            ix, iy = self.cell_of(np.array([box[0], box[2]]), np.array([box[1], box[3]]))
            if ix[1] < 0 or iy[1] < 0 or ix[0] >= self.width or iy[0] >= self.height:
                return []
            tx0, tx1 = _tile_span(ix, self.width, self.shift_x)
            ty0, ty1 = _tile_span(iy, self.height, self.shift_y)
        window = self.stale[ty0:ty1, tx0:tx1]
        rows = np.flatnonzero(window.any(axis=1))
        if rows.size == 0:
            return []
        done: list[tuple[int, int, int, int]] = []
        open_runs: dict[tuple[int, int], int] = {}  # columns -> first row of the rectangle growing down
        previous = -2
        for row in rows:
            edges = np.flatnonzero(np.diff(np.concatenate([[False], window[row], [False]]).astype(np.int8)))
            runs = {(int(edges[k]), int(edges[k + 1])) for k in range(0, edges.size, 2)}
            ended = open_runs if row != previous + 1 else {r: s for r, s in open_runs.items() if r not in runs}
            done.extend((ty0 + s, ty0 + previous + 1, tx0 + r[0], tx0 + r[1]) for r, s in ended.items())
            open_runs = {r: open_runs.get(r, row) if row == previous + 1 else row for r in runs}
            previous = row
        done.extend((ty0 + s, ty0 + previous + 1, tx0 + r[0], tx0 + r[1]) for r, s in open_runs.items())
        if len(done) > REDRAW_RECTANGLES:
            done = [
                (min(d[0] for d in done), max(d[1] for d in done), min(d[2] for d in done), max(d[3] for d in done))
            ]
        return done

    def redraw(self, rects: list[tuple[int, int, int, int]], scans: Iterable[tuple[Pose2D, BeamSplit]]) -> None:
        """Draw the out-of-date tiles in the tile rectangles ``rects`` (:meth:`stale_regions`) again from
        ``scans`` (laser pose in the map frame, beams), in their order, as :meth:`integrate` would have drawn
        them into a cleared grid; those tiles are then up to date. ``scans`` must hold every scan of the redraw
        that can reach the tiles (others are cast only where they cross ``rects``: cheap), and nothing may have
        been integrated into the tiles since :meth:`invalidate` (the caller draws the tiles a scan reaches first).
        The scans are taken :data:`REDRAW_CHUNK` at a time, so that their rays need little memory at once.
        """
        target = np.zeros_like(self.stale)
        for ty0, ty1, tx0, tx1 in rects:
            target[ty0:ty1, tx0:tx1] = self.stale[ty0:ty1, tx0:tx1]
        self._reserve(int(np.count_nonzero(target & (self.table < 0))), 0)
        spare_hits = int(np.count_nonzero(target & (self.hit_table < 0)))
        # The rectangles in metres, a cell wider each side, for clipping beams
        boxes = np.array([self.tiles_box(rect) for rect in rects], dtype=np.float64).reshape(-1, 4)
        update = np.array([self.lfree, self.loccupied, self.lmax], dtype=np.float32)
        # Per log-odds pool slot: the number (from 1) of the last scan that marked a cell of the tile, and which
        # cells it marked, a bit each (12 bytes a tile; pages mapped only where written)
        marked_by = np.zeros(len(self.logodds), dtype=np.int32)
        marks = np.zeros(len(self.logodds), dtype=np.uint64)
        done, remaining = 0, iter(scans)
        while chunk := list(itertools.islice(remaining, REDRAW_CHUNK)):
            hits = sum(b.hit_ranges.size for _, b in chunk)
            self._reserve(0, min(spare_hits, hits))
            # numpy's cosine, as integrate takes it (numba's differs in the last bits)
            rays = [_rays(sensor, b) for sensor, b in chunk]
            _redraw(
                self.kernel_args(),
                self.tiles,
                target,
                boxes,
                marked_by,
                marks,
                done,
                np.array([(sensor.x, sensor.y) for sensor, _ in chunk], dtype=np.float64),
                np.concatenate([r[0] for r in rays]),
                np.concatenate([r[1] for r in rays]),
                np.concatenate([r[2] for r in rays]),
                np.concatenate([[0], np.cumsum([r[2].size for r in rays])]).astype(np.int64),
                np.array([b.hit_ranges.size for _, b in chunk], dtype=np.int64),
                update,
            )
            done += len(chunk)
        self.stale_tiles -= int(np.count_nonzero(target))
        self.stale[target] = False

    def _reserve(self, tiles: int, hit_tiles: int) -> None:
        """Grow the pools (by half at least) so that ``tiles`` log-odds and ``hit_tiles`` hit tiles are spare."""
        used, hits = int(self.tiles[0]), int(self.tiles[1])
        if used + tiles > len(self.logodds):
            self.logodds = _grown(self.logodds, used, used + tiles)
        if hits + hit_tiles > len(self.hit_count):
            # One pool at a time: each assignment frees the old pool before the next is copied.
            self.hit_x = _grown(self.hit_x, hits, hits + hit_tiles)
            self.hit_y = _grown(self.hit_y, hits, hits + hit_tiles)
            self.hit_count = _grown(self.hit_count, hits, hits + hit_tiles)

    def logodds_at(self, iy: IntArray, ix: IntArray) -> Float32Array:
        """Log-odds of cells ``(iy, ix)`` (0 outside the grid and where nothing was seen)."""
        return _lookup(self.table, self.logodds, self.cells, iy, ix)

    def mean_hits(self, iy: IntArray, ix: IntArray) -> tuple[FloatArray, FloatArray]:
        """Mean end point (m) of cells ``(iy, ix)``; the cell centre where nothing was hit."""
        count = _lookup(self.hit_table, self.hit_count, self.cells, iy, ix).astype(np.float64)
        res = self.resolution
        safe = np.maximum(count, 1.0)
        dx = np.where(count > 0, _lookup(self.hit_table, self.hit_x, self.cells, iy, ix) / safe, 0.5 * res)
        dy = np.where(count > 0, _lookup(self.hit_table, self.hit_y, self.cells, iy, ix) / safe, 0.5 * res)
        return self.origin_x + ix * res + dx, self.origin_y + iy * res + dy

    def window(self, y0: int, y1: int, x0: int, x1: int) -> Float32Array:
        """Log-odds of the cells ``[y0, y1) x [x0, x1)`` (inside the grid) as a dense array."""
        out: Float32Array = _window(self.table, self.logodds, self.cells, (y0, y1), (x0, x1))
        return out

    def dense(self) -> tuple[Float32Array, Float32Array, Float32Array, Float32Array]:
        """The whole grid as dense arrays: log-odds, hit offset sums in x and in y, hit counts (for tests and
        small grids: 16 bytes a cell of the bounding box)."""
        return (
            self.window(0, self.height, 0, self.width),
            _window(self.hit_table, self.hit_x, self.cells, (0, self.height), (0, self.width)),
            _window(self.hit_table, self.hit_y, self.cells, (0, self.height), (0, self.width)),
            _window(self.hit_table, self.hit_count, self.cells, (0, self.height), (0, self.width)),
        )

    def assign(self, logodds: Float32Array, hit_x: Float32Array, hit_y: Float32Array, hit_count: Float32Array) -> None:
        """Set the whole grid from dense arrays of its shape (what :meth:`dense` returns)."""
        self.clear()
        shape = (self.table.shape[0], TILE, self.table.shape[1], TILE)
        rows = slice(self.shift_y, self.shift_y + self.height)
        cols = slice(self.shift_x, self.shift_x + self.width)
        occupied = None  # tiles of log-odds above 0: they take hit tiles too (module docstring), zero sums or not
        for table, pools, index in (
            (self.table, [logodds], 0),
            (self.hit_table, [hit_x, hit_y, hit_count], 1),
        ):
            tiles = []
            for array in pools:
                covering = np.zeros((shape[0] * TILE, shape[2] * TILE), dtype=np.float32)  # the tables' cells
                covering[rows, cols] = array
                tiles.append(covering.reshape(shape).transpose(0, 2, 1, 3))
            taken = np.any([t.any(axis=(2, 3)) for t in tiles], axis=0)
            if occupied is None:
                occupied = (tiles[0] > 0.0).any(axis=(2, 3))
            else:
                taken |= occupied
            ty, tx = np.nonzero(taken)
            table[ty, tx] = np.arange(ty.size, dtype=np.int32)
            self.tiles[index] = ty.size
            if index == 0:
                self.logodds = np.ascontiguousarray(tiles[0][ty, tx])
            else:
                self.hit_x, self.hit_y, self.hit_count = (np.ascontiguousarray(t[ty, tx]) for t in tiles)

    def kernel_args(self) -> GridArrays:
        """The grid's tables, pools and geometry, for compiled kernels (they see the arrays, not copies)."""
        return (
            self.table,
            self.logodds,
            self.hit_table,
            self.hit_x,
            self.hit_y,
            self.hit_count,
            self.cells,
            self.origin_x,
            self.origin_y,
            self.resolution,
        )

    def occupied(self) -> npt.NDArray[np.bool_]:
        """Cells that are more likely occupied than free (what the scan matcher aligns to)."""
        return np.asarray(self.window(0, self.height, 0, self.width) > 0.0)

    def to_occupancy(self) -> npt.NDArray[np.int8]:
        """ROS ``OccupancyGrid`` values: 100 occupied (p >= 0.65), 0 free (p < 0.5), -1 unknown."""
        out: npt.NDArray[np.int8] = _occupancy(self.table, self.logodds, self.cells, OCCUPIED_LOGODDS, FREE_LOGODDS)
        return out


def _tile_span(cells: IntArray, size: int, shift: int) -> tuple[int, int]:
    """Tiles ``[t0, t1)`` along one axis that hold cells ``cells[0]`` to ``cells[1]`` clipped to the grid's
    ``size`` cells (``shift``: of cell 0 into its tile)."""
    first, last = (min(max(int(i), 0), size - 1) + shift for i in cells)
    return first // TILE, last // TILE + 1


def _rays(sensor: Pose2D, beams: BeamSplit) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cosine and sine of each beam's direction in the map frame and its range (m): hits first."""
    angles = np.concatenate([beams.hit_angles, beams.free_angles]) + sensor.yaw
    return np.cos(angles), np.sin(angles), np.concatenate([beams.hit_ranges, beams.free_ranges])


def _box(sensor: Pose2D, cos: FloatArray, sin: FloatArray, ranges: FloatArray) -> tuple[float, float, float, float]:
    """The box (m) holding the sensor and every beam's end."""
    ends_x = sensor.x + ranges * cos
    ends_y = sensor.y + ranges * sin
    return (
        min(sensor.x, float(ends_x.min())),
        min(sensor.y, float(ends_y.min())),
        max(sensor.x, float(ends_x.max())),
        max(sensor.y, float(ends_y.max())),
    )


def _pool(tiles: int) -> Float32Array:
    """A pool of ``tiles`` zeroed tiles (np.zeros: pages are mapped only when first written)."""
    return np.zeros((tiles, TILE, TILE), dtype=np.float32)


def _grown(pool: Float32Array, used: int, needed: int) -> Float32Array:
    """``pool`` with room for ``needed`` tiles, by half more at least; its first ``used`` tiles kept."""
    out = _pool(max(needed, len(pool) + len(pool) // 2, 64))
    out[:used] = pool[:used]
    return out


def _lookup(
    table: TileTable, pool: Float32Array, cells: GridCells, iy: npt.ArrayLike, ix: npt.ArrayLike
) -> Float32Array:
    """Values of cells ``(iy, ix)`` (arrays of any integer type and shape) of a tiled array (:func:`_cells`)."""
    rows, cols = np.broadcast_arrays(np.asarray(iy, dtype=np.int64), np.asarray(ix, dtype=np.int64))
    flat_rows, flat_cols = np.ascontiguousarray(rows).ravel(), np.ascontiguousarray(cols).ravel()
    out: Float32Array = _cells(table, pool, cells, flat_rows, flat_cols)
    return out.reshape(rows.shape)
