"""Free positions for RRT*, drawn in batches and filtered in compiled code: uniform over the map, or uniform in
the informed ellipse once a path exists.

A batch of points is drawn with one call of the generator, the free ones are kept by one compiled lookup
(:func:`mrs_nav.trees.kernels.lookup` on the free mask) and handed out in turn: each is still uniform over the free
part of the region, and a sample costs an index instead of a dozen numpy calls on a few points (issue 42).
"""

from __future__ import annotations

import math

import numpy as np

from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.trees import kernels
from mrs_nav.trees.rrt import sample_random_position

# Points drawn per batch, and batches tried before falling back to :func:`sample_random_position`.
_BATCH = 256
_BATCHES = 8


class _BatchSampler:
    """Free positions among batches of :meth:`_draw`; see the module docstring."""

    def __init__(self, grid: OccupancyGrid) -> None:
        self.grid = grid
        self._grid_args = kernels.grid_args(grid)
        self._free = np.zeros((0, 2))
        self._next = 0

    def _draw(self, rng: np.random.Generator) -> FloatArray:
        """``(_BATCH, 2)`` points uniform over the sampled region."""
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> FloatArray:
        """One free position of the region (or anywhere free on the map if a few batches show none)."""
        out: FloatArray = self.peek(rng, 1)[0]
        self.advance(1)
        return out

    def peek(self, rng: np.random.Generator, count: int) -> FloatArray:
        """The next free positions ``(k, 2)``, ``1 <= k <= count``, that :meth:`sample` would give, without taking
        them (:meth:`advance` takes them): those left of the last batch, or of a new one; a position anywhere
        free on the map if a few batches show none."""
        for _ in range(_BATCHES):
            if self._next < len(self._free):
                return self._free[self._next : self._next + count]
            points = self._draw(rng)
            self._free = points[kernels.lookup(points, self._grid_args[1], self._grid_args)]
            self._next = 0
        self._free = sample_random_position(self.grid, rng)[None, :]
        return self._free

    def advance(self, count: int) -> None:
        """Take ``count`` of the positions :meth:`peek` showed."""
        self._next += count


class UniformSampler(_BatchSampler):
    """Free positions uniform over the grid's extent (what :func:`sample_random_position` draws, a batch at once)."""

    def __init__(self, grid: OccupancyGrid) -> None:
        super().__init__(grid)
        x0, y0, yaw = grid.origin
        c, s = math.cos(yaw), math.sin(yaw)
        # unit square -> the grid's rectangle: scale by its size, rotate by the origin's yaw
        span = np.array([grid.width, grid.height]) * grid.resolution
        self.transform = np.array([[c, s], [-s, c]]) * span[:, None]
        self.offset = np.array([x0, y0])

    def _draw(self, rng: np.random.Generator) -> FloatArray:
        out: FloatArray = rng.random((_BATCH, 2)) @ self.transform + self.offset
        return out


class InformedSampler(_BatchSampler):
    """Free positions uniform in the ellipse ``|x - start| + |x - goal| <= best`` (Gammell et al.'s informed set).

    The ellipse is fixed per best length, so its transform is built once per improvement, not per sample.
    """

    def __init__(self, grid: OccupancyGrid, start: FloatArray, goal: FloatArray, best: float) -> None:
        super().__init__(grid)
        c_min = float(np.hypot(*(goal - start)))
        a = best / 2.0
        b = math.sqrt(max(best * best - c_min * c_min, 0.0)) / 2.0
        angle = math.atan2(goal[1] - start[1], goal[0] - start[0])
        c, s = math.cos(angle), math.sin(angle)
        # unit disk -> ellipse: scale by (a, b), rotate by angle
        self.transform = np.array([[a * c, a * s], [-b * s, b * c]])
        self.centre = (start + goal) / 2.0

    def _draw(self, rng: np.random.Generator) -> FloatArray:
        r = np.sqrt(rng.random(_BATCH))
        t = rng.random(_BATCH) * (2.0 * math.pi)
        out: FloatArray = np.stack([r * np.cos(t), r * np.sin(t)], axis=1) @ self.transform + self.centre
        return out
