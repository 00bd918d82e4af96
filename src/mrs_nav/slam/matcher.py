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
   end point of its nearest occupied cell (found through the distance transform's nearest-cell indices) and the
   surface normal there (principal axes of the neighbouring mean hits), for sub-cell, sub-degree accuracy
   without sticking to the cell grid along walls; pairs farther than 4 cells apart are ignored. The same
   odometry prior keeps directions the scan does not constrain (along a corridor) where odometry put them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.geometry import FloatArray, Pose2D, wrap_angle
from mrs_nav.slam.grid import LogOddsGrid

COARSE = 4  # cells per coarse translation step
COARSE_ANGLE = math.radians(1.0)
FINE_ANGLE = math.radians(0.25)
TOP_CANDIDATES = 8
PRIOR_WEIGHT = 0.05  # score units (mean likelihood, 0..1) per squared prior standard deviation, halved
NORMAL_RADIUS = 2  # cells: the neighbourhood whose hits define a surface normal
POINT_SIGMA_CELLS = 0.5  # assumed standard deviation of a point-to-hit residual, in cells
INDEPENDENT_POINTS = 20.0  # neighbouring scan points are correlated; count at most this many as independent


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
        occ = grid.occupied()[y0:y1, x0:x1] if x1 > x0 and y1 > y0 else np.zeros((0, 0), dtype=bool)
        self.empty = not bool(occ.any())
        if self.empty:
            dist = np.full((1, 1), max_distance, dtype=np.float64)
            near = np.zeros((2, 1, 1), dtype=np.int64)
        else:
            # The nearest occupied cells give the distances too: the transform need not compute them twice.
            near = ndimage.distance_transform_edt(~occ, return_distances=False, return_indices=True)
            rows, cols = np.indices(occ.shape)
            dist = np.minimum(np.hypot(near[0] - rows, near[1] - cols) * res, max_distance)
        self.distance: FloatArray = np.pad(dist, pad, constant_values=max_distance)
        self.origin_x = grid.origin_x + (x0 - pad) * res
        self.origin_y = grid.origin_y + (y0 - pad) * res
        # Grid indices of the nearest occupied cell, per window cell (-1 in the padding).
        self.grid = grid
        self.near_iy = np.pad(near[0] + y0, pad, constant_values=-1)
        self.near_ix = np.pad(near[1] + x0, pad, constant_values=-1)
        # Surface normals computed so far (nearest_surface): grid flat index -> angle, sorted by index.
        self._normal_keys = np.zeros(0, dtype=np.int64)
        self._normals = np.zeros(0, dtype=np.float64)

    def nearest_surface(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """For each point: the mean hit point ``(mx, my)`` (m) of the nearest occupied cell and the angle (rad)
        of the surface normal there, from the principal axes of the mean hits of the occupied cells within
        ``NORMAL_RADIUS`` cells. NaN outside the window or where fewer than 3 hits define no line."""
        ix, iy = self.cells(x, y)
        niy, nix = self.near_iy[iy, ix], self.near_ix[iy, ix]
        inside = niy >= 0
        niy, nix = np.maximum(niy, 0), np.maximum(nix, 0)
        hx, hy = self.grid.mean_hits(niy, nix)
        # A cell's normal depends on the grid only, which does not change while the field is in use, and the
        # refinement's iterations ask for much the same cells: each is computed once.
        key = niy * self.grid.width + nix
        at, known = self._cached(key)
        new = np.unique(key[inside & ~known])
        if new.size:
            self._normal_keys = np.concatenate([self._normal_keys, new])
            normals = self._normals_at(new // self.grid.width, new % self.grid.width)
            self._normals = np.concatenate([self._normals, normals])
            order = np.argsort(self._normal_keys)
            self._normal_keys, self._normals = self._normal_keys[order], self._normals[order]
            at, _ = self._cached(key)
        normal = self._normals[at] if self._normals.size else np.full(x.shape, np.nan)
        good = inside & np.isfinite(normal)
        nan = np.full(x.shape, np.nan)
        return np.where(good, hx, nan), np.where(good, hy, nan), np.where(good, normal, nan)

    def _cached(self, key: npt.NDArray[np.int64]) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        """Where each grid flat index ``key`` is (or would go) among the cached normals, and whether it is there."""
        at = _clamp(np.searchsorted(self._normal_keys, key), max(self._normal_keys.size - 1, 0))
        known = self._normal_keys[at] == key if self._normal_keys.size else np.zeros(key.shape, dtype=bool)
        return at, known

    def _normals_at(self, niy: npt.NDArray[np.int64], nix: npt.NDArray[np.int64]) -> FloatArray:
        """Surface normal angle (rad) at grid cells ``(niy, nix)``; NaN where fewer than 3 hits are near."""
        offsets = np.arange(-NORMAL_RADIUS, NORMAL_RADIUS + 1)
        oy, ox = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
        gy = np.clip(niy[:, None] + oy[None, :], 0, self.grid.height - 1)
        gx = np.clip(nix[:, None] + ox[None, :], 0, self.grid.width - 1)
        occupied = (self.grid.logodds[gy, gx] > 0.0) & (self.grid.hit_count[gy, gx] > 0)
        px, py = self.grid.mean_hits(gy, gx)
        w = occupied.astype(np.float64)
        count = w.sum(axis=1)
        safe = np.maximum(count, 1.0)
        cx = (w * px).sum(axis=1) / safe
        cy = (w * py).sum(axis=1) / safe
        dx, dy = px - cx[:, None], py - cy[:, None]
        sxx, syy, sxy = (w * dx * dx).sum(axis=1), (w * dy * dy).sum(axis=1), (w * dx * dy).sum(axis=1)
        # Principal (tangent) direction of the local hits; the normal is perpendicular to it.
        normal = 0.5 * np.arctan2(2.0 * sxy, sxx - syy) + 0.5 * np.pi
        return np.where(count >= 3, normal, np.nan)

    def cells(self, x: FloatArray, y: FloatArray) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """Cell indices of points, clipped into the padded window."""
        h, w = self.distance.shape
        ix = _clamp(np.floor((x - self.origin_x) / self.resolution).astype(np.int64), w - 1)
        iy = _clamp(np.floor((y - self.origin_y) / self.resolution).astype(np.int64), h - 1)
        return ix, iy

    def interpolate(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Bilinear ``D`` at points and its gradient ``(dD/dx, dD/dy)`` (unitless)."""
        h, w = self.distance.shape
        u = (x - self.origin_x) / self.resolution - 0.5
        v = (y - self.origin_y) / self.resolution - 0.5
        u = np.clip(u, 0.0, w - 1.001)
        v = np.clip(v, 0.0, h - 1.001)
        i, j = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
        fu, fv = u - i, v - j
        d = self.distance
        d00, d01, d10, d11 = d[j, i], d[j, i + 1], d[j + 1, i], d[j + 1, i + 1]
        value = (1 - fu) * (1 - fv) * d00 + fu * (1 - fv) * d01 + (1 - fu) * fv * d10 + fu * fv * d11
        gx = ((1 - fv) * (d01 - d00) + fv * (d11 - d10)) / self.resolution
        gy = ((1 - fu) * (d10 - d00) + fu * (d11 - d01)) / self.resolution
        return value, gx, gy


def _clamp(index: npt.NDArray[np.int64], highest: int) -> npt.NDArray[np.int64]:
    """``index`` clipped to ``0..highest`` in place; np.clip's argument checks cost more than the clipping on
    the matcher's many small arrays."""
    return np.minimum(np.maximum(index, 0, out=index), highest, out=index)


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
        likelihood = np.exp(-(field.distance**2) / (2.0 * self.sigma**2))
        # The coarse level also uses a wider likelihood: its 1-degree heading steps move far points by more
        # than a cell, and a too-sharp score would rank the right block below a lucky wrong one.
        sigma_c = max(self.sigma, 0.5 * COARSE * field.resolution)
        wide = np.exp(-(field.distance**2) / (2.0 * sigma_c**2))
        pooled = ndimage.maximum_filter(wide, size=COARSE + 1, mode="nearest")
        res = field.resolution
        n_lin = max(1, math.ceil(self.search_linear / (COARSE * res)))
        n_ang = max(1, math.ceil(self.search_angular / COARSE_ANGLE))
        coarse_offsets = np.arange(-n_lin, n_lin + 1) * COARSE
        coarse_angles = np.arange(-n_ang, n_ang + 1) * COARSE_ANGLE
        scores = self._scores(field, pooled, points, prior, angles=coarse_angles, offsets=coarse_offsets, spread=spread)
        best: tuple[float, float, int, int] = (-math.inf, 0.0, 0, 0)
        for flat in np.argsort(scores, axis=None)[::-1][:TOP_CANDIDATES]:
            a, ox, oy = np.unravel_index(flat, scores.shape)
            fine_angles = coarse_angles[a] + np.arange(-2, 3) * FINE_ANGLE
            half = COARSE // 2
            fine_offsets = np.arange(-half, half + 1)
            fine = self._scores(
                field,
                likelihood,
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
        return self._evaluate(field, likelihood, points, pose)

    def _scores(
        self,
        field: DistanceField,
        table: FloatArray,
        points: FloatArray,
        prior: Pose2D,
        *,
        angles: FloatArray,
        offsets: npt.NDArray[np.int64],
        base: tuple[int, int] = (0, 0),
        spread: tuple[float, float] = (1.0, 1.0),
    ) -> FloatArray:
        """Mean table value minus the prior penalty, for every (angle, x offset, y offset) in cells."""
        res = field.resolution
        yaw = prior.yaw + angles
        c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        wx = prior.x + c * points[:, 0] - s * points[:, 1] + base[0] * res
        wy = prior.y + s * points[:, 0] + c * points[:, 1] + base[1] * res
        ix, iy = field.cells(wx, wy)  # (A, N)
        h, w = table.shape
        # Offsets within the padding never leave the padded table; clip anyway for very far points.
        cx = _clamp(ix[:, None, :] + offsets[None, :, None], w - 1)  # (A, K, N)
        cy = _clamp(iy[:, None, :] + offsets[None, :, None], h - 1)
        flat = cy[:, None, :, :] * w + cx[:, :, None, :]  # (A, Kx, Ky, N)
        score = table.ravel()[flat].mean(axis=3)
        ox = (base[0] + offsets) * res / spread[0]
        oy = (base[1] + offsets) * res / spread[0]
        oa = angles / spread[1]
        z2 = oa[:, None, None] ** 2 + ox[None, :, None] ** 2 + oy[None, None, :] ** 2
        penalty = PRIOR_WEIGHT * np.log1p(0.5 * z2)
        return np.asarray(score - penalty, dtype=np.float64)

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
        prior_info = np.array([spread[0] ** -2, spread[0] ** -2, spread[1] ** -2])
        res = field.resolution
        x, y, yaw = start.x, start.y, start.yaw
        cutoff = 4.0 * res
        huber = 0.5 * res
        for _ in range(iterations):
            c, s = math.cos(yaw), math.sin(yaw)
            wx = x + c * points[:, 0] - s * points[:, 1]
            wy = y + s * points[:, 0] + c * points[:, 1]
            mx, my, normal = field.nearest_surface(wx, wy)
            use = np.isfinite(normal) & (np.hypot(wx - mx, wy - my) < cutoff)
            if int(use.sum()) < 3:
                break
            nx, ny = np.cos(normal[use]), np.sin(normal[use])
            # residual r = n . (R p + t - m); dr/dtheta = n . (-s px - c py, c px - s py)
            r = nx * (wx[use] - mx[use]) + ny * (wy[use] - my[use])
            px, py = points[use, 0], points[use, 1]
            jac = np.stack([nx, ny, nx * (-s * px - c * py) + ny * (c * px - s * py)], axis=1)
            n = r.size
            weight = np.where(np.abs(r) <= huber, 1.0, huber / np.maximum(np.abs(r), 1e-12))
            w = weight / ((POINT_SIGMA_CELLS * res) ** 2 * max(1.0, n / INDEPENDENT_POINTS))
            deviation = np.array([x - prior.x, y - prior.y, wrap_angle(yaw - prior.yaw)])
            # Iteratively reweighted Cauchy prior, as in the search: far from odometry it pulls less.
            info = prior_info / (1.0 + 0.5 * float(np.sum(prior_info * deviation**2)))
            hess = (jac * w[:, None]).T @ jac + np.diag(info)
            step = -np.linalg.solve(hess, (jac * w[:, None]).T @ r + info * deviation)
            x, y, yaw = x + step[0], y + step[1], yaw + step[2]
            if abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-5:
                break
        return Pose2D(x, y, wrap_angle(yaw))

    def _evaluate(self, field: DistanceField, likelihood: FloatArray, points: FloatArray, pose: Pose2D) -> MatchResult:
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        wx = pose.x + c * points[:, 0] - s * points[:, 1]
        wy = pose.y + s * points[:, 0] + c * points[:, 1]
        d, _, _ = field.interpolate(wx, wy)
        score = float(np.mean(np.exp(-(d**2) / (2.0 * self.sigma**2))))
        return MatchResult(pose, score, float(np.mean(d < 1.5 * field.resolution)))
