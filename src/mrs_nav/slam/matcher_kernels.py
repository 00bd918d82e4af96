"""Compiled kernels of the scan matcher (:mod:`mrs_nav.slam.matcher`): the per-point work of the correlative
search and the Gauss-Newton refinement, the truncated distance field and its likelihood tables.

Why compiled (:mod:`mrs_nav.jit`): numpy can do this work only through (angles x offsets x points) temporaries and
dozens of small-array calls per iteration.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray
from mrs_nav.slam.grid_kernels import (
    GRID_ARRAYS_TYPE,
    TILE,
    Float32Array,
    GridArrays,
    GridCells,
    IntArray,
    TileTable,
    _tile_value,
)

PRIOR_WEIGHT = 0.05  # score units (mean likelihood, 0..1) per squared prior standard deviation, halved
NORMAL_RADIUS = 2  # cells: the neighbourhood whose hits define a surface normal
POINT_SIGMA_CELLS = 0.5  # assumed standard deviation of a point-to-hit residual, in cells
INDEPENDENT_POINTS = 20.0  # neighbouring scan points are correlated; count at most this many as independent

CellArray = npt.NDArray[np.int32]  # squared cell distances and grid indices of the distance field
# What the compiled surface lookup needs of a field (DistanceField.kernel_args): the window's origin (m), the
# nearest occupied cell's grid indices per window cell, and the grid.
SurfaceArgs = tuple[float, float, CellArray, CellArray, GridArrays]


# SurfaceArgs (DistanceField.kernel_args) as a numba type.
_SURFACE_ARGS = "Tuple((float64, float64, int32[:, ::1], int32[:, ::1], " + GRID_ARRAYS_TYPE + "))"


@numba.njit("UniTuple(float64, 2)(" + GRID_ARRAYS_TYPE + ", int64, int64)", cache=True)  # type: ignore[misc]
def _mean_hit(grid: GridArrays, iy: int, ix: int) -> tuple[float, float]:
    """LogOddsGrid.mean_hits of one cell."""
    _, _, hit_table, hit_x, hit_y, hit_count, cells, origin_x, origin_y, res = grid
    gy, gx = iy + cells[2], ix + cells[3]
    # The slot looked up once for the three pools: _tile_value for each took a quarter longer in the refinement.
    slot = hit_table[gy // TILE, gx // TILE]
    # np.float64, not float(): numba's float() of a float32 stays float32, and so would the division.
    count = np.float64(hit_count[slot, gy % TILE, gx % TILE]) if slot >= 0 else 0.0
    dx = np.float64(hit_x[slot, gy % TILE, gx % TILE]) / count if count > 0.0 else 0.5 * res
    dy = np.float64(hit_y[slot, gy % TILE, gx % TILE]) / count if count > 0.0 else 0.5 * res
    return float(origin_x + ix * res + dx), float(origin_y + iy * res + dy)


@numba.njit("float64(" + GRID_ARRAYS_TYPE + ", int64, int64)", cache=True)  # type: ignore[misc]
def _normal_at(grid: GridArrays, iy: int, ix: int) -> float:
    """Surface normal angle (rad) at grid cell ``(iy, ix)`` from the principal axes of the mean hits of the
    occupied cells within ``NORMAL_RADIUS`` (clipped at the grid's edge); NaN where fewer than 3 are."""
    table, logodds, hit_table, _, _, hit_count, cells, _, _, _ = grid
    height, width, shift_y, shift_x = cells
    size = 2 * NORMAL_RADIUS + 1
    px = np.empty(size * size)
    py = np.empty(size * size)
    n = 0
    for oy in range(-NORMAL_RADIUS, NORMAL_RADIUS + 1):
        gy = min(max(iy + oy, 0), height - 1)
        for ox in range(-NORMAL_RADIUS, NORMAL_RADIUS + 1):
            gx = min(max(ix + ox, 0), width - 1)
            occupied = _tile_value(table, logodds, gy + shift_y, gx + shift_x) > 0.0
            if occupied and _tile_value(hit_table, hit_count, gy + shift_y, gx + shift_x) > 0.0:
                px[n], py[n] = _mean_hit(grid, gy, gx)
                n += 1
    if n < 3:
        return np.nan
    cx = px[:n].sum() / n
    cy = py[:n].sum() / n
    sxx = syy = sxy = 0.0
    for k in range(n):
        dx, dy = px[k] - cx, py[k] - cy
        sxx += dx * dx
        syy += dy * dy
        sxy += dx * dy
    # Principal (tangent) direction of the local hits; the normal is perpendicular to it.
    return 0.5 * math.atan2(2.0 * sxy, sxx - syy) + 0.5 * math.pi


@numba.njit("UniTuple(int64, 2)(float64, float64, " + _SURFACE_ARGS + ")", cache=True)  # type: ignore[misc]
def _nearest_cell(x: float, y: float, surface: SurfaceArgs) -> tuple[int, int]:
    """Grid indices of the nearest occupied cell to a point (m) in the field's window (the point clipped into
    it); -1 where none is within the truncation."""
    field_x, field_y, near_iy, near_ix, grid = surface
    res = grid[9]
    height, width = near_iy.shape
    ix = min(max(math.floor((x - field_x) / res), 0), width - 1)
    iy = min(max(math.floor((y - field_y) / res), 0), height - 1)
    return near_iy[iy, ix], near_ix[iy, ix]


@numba.njit("UniTuple(float64, 3)(" + GRID_ARRAYS_TYPE + ", int64, int64)", cache=True)  # type: ignore[misc]
def _cell_surface(grid: GridArrays, iy: int, ix: int) -> tuple[float, float, float]:
    """Mean hit (m) of the occupied grid cell ``(iy, ix)`` and the surface normal (rad) there; NaN where no
    normal is defined, or no cell is (``iy`` -1)."""
    if iy < 0:
        return np.nan, np.nan, np.nan
    normal = _normal_at(grid, iy, ix)
    if not math.isfinite(normal):
        return np.nan, np.nan, np.nan
    mx, my = _mean_hit(grid, iy, ix)
    return mx, my, normal


@numba.njit("float64[:, ::1](float64[::1], float64[::1], " + _SURFACE_ARGS + ")", cache=True)  # type: ignore[misc]
def _nearest_surfaces(
    x: FloatArray,
    y: FloatArray,
    surface: SurfaceArgs,
) -> FloatArray:
    """DistanceField.nearest_surface: rows mx, my, normal of the nearest occupied cell of every point."""
    out = np.empty((3, x.size))
    for k in range(x.size):
        iy, ix = _nearest_cell(x[k], y[k], surface)
        out[0, k], out[1, k], out[2, k] = _cell_surface(surface[4], iy, ix)
    return out


@numba.njit(  # type: ignore[misc]
    "UniTuple(float64, 3)(float64[:, ::1], UniTuple(float64, 3), UniTuple(float64, 3), float64[::1], int64, "
    + _SURFACE_ARGS
    + ")",
    cache=True,
)
def _refine(  # noqa: PLR0917 - numba kernels take positional arguments
    points: FloatArray,
    start: tuple[float, float, float],
    prior: tuple[float, float, float],
    prior_info: FloatArray,
    iterations: int,
    surface: SurfaceArgs,
) -> tuple[float, float, float]:
    """ScanMatcher.refine's Gauss-Newton iterations from the laser pose ``start`` (x, y m, yaw rad) with the
    odometry prior ``prior``; the refined pose (yaw not wrapped)."""
    x, y, yaw = start
    prior_x, prior_y, prior_yaw = prior
    res = surface[4][9]
    n_points = points.shape[0]
    cutoff = 4.0 * res  # pairs farther apart than this are not the same surface
    huber = 0.5 * res
    residual = np.empty(n_points)
    jac = np.empty((n_points, 3))
    # Each point's nearest occupied cell and its surface (mean hit, normal) as last looked up: from one iteration
    # to the next most points keep their cell, and the normal, from up to 25 cells' mean hits, is most of the
    # refinement's work.
    cell_y = np.full(n_points, -1, dtype=np.int64)
    cell_x = np.full(n_points, -1, dtype=np.int64)
    found = np.full((n_points, 3), np.nan)  # cell -1: no surface
    for _ in range(iterations):
        c, s = math.cos(yaw), math.sin(yaw)
        n = 0
        for k in range(n_points):
            px, py = points[k, 0], points[k, 1]
            wx = x + c * px - s * py
            wy = y + s * px + c * py
            iy, ix = _nearest_cell(wx, wy, surface)
            if iy != cell_y[k] or ix != cell_x[k]:
                found[k, 0], found[k, 1], found[k, 2] = _cell_surface(surface[4], iy, ix)
                cell_y[k], cell_x[k] = iy, ix
            mx, my, normal = found[k, 0], found[k, 1], found[k, 2]
            if not (math.isfinite(normal) and math.hypot(wx - mx, wy - my) < cutoff):
                continue
            nx, ny = math.cos(normal), math.sin(normal)
            # residual r = n . (R p + t - m); dr/dtheta = n . (-s px - c py, c px - s py)
            residual[n] = nx * (wx - mx) + ny * (wy - my)
            jac[n, 0], jac[n, 1] = nx, ny
            jac[n, 2] = nx * (-s * px - c * py) + ny * (c * px - s * py)
            n += 1
        if n < 3:
            break
        scale = 1.0 / ((POINT_SIGMA_CELLS * res) ** 2 * max(1.0, n / INDEPENDENT_POINTS))
        deviation = np.array([x - prior_x, y - prior_y, (yaw - prior_yaw + math.pi) % (2.0 * math.pi) - math.pi])
        # Iteratively reweighted Cauchy prior, as in the search: far from odometry it pulls less.
        info = prior_info / (1.0 + 0.5 * np.sum(prior_info * deviation**2))
        hess = np.diag(info)
        grad = info * deviation
        for k in range(n):
            r = residual[k]
            w = scale * (1.0 if abs(r) <= huber else huber / max(abs(r), 1e-12))
            for i in range(3):
                grad[i] += w * jac[k, i] * r
                for j in range(3):
                    hess[i, j] += w * jac[k, i] * jac[k, j]
        step = -np.linalg.solve(hess, grad)
        x, y, yaw = x + step[0], y + step[1], yaw + step[2]
        if abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-5:
            break
    return x, y, yaw


@numba.njit(  # type: ignore[misc]
    "float64[:, :, ::1](int32[:, ::1], float64[::1], UniTuple(float64, 3), float64[:, ::1], UniTuple(float64, 3), "
    "float64[::1], int64[::1], UniTuple(int64, 2), UniTuple(float64, 2))",
    cache=True,
)
def _search_scores(  # noqa: PLR0917 - numba kernels take positional arguments
    squared: CellArray,
    values: FloatArray,
    window: tuple[float, float, float],
    points: FloatArray,
    prior: tuple[float, float, float],
    angles: FloatArray,
    offsets: IntArray,
    base: tuple[int, int],
    spread: tuple[float, float],
) -> FloatArray:
    """ScanMatcher._scores: for every heading ``prior`` yaw + ``angles`` (rad) and every (x, y) cell offset
    ``base`` + ``offsets``, the mean value ``values[squared]`` (a window: corner x, y and resolution, m) under
    ``points`` (laser frame) placed there, cell indices clipped into the window, minus the odometry prior's penalty
    with standard deviations ``spread`` (m, rad): an (angles, x offsets, y offsets) array."""
    origin_x, origin_y, res = window
    x, y = prior[0] + base[0] * res, prior[1] + base[1] * res
    height, width = squared.shape
    cells = squared.ravel()
    n = points.shape[0]
    k = offsets.size
    out = np.empty((angles.size, k, k))
    # Per heading, each point's cell moved by each offset and clipped: row starts in ``cells`` per y offset,
    # columns per x offset; then the point's values at every offset added to that offset's sum. Point by point,
    # not offset by offset over all points: a point's k x k cells lie within a few cache lines, and the sums
    # still add the points in their order, the same sums to the bit (over a quarter less time on the Freiburg
    # campus log's windows, some of a million cells; a tenth on the Freiburg 079 log's).
    rows = np.empty(k, dtype=np.int64)
    cols = np.empty(k, dtype=np.int64)
    total = np.empty((k, k))
    for a in range(angles.size):
        yaw = prior[2] + angles[a]
        c, s = math.cos(yaw), math.sin(yaw)
        total[:] = 0.0
        for p in range(n):
            px, py = points[p, 0], points[p, 1]
            ix = min(max(math.floor((x + c * px - s * py - origin_x) / res), 0), width - 1)
            iy = min(max(math.floor((y + s * px + c * py - origin_y) / res), 0), height - 1)
            for j in range(k):
                rows[j] = min(max(iy + offsets[j], 0), height - 1) * width
                cols[j] = min(max(ix + offsets[j], 0), width - 1)
            for kx in range(k):
                for ky in range(k):
                    total[kx, ky] += values[cells[rows[ky] + cols[kx]]]
        for kx in range(k):
            for ky in range(k):
                z2 = (angles[a] / spread[1]) ** 2 + ((base[0] + offsets[kx]) * res / spread[0]) ** 2
                z2 += ((base[1] + offsets[ky]) * res / spread[0]) ** 2
                out[a, kx, ky] = total[kx, ky] / n - PRIOR_WEIGHT * math.log1p(0.5 * z2)
    return out


# A cell's 8 neighbours (rows, columns), in row-major order: the first four come before it, the last four after it
_NEIGHBOURS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)], dtype=np.int64)


@numba.njit(  # type: ignore[misc]
    "Tuple((int32[:, ::1], int32[:, ::1], int32[:, ::1], int64))("
    "int32[:, ::1], float32[:, :, ::1], int32[:, ::1], UniTuple(int64, 4), UniTuple(int64, 2), UniTuple(int64, 2), "
    "int64, int64)",
    cache=True,
)
def _truncated_field(  # noqa: PLR0917 - numba kernels take positional arguments
    table: TileTable,
    logodds: Float32Array,
    hit_table: TileTable,
    cells: GridCells,
    rows: tuple[int, int],
    cols: tuple[int, int],
    pad: int,
    cap: int,
) -> tuple[CellArray, CellArray, CellArray, int]:
    """DistanceField's arrays for the window ``[y0, y1) x [x0, x1)`` (``rows``, ``cols``; inside the grid) of a
    grid's log-odds tiles (``table``, ``logodds``, ``hit_table``, ``cells``: as in LogOddsGrid.kernel_args): the
    squared distance in cells to the nearest occupied cell (log-odds above 0), at most ``cap``, and that cell's grid
    indices (-1 where none is nearer than the cap), padded by ``pad`` cells of ``cap`` and -1; and how many cells
    are occupied.

    Each occupied cell writes its distance into the disc of cells it can be nearest to (squared distance below
    ``cap``). Why not a Euclidean distance transform: only the truncated distances matter, walls are a few per
    cent of a window's cells, and the transform's exact distances across the empty rest cost six times as much
    on the Intel log's windows, for the same capped distances. Of equally near cells the first in row order is
    kept; scipy's transform keeps another in about 1 % of cells, and the last in row order gives the Intel
    replay's ATE 0.073 m against 0.070 m: the choice matters no more than any small perturbation does.

    Two shortcuts that leave every array as the whole discs give it, to the bit. Only tiles with hit tiles are read:
    no other tile holds an occupied cell (mrs_nav.slam.grid), and the Freiburg campus log's windows are half a
    million cells of mostly open ground. And an occupied cell writes only where none of its occupied neighbours is
    nearer, or as near and first in row order (the discs' order): a neighbour one cell away is nearer on one side of
    a line between the two, so in a wall one cell thick a cell writes a line of its disc, not all of it. Both took
    the field from 1.0 to 0.55 ms a window on the Freiburg 079 log and from 3.7 to 1.7 ms on the campus (their
    replays' first 2500 windows, the same arrays).
    """
    _, _, shift_y, shift_x = cells
    (y0, y1), (x0, x1) = rows, cols
    height, width = y1 - y0, x1 - x0
    shape = (height + 2 * pad, width + 2 * pad)
    squared = np.full(shape, cap, dtype=np.int32)
    near_iy = np.full(shape, -1, dtype=np.int32)
    near_ix = np.full(shape, -1, dtype=np.int32)
    reach = int(math.sqrt(cap))  # cells with a squared distance below cap lie within this many cells
    # Half-width of the disc in each row dr away: the columns dc with dr^2 + dc^2 < cap (-1: none)
    spans = np.empty(reach + 1, dtype=np.int64)
    for dr in range(reach + 1):
        spans[dr] = int(math.sqrt(cap - 1 - dr * dr)) if dr * dr < cap else -1
    # Per set of occupied neighbours (a bit each, _NEIGHBOURS' order), once it is met: the columns dc from low[dr]
    # to high[dr] of each disc row dr (from -reach) where the cell is nearer than each of those neighbours, or
    # as near and before it. A neighbour (ny, nx) is as near as the cell where 2 (dr ny + dc nx) = ny^2 + nx^2.
    ready = np.zeros(1 << _NEIGHBOURS.shape[0], dtype=np.bool_)
    low = np.empty((ready.size, 2 * reach + 1), dtype=np.int64)
    high = np.empty((ready.size, 2 * reach + 1), dtype=np.int64)
    occupied = 0
    if height <= 0 or width <= 0:  # a window past the grid's edge: no tile to look up
        return squared, near_iy, near_ix, occupied
    gy0, gx0 = y0 + shift_y, x0 + shift_x
    # Row by row, the window's tiles along each: the occupied cells in row order, as the discs' ties need
    for gy in range(gy0, gy0 + height):
        row = gy - gy0
        for tx in range(gx0 // TILE, (gx0 + width - 1) // TILE + 1):
            slot = table[gy // TILE, tx]
            if hit_table[gy // TILE, tx] < 0 or slot < 0:
                continue
            for gx in range(max(tx * TILE, gx0), min(tx * TILE + TILE, gx0 + width)):
                if not logodds[slot, gy % TILE, gx % TILE] > 0.0:
                    continue
                occupied += 1
                col = gx - gx0
                mask = 0
                for b in range(_NEIGHBOURS.shape[0]):
                    r, c = row + _NEIGHBOURS[b, 0], col + _NEIGHBOURS[b, 1]
                    if 0 <= r < height and 0 <= c < width and _tile_value(table, logodds, gy0 + r, gx0 + c) > 0.0:
                        mask |= 1 << b
                if not ready[mask]:
                    ready[mask] = True
                    for dr in range(-reach, reach + 1):
                        lo, hi = -spans[abs(dr)], spans[abs(dr)]
                        for b in range(_NEIGHBOURS.shape[0]):
                            if not mask & (1 << b):
                                continue
                            ny, nx = _NEIGHBOURS[b, 0], _NEIGHBOURS[b, 1]
                            # the cell keeps the dc with 2 dc nx <= bound
                            bound = ny * ny + nx * nx - (1 if b < 4 else 0) - 2 * dr * ny
                            if nx > 0:
                                hi = min(hi, bound // 2)
                            elif nx < 0:
                                lo = max(lo, -(bound // 2))
                            elif bound < 0:
                                hi = lo - 1
                        low[mask, dr + reach], high[mask, dr + reach] = lo, hi
                for r in range(max(row - reach, 0), min(row + reach, height - 1) + 1):
                    k = r - row + reach
                    for c in range(max(col + low[mask, k], 0), min(col + high[mask, k], width - 1) + 1):
                        d = (r - row) ** 2 + (c - col) ** 2
                        if d < squared[r + pad, c + pad]:
                            squared[r + pad, c + pad] = d
                            near_iy[r + pad, c + pad] = row + y0
                            near_ix[r + pad, c + pad] = col + x0
    return squared, near_iy, near_ix, occupied


@numba.njit(  # type: ignore[misc]
    "Tuple((float64[::1], float64[::1], int32[:, ::1]))(int32[:, ::1], float64[::1], float64, float64, int64)",
    cache=True,
)
def _likelihoods(
    squared: CellArray, distance_table: FloatArray, sigma: float, sigma_coarse: float, half: int
) -> tuple[FloatArray, FloatArray, CellArray]:
    """The likelihoods ``exp(-d^2 / (2 sigma^2))`` of the distances ``distance_table`` (m), and the coarse ones
    (``sigma_coarse``), by squared cell distance; and the squared distances ``squared`` min-pooled over
    ``2 half + 1`` cells square (edge cells repeated beyond the edge). The likelihood falls as the distance
    grows, so the coarse likelihood of the pooled distances is the coarse likelihood max-pooled.

    Why tables and not likelihood arrays over the window: the search reads a few cells per point, and writing two
    float arrays of the window took half as long again as the pooling (0.18 ms against 0.36 ms on the Intel log's
    windows of about 65 000 cells; the Freiburg campus log's are a million cells or more)."""
    fine_table = np.exp(-(distance_table**2) / (2.0 * sigma**2))
    wide_table = np.exp(-(distance_table**2) / (2.0 * sigma_coarse**2))
    height, width = squared.shape
    # Pooled separably, each as the minimum with shifted copies: loops along rows that the compiler vectorises (a
    # window's pooling took four times as long cell by cell). Down the columns first, each row the minimum of the
    # rows of its run begun from the run's first (not from a copy of itself, which the run holds again), then
    # along the rows: a fifth to a quarter less time than along the rows first (0.22 against 0.17 ms on the
    # Freiburg 079 log's windows, 1.47 against 1.16 ms on the campus's).
    down = np.empty((height, width), dtype=np.int32)
    for row in range(height):
        first, last = max(row - half, 0), min(row + half, height - 1)
        for col in range(width):  # a loop: a slice assignment took up to a third longer
            down[row, col] = squared[first, col]
        for r in range(first + 1, last + 1):
            for col in range(width):
                down[row, col] = min(down[row, col], squared[r, col])
    pooled = down.copy()
    for row in range(height):
        for shift in range(1, half + 1):
            for col in range(shift, width):
                pooled[row, col] = min(pooled[row, col], down[row, col - shift])
            for col in range(width - shift):
                pooled[row, col] = min(pooled[row, col], down[row, col + shift])
    return fine_table, wide_table, pooled
