"""The likelihood-field sensor model (Thrun et al., *Probabilistic Robotics*, table 6.3) on precomputed tables.

A beam's endpoint, projected from a particle's pose, is scored by its distance ``d`` to the nearest occupied
cell of the map: ``p = z_hit * exp(-d^2 / (2 sigma^2)) + z_rand / range_max`` (AMCL's form, so that ``p`` of a
perfect fit is about ``z_hit``), with ``d`` clipped at ``max_dist`` and endpoints off the map scored at that
distance, as AMCL does. Unlike AMCL, an endpoint in an unknown cell scores as a hit: a saved SLAM map knows
little of the rooms the robot only glimpsed, and their walls must not read as misses that make every particle,
the right ones too, look wrong (the fit collapses and random particles take over: measured, the robot was lost
10 m off on entering a room). The distance transform
(``scipy.ndimage.distance_transform_edt``) is computed once per map and ``log p`` per cell once per ``sigma``,
so scoring is one table lookup per particle and beam.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import UNKNOWN, OccupancyGrid


class LikelihoodField:
    """Per-cell log-likelihood of a beam endpoint for one map, for any ``sigma`` (tables cached)."""

    def __init__(self, grid: OccupancyGrid, *, z_hit: float, z_rand: float, max_dist: float, range_max: float) -> None:
        self.grid = grid
        self.z_hit, self.z_rand, self.max_dist, self.range_max = z_hit, z_rand, max_dist, range_max
        distance = ndimage.distance_transform_edt(~grid.occupied_mask) * grid.resolution
        distance[grid.values == UNKNOWN] = 0.0  # not held against a particle: see the module docstring
        # One extra cell at the end of the flat table holds the off-map distance.
        self._distance = np.append(np.minimum(distance, max_dist).ravel(), max_dist)
        self._off_map = self._distance.size - 1
        self._tables: dict[float, FloatArray] = {}

    def log_p(self, distance: FloatArray, sigma: float) -> FloatArray:
        """``log p`` of endpoints at ``distance`` (m) from the nearest obstacle."""
        gauss = np.exp(-0.5 * (distance / sigma) ** 2)
        return np.asarray(np.log(self.z_hit * gauss + self.z_rand / self.range_max), dtype=np.float64)

    def log_likelihood(self, xs: FloatArray, ys: FloatArray, sigma: float) -> FloatArray:
        """``log p`` of endpoints at ``xs``, ``ys`` (any equal shapes, metres in the map frame)."""
        table = self._tables.get(sigma)
        if table is None:
            table = self._tables[sigma] = self.log_p(self._distance, sigma).astype(np.float32)
        g = self.grid
        col = np.floor((xs - g.origin[0]) / g.resolution).astype(np.intp)
        row = np.floor((ys - g.origin[1]) / g.resolution).astype(np.intp)
        inside = (col.view(np.uintp) < g.width) & (row.view(np.uintp) < g.height)
        flat = np.where(inside, row * g.width + col, self._off_map)
        return np.asarray(table.take(flat), dtype=np.float64)
