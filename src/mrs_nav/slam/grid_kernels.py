"""Compiled kernels of the tiled log-odds grid (:mod:`mrs_nav.slam.grid`, whose docstring describes the tiles), and
the types in which compiled code takes a grid.

Why a module of their own: the grid's bookkeeping (growth, tile pools, which tiles are out of date) is Python,
these are the per-cell loops numba compiles (:mod:`mrs_nav.jit`): ray casting into tiles, the lazy redraw, and
reading tiles back as dense windows or an occupancy image.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar

import numba
import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray

IntArray = npt.NDArray[np.int64]
Float32Array = npt.NDArray[np.float32]
TileTable = npt.NDArray[np.int32]
TILE = 8  # cells a tile side: 0.4 m at 5 cm, so that the hit tiles along a wall hold little besides it
# (the kernels of mrs_nav.slam.grid_kernels and mrs_nav.slam.matcher_kernels compile TILE and _tile_value in, and
# numba's cache of a module's kernels does not see a change in another: after changing them, delete the cached
# kernels, mrs_nav/slam/__pycache__/*.nbi and *.nbc.)
# A grid's cells (LogOddsGrid.cells): height, width, and the shift of cell (0, 0) into its tile, rows and columns.
GridCells = tuple[int, int, int, int]
# A grid as compiled kernels take it (LogOddsGrid.kernel_args): the log-odds tile table and pool, the hit tile
# table, the pools of hit offset sums in x and in y and of hit counts, its cells, origin x, origin y and
# resolution (m); and that as a numba type.
GridArrays = tuple[
    TileTable, Float32Array, TileTable, Float32Array, Float32Array, Float32Array, GridCells, float, float, float
]
_POOL = "float32[:, :, ::1]"
GRID_ARRAYS_TYPE = (
    f"Tuple((int32[:, ::1], {_POOL}, int32[:, ::1], {_POOL}, {_POOL}, {_POOL}, UniTuple(int64, 4), "
    "float64, float64, float64))"
)


_TILED = "int32[:, ::1], float32[:, :, ::1], UniTuple(int64, 4)"  # a tile table, its pool, the grid's cells


# The tile arithmetic of one cell, once, for the kernels here and in mrs_nav.slam.matcher_kernels: ``(gy, gx)`` is a
# cell shifted into the tiles, ``(iy + shift_y, ix + shift_x)`` (mrs_nav.slam.grid's docstring).
_Helper = TypeVar("_Helper", bound=Callable[..., Any])


def _cell_helper(signature: str) -> Callable[[_Helper], _Helper]:
    """``numba.njit(signature, cache=True)`` without numba's reference counting (``_nrt=False``), for the small
    helpers below: they only index arrays their caller holds, and so LLVM inlines them into the kernels' loops,
    where they cost nothing. Why: with it, every call counts references to each array it is given, counts that
    numba cannot drop around the helpers' branches; on synthetic scans redraw then took 1.7-2 times as long as
    with the blocks written out (inlined as numba IR, ``inline="always"``, or by LLVM, ``forceinline=True``),
    integrate 1.15-1.3 times. (numba's type stubs do not list ``_nrt``.)"""
    compile_: Callable[[_Helper], _Helper] = numba.njit(signature, _nrt=False, cache=True)  # type: ignore[call-overload]
    return compile_


@_cell_helper("float32(int32[:, ::1], float32[:, :, ::1], int64, int64)")
def _tile_value(table: TileTable, pool: Float32Array, gy: int, gx: int) -> np.float32:
    """Cell ``(gy, gx)`` of a tiled array; 0 in a tile not allocated (an unknown cell: no log-odds, no hits)."""
    slot = table[gy // TILE, gx // TILE]
    return pool[slot, gy % TILE, gx % TILE] if slot >= 0 else np.float32(0.0)


@_cell_helper("int64(int32[:, ::1], int64[::1], int64, int64, int64)")
def _taken_slot(table: TileTable, tiles: IntArray, kind: int, gy: int, gx: int) -> int:
    """The pool slot of the tile of cell ``(gy, gx)`` in ``table``; where the tile has none, the next spare one,
    counting ``tiles[kind]`` (0 log-odds, 1 hits) up: the caller made room (LogOddsGrid._reserve)."""
    ty, tx = gy // TILE, gx // TILE
    slot: int = table[ty, tx]
    if slot < 0:
        slot = tiles[kind]
        tiles[kind] += 1
        table[ty, tx] = slot
    return slot


@_cell_helper("void(" + GRID_ARRAYS_TYPE + ", int64[::1], float64, float64, int64, int64)")
def _add_hit(  # noqa: PLR0917 - numba kernels take positional arguments
    grid: GridArrays, tiles: IntArray, ex: float, ey: float, iy: int, ix: int
) -> None:
    """An end point ``(ex, ey)`` (m) added to the hit sums and count of its cell ``(iy, ix)`` (inside the grid),
    for :func:`_integrate` and :func:`_redraw` alike, so that a redrawn tile holds what integrating put there."""
    _, _, hit_table, hit_x, hit_y, hit_count, cells, origin_x, origin_y, res = grid
    gy, gx = iy + cells[2], ix + cells[3]
    slot = _taken_slot(hit_table, tiles, 1, gy, gx)
    hit_x[slot, gy % TILE, gx % TILE] += ex - (origin_x + ix * res)
    hit_y[slot, gy % TILE, gx % TILE] += ey - (origin_y + iy * res)
    hit_count[slot, gy % TILE, gx % TILE] += 1.0


@_cell_helper("void(float32[:, :, ::1], int64, int64, int64, float32, float32)")
def _add_clamped(  # noqa: PLR0917 - numba kernels take positional arguments
    logodds: Float32Array, slot: int, gy: int, gx: int, change: float, lmax: float
) -> None:
    """``change`` (loccupied, or minus lfree: float32, as the grid's own arithmetic rounds) added to the log-odds
    of cell ``(gy, gx)`` in pool slot ``slot``, clamped to ``[-lmax, lmax]``; one arithmetic for
    :func:`_integrate` and :func:`_redraw`, so that both give a cell the same value to the bit."""
    cell = logodds[slot, gy % TILE, gx % TILE] + change
    logodds[slot, gy % TILE, gx % TILE] = min(max(cell, -lmax), lmax)


@_cell_helper("void(UniTuple(float64, 5), float64, float64, int64, int64, int64[::1], int64[::1])")
def _sample_cells(  # noqa: PLR0917 - numba kernels take positional arguments
    frame: tuple[float, float, float, float, float],
    cos: float,
    sin: float,
    first: int,
    last: int,
    cell_x: IntArray,
    cell_y: IntArray,
) -> None:
    """The cells ``(ix, iy)`` of a beam's samples ``first`` to ``last`` - 1, half a cell apart from the sensor in
    the direction ``(cos, sin)``, into the first entries of ``cell_x`` and ``cell_y``; ``frame``: the sensor's
    x and y, the grid's origin x and y, and its resolution (m). One arithmetic for :func:`_integrate` and
    :func:`_redraw`, so that both sample a beam alike.

    Why the cells first and the marks after, not each sample marked as it is taken: this loop stores nothing
    but its results, so the compiler vectorises it, divisions and all. With it (and a cell's second sample
    skipped) integrate took 0.28 instead of 0.50 ms a scan on the Freiburg 079 log, 1.5 instead of 2.5 ms on the
    Freiburg campus log (scans taken from their replays, the same grids after)."""
    sx, sy, origin_x, origin_y, res = frame
    step = 0.5 * res
    for k in range(first, last):
        t = k * step
        cell_x[k - first] = math.floor((sx + t * cos - origin_x) / res)
        cell_y[k - first] = math.floor((sy + t * sin - origin_y) / res)


@numba.njit("float32[::1](" + _TILED + ", int64[::1], int64[::1])", cache=True)  # type: ignore[misc]
def _cells(table: TileTable, pool: Float32Array, cells: GridCells, iy: IntArray, ix: IntArray) -> Float32Array:
    """Values of cells ``(iy, ix)`` of a tiled array; 0 outside the grid and in tiles not allocated."""
    height, width, shift_y, shift_x = cells
    out = np.zeros(iy.size, dtype=np.float32)
    for k in range(iy.size):
        if 0 <= iy[k] < height and 0 <= ix[k] < width:
            out[k] = _tile_value(table, pool, iy[k] + shift_y, ix[k] + shift_x)
    return out


@numba.njit("float32[:, ::1](" + _TILED + ", UniTuple(int64, 2), UniTuple(int64, 2))", cache=True)  # type: ignore[misc]
def _window(
    table: TileTable, pool: Float32Array, cells: GridCells, rows: tuple[int, int], cols: tuple[int, int]
) -> Float32Array:
    """Cells ``[y0, y1) x [x0, x1)`` (``rows``, ``cols``; inside the grid) of a tiled array, densely; 0 in tiles
    not allocated."""
    _, _, shift_y, shift_x = cells
    (y0, y1), (x0, x1) = rows, cols
    out = np.zeros((max(y1 - y0, 0), max(x1 - x0, 0)), dtype=np.float32)
    for iy in range(y0, y1):
        for ix in range(x0, x1):
            out[iy - y0, ix - x0] = _tile_value(table, pool, iy + shift_y, ix + shift_x)
    return out


@numba.njit("int8[:, ::1](" + _TILED + ", float64, float64)", cache=True)  # type: ignore[misc]
def _occupancy(
    table: TileTable, pool: Float32Array, cells: GridCells, occupied: float, free: float
) -> npt.NDArray[np.int8]:
    """LogOddsGrid.to_occupancy: 100 at log-odds >= ``occupied``, 0 below ``free``, -1 else and where unseen;
    tile by tile, so that only the map's 1 byte a cell is allocated."""
    height, width, shift_y, shift_x = cells
    out = np.full((height, width), -1, dtype=np.int8)
    for ty in range(table.shape[0]):
        for tx in range(table.shape[1]):
            slot = table[ty, tx]
            if slot < 0:
                continue
            for row in range(TILE):
                iy = ty * TILE + row - shift_y
                for col in range(TILE):
                    ix = tx * TILE + col - shift_x
                    if 0 <= iy < height and 0 <= ix < width:
                        value = pool[slot, row, col]
                        if value >= occupied:
                            out[iy, ix] = 100
                        elif value < free:
                            out[iy, ix] = 0
    return out


_FREE, _HIT = 1, 2  # what one scan says of a cell


@numba.njit(  # type: ignore[misc]
    "void("
    + GRID_ARRAYS_TYPE
    + ", int64[::1], UniTuple(float64, 2), float64[::1], float64[::1], float64[::1], int64, float32[::1])",
    cache=True,
)
def _integrate(  # noqa: PLR0917 - numba kernels take positional arguments
    grid: GridArrays,
    tiles: IntArray,
    sensor: tuple[float, float],
    cos: FloatArray,
    sin: FloatArray,
    ranges: FloatArray,
    n_hit: int,
    update: npt.NDArray[np.float32],
) -> None:
    """LogOddsGrid.integrate's ray casting: beams from ``sensor`` (m) in directions ``(cos, sin)`` of length
    ``ranges`` (m), the first ``n_hit`` ending on an obstacle; ``update``: lfree, loccupied, lmax. New tiles are
    taken from the pools' spare slots, counting ``tiles`` (log-odds, hits) up: the caller made room."""
    table, logodds, _, _, _, _, cells, origin_x, origin_y, res = grid
    height, width, shift_y, shift_x = cells
    sx, sy = sensor
    lfree, loccupied, lmax = update[0], update[1], update[2]
    # Every sample lies between the sensor and a beam's end: their bounding box, clipped to the grid, holds
    # all the cells this scan marks, so marking costs O(that window), not O(map).
    x_lo = x_hi = math.floor((sx - origin_x) / res)
    y_lo = y_hi = math.floor((sy - origin_y) / res)
    step = 0.5 * res
    most = 0  # samples of a beam at most (below)
    for b in range(ranges.size):
        ix = math.floor((sx + ranges[b] * cos[b] - origin_x) / res)
        iy = math.floor((sy + ranges[b] * sin[b] - origin_y) / res)
        x_lo, x_hi, y_lo, y_hi = min(x_lo, ix), max(x_hi, ix), min(y_lo, iy), max(y_hi, iy)
        most = max(most, math.ceil(ranges[b] / step))
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
            _add_hit(grid, tiles, ex, ey, iy, ix)
            mark[iy - y_lo, ix - x_lo] = _HIT
    # Every beam sampled at half a cell up to half a cell before its end, so no crossed cell is skipped on
    # axis-aligned beams and the end cell is left to the occupied update.
    frame = (sx, sy, origin_x, origin_y, res)
    cell_x = np.empty(most, dtype=np.int64)
    cell_y = np.empty(most, dtype=np.int64)
    for b in range(ranges.size):
        length = ranges[b] - 0.5 * res if b < n_hit else ranges[b]
        samples = max(math.ceil(length / step), 0)
        _sample_cells(frame, cos[b], sin[b], 0, samples, cell_x, cell_y)
        last_ix = last_iy = -1
        for k in range(samples):
            ix, iy = cell_x[k], cell_y[k]
            if ix == last_ix and iy == last_iy:  # half-cell steps: most cells take two samples
                continue
            last_ix, last_iy = ix, iy
            if 0 <= ix < width and 0 <= iy < height and mark[iy - y_lo, ix - x_lo] == 0:
                mark[iy - y_lo, ix - x_lo] = _FREE
    # Each marked cell updated once, however many beams crossed it.
    for row in range(mark.shape[0]):
        gy = y_lo + row + shift_y
        for col in range(mark.shape[1]):
            if mark[row, col] == 0:
                continue
            gx = x_lo + col + shift_x
            slot = _taken_slot(table, tiles, 0, gy, gx)
            _add_clamped(logodds, slot, gy, gx, -lfree if mark[row, col] == _FREE else loccupied, lmax)


@_cell_helper(
    "void(int32[:, ::1], float32[:, :, ::1], int64[::1], int32[::1], uint64[::1], int64, int64, int64, float32, "
    "float32)"
)
def _update_once(  # noqa: PLR0917 - numba kernels take positional arguments
    table: TileTable,
    logodds: Float32Array,
    tiles: IntArray,
    marked_by: npt.NDArray[np.int32],
    marks: npt.NDArray[np.uint64],
    number: int,
    gy: int,
    gx: int,
    change: float,
    lmax: float,
) -> None:
    """:func:`_redraw`'s update of cell ``(gy, gx)`` by scan ``number``, for end points and crossed cells alike:
    the tile's log-odds slot taken (a spare one if it has none), then, if the scan has not marked the cell yet
    (``marked_by``, ``marks``: _redraw), the cell marked and ``change`` added (:func:`_add_clamped`)."""
    slot = _taken_slot(table, tiles, 0, gy, gx)
    if marked_by[slot] != number:
        marked_by[slot], marks[slot] = number, 0
    bit = np.uint64(1) << np.uint64(gy % TILE * TILE + gx % TILE)
    if marks[slot] & bit == 0:
        marks[slot] |= bit
        _add_clamped(logodds, slot, gy, gx, change, lmax)


@numba.njit(  # type: ignore[misc]
    "void("
    + GRID_ARRAYS_TYPE
    + ", int64[::1], boolean[:, ::1], float64[:, ::1], int32[::1], uint64[::1], int64, float64[:, ::1], float64[::1],"
    " float64[::1], float64[::1], int64[::1], int64[::1], float32[::1])",
    cache=True,
)
def _redraw(  # noqa: PLR0917 - numba kernels take positional arguments
    grid: GridArrays,
    tiles: IntArray,
    target: npt.NDArray[np.bool_],
    boxes: FloatArray,
    marked_by: npt.NDArray[np.int32],
    marks: npt.NDArray[np.uint64],
    first: int,
    sensors: FloatArray,
    cos: FloatArray,
    sin: FloatArray,
    ranges: FloatArray,
    starts: IntArray,
    n_hits: IntArray,
    update: npt.NDArray[np.float32],
) -> None:
    """LogOddsGrid.redraw: :func:`_integrate` of scan ``s`` (from ``sensors[s]``, beams ``starts[s]`` to
    ``starts[s + 1]``, the first ``n_hits[s]`` ending on an obstacle) for each scan in order, into the
    ``target`` tiles only, which lie in the boxes ``boxes`` (m: x0, y0, x1, y1, LogOddsGrid.tiles_box). Each
    beam is sampled only over the parts of it that can cross ``boxes``: the same samples as _integrate takes
    there, so those tiles get the same values.

    Instead of _integrate's marks over the scan's whole window, per log-odds pool slot ``marked_by`` holds the
    number of the last scan that updated a cell of the tile (``first`` + 1 for the first scan here; earlier
    calls of one redraw numbered those before) and ``marks`` which cells it updated, a bit each: a cell is
    updated when a scan first marks it, end points first, so once per scan, occupied where the scan holds an end
    point, else free."""
    table, logodds, _, _, _, _, cells, origin_x, origin_y, res = grid
    height, width, shift_y, shift_x = cells
    lfree, loccupied, lmax = update[0], update[1], update[2]
    step = 0.5 * res
    most = 0  # samples of a beam at most (_sample_cells)
    for b in range(ranges.size):
        most = max(most, math.ceil(ranges[b] / step))
    cell_x = np.empty(most, dtype=np.int64)
    cell_y = np.empty(most, dtype=np.int64)
    for s in range(starts.size - 1):
        number = first + s + 1
        sx, sy = sensors[s, 0], sensors[s, 1]
        frame = (sx, sy, origin_x, origin_y, res)
        for b in range(starts[s], starts[s] + n_hits[s]):  # end points, as _integrate marks them
            ex = sx + ranges[b] * cos[b]
            ey = sy + ranges[b] * sin[b]
            ix = math.floor((ex - origin_x) / res)
            iy = math.floor((ey - origin_y) / res)
            if not (0 <= ix < width and 0 <= iy < height):
                continue
            gy, gx = iy + shift_y, ix + shift_x
            if not target[gy // TILE, gx // TILE]:
                continue
            _add_hit(grid, tiles, ex, ey, iy, ix)
            _update_once(table, logodds, tiles, marked_by, marks, number, gy, gx, loccupied, lmax)
        for b in range(starts[s], starts[s + 1]):
            length = ranges[b] - 0.5 * res if b - starts[s] < n_hits[s] else ranges[b]
            samples = max(math.ceil(length / step), 0)
            for r in range(boxes.shape[0]):
                # The samples whose distance along the beam lies where it crosses the rectangle, and one more
                # each side: the cell test below decides, as in _integrate.
                t_lo, t_hi = 0.0, samples * step
                for start, direction, lo, hi in (
                    (sx, cos[b], boxes[r, 0], boxes[r, 2]),
                    (sy, sin[b], boxes[r, 1], boxes[r, 3]),
                ):
                    if direction == 0.0:
                        if not lo <= start <= hi:
                            t_hi = -1.0
                    else:
                        t_a, t_b = (lo - start) / direction, (hi - start) / direction
                        t_lo, t_hi = max(t_lo, min(t_a, t_b)), min(t_hi, max(t_a, t_b))
                if t_hi < t_lo:
                    continue
                k_lo, k_hi = max(math.floor(t_lo / step) - 1, 0), min(math.ceil(t_hi / step) + 2, samples)
                _sample_cells(frame, cos[b], sin[b], k_lo, k_hi, cell_x, cell_y)
                last_ix = last_iy = -1
                for k in range(k_hi - k_lo):
                    ix, iy = cell_x[k], cell_y[k]
                    if ix == last_ix and iy == last_iy:  # half-cell steps: most cells take two samples
                        continue
                    last_ix, last_iy = ix, iy
                    if not (0 <= ix < width and 0 <= iy < height):
                        continue
                    gy, gx = iy + shift_y, ix + shift_x
                    if not target[gy // TILE, gx // TILE]:
                        continue
                    _update_once(table, logodds, tiles, marked_by, marks, number, gy, gx, -lfree, lmax)
