"""A wavefront navigation function on an occupancy grid: the geodesic distance to a goal through free cells.

The grid is coarsened by an integer ``factor`` (blocks of ``factor x factor`` cells; a coarse cell is free when
*all* its cells are free, or, in the optimistic variant, when *any* is) and searched by Dijkstra over 8-connected
free coarse cells (steps of one cell or one diagonal; a diagonal step needs both cells of the corner it cuts
free). The distance has no local minimum other than the goal, so following it downhill from any cell that
reaches the goal ends at the goal: the tree planners sample along that corridor, and the potential field falls
back to it when its own field traps the robot.

The coarse grid and its graph depend only on the grid, so they are built once per grid (and variant) and kept
while the grid lives; one query is then one Dijkstra run in compiled code (scipy.sparse.csgraph).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from mrs_nav.errors import NoPathFoundError
from mrs_nav.geometry import FloatArray, format_point
from mrs_nav.maps.occupancy_grid import BoolArray, IntArray, OccupancyGrid

# Neighbour steps (rows, cols) and their lengths in coarse cells; the other half are the reverses.
_STEPS = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2.0)), (1, -1, math.sqrt(2.0)))


@dataclass(frozen=True, eq=False)
class _Coarse:
    """A coarse free mask ``(H, W)`` and its cell graph (CSR, edge weights in coarse cells)."""

    free: BoolArray
    graph: csr_matrix


_CACHE: weakref.WeakKeyDictionary[OccupancyGrid, dict[tuple[int, bool], _Coarse]] = weakref.WeakKeyDictionary()


def coarse_free(grid: OccupancyGrid, factor: int, optimistic: bool = False) -> BoolArray:
    """``(ceil(h / factor), ceil(w / factor))``: blocks whose cells are all (``optimistic``: any) free."""
    rows, cols = -(-grid.height // factor), -(-grid.width // factor)
    # Padding beyond the border takes the value that leaves each test to the block's real cells.
    padded = np.full((rows * factor, cols * factor), not optimistic)
    padded[: grid.height, : grid.width] = grid.free_mask
    blocks = padded.reshape(rows, factor, cols, factor)
    out: BoolArray = blocks.any(axis=(1, 3)) if optimistic else blocks.all(axis=(1, 3))
    return out


def _graph(free: BoolArray) -> csr_matrix:
    rows, cols = free.shape
    index = np.arange(rows * cols).reshape(rows, cols)
    src, dst, weight = [], [], []
    for dr, dc, length in _STEPS:
        r0, r1 = 0, rows - dr
        c0, c1 = max(0, -dc), cols - max(0, dc)
        a = (slice(r0, r1), slice(c0, c1))
        b = (slice(r0 + dr, r1 + dr), slice(c0 + dc, c1 + dc))
        ok = free[a] & free[b]
        if dr and dc:
            ok &= free[r0 + dr : r1 + dr, c0:c1] & free[r0:r1, c0 + dc : c1 + dc]
        i, j = index[a][ok], index[b][ok]
        src += [i, j]
        dst += [j, i]
        weight.append(np.full(2 * len(i), length))
    n = rows * cols
    return csr_matrix((np.concatenate(weight), (np.concatenate(src), np.concatenate(dst))), shape=(n, n))


def _coarse(grid: OccupancyGrid, factor: int, optimistic: bool) -> _Coarse:
    per_grid = _CACHE.setdefault(grid, {})
    key = (factor, optimistic)
    if key not in per_grid:
        free = coarse_free(grid, factor, optimistic)
        per_grid[key] = _Coarse(free, _graph(free))
    return per_grid[key]


@dataclass(frozen=True, eq=False)
class Wavefront:
    """Geodesic distance (m) to ``goal`` over a coarsened ``grid``; see the module docstring.

    ``distance``: ``(H, W)`` coarse cells, ``inf`` where the goal cannot be reached; ``towards``: the flat index
    of the next coarse cell on a shortest way to the goal (-1 at the goal and where unreachable).
    """

    grid: OccupancyGrid
    factor: int
    goal: tuple[float, float]
    distance: FloatArray
    towards: IntArray

    def coarse_cells(self, points: npt.ArrayLike) -> tuple[IntArray, BoolArray]:
        """Flat coarse indices of ``(N, 2)`` points and whether they lie inside the grid."""
        row, col, inside = self.grid.cells(points)
        flat = (row // self.factor) * self.distance.shape[1] + col // self.factor
        flat *= inside
        return flat, inside

    def at(self, points: npt.ArrayLike) -> FloatArray:
        """Distance to the goal (m) at ``(N, 2)`` points; ``inf`` outside the grid or where it is unreachable."""
        flat, inside = self.coarse_cells(points)
        out: FloatArray = np.where(inside, self.distance.reshape(-1).take(flat), math.inf)
        return out

    def centres(self, flat: IntArray) -> FloatArray:
        """World positions ``(N, 2)`` of coarse cell centres given by flat index."""
        rows, cols = np.divmod(np.asarray(flat), self.distance.shape[1])
        size = self.factor * self.grid.resolution
        u, v = (cols + 0.5) * size, (rows + 0.5) * size
        x0, y0, yaw = self.grid.origin
        c, s = math.cos(yaw), math.sin(yaw)
        return np.stack([x0 + c * u - s * v, y0 + s * u + c * v], axis=1)

    def corridor(self, start: npt.ArrayLike) -> FloatArray:
        """Positions ``(K, 2)`` from ``start`` down the distance to the goal (cell centres between the two exact
        end points); raises :class:`NoPathFoundError` when the goal cannot be reached from ``start``'s coarse cell."""
        xy = np.asarray(start, dtype=np.float64)[:2]
        flat, inside = self.coarse_cells(xy[None, :])
        cell = int(flat[0])
        if not inside[0]:
            raise NoPathFoundError(f"no path: {format_point(*xy)} lies outside the grid")
        if not math.isfinite(self.distance.reshape(-1)[cell]):
            raise NoPathFoundError(
                f"no path: the goal {format_point(*self.goal)} cannot be reached from {format_point(*xy)}"
            )
        chain = []
        towards = self.towards.reshape(-1)
        while cell >= 0:
            chain.append(cell)
            cell = int(towards[cell])
        points = self.centres(np.array(chain[1:-1], dtype=np.intp))
        return np.vstack([np.asarray(start, dtype=np.float64)[:2], points, self.goal])


def wavefront(grid: OccupancyGrid, goal: npt.ArrayLike, cell_m: float = 0.2, optimistic: bool = False) -> Wavefront:
    """The navigation function towards ``goal`` (x, y) on ``grid`` coarsened to cells of about ``cell_m`` metres.

    The goal's coarse cell seeds the search even when it is not free in the coarse mask (a goal next to a wall),
    as long as one of its neighbours is.
    """
    factor = max(1, round(cell_m / grid.resolution))
    coarse = _coarse(grid, factor, optimistic)
    goal_xy = np.asarray(goal, dtype=np.float64)[:2]
    rows, cols = coarse.free.shape
    distance = np.full(rows * cols, math.inf)
    towards = np.full(rows * cols, -1, dtype=np.intp)
    row, col, inside = grid.cells(goal_xy)
    if inside[0]:
        g = int(row[0] // factor) * cols + int(col[0] // factor)
        seeds = [g] if coarse.free.reshape(-1)[g] else _free_neighbours(coarse.free, g)
        if seeds:
            dist, pred, _ = dijkstra(coarse.graph, indices=seeds, return_predecessors=True, min_only=True)
            distance = dist * (factor * grid.resolution)
            towards = np.where(pred >= 0, pred, -1).astype(np.intp)
            if g not in seeds:
                distance[g] = float(np.min(distance[seeds])) + factor * grid.resolution
                towards[seeds] = g
                towards[g] = -1
    return Wavefront(grid, factor, (float(goal_xy[0]), float(goal_xy[1])), distance.reshape(rows, cols), towards)


def _free_neighbours(free: BoolArray, flat: int) -> list[int]:
    rows, cols = free.shape
    r, c = divmod(flat, cols)
    out = []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            rr, cc = r + dr, c + dc
            if (dr or dc) and 0 <= rr < rows and 0 <= cc < cols and free[rr, cc]:
                out.append(rr * cols + cc)
    return out
