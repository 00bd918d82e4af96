"""Compiled search of the wavefront's coarse grid: A* from the goal towards one start, over the implicit graph.

A planner needs the goal distance only near the way from its start, not over the whole map: a Dijkstra run over a
100 m building's 250,000 coarse cells was 75 % of a first path (issue 42). This search grows from the goal like
Dijkstra but orders its cells by ``g + h``, ``g`` the distance to the goal so far and ``h`` the octile distance
to the start (a consistent heuristic on this graph: each step is at least as long as the change in ``h``, and the
corner rule only removes steps). It ends when the start is settled, so it settles only cells with ``g + h`` at
most the start's distance (the band round the shortest ways) and every settled distance is exact; cells left
unsettled read ``inf``. The graph is the one of :mod:`mrs_nav.maps.wavefront` (8-connected free cells, a
diagonal needs both cells of the corner free), walked on the mask itself, so no edge list is built per map.

On a large map the octile distance underestimates a building's detours badly and the band is a third of the map;
distances from a few landmark cells, computed once per map, raise the bound by the triangle inequality (ALT:
Goldberg & Harrelson 2005, "Computing the shortest path: A* search meets graph theory") and narrow the band.
"""

# ruff: noqa: PLR0917

from __future__ import annotations

import math

import numba
import numpy as np
import numpy.typing as npt
from numba import types as nt

from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import BoolArray, IntArray

_F = nt.float64
_I = nt.intp
_F1 = nt.Array(_F, 1, "C")
_F2 = nt.Array(_F, 2, "C")
_I1 = nt.Array(_I, 1, "C")
_B1 = nt.Array(nt.boolean, 1, "C")
_B2 = nt.Array(nt.boolean, 2, "C")
_FIELD = nt.Tuple((_F1, _I1))  # type: ignore[no-untyped-call]
_F32_2 = nt.Array(nt.float32, 2, "C")

Float32Array = npt.NDArray[np.float32]

_SQRT2 = math.sqrt(2.0)
# Landmark distances are kept in float32 (half the memory); a bound lowered by this many cells stays below the
# true distance whatever their rounding (float32 keeps about 7 digits: 1e-3 cells at 10,000 cells).
_LANDMARK_MARGIN = 2e-3


@numba.njit(_F(_I, _I, _I, _I), cache=True)
def _octile(r0: int, c0: int, r1: int, c1: int) -> float:
    dr, dc = abs(r0 - r1), abs(c0 - c1)
    return max(dr, dc) + (_SQRT2 - 1.0) * min(dr, dc)


@numba.njit(nt.void(_F1, _I1, _I, _F, _I), cache=True, inline="always")
def _push(keys: FloatArray, items: IntArray, n: int, key: float, item: int) -> None:
    """Push onto the binary min-heap ``keys[:n]`` / ``items[:n]``, which has room for one more."""
    i = n
    while i > 0:
        up = (i - 1) // 2
        if keys[up] <= key:
            break
        keys[i], items[i] = keys[up], items[up]
        i = up
    keys[i], items[i] = key, item


@numba.njit(_I(_F1, _I1, _I), cache=True, inline="always")
def _pop(keys: FloatArray, items: IntArray, n: int) -> int:
    """Remove the least key of the heap of size ``n`` (> 0); return its item (the heap has ``n - 1`` left)."""
    top: int = items[0]
    n -= 1
    key, item = keys[n], items[n]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= n:
            break
        if child + 1 < n and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[i], items[i] = keys[child], items[child]
        i = child
    if n > 0:
        keys[i], items[i] = key, item
    return top


@numba.njit(_F(_I, _I, _I, _I, _I, _F32_2), cache=True)
def _lower_bound(cell: int, cols: int, start: int, sr: int, sc: int, landmarks: Float32Array) -> float:
    """A lower bound on the distance (cells) from ``cell`` to ``start``: the octile distance, raised by each
    landmark's triangle inequality ``|d(L, cell) - d(L, start)|`` (less a margin for the float32 rounding)."""
    if start < 0:
        return 0.0
    h = _octile(cell // cols, cell % cols, sr, sc)
    for k in range(landmarks.shape[0]):
        a, b = landmarks[k, cell], landmarks[k, start]
        if math.isfinite(a) and math.isfinite(b):
            h = max(h, abs(a - b) - _LANDMARK_MARGIN)
    return h


@numba.njit(_I(_B2, _F1, _I1, _B1, _F1, _I1, _I, _I, _F32_2), cache=True)
def _settle(
    free: BoolArray,
    dist: FloatArray,
    towards: IntArray,
    done: BoolArray,
    keys: FloatArray,
    items: IntArray,
    size: int,
    start: int,
    landmarks: Float32Array,
) -> int:
    """A* of :func:`goal_search` on its state, until ``start`` is settled or no cell is left (-1), or until the heap
    might not hold one more cell's pushes (its size: grow it and call again)."""
    rows, cols = free.shape
    sr, sc = (start // cols, start % cols) if start >= 0 else (0, 0)
    while size > 0:
        if size + 8 > len(keys):
            return size
        cell = _pop(keys, items, size)
        size -= 1
        if done[cell]:
            continue
        done[cell] = True
        if cell == start:
            break
        r, c = cell // cols, cell % cols
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                rr, cc = r + dr, c + dc
                if (dr == 0 and dc == 0) or rr < 0 or rr >= rows or cc < 0 or cc >= cols or not free[rr, cc]:
                    continue
                if dr != 0 and dc != 0 and not (free[r, cc] and free[rr, c]):
                    continue
                nxt = rr * cols + cc
                g = dist[cell] + (_SQRT2 if dr != 0 and dc != 0 else 1.0)
                if done[nxt] or g >= dist[nxt]:
                    continue
                dist[nxt] = g
                towards[nxt] = cell
                _push(keys, items, size, g + _lower_bound(nxt, cols, start, sr, sc, landmarks), nxt)
                size += 1
    return -1


@numba.njit(_FIELD(_B2, _I1, _I, _F32_2), cache=True)
def goal_search(free: BoolArray, seeds: IntArray, start: int, landmarks: Float32Array) -> tuple[FloatArray, IntArray]:
    """Distances (coarse cells) to the nearest of ``seeds`` (flat indices of free cells) and the next cell towards
    it, over the free cells of ``free``, settled until ``start`` (flat index; -1: every reachable cell) is.
    ``landmarks`` ``(K, cells)``: distances from K cells (inf where unreachable), which tighten the heuristic in
    a building (K may be 0).

    Returns ``(distance, towards)`` flat: ``inf`` / -1 for cells not settled; ``towards`` is -1 at the seeds.
    """
    n = free.size
    dist = np.full(n, np.inf)
    towards = np.full(n, -1, dtype=np.intp)
    done = np.zeros(n, dtype=np.bool_)
    keys, items, size = np.empty(256 + len(seeds)), np.empty(256 + len(seeds), dtype=np.intp), 0
    sr, sc = (start // free.shape[1], start % free.shape[1]) if start >= 0 else (0, 0)
    for seed in seeds:
        dist[seed] = 0.0
        _push(keys, items, size, _lower_bound(seed, free.shape[1], start, sr, sc, landmarks), seed)
        size += 1
    # The heap grows here, between calls: arrays replaced inside the search loop made it several times slower.
    while True:
        size = _settle(free, dist, towards, done, keys, items, size, start, landmarks)
        if size < 0:
            break
        keys = np.concatenate((keys, np.empty(len(keys))))
        items = np.concatenate((items, np.empty(len(items), dtype=np.intp)))
    dist[~done] = np.inf
    towards[~done] = -1
    return dist, towards


@numba.njit(_F2(_I1, _I, _I, _F, _F, _F, _F, _F, _F, _F, _F, _F), cache=True)
def corridor_points(
    towards: IntArray,
    cell: int,
    cols: int,
    size: float,
    x0: float,
    y0: float,
    c: float,
    s: float,
    sx: float,
    sy: float,
    gx: float,
    gy: float,
) -> FloatArray:
    """``(K, 2)``: the start ``(sx, sy)``, the centres (m) of the coarse cells after ``cell`` along ``towards`` (each
    cell's next one, -1 at the end) but the last, and the goal ``(gx, gy)``; cells of ``size`` metres in rows of
    ``cols``, on a grid with origin ``(x0, y0)`` and yaw of cosine ``c`` and sine ``s``."""
    count, at = 0, cell
    while at >= 0:
        count += 1
        at = towards[at]
    out = np.empty((max(count, 2), 2))
    out[0] = sx, sy
    at = towards[cell]
    for i in range(1, count - 1):
        u, v = (at % cols + 0.5) * size, (at // cols + 0.5) * size
        out[i] = x0 + c * u - s * v, y0 + s * u + c * v
        at = towards[at]
    out[-1] = gx, gy
    return out


@numba.njit(_F32_2(_B2, _I), cache=True)
def landmark_fields(free: BoolArray, count: int) -> Float32Array:
    """Distances (cells, float32) from ``count`` landmarks over ``free``: the first free cell, then each time the
    cell farthest (least distance to the landmarks so far, largest) from those chosen, which puts them at the
    map's extremes where their triangle bounds are tightest. No free cell: no landmark."""
    cells = free.size
    out = np.full((count, cells), np.inf, dtype=np.float32)
    flat = free.ravel()
    nearest = np.full(cells, np.inf)
    pick = -1
    for i in range(cells):
        if flat[i]:
            pick = i
            break
    none = np.zeros((0, cells), dtype=np.float32)
    for k in range(count):
        if pick < 0:
            return out[:k].copy()
        dist, _ = goal_search(free, np.array([pick], dtype=np.intp), -1, none)
        out[k] = dist.astype(np.float32)
        pick, best = -1, 0.0
        for i in range(cells):
            nearest[i] = min(nearest[i], dist[i])
            if math.isfinite(nearest[i]) and nearest[i] > best:
                pick, best = i, nearest[i]
    return out
