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
_I1 = nt.Array(_I, 1, "C")
_B2 = nt.Array(nt.boolean, 2, "C")
_FIELD = nt.Tuple((_F1, _I1))  # type: ignore[no-untyped-call]
_HEAP = nt.Tuple((_F1, _I1, _I))  # type: ignore[no-untyped-call]
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


@numba.njit(_HEAP(_F1, _I1, _I, _F, _I), cache=True)
def _push(keys: FloatArray, items: IntArray, n: int, key: float, item: int) -> tuple[FloatArray, IntArray, int]:
    """Push onto the binary min-heap ``keys[:n]`` / ``items[:n]`` (grown by doubling); the arrays and new size."""
    if n == len(keys):
        keys = np.concatenate((keys, np.empty(n)))
        items = np.concatenate((items, np.empty(n, dtype=np.intp)))
    i = n
    while i > 0:
        up = (i - 1) // 2
        if keys[up] <= key:
            break
        keys[i], items[i] = keys[up], items[up]
        i = up
    keys[i], items[i] = key, item
    return keys, items, n + 1


@numba.njit(_I(_F1, _I1, _I), cache=True)
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


@numba.njit(_FIELD(_B2, _I1, _I, _F32_2), cache=True)
def goal_search(free: BoolArray, seeds: IntArray, start: int, landmarks: Float32Array) -> tuple[FloatArray, IntArray]:
    """Distances (coarse cells) to the nearest of ``seeds`` (flat indices of free cells) and the next cell towards
    it, over the free cells of ``free``, settled until ``start`` (flat index; -1: every reachable cell) is.
    ``landmarks`` ``(K, cells)``: distances from K cells (inf where unreachable), which tighten the heuristic in
    a building (K may be 0).

    Returns ``(distance, towards)`` flat: ``inf`` / -1 for cells not settled; ``towards`` is -1 at the seeds.
    """
    rows, cols = free.shape
    n = rows * cols
    dist = np.full(n, np.inf)
    towards = np.full(n, -1, dtype=np.intp)
    done = np.zeros(n, dtype=np.bool_)
    sr, sc = (start // cols, start % cols) if start >= 0 else (0, 0)
    keys, items, size = np.empty(256), np.empty(256, dtype=np.intp), 0
    for seed in seeds:
        dist[seed] = 0.0
        keys, items, size = _push(keys, items, size, _lower_bound(seed, cols, start, sr, sc, landmarks), seed)
    while size > 0:
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
                h = _lower_bound(nxt, cols, start, sr, sc, landmarks)
                keys, items, size = _push(keys, items, size, g + h, nxt)
    dist[~done] = np.inf
    towards[~done] = -1
    return dist, towards


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
