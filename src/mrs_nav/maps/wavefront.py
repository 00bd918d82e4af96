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
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from mrs_nav.errors import NoPathFoundError
from mrs_nav.geometry import FloatArray, format_point
from mrs_nav.maps.occupancy_grid import BoolArray, IntArray, OccupancyGrid
from mrs_nav.maps.route_kernels import Float32Array, corridor_points, goal_search, landmark_fields

# Neighbour steps (rows, cols) and their lengths in coarse cells; the other half are the reverses.
_STEPS = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2.0)), (1, -1, math.sqrt(2.0)))


#: Landmarks of a map's coarse grid (:func:`route_landmarks`): four at the map's extremes settled a fifth of the
#: cells plain A* did in the 100 m building, and cut the office's searches by 1.5-4.4x (50-80 us against 80-370 us,
#: for 2.7 ms once per map).
LANDMARKS = 4

# Per grid, by (factor, optimistic): the coarse free mask, and its cell graph (CSR, edge weights in coarse cells)
# once a full wavefront needed it.
_MASKS: weakref.WeakKeyDictionary[OccupancyGrid, dict[tuple[int, bool], BoolArray]] = weakref.WeakKeyDictionary()
_LANDMARKS: weakref.WeakKeyDictionary[OccupancyGrid, dict[tuple[int, bool], Float32Array]] = weakref.WeakKeyDictionary()
_GRAPHS: weakref.WeakKeyDictionary[OccupancyGrid, dict[tuple[int, bool], csr_matrix]] = weakref.WeakKeyDictionary()


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


def coarse_mask(grid: OccupancyGrid, cell_m: float, optimistic: bool = False) -> BoolArray:
    """:func:`coarse_free` for cells of about ``cell_m`` metres, built once per grid and variant and kept while
    the grid lives (the part of a route's cost that scales with the map: paid once per map)."""
    key = (_factor(grid, cell_m), optimistic)
    per_grid = _MASKS.setdefault(grid, {})
    if key not in per_grid:
        per_grid[key] = coarse_free(grid, key[0], optimistic)
    return per_grid[key]


def route_landmarks(grid: OccupancyGrid, cell_m: float, optimistic: bool = False) -> Float32Array:
    """The ``LANDMARKS`` landmark distances (:func:`mrs_nav.maps.route_kernels.landmark_fields`) that
    :func:`goal_field` uses on this grid, built once per grid and kept."""
    key = (_factor(grid, cell_m), optimistic)
    per_grid = _LANDMARKS.setdefault(grid, {})
    if key not in per_grid:
        free = coarse_mask(grid, cell_m, optimistic)
        per_grid[key] = landmark_fields(free, LANDMARKS)
    return per_grid[key]


def _coarse_graph(grid: OccupancyGrid, cell_m: float, optimistic: bool) -> csr_matrix:
    key = (_factor(grid, cell_m), optimistic)
    per_grid = _GRAPHS.setdefault(grid, {})
    if key not in per_grid:
        per_grid[key] = _graph(coarse_mask(grid, cell_m, optimistic))
    return per_grid[key]


def _factor(grid: OccupancyGrid, cell_m: float) -> int:
    return max(1, round(cell_m / grid.resolution))


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
        cell = self.coarse_cell(float(xy[0]), float(xy[1]))
        if cell < 0:
            raise NoPathFoundError(f"no path: {format_point(*xy)} lies outside the grid")
        if not math.isfinite(self.distance.reshape(-1)[cell]):
            raise NoPathFoundError(
                f"no path: the goal {format_point(*self.goal)} cannot be reached from {format_point(*xy)}"
            )
        x0, y0, yaw = self.grid.origin
        size = self.factor * self.grid.resolution
        return corridor_points(
            self.towards.reshape(-1),
            cell,
            self.distance.shape[1],
            size,
            x0,
            y0,
            math.cos(yaw),
            math.sin(yaw),
            float(xy[0]),
            float(xy[1]),
            *self.goal,
        )

    def coarse_cell(self, x: float, y: float) -> int:
        """Flat coarse index of one point, -1 outside the grid."""
        return _coarse_index(self.grid, self.factor, self.distance.shape[1], x, y)


def wavefront(grid: OccupancyGrid, goal: npt.ArrayLike, cell_m: float = 0.2, optimistic: bool = False) -> Wavefront:
    """The navigation function towards ``goal`` (x, y) on ``grid`` coarsened to cells of about ``cell_m`` metres,
    over every cell that reaches the goal (one Dijkstra run over the whole coarse grid).

    The goal's coarse cell seeds the search even when it is not free in the coarse mask (a goal next to a wall),
    as long as one of its neighbours is.
    """
    free = coarse_mask(grid, cell_m, optimistic)
    graph = _coarse_graph(grid, cell_m, optimistic)

    def search(seeds: list[int]) -> tuple[FloatArray, IntArray]:
        dist, pred, _ = dijkstra(graph, indices=seeds, return_predecessors=True, min_only=True)
        return dist, np.where(pred >= 0, pred, -1).astype(np.intp)

    return _seeded(grid, _factor(grid, cell_m), free, goal, search)


def goal_field(
    grid: OccupancyGrid, goal: npt.ArrayLike, start: npt.ArrayLike, cell_m: float = 0.2, optimistic: bool = False
) -> Wavefront:
    """:func:`wavefront` settled only as far as ``start`` (x, y) needs (A* from the goal towards it,
    :func:`mrs_nav.maps.route_kernels.goal_search`): exact distances in the band of cells no farther from the goal
    via them than the start is, ``inf`` elsewhere; its corridor from ``start`` is a shortest one like the full
    field's. The search costs what the band holds, not what the map holds."""
    free = coarse_mask(grid, cell_m, optimistic)
    landmarks = route_landmarks(grid, cell_m, optimistic)
    rows, cols = free.shape
    factor = _factor(grid, cell_m)
    start_xy = np.asarray(start, dtype=np.float64)[:2]
    target = _coarse_index(grid, factor, cols, float(start_xy[0]), float(start_xy[1]))
    if target >= 0 and not free.reshape(-1)[target]:
        # A start cell outside the coarse free space is never reached: do not search the whole map to learn it.
        return Wavefront(grid, factor, _xy(goal), np.full((rows, cols), math.inf), np.full(rows * cols, -1))
    return _seeded(
        grid, factor, free, goal, lambda seeds: goal_search(free, np.array(seeds, dtype=np.intp), target, landmarks)
    )


def _coarse_index(grid: OccupancyGrid, factor: int, cols: int, x: float, y: float) -> int:
    """Flat index of the coarse cell (``factor`` grid cells, rows of ``cols``) under ``(x, y)``, -1 outside."""
    cell = grid.cell(x, y)
    return -1 if cell is None else (cell[0] // factor) * cols + cell[1] // factor


def _xy(point: npt.ArrayLike) -> tuple[float, float]:
    xy = np.asarray(point, dtype=np.float64)[:2]
    return float(xy[0]), float(xy[1])


def _seeded(
    grid: OccupancyGrid,
    factor: int,
    free: BoolArray,
    goal: npt.ArrayLike,
    search: Callable[[list[int]], tuple[FloatArray, IntArray]],
) -> Wavefront:
    """The field of ``search`` (coarse-cell distances and next cells from seed cells) on ``free`` (cells of
    ``factor`` grid cells) seeded at the goal's cell, or at its free neighbours when that cell is not free."""
    goal_xy = np.asarray(goal, dtype=np.float64)[:2]
    rows, cols = free.shape
    distance = np.full(rows * cols, math.inf)
    towards = np.full(rows * cols, -1, dtype=np.intp)
    g = _coarse_index(grid, factor, cols, float(goal_xy[0]), float(goal_xy[1]))
    if g >= 0:
        seeds = [g] if free.reshape(-1)[g] else _free_neighbours(free, g)
        if seeds:
            dist, towards = search(seeds)
            distance = dist * (factor * grid.resolution)
            if g not in seeds:
                distance[g] = float(np.min(distance[seeds])) + factor * grid.resolution
                towards[seeds] = g
                towards[g] = -1
    return Wavefront(grid, factor, _xy(goal_xy), distance.reshape(rows, cols), towards)


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
