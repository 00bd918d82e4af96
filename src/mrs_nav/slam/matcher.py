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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray, Pose2D, poses_agree, wrap_angle
from mrs_nav.slam.grid import (
    GRID_ARRAYS_TYPE,
    TILE,
    Float32Array,
    GridArrays,
    GridCells,
    IntArray,
    LogOddsGrid,
    TileTable,
    _tile_value,
)

COARSE = 4  # cells per coarse translation step
COARSE_ANGLE = math.radians(1.0)
FINE_ANGLE = math.radians(0.25)
TOP_CANDIDATES = 8
PRIOR_WEIGHT = 0.05  # score units (mean likelihood, 0..1) per squared prior standard deviation, halved
NORMAL_RADIUS = 2  # cells: the neighbourhood whose hits define a surface normal
POINT_SIGMA_CELLS = 0.5  # assumed standard deviation of a point-to-hit residual, in cells
FIELD_MAX_DISTANCE = 0.5  # m, truncation of the distance field
# A match explaining fewer of the scan's points than this is lost, and searched for again widely (match_in_grid)
LOST_BELOW = 0.3
RECOVERY_SEARCH_M = 1.0  # m, half-width of that search's translation window; its headings: all round
RECOVERED_INLIERS = 0.5  # share of points the wide search must explain to be taken
# A pose the wide search finds is taken for a scan only when the search for the next scan asks for the same
# correction of its prediction, within this much (m, rad) (Recoveries)
RECOVERY_AGREES = (0.2, math.radians(3.0))
INDEPENDENT_POINTS = 20.0  # neighbouring scan points are correlated; count at most this many as independent
# A match explaining fewer of the scan's points than this is weak, and searched for again in a window of
# WINDOW_SIGMAS standard deviations of the odometry prediction (at most WINDOW_MAX, m and rad) where that is wider
# than the usual one; the wider search's match is taken where it explains WIDER_GAIN times as many (match_in_grid).
WEAK_BELOW = 0.5
WINDOW_SIGMAS = 3.0
WINDOW_MAX = (2.0, math.pi)
WIDER_GAIN = 1.5

CellArray = npt.NDArray[np.int32]  # squared cell distances and grid indices of the distance field
# What the compiled surface lookup needs of a field (DistanceField.kernel_args): the window's origin (m), the
# nearest occupied cell's grid indices per window cell, and the grid.
SurfaceArgs = tuple[float, float, CellArray, CellArray, GridArrays]


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


def match_reach(matcher: ScanMatcher, resolution: float) -> float:
    """How far (m) beyond the scan's points at the prior :func:`match_in_grid` may read the grid: its widest
    translation window (the matcher's, the wider search's, the recovery search's), the distance field's reach,
    and the cells round the nearest walls whose hits give their normals (and one for rounding)."""
    window = max(matcher.search_linear, WINDOW_MAX[0], RECOVERY_SEARCH_M)
    return window + FIELD_MAX_DISTANCE + (NORMAL_RADIUS + 2) * resolution


@dataclass
class Recoveries:
    """The wide searches of one map's scans (:func:`match_in_grid`): the correction of its prediction that the
    last scan's search asked for, held until the next scan's search confirms or drops it (while it is held, the
    last scan is in doubt)."""

    # found pose o prior^-1 (a move of the map frame) of the last scan, when its search found one
    pending: Pose2D | None = None


def match_in_grid(  # noqa: PLR0917 - the local track and the SLAM call it alike, positionally
    matcher: ScanMatcher,
    grid: LogOddsGrid,
    points: FloatArray,
    prior: Pose2D,
    spread: tuple[float, float],
    recoveries: Recoveries | None = None,
) -> MatchResult:
    """``matcher``'s match of the scan ``points`` (laser frame) in ``grid`` near the laser pose ``prior``, whose
    odometry prediction has standard deviations ``spread`` (m, rad).

    A weak match (explaining fewer than :data:`WEAK_BELOW` of the points) is searched for again in a window of
    :data:`WINDOW_SIGMAS` times ``spread`` when that is wider than ``matcher``'s, with the same prior, and
    replaced where the wider match explains :data:`WIDER_GAIN` times as many points. Why: the window is sized for
    scans a few tens of centimetres apart; on a log whose scans are metres apart (Orebro's, 1 m median, up to 3 m)
    the odometry can be off by more than the window, and the best fit inside it is a wrong one (there, one scan
    3 m on from the last was mapped 0.7 m and 9 degrees off, its match explaining a quarter of its points, and
    the recovery search below found no better fit without the prior; the map was broken, ATE 1.5 m).
    Only weak matches are searched again: where odometry is good (FHW's scans are as far apart), a wider window
    over a crowd finds wrong fits that a strong match would not have been replaced by (FHW's map broke when every
    scan was searched so).

    When the match still explains fewer than :data:`LOST_BELOW` of the points, the scan is searched for again
    over every heading and :data:`RECOVERY_SEARCH_M` around ``prior``, without the odometry prior, and the result
    taken where it explains at least :data:`RECOVERED_INLIERS` of them and twice as many as the match so far.

    Why: odometry can miss a whole turn (the Seattle log has a scan after an unrecorded 80 degree turn; wheels
    slip, a robot is carried). Searched only near the odometry, such a scan fits nowhere (7 % of its points on
    walls), is mapped at the wrong heading, and the rest of the map is built on it, consistent with itself and
    wrong. On that log 95 % of the matches explain at least half of their points and 99 % at least 30 %, so the
    wide search runs only where it can help.

    With ``recoveries`` (the SLAM's whole map), a pose the wide search finds is taken only when the search for
    the next scan asks for the same correction of its prediction (:data:`RECOVERY_AGREES`); until then the scan
    is in doubt: ``recoveries.pending`` is set and the match returned is the one near the prediction. Why: a scan
    that sees mostly unmapped space (round a corner into a new corridor) explains few points anywhere, and a
    search over every heading finds some wrong pose that explains half. On the 13 public logs, of the four poses
    this search gave the whole map's scans at once, only Seattle's (odometry 80 degrees short) was right: the
    MIT Infinite Corridor's was turned 95 degrees at a corridor junction, FHW's and the Freiburg campus's moved
    1.5 m and 0.9 m along repeated structure, each where odometry was within 0.05 m and 2 degrees of the truth.
    A turn that odometry missed leaves the next scan lost the same way; these wrong fits were not repeated (the
    Infinite Corridor's four scans in doubt were none confirmed; Seattle's turn is taken one scan later).
    Without ``recoveries`` (the local track's submap of the last few metres) the pose is taken at once.
    """
    correction = None
    if recoveries is not None:
        correction, recoveries.pending = recoveries.pending, None
    match = matcher.match(window_field(grid, points, prior, matcher.search_linear), points, prior, spread)
    linear = min(max(matcher.search_linear, WINDOW_SIGMAS * spread[0]), max(matcher.search_linear, WINDOW_MAX[0]))
    angular = min(max(matcher.search_angular, WINDOW_SIGMAS * spread[1]), max(matcher.search_angular, WINDOW_MAX[1]))
    if match.inlier_fraction < WEAK_BELOW and (linear, angular) != (matcher.search_linear, matcher.search_angular):
        wider = ScanMatcher(matcher.sigma, linear, angular).match(
            window_field(grid, points, prior, linear), points, prior, spread
        )
        if wider.inlier_fraction >= WIDER_GAIN * match.inlier_fraction:
            match = wider
    if match.inlier_fraction >= LOST_BELOW or points.shape[0] < 3:
        return match
    wide = ScanMatcher(matcher.sigma, RECOVERY_SEARCH_M, math.pi)
    # The window holds the scan turned any way round the prior: a disc of its reach plus the search.
    reach = float(np.max(np.hypot(points[:, 0], points[:, 1]))) + RECOVERY_SEARCH_M + FIELD_MAX_DISTANCE
    bounds = (prior.x - reach, prior.y - reach, prior.x + reach, prior.y + reach)
    field = DistanceField(grid, bounds, FIELD_MAX_DISTANCE, math.ceil(FIELD_MAX_DISTANCE / grid.resolution) + 2)
    found = wide.match(field, points, prior, (1e3, 1e3))
    if found.inlier_fraction < max(RECOVERED_INLIERS, 2.0 * match.inlier_fraction):
        return match
    if recoveries is None or (
        correction is not None and poses_agree(correction.compose(prior), found.pose, RECOVERY_AGREES)
    ):
        return found
    recoveries.pending = found.pose.compose(prior.inverse())
    return match


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


# Compiled kernels (mrs_nav.jit): the per-point work of the search and the refinement, which numpy can only do
# through (angles x offsets x points) temporaries and dozens of small-array calls per iteration.

# SurfaceArgs (DistanceField.kernel_args) as a numba type.
_SURFACE_ARGS = "Tuple((float64, float64, int32[:, ::1], int32[:, ::1], " + GRID_ARRAYS_TYPE + "))"


@numba.njit("UniTuple(float64, 2)(" + GRID_ARRAYS_TYPE + ", int64, int64)", cache=True)  # type: ignore[misc]
def _mean_hit(grid: GridArrays, iy: int, ix: int) -> tuple[float, float]:
    """LogOddsGrid.mean_hits of one cell."""
    _, _, hit_table, hit_x, hit_y, hit_count, cells, origin_x, origin_y, res = grid
    gy, gx = iy + cells[2], ix + cells[3]
    # The slot looked up once for the three pools: _tile_value for each took a quarter longer in the refinement.
    slot = hit_table[gy // TILE, gx // TILE]
    # np.float64, not float(): numba's float() of a float32 stays float32, and so would the division.
    count = np.float64(hit_count[slot, gy % TILE, gx % TILE]) if slot >= 0 else 0.0
    dx = np.float64(hit_x[slot, gy % TILE, gx % TILE]) / count if count > 0.0 else 0.5 * res
    dy = np.float64(hit_y[slot, gy % TILE, gx % TILE]) / count if count > 0.0 else 0.5 * res
    return float(origin_x + ix * res + dx), float(origin_y + iy * res + dy)


@numba.njit("float64(" + GRID_ARRAYS_TYPE + ", int64, int64)", cache=True)  # type: ignore[misc]
def _normal_at(grid: GridArrays, iy: int, ix: int) -> float:
    """Surface normal angle (rad) at grid cell ``(iy, ix)`` from the principal axes of the mean hits of the
    occupied cells within ``NORMAL_RADIUS`` (clipped at the grid's edge); NaN where fewer than 3 are."""
    table, logodds, hit_table, _, _, hit_count, cells, _, _, _ = grid
    height, width, shift_y, shift_x = cells
    size = 2 * NORMAL_RADIUS + 1
    px = np.empty(size * size)
    py = np.empty(size * size)
    n = 0
    for oy in range(-NORMAL_RADIUS, NORMAL_RADIUS + 1):
        gy = min(max(iy + oy, 0), height - 1)
        for ox in range(-NORMAL_RADIUS, NORMAL_RADIUS + 1):
            gx = min(max(ix + ox, 0), width - 1)
            occupied = _tile_value(table, logodds, gy + shift_y, gx + shift_x) > 0.0
            if occupied and _tile_value(hit_table, hit_count, gy + shift_y, gx + shift_x) > 0.0:
                px[n], py[n] = _mean_hit(grid, gy, gx)
                n += 1
    if n < 3:
        return np.nan
    cx = px[:n].sum() / n
    cy = py[:n].sum() / n
    sxx = syy = sxy = 0.0
    for k in range(n):
        dx, dy = px[k] - cx, py[k] - cy
        sxx += dx * dx
        syy += dy * dy
        sxy += dx * dy
    # Principal (tangent) direction of the local hits; the normal is perpendicular to it.
    return 0.5 * math.atan2(2.0 * sxy, sxx - syy) + 0.5 * math.pi


@numba.njit("UniTuple(int64, 2)(float64, float64, " + _SURFACE_ARGS + ")", cache=True)  # type: ignore[misc]
def _nearest_cell(x: float, y: float, surface: SurfaceArgs) -> tuple[int, int]:
    """Grid indices of the nearest occupied cell to a point (m) in the field's window (the point clipped into
    it); -1 where none is within the truncation."""
    field_x, field_y, near_iy, near_ix, grid = surface
    res = grid[9]
    height, width = near_iy.shape
    ix = min(max(math.floor((x - field_x) / res), 0), width - 1)
    iy = min(max(math.floor((y - field_y) / res), 0), height - 1)
    return near_iy[iy, ix], near_ix[iy, ix]


@numba.njit("UniTuple(float64, 3)(" + GRID_ARRAYS_TYPE + ", int64, int64)", cache=True)  # type: ignore[misc]
def _cell_surface(grid: GridArrays, iy: int, ix: int) -> tuple[float, float, float]:
    """Mean hit (m) of the occupied grid cell ``(iy, ix)`` and the surface normal (rad) there; NaN where no
    normal is defined, or no cell is (``iy`` -1)."""
    if iy < 0:
        return np.nan, np.nan, np.nan
    normal = _normal_at(grid, iy, ix)
    if not math.isfinite(normal):
        return np.nan, np.nan, np.nan
    mx, my = _mean_hit(grid, iy, ix)
    return mx, my, normal


@numba.njit("float64[:, ::1](float64[::1], float64[::1], " + _SURFACE_ARGS + ")", cache=True)  # type: ignore[misc]
def _nearest_surfaces(
    x: FloatArray,
    y: FloatArray,
    surface: SurfaceArgs,
) -> FloatArray:
    """DistanceField.nearest_surface: rows mx, my, normal of the nearest occupied cell of every point."""
    out = np.empty((3, x.size))
    for k in range(x.size):
        iy, ix = _nearest_cell(x[k], y[k], surface)
        out[0, k], out[1, k], out[2, k] = _cell_surface(surface[4], iy, ix)
    return out


@numba.njit(  # type: ignore[misc]
    "UniTuple(float64, 3)(float64[:, ::1], UniTuple(float64, 3), UniTuple(float64, 3), float64[::1], int64, "
    + _SURFACE_ARGS
    + ")",
    cache=True,
)
def _refine(  # noqa: PLR0917 - numba kernels take positional arguments
    points: FloatArray,
    start: tuple[float, float, float],
    prior: tuple[float, float, float],
    prior_info: FloatArray,
    iterations: int,
    surface: SurfaceArgs,
) -> tuple[float, float, float]:
    """ScanMatcher.refine's Gauss-Newton iterations from the laser pose ``start`` (x, y m, yaw rad) with the
    odometry prior ``prior``; the refined pose (yaw not wrapped)."""
    x, y, yaw = start
    prior_x, prior_y, prior_yaw = prior
    res = surface[4][9]
    n_points = points.shape[0]
    cutoff = 4.0 * res  # pairs farther apart than this are not the same surface
    huber = 0.5 * res
    residual = np.empty(n_points)
    jac = np.empty((n_points, 3))
    # Each point's nearest occupied cell and its surface (mean hit, normal) as last looked up: from one iteration
    # to the next most points keep their cell, and the normal, from up to 25 cells' mean hits, is most of the
    # refinement's work.
    cell_y = np.full(n_points, -1, dtype=np.int64)
    cell_x = np.full(n_points, -1, dtype=np.int64)
    found = np.full((n_points, 3), np.nan)  # cell -1: no surface
    for _ in range(iterations):
        c, s = math.cos(yaw), math.sin(yaw)
        n = 0
        for k in range(n_points):
            px, py = points[k, 0], points[k, 1]
            wx = x + c * px - s * py
            wy = y + s * px + c * py
            iy, ix = _nearest_cell(wx, wy, surface)
            if iy != cell_y[k] or ix != cell_x[k]:
                found[k, 0], found[k, 1], found[k, 2] = _cell_surface(surface[4], iy, ix)
                cell_y[k], cell_x[k] = iy, ix
            mx, my, normal = found[k, 0], found[k, 1], found[k, 2]
            if not (math.isfinite(normal) and math.hypot(wx - mx, wy - my) < cutoff):
                continue
            nx, ny = math.cos(normal), math.sin(normal)
            # residual r = n . (R p + t - m); dr/dtheta = n . (-s px - c py, c px - s py)
            residual[n] = nx * (wx - mx) + ny * (wy - my)
            jac[n, 0], jac[n, 1] = nx, ny
            jac[n, 2] = nx * (-s * px - c * py) + ny * (c * px - s * py)
            n += 1
        if n < 3:
            break
        scale = 1.0 / ((POINT_SIGMA_CELLS * res) ** 2 * max(1.0, n / INDEPENDENT_POINTS))
        deviation = np.array([x - prior_x, y - prior_y, (yaw - prior_yaw + math.pi) % (2.0 * math.pi) - math.pi])
        # Iteratively reweighted Cauchy prior, as in the search: far from odometry it pulls less.
        info = prior_info / (1.0 + 0.5 * np.sum(prior_info * deviation**2))
        hess = np.diag(info)
        grad = info * deviation
        for k in range(n):
            r = residual[k]
            w = scale * (1.0 if abs(r) <= huber else huber / max(abs(r), 1e-12))
            for i in range(3):
                grad[i] += w * jac[k, i] * r
                for j in range(3):
                    hess[i, j] += w * jac[k, i] * jac[k, j]
        step = -np.linalg.solve(hess, grad)
        x, y, yaw = x + step[0], y + step[1], yaw + step[2]
        if abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-5:
            break
    return x, y, yaw


@numba.njit(  # type: ignore[misc]
    "float64[:, :, ::1](int32[:, ::1], float64[::1], UniTuple(float64, 3), float64[:, ::1], UniTuple(float64, 3), "
    "float64[::1], int64[::1], UniTuple(int64, 2), UniTuple(float64, 2))",
    cache=True,
)
def _search_scores(  # noqa: PLR0917 - numba kernels take positional arguments
    squared: CellArray,
    values: FloatArray,
    window: tuple[float, float, float],
    points: FloatArray,
    prior: tuple[float, float, float],
    angles: FloatArray,
    offsets: IntArray,
    base: tuple[int, int],
    spread: tuple[float, float],
) -> FloatArray:
    """ScanMatcher._scores: for every heading ``prior`` yaw + ``angles`` (rad) and every (x, y) cell offset
    ``base`` + ``offsets``, the mean value ``values[squared]`` (a window: corner x, y and resolution, m) under
    ``points`` (laser frame) placed there, cell indices clipped into the window, minus the odometry prior's penalty
    with standard deviations ``spread`` (m, rad): an (angles, x offsets, y offsets) array."""
    origin_x, origin_y, res = window
    x, y = prior[0] + base[0] * res, prior[1] + base[1] * res
    height, width = squared.shape
    cells = squared.ravel()
    n = points.shape[0]
    k = offsets.size
    out = np.empty((angles.size, k, k))
    # Per heading, each point's cell moved by each offset and clipped: row starts in ``cells`` per y offset,
    # columns per x offset; then the point's values at every offset added to that offset's sum. Point by point,
    # not offset by offset over all points: a point's k x k cells lie within a few cache lines, and the sums
    # still add the points in their order, the same sums to the bit (over a quarter less time on the Freiburg
    # campus log's windows, some of a million cells; a tenth on the Freiburg 079 log's).
    rows = np.empty(k, dtype=np.int64)
    cols = np.empty(k, dtype=np.int64)
    total = np.empty((k, k))
    for a in range(angles.size):
        yaw = prior[2] + angles[a]
        c, s = math.cos(yaw), math.sin(yaw)
        total[:] = 0.0
        for p in range(n):
            px, py = points[p, 0], points[p, 1]
            ix = min(max(math.floor((x + c * px - s * py - origin_x) / res), 0), width - 1)
            iy = min(max(math.floor((y + s * px + c * py - origin_y) / res), 0), height - 1)
            for j in range(k):
                rows[j] = min(max(iy + offsets[j], 0), height - 1) * width
                cols[j] = min(max(ix + offsets[j], 0), width - 1)
            for kx in range(k):
                for ky in range(k):
                    total[kx, ky] += values[cells[rows[ky] + cols[kx]]]
        for kx in range(k):
            for ky in range(k):
                z2 = (angles[a] / spread[1]) ** 2 + ((base[0] + offsets[kx]) * res / spread[0]) ** 2
                z2 += ((base[1] + offsets[ky]) * res / spread[0]) ** 2
                out[a, kx, ky] = total[kx, ky] / n - PRIOR_WEIGHT * math.log1p(0.5 * z2)
    return out


# A cell's 8 neighbours (rows, columns), in row-major order: the first four come before it, the last four after it
_NEIGHBOURS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)], dtype=np.int64)


@numba.njit(  # type: ignore[misc]
    "Tuple((int32[:, ::1], int32[:, ::1], int32[:, ::1], int64))("
    "int32[:, ::1], float32[:, :, ::1], int32[:, ::1], UniTuple(int64, 4), UniTuple(int64, 2), UniTuple(int64, 2), "
    "int64, int64)",
    cache=True,
)
def _truncated_field(  # noqa: PLR0917 - numba kernels take positional arguments
    table: TileTable,
    logodds: Float32Array,
    hit_table: TileTable,
    cells: GridCells,
    rows: tuple[int, int],
    cols: tuple[int, int],
    pad: int,
    cap: int,
) -> tuple[CellArray, CellArray, CellArray, int]:
    """DistanceField's arrays for the window ``[y0, y1) x [x0, x1)`` (``rows``, ``cols``; inside the grid) of a
    grid's log-odds tiles (``table``, ``logodds``, ``hit_table``, ``cells``: as in LogOddsGrid.kernel_args): the
    squared distance in cells to the nearest occupied cell (log-odds above 0), at most ``cap``, and that cell's grid
    indices (-1 where none is nearer than the cap), padded by ``pad`` cells of ``cap`` and -1; and how many cells
    are occupied.

    Each occupied cell writes its distance into the disc of cells it can be nearest to (squared distance below
    ``cap``). Why not a Euclidean distance transform: only the truncated distances matter, walls are a few per
    cent of a window's cells, and the transform's exact distances across the empty rest cost six times as much
    on the Intel log's windows, for the same capped distances. Of equally near cells the first in row order is
    kept; scipy's transform keeps another in about 1 % of cells, and the last in row order gives the Intel
    replay's ATE 0.073 m against 0.070 m: the choice matters no more than any small perturbation does.

    Two shortcuts that leave every array as the whole discs give it, to the bit. Only tiles with hit tiles are read:
    no other tile holds an occupied cell (mrs_nav.slam.grid), and the Freiburg campus log's windows are half a
    million cells of mostly open ground. And an occupied cell writes only where none of its occupied neighbours is
    nearer, or as near and first in row order (the discs' order): a neighbour one cell away is nearer on one side of
    a line between the two, so in a wall one cell thick a cell writes a line of its disc, not all of it. Both took
    the field from 1.0 to 0.55 ms a window on the Freiburg 079 log and from 3.7 to 1.7 ms on the campus (their
    replays' first 2500 windows, the same arrays).
    """
    _, _, shift_y, shift_x = cells
    (y0, y1), (x0, x1) = rows, cols
    height, width = y1 - y0, x1 - x0
    shape = (height + 2 * pad, width + 2 * pad)
    squared = np.full(shape, cap, dtype=np.int32)
    near_iy = np.full(shape, -1, dtype=np.int32)
    near_ix = np.full(shape, -1, dtype=np.int32)
    reach = int(math.sqrt(cap))  # cells with a squared distance below cap lie within this many cells
    # Half-width of the disc in each row dr away: the columns dc with dr^2 + dc^2 < cap (-1: none)
    spans = np.empty(reach + 1, dtype=np.int64)
    for dr in range(reach + 1):
        spans[dr] = int(math.sqrt(cap - 1 - dr * dr)) if dr * dr < cap else -1
    # Per set of occupied neighbours (a bit each, _NEIGHBOURS' order), once it is met: the columns dc from low[dr]
    # to high[dr] of each disc row dr (from -reach) where the cell is nearer than each of those neighbours, or
    # as near and before it. A neighbour (ny, nx) is as near as the cell where 2 (dr ny + dc nx) = ny^2 + nx^2.
    ready = np.zeros(1 << _NEIGHBOURS.shape[0], dtype=np.bool_)
    low = np.empty((ready.size, 2 * reach + 1), dtype=np.int64)
    high = np.empty((ready.size, 2 * reach + 1), dtype=np.int64)
    occupied = 0
    if height <= 0 or width <= 0:  # a window past the grid's edge: no tile to look up
        return squared, near_iy, near_ix, occupied
    gy0, gx0 = y0 + shift_y, x0 + shift_x
    # Row by row, the window's tiles along each: the occupied cells in row order, as the discs' ties need
    for gy in range(gy0, gy0 + height):
        row = gy - gy0
        for tx in range(gx0 // TILE, (gx0 + width - 1) // TILE + 1):
            slot = table[gy // TILE, tx]
            if hit_table[gy // TILE, tx] < 0 or slot < 0:
                continue
            for gx in range(max(tx * TILE, gx0), min(tx * TILE + TILE, gx0 + width)):
                if not logodds[slot, gy % TILE, gx % TILE] > 0.0:
                    continue
                occupied += 1
                col = gx - gx0
                mask = 0
                for b in range(_NEIGHBOURS.shape[0]):
                    r, c = row + _NEIGHBOURS[b, 0], col + _NEIGHBOURS[b, 1]
                    if 0 <= r < height and 0 <= c < width and _tile_value(table, logodds, gy0 + r, gx0 + c) > 0.0:
                        mask |= 1 << b
                if not ready[mask]:
                    ready[mask] = True
                    for dr in range(-reach, reach + 1):
                        lo, hi = -spans[abs(dr)], spans[abs(dr)]
                        for b in range(_NEIGHBOURS.shape[0]):
                            if not mask & (1 << b):
                                continue
                            ny, nx = _NEIGHBOURS[b, 0], _NEIGHBOURS[b, 1]
                            # the cell keeps the dc with 2 dc nx <= bound
                            bound = ny * ny + nx * nx - (1 if b < 4 else 0) - 2 * dr * ny
                            if nx > 0:
                                hi = min(hi, bound // 2)
                            elif nx < 0:
                                lo = max(lo, -(bound // 2))
                            elif bound < 0:
                                hi = lo - 1
                        low[mask, dr + reach], high[mask, dr + reach] = lo, hi
                for r in range(max(row - reach, 0), min(row + reach, height - 1) + 1):
                    k = r - row + reach
                    for c in range(max(col + low[mask, k], 0), min(col + high[mask, k], width - 1) + 1):
                        d = (r - row) ** 2 + (c - col) ** 2
                        if d < squared[r + pad, c + pad]:
                            squared[r + pad, c + pad] = d
                            near_iy[r + pad, c + pad] = row + y0
                            near_ix[r + pad, c + pad] = col + x0
    return squared, near_iy, near_ix, occupied


@numba.njit(  # type: ignore[misc]
    "Tuple((float64[::1], float64[::1], int32[:, ::1]))(int32[:, ::1], float64[::1], float64, float64, int64)",
    cache=True,
)
def _likelihoods(
    squared: CellArray, distance_table: FloatArray, sigma: float, sigma_coarse: float, half: int
) -> tuple[FloatArray, FloatArray, CellArray]:
    """The likelihoods ``exp(-d^2 / (2 sigma^2))`` of the distances ``distance_table`` (m), and the coarse ones
    (``sigma_coarse``), by squared cell distance; and the squared distances ``squared`` min-pooled over
    ``2 half + 1`` cells square (edge cells repeated beyond the edge). The likelihood falls as the distance
    grows, so the coarse likelihood of the pooled distances is the coarse likelihood max-pooled.

    Why tables and not likelihood arrays over the window: the search reads a few cells per point, and writing two
    float arrays of the window took half as long again as the pooling (0.18 ms against 0.36 ms on the Intel log's
    windows of about 65 000 cells; the Freiburg campus log's are a million cells or more)."""
    fine_table = np.exp(-(distance_table**2) / (2.0 * sigma**2))
    wide_table = np.exp(-(distance_table**2) / (2.0 * sigma_coarse**2))
    height, width = squared.shape
    # Pooled separably, each as the minimum with shifted copies: loops along rows that the compiler vectorises (a
    # window's pooling took four times as long cell by cell). Down the columns first, each row the minimum of the
    # rows of its run begun from the run's first (not from a copy of itself, which the run holds again), then
    # along the rows: a fifth to a quarter less time than along the rows first (0.22 against 0.17 ms on the
    # Freiburg 079 log's windows, 1.47 against 1.16 ms on the campus's).
    down = np.empty((height, width), dtype=np.int32)
    for row in range(height):
        first, last = max(row - half, 0), min(row + half, height - 1)
        for col in range(width):  # a loop: a slice assignment took up to a third longer
            down[row, col] = squared[first, col]
        for r in range(first + 1, last + 1):
            for col in range(width):
                down[row, col] = min(down[row, col], squared[r, col])
    pooled = down.copy()
    for row in range(height):
        for shift in range(1, half + 1):
            for col in range(shift, width):
                pooled[row, col] = min(pooled[row, col], down[row, col - shift])
            for col in range(width - shift):
                pooled[row, col] = min(pooled[row, col], down[row, col + shift])
    return fine_table, wide_table, pooled
