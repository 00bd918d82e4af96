"""The likelihood-field sensor model (Thrun et al., *Probabilistic Robotics*, table 6.3) on precomputed tables.

A beam's endpoint, projected from a particle's pose, is scored by its distance ``d`` to the nearest occupied
cell of the map: ``p = z_hit * exp(-d^2 / (2 sigma^2)) + z_rand / range_max`` (AMCL's form, so that ``p`` of a
perfect fit is about ``z_hit``), with ``d`` clipped at ``max_dist``.

An endpoint in a cell the map does not know (unknown, or off the map: a saved map is cropped to what the
mapping drive saw) says nothing either way. AMCL scores such endpoints by their distance to the nearest known wall
(off the map: a miss), so the true pose loses to others whenever the robot sees into rooms the map never saw; this
model scored them as perfect hits until issue 38, which let a particle in unknown space, whose beams all end in
unknown cells, beat the true one: the estimate jumped 2.3 m into a room the mapping drive never saw. A fixed middle
value (0.61 of a hit) then stopped the jump but pulled the estimate towards the known map: where the robot drives
out of what the map knows, a particle that lags behind it still puts its beams on known walls, scores more than
the true pose whose beams end in unknown cells, and wins. Along the office's west corridor beyond the mapped part
the estimate fell 0.35 m behind the robot this way while the cloud stayed narrow (confidently wrong), and a goal in
the room there was reached by the estimate with the robot 0.55 m off. Now an endpoint in unknown space scores what
the same beam scores, on average over the current belief, at the particles where it ends in known space: unknown
cells neither reward nor cost a particle against the others, so the scan compares particles on what the map knows
and the cloud spreads by the motion model alone where it knows nothing. A beam unknown at every particle says
nothing and scores 0. A particle standing in unknown space pays ``UNKNOWN_POSE_COST`` once per scan instead: a robot
is far more often where its map was made than beyond it, and without that cost a pose in a room the map does
not know, whose beams all end there, would tie with the true pose in the corridor. The cost is the same for
every particle once the whole cloud is beyond the map (the robot drove into an unmapped room): it then weighs
nothing.

:meth:`LikelihoodField.log_likelihood` also returns the endpoints' scores at a fixed spread with unknown ones
counted as perfect hits: the filter's measure of how well the scans fit (which calls in random particles when it
falls) must not fall because the robot looks into a room the map does not know.

The distance transform (``scipy.ndimage.distance_transform_edt``) is computed once per map and ``log p`` per
cell once per ``sigma``, so scoring is one table lookup per particle and beam.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import UNKNOWN, OccupancyGrid

#: log-likelihood cost of a particle whose own cell is unknown (or off the map): 5 nats, a pose in unknown space
#: has 1/150 of the weight of an equally good one in known space.
UNKNOWN_POSE_COST = 5.0


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
            table = self._tables[sigma] = self.log_p(self._distance, sigma).astype(np.float32)
        return table

    def log_likelihood(
        self, xs: FloatArray, ys: FloatArray, belief: FloatArray, sigma: float, fit_sigma: float
    ) -> tuple[FloatArray, FloatArray]:
        """``log p`` of endpoints at ``xs``, ``ys`` (shape ``(particles, beams)``, metres in the map frame) at
        ``sigma``, those in unknown space scored by the ``belief``-weighted mean (normalised weights, shape
        ``(particles,)``) of the same beam's known endpoints (see the module docstring), and the same at
        ``fit_sigma`` with endpoints in unknown space scored as perfect hits (for the fit: see the module
        docstring; one spread for it, whatever the weighting uses, so that the fit of one scan compares with
        the last's)."""
        unknown = self._unknown.take(flat := self._cells(xs, ys))
        known_weight = belief[:, None] * ~unknown
        support = known_weight.sum(axis=0)
        log_p = np.asarray(self._table(sigma).take(flat), dtype=np.float64)
        expected = np.einsum("pb,pb->b", known_weight, log_p) / np.where(support > 0.0, support, 1.0)
        log_p = np.where(unknown, expected, log_p)
        fit = np.asarray(self._table(fit_sigma).take(flat), dtype=np.float64)
        perfect = float(self.log_p(np.array(0.0), fit_sigma))
        return log_p, np.where(unknown, perfect, fit)

    def mean_log_p(self, xs: FloatArray, ys: FloatArray, sigma: float) -> FloatArray:
        """Per row, the mean ``log p`` at ``sigma`` of endpoints at ``xs``, ``ys`` (shape ``(poses, beams)``, m in
        the map frame), those in unknown space or off the map scored as one ``sigma`` off a wall: neither a hit nor
        a miss, the same at every pose (for comparing poses far apart, see :mod:`.global_match`)."""
        flat = self._cells(xs, ys)
        log_p = np.asarray(self._table(sigma).take(flat), dtype=np.float64)
        middle = float(self.log_p(np.array(sigma), sigma))
        return np.asarray(np.where(self._unknown.take(flat), middle, log_p).mean(axis=1), dtype=np.float64)

    def pose_cost(self, xs: FloatArray, ys: FloatArray) -> FloatArray:
        """``UNKNOWN_POSE_COST`` for each position (m, map frame) in unknown space or off the map, else 0."""
        return np.where(self._unknown.take(self._cells(xs, ys)), UNKNOWN_POSE_COST, 0.0)

    def _cells(self, xs: FloatArray, ys: FloatArray) -> npt.NDArray[np.intp]:
        """The flat table index of each point (the extra last one off the map)."""
        g = self.grid
        col = np.floor((xs - g.origin[0]) / g.resolution).astype(np.intp)
        row = np.floor((ys - g.origin[1]) / g.resolution).astype(np.intp)
        inside = (col.view(np.uintp) < g.width) & (row.view(np.uintp) < g.height)
        return np.asarray(np.where(inside, row * g.width + col, self._off_map), dtype=np.intp)
