"""The likelihood-field sensor model (Thrun et al., *Probabilistic Robotics*, table 6.3) on precomputed tables.

A beam's endpoint, projected from a particle's pose, is scored by its distance ``d`` to the nearest occupied
cell of the map: ``p = z_hit * exp(-d^2 / (2 sigma^2)) + z_rand / range_max`` (AMCL's form, so that ``p`` of a
perfect fit is about ``z_hit``), with ``d`` clipped at ``max_dist``.

An endpoint in a cell the map does not know (unknown, or off the map: a saved map is cropped to what the
mapping drive saw) says nothing either way, and scores a fixed middle value: a hit ``UNKNOWN_SIGMAS`` spreads
off. AMCL scores such endpoints by their distance to the nearest known wall (off the map: a miss), so the true
pose loses to others whenever the robot sees into rooms the map never saw; this model scored them as perfect
hits until issue 38, which let a particle in unknown space, whose beams all end in unknown cells, beat the true
one: the estimate jumped 2.3 m into a room the mapping drive never saw. With the middle value a particle that
explains the scan by known walls beats one that explains it by unknown space, and unknown beams cost the true
pose nothing against its neighbours, which see the same unknown cells.

:meth:`LikelihoodField.log_likelihood` also returns the endpoints' scores at a fixed spread with unknown ones
counted as perfect hits: the filter's measure of how well the scans fit (which calls in random particles when it
falls) must not fall because the robot looks into a room the map does not know.

The distance transform (``scipy.ndimage.distance_transform_edt``) is computed once per map and ``log p`` per
cell once per ``sigma``, so scoring is one table lookup per particle and beam.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import UNKNOWN, OccupancyGrid

#: An endpoint in unknown space scores as a hit this many ``sigma`` from a wall (exp(-1/2) = 0.61 of a hit).
UNKNOWN_SIGMAS = 1.0


class LikelihoodField:
    """Per-cell log-likelihood of a beam endpoint for one map, for any ``sigma`` (tables cached)."""

    def __init__(self, grid: OccupancyGrid, *, z_hit: float, z_rand: float, max_dist: float, range_max: float) -> None:
        self.grid = grid
        self.z_hit, self.z_rand, self.max_dist, self.range_max = z_hit, z_rand, max_dist, range_max
        distance = ndimage.distance_transform_edt(~grid.occupied_mask) * grid.resolution
        # One extra cell at the end of the flat tables stands for every point off the map.
        self._distance = np.append(np.minimum(distance, max_dist).ravel(), max_dist)
        self._unknown = np.append(grid.values.ravel() == UNKNOWN, True)
        self._off_map = self._distance.size - 1
        self._tables: dict[float, FloatArray] = {}

    def log_p(self, distance: FloatArray, sigma: float) -> FloatArray:
        """``log p`` of endpoints at ``distance`` (m) from the nearest obstacle."""
        gauss = np.exp(-0.5 * (distance / sigma) ** 2)
        return np.asarray(np.log(self.z_hit * gauss + self.z_rand / self.range_max), dtype=np.float64)

    def _table(self, sigma: float) -> FloatArray:
        table = self._tables.get(sigma)
        if table is None:
            table = self.log_p(self._distance, sigma)
            table[self._unknown] = self.log_p(np.array(UNKNOWN_SIGMAS * sigma), sigma)
            table = self._tables[sigma] = table.astype(np.float32)
        return table

    def log_likelihood(
        self, xs: FloatArray, ys: FloatArray, sigma: float, fit_sigma: float
    ) -> tuple[FloatArray, FloatArray]:
        """``log p`` of endpoints at ``xs``, ``ys`` (any equal shapes, metres in the map frame) at ``sigma``, and
        at ``fit_sigma`` with endpoints in unknown space scored as perfect hits (for the fit: see the module
        docstring; one spread for it, whatever the weighting uses, so that the fit of one scan compares with
        the last's)."""
        g = self.grid
        col = np.floor((xs - g.origin[0]) / g.resolution).astype(np.intp)
        row = np.floor((ys - g.origin[1]) / g.resolution).astype(np.intp)
        inside = (col.view(np.uintp) < g.width) & (row.view(np.uintp) < g.height)
        flat = np.where(inside, row * g.width + col, self._off_map)
        log_p = np.asarray(self._table(sigma).take(flat), dtype=np.float64)
        fit = np.asarray(self._table(fit_sigma).take(flat), dtype=np.float64)
        perfect = float(self.log_p(np.array(0.0), fit_sigma))
        return log_p, np.where(self._unknown.take(flat), perfect, fit)
