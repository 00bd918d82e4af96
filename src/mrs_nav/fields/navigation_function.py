"""The potential field's fallback guide: a wavefront navigation function over the field's obstacles.

The obstacles (already grown by the robot radius, so a point stands for the robot) are rasterised
conservatively: a cell is blocked when any of its points could lie in an obstacle (its centre is within half a
diagonal of one). :func:`mrs_nav.maps.wavefront.wavefront` then gives the geodesic distance to the goal over
the free cells, which has no local minimum but the goal, and :meth:`NavigationFunction.downhill` the point a
few cells further down it, which the trapped point heads for. A gap narrower than the robot is closed in the
grown obstacles, so neither the field nor this guide leads through it.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mrs_nav.fields.potential_field import Bounds
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from mrs_nav.maps.wavefront import wavefront

#: Cell size (m) of the navigation function's grid.
RESOLUTION = 0.025
# How many cells down the wavefront the trapped point aims (a look-ahead smooths the staircase of cells).
_AHEAD = 6


class NavigationFunction:
    """Geodesic distance to ``goal`` around ``obstacles`` over ``bounds`` (metres); see the module docstring."""

    def __init__(self, obstacles: Obstacles, goal: tuple[float, float], bounds: Bounds) -> None:
        xmin, ymin, xmax, ymax = bounds
        cols, rows = math.ceil((xmax - xmin) / RESOLUTION), math.ceil((ymax - ymin) / RESOLUTION)
        xs = xmin + (np.arange(cols) + 0.5) * RESOLUTION
        ys = ymin + (np.arange(rows) + 0.5) * RESOLUTION
        centres = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        blocked = obstacles.contains(centres, RESOLUTION / math.sqrt(2.0)).reshape(rows, cols)
        grid = OccupancyGrid(np.where(blocked, OCCUPIED, FREE).astype(np.int8), RESOLUTION, (xmin, ymin, 0.0))
        self.wave = wavefront(grid, goal, RESOLUTION)
        self.obstacles = obstacles

    def distance(self, points: npt.ArrayLike) -> FloatArray:
        """Geodesic distance to the goal (m) at ``(N, 2)`` points; ``inf`` in blocked or cut-off cells."""
        return self.wave.at(points)

    def corridor(self, start: npt.ArrayLike) -> FloatArray:
        """Points ``(K, 2)`` from ``start`` down the distance to the goal through cell centres; raises
        :class:`~mrs_nav.errors.NoPathFoundError` when the goal cannot be reached from ``start``'s cell."""
        return self.wave.corridor(start)

    def _cells(self, points: npt.ArrayLike) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.bool_]]:
        """Each point's coarse cell, or the best of its 5 x 5 neighbourhood that it sees in a straight line when its
        own is blocked (a point just clear of an obstacle can sit in a conservatively blocked cell; a cell beyond
        an obstacle's corner would lead it into the corner), and whether it lies in the grid."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        flat, inside = self.wave.coarse_cells(p)
        rows, cols = self.wave.distance.shape
        distance = self.wave.distance.reshape(-1)
        r, c = np.divmod(flat, cols)
        offsets = np.arange(-2, 3)
        rr = np.clip(r[:, None, None] + offsets[None, :, None], 0, rows - 1)
        cc = np.clip(c[:, None, None] + offsets[None, None, :], 0, cols - 1)
        around = (rr * cols + cc).reshape(len(p), -1)
        seen = self.obstacles.segments_free(
            np.repeat(p, around.shape[1], axis=0), self.wave.centres(around.reshape(-1))
        )
        cost = np.where(seen.reshape(around.shape), distance[around], math.inf)
        best = around[np.arange(len(p)), np.argmin(cost, axis=1)]
        return np.where(np.isfinite(distance[flat]), flat, best), inside

    def reaches_goal(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Whether the goal can be reached from each of ``(N, 2)`` points (for the point the grown obstacles
        leave: a gap closed for the robot counts as a wall)."""
        cell, inside = self._cells(points)
        out: npt.NDArray[np.bool_] = inside & np.isfinite(self.wave.distance.reshape(-1)[cell])
        return out

    def downhill(self, points: npt.ArrayLike, ahead: int = _AHEAD) -> FloatArray:
        """``(N, 2)`` targets a few cells down the distance from each point (see :meth:`_cells`); the point
        itself where nothing nearby reaches the goal."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        cell, inside = self._cells(p)
        towards = self.wave.towards.reshape(-1)
        for _ in range(ahead):
            cell = np.where(towards[cell] >= 0, towards[cell], cell)
        reachable = inside & np.isfinite(self.wave.distance.reshape(-1)[cell])
        out: FloatArray = np.where(reachable[:, None], self.wave.centres(cell), p)
        return out
