"""Scan-to-map matching: multi-resolution correlative search, then Gauss-Newton refinement.

The map is turned into a distance field ``D`` (metres to the nearest occupied cell, truncated) over the window
the scan can reach, and into a likelihood field ``L = exp(-D^2 / (2 sigma^2))``.

1. Coarse search (Olson, "Real-time correlative scan matching", ICRA 2009): for every candidate heading in the
   angular window, every translation on a grid of ``COARSE`` cells is scored with ``L`` max-pooled over
   ``COARSE`` x ``COARSE`` cells, an upper bound of the fine score anywhere in that block, minus the odometry
   prior ``PRIOR_WEIGHT * log(1 + z^2 / 2)``, ``z^2 = (dx^2 + dy^2) / s_xy^2 + dtheta^2 / s_theta^2`` with the
   spreads expected of the odometry over the motion since the last scan: a Cauchy (heavy-tailed) prior, so a
   scan in a featureless corridor does not slide along it, yet a clear match far from a bad odometry reading
   still wins.
2. Fine search: the best coarse blocks are searched cell by cell with a finer angular step.
3. Refinement: point-to-line ICP (Gauss-Newton, Huber-weighted) where each scan point is paired with the mean
   end point of its nearest occupied cell (found through the distance field's nearest-cell indices) and the
   surface normal there (principal axes of the neighbouring mean hits), for sub-cell, sub-degree accuracy
   without sticking to the cell grid along walls; pairs farther than 4 cells apart are ignored. The same
   odometry prior keeps directions the scan does not constrain (along a corridor) where odometry put them.

The matcher only matches: what to do with a weak or lost match (search again wider, all round, hold a pose in
doubt) is the front end's (:mod:`mrs_nav.slam.tracking`); the per-point loops are compiled
(:mod:`mrs_nav.slam.matcher_kernels`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray, Pose2D, wrap_angle
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.matcher_kernels import (
    CellArray,
    SurfaceArgs,
    _likelihoods,
    _nearest_surfaces,
    _refine,
    _search_scores,
    _truncated_field,
)

COARSE = 4  # cells per coarse translation step
COARSE_ANGLE = math.radians(1.0)
FINE_ANGLE = math.radians(0.25)
TOP_CANDIDATES = 8
FIELD_MAX_DISTANCE = 0.5  # m, truncation of the distance field


@dataclass(frozen=True)
class MatchResult:
    """A laser pose in the map frame and how well the scan fits there.

    ``score``: mean likelihood of the points (0..1); ``inlier_fraction``: share of points within 1.5 cells of
    an occupied cell after refinement.
    """

    pose: Pose2D
    score: float
    inlier_fraction: float


class DistanceField:
    """Truncated distance (m) to the nearest occupied cell over a window of a grid, padded by ``pad`` cells."""

    def __init__(self, grid: LogOddsGrid, bounds: tuple[float, float, float, float], max_distance: float, pad: int):
        res = grid.resolution
        x0 = max(0, math.floor((bounds[0] - grid.origin_x) / res))
        y0 = max(0, math.floor((bounds[1] - grid.origin_y) / res))
        x1 = min(grid.width, math.ceil((bounds[2] - grid.origin_x) / res) + 1)
        y1 = min(grid.height, math.ceil((bounds[3] - grid.origin_y) / res) + 1)
        self.resolution = res
        self.max_distance = max_distance
        self.origin_x = grid.origin_x + (x0 - pad) * res
        self.origin_y = grid.origin_y + (y0 - pad) * res
        self.grid = grid
        # Squared distance in cells to the nearest occupied cell, capped where the distance reaches the
        # truncation: distances, and the matcher's likelihoods, take only these few values, so they are
        # computed once per value (distance_table) and looked up per cell.
        cap = math.ceil((max_distance / res) ** 2) + 1
        self.distance_table: FloatArray = np.minimum(np.sqrt(np.arange(cap + 1)) * res, max_distance)
        self.squared: CellArray
        # Grid indices of the nearest occupied cell, per window cell (-1 in the padding).
        self.near_iy: CellArray
        self.near_ix: CellArray
        # The window only: the whole map's occupied() would cost O(map) per scan.
        tiled = (grid.table, grid.logodds, grid.hit_table, grid.cells)
        window = ((y0, max(y1, y0)), (x0, max(x1, x0)))
        self.squared, self.near_iy, self.near_ix, occupied = _truncated_field(*tiled, *window, pad, cap)
        self.empty = occupied == 0
        if self.empty:
            shape = (1 + 2 * pad, 1 + 2 * pad)
            self.squared = np.full(shape, cap, dtype=np.int32)
            self.near_iy = self.near_ix = np.full(shape, -1, dtype=np.int32)

    def nearest_surface(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """For each point: the mean hit point ``(mx, my)`` (m) of the nearest occupied cell and the angle (rad)
        of the surface normal there, from the principal axes of the mean hits of the occupied cells within
        ``NORMAL_RADIUS`` cells. NaN outside the window or where fewer than 3 hits define no line."""
        shape = np.shape(x)
        wx = np.ascontiguousarray(x, dtype=np.float64).ravel()
        wy = np.ascontiguousarray(y, dtype=np.float64).ravel()
        out: FloatArray = _nearest_surfaces(wx, wy, self.kernel_args())
        return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)

    def kernel_args(self) -> SurfaceArgs:
        """The field and its grid as the compiled surface lookup (:func:`_surface`) takes them."""
        return self.origin_x, self.origin_y, self.near_iy, self.near_ix, self.grid.kernel_args()

    def interpolate(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Bilinear ``D`` at points and its gradient ``(dD/dx, dD/dy)`` (unitless)."""
        h, w = self.squared.shape
        u = (x - self.origin_x) / self.resolution - 0.5
        v = (y - self.origin_y) / self.resolution - 0.5
        u = np.clip(u, 0.0, w - 1.001)
        v = np.clip(v, 0.0, h - 1.001)
        i, j = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
        fu, fv = u - i, v - j
        d, s = self.distance_table, self.squared
        d00, d01, d10, d11 = d[s[j, i]], d[s[j, i + 1]], d[s[j + 1, i]], d[s[j + 1, i + 1]]
        value = (1 - fu) * (1 - fv) * d00 + fu * (1 - fv) * d01 + (1 - fu) * fv * d10 + fu * fv * d11
        gx = ((1 - fv) * (d01 - d00) + fv * (d11 - d10)) / self.resolution
        gy = ((1 - fu) * (d10 - d00) + fu * (d11 - d01)) / self.resolution
        return value, gx, gy


def _floats(pose: Pose2D) -> tuple[float, float, float]:
    """A pose as the kernels take it (a pose of ints, say, would match no kernel signature)."""
    return float(pose.x), float(pose.y), float(pose.yaw)


def thin_points(points: FloatArray, spacing: float) -> FloatArray:
    """One point per ``spacing``-sized cell (laser frame): the mean of the points in it, so dense near returns
    do not dominate.

    Why the mean and not one of the points: which points fall into a cell depends on their range noise, so
    keeping a particular one (say the first in beam order) keeps a noise-selected sample, and the matcher then
    aligns to a biased surface. With 1 cm noise and 5 cm cells that bias turned into a steady heading drift of
    about 0.03 degrees per metre on the simulated office drive (ATE 1-1.5 cm); the mean keeps every point's
    information (ATE 2-5 mm) and also averages the noise of the points it merges.
    """
    if points.shape[0] == 0:
        return points
    keys = np.floor(points / spacing).astype(np.int64)
    _, first, inverse, count = np.unique(
        keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True, return_inverse=True, return_counts=True
    )
    inverse = inverse.ravel()
    mean = np.stack([np.bincount(inverse, points[:, 0]), np.bincount(inverse, points[:, 1])], axis=1) / count[:, None]
    # In beam order (of each cell's first point), as the callers' scans are.
    return np.asarray(mean[np.argsort(first)], dtype=np.float64)


def window_field(grid: LogOddsGrid, points: FloatArray, sensor_prior: Pose2D, search_linear: float) -> DistanceField:
    """The distance field of ``grid`` over the window the scan ``points`` can reach from ``sensor_prior``."""
    wx, wy = sensor_prior.apply(points).T
    # The window covers the predicted scan plus the linear search; points that the angular search swings
    # farther out fall in the padding, where they score nothing, which is what a wrong heading deserves.
    reach = search_linear + FIELD_MAX_DISTANCE
    bounds = (float(wx.min()) - reach, float(wy.min()) - reach, float(wx.max()) + reach, float(wy.max()) + reach)
    pad = math.ceil(reach / grid.resolution) + 2
    return DistanceField(grid, bounds, FIELD_MAX_DISTANCE, pad)


class ScanMatcher:
    """Aligns a scan (points in the laser frame) to a :class:`DistanceField` near a predicted laser pose."""

    def __init__(self, sigma: float, search_linear: float, search_angular: float):
        self.sigma = sigma
        self.search_linear = search_linear
        self.search_angular = search_angular

    def match(
        self, field: DistanceField, points: FloatArray, prior: Pose2D, spread: tuple[float, float] = (1.0, 1.0)
    ) -> MatchResult:
        """Best laser pose for ``points`` (N x 2, laser frame) near ``prior``; ``prior`` if nothing to match.

        ``spread``: standard deviations (m, rad) of the odometry prediction ``prior``.
        """
        if field.empty or points.shape[0] < 3:
            return MatchResult(prior, 0.0, 0.0)
        points = np.ascontiguousarray(points, dtype=np.float64)
        # The coarse level also uses a wider likelihood: its 1-degree heading steps move far points by more
        # than a cell, and a too-sharp score would rank the right block below a lucky wrong one.
        sigma_c = max(self.sigma, 0.5 * COARSE * field.resolution)
        fine_values, coarse_values, pooled = _likelihoods(
            field.squared, field.distance_table, self.sigma, sigma_c, COARSE // 2
        )
        res = field.resolution
        n_lin = max(1, math.ceil(self.search_linear / (COARSE * res)))
        n_ang = max(1, math.ceil(self.search_angular / COARSE_ANGLE))
        coarse_offsets = np.arange(-n_lin, n_lin + 1) * COARSE
        coarse_angles = np.arange(-n_ang, n_ang + 1) * COARSE_ANGLE
        coarse = (pooled, coarse_values)
        scores = self._scores(field, coarse, points, prior, angles=coarse_angles, offsets=coarse_offsets, spread=spread)
        best: tuple[float, float, int, int] = (-math.inf, 0.0, 0, 0)
        for flat in np.argsort(scores, axis=None)[::-1][:TOP_CANDIDATES]:
            a, ox, oy = np.unravel_index(flat, scores.shape)
            fine_angles = coarse_angles[a] + np.arange(-2, 3) * FINE_ANGLE
            half = COARSE // 2
            fine_offsets = np.arange(-half, half + 1)
            fine = self._scores(
                field,
                (field.squared, fine_values),
                points,
                prior,
                angles=fine_angles,
                offsets=fine_offsets,
                base=(int(coarse_offsets[ox]), int(coarse_offsets[oy])),
                spread=spread,
            )
            fa, fx, fy = np.unravel_index(int(np.argmax(fine)), fine.shape)
            if fine[fa, fx, fy] > best[0]:
                best = (
                    float(fine[fa, fx, fy]),
                    float(fine_angles[fa]),
                    int(coarse_offsets[ox] + fine_offsets[fx]),
                    int(coarse_offsets[oy] + fine_offsets[fy]),
                )
        _, dyaw, dx, dy = best
        start = Pose2D(prior.x + dx * res, prior.y + dy * res, wrap_angle(prior.yaw + dyaw))
        pose = self.refine(field, points, start, prior=prior, spread=spread)
        return self.evaluate(field, points, pose)

    def _scores(
        self,
        field: DistanceField,
        table: tuple[CellArray, FloatArray],
        points: FloatArray,
        prior: Pose2D,
        *,
        angles: FloatArray,
        offsets: npt.NDArray[np.int64],
        base: tuple[int, int] = (0, 0),
        spread: tuple[float, float] = (1.0, 1.0),
    ) -> FloatArray:
        """Mean table value minus the prior penalty, for every (angle, x offset, y offset) in cells; ``table``:
        squared cell distances over the field's window and the value of each."""
        window = (field.origin_x, field.origin_y, field.resolution)
        floats = (float(spread[0]), float(spread[1]))
        scores: FloatArray = _search_scores(*table, window, points, _floats(prior), angles, offsets, base, floats)
        return scores

    def refine(
        self,
        field: DistanceField,
        points: FloatArray,
        start: Pose2D,
        *,
        prior: Pose2D,
        spread: tuple[float, float],
        iterations: int = 10,
    ) -> Pose2D:
        """Point-to-line ICP from ``start`` against the surfaces at the nearest occupied cells.

        A maximum a posteriori Gauss-Newton: point residuals with standard deviation ``POINT_SIGMA_CELLS``
        (at most ``INDEPENDENT_POINTS`` counted as independent) plus the odometry prior ``prior`` / ``spread``.
        """
        prior_info = np.array([spread[0] ** -2, spread[0] ** -2, spread[1] ** -2], dtype=np.float64)
        points = np.ascontiguousarray(points, dtype=np.float64)
        x, y, yaw = _refine(points, _floats(start), _floats(prior), prior_info, iterations, field.kernel_args())
        return Pose2D(x, y, wrap_angle(yaw))

    def evaluate(self, field: DistanceField, points: FloatArray, pose: Pose2D) -> MatchResult:
        """How well ``points`` (laser frame) fit ``field`` at the laser pose ``pose``, without moving it."""
        wx, wy = pose.apply(points).T
        d, _, _ = field.interpolate(wx, wy)
        score = float(np.mean(np.exp(-(d**2) / (2.0 * self.sigma**2))))
        return MatchResult(pose, score, float(np.mean(d < 1.5 * field.resolution)))
