"""The compiled kernels of the matcher and the grid against plain numpy references on random inputs.

The references are the numpy implementations the kernels replaced; sums are taken in another order, so
results agree to float rounding, not bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.matcher import COARSE, DistanceField, ScanMatcher
from mrs_nav.slam.matcher_kernels import (
    INDEPENDENT_POINTS,
    NORMAL_RADIUS,
    POINT_SIGMA_CELLS,
    PRIOR_WEIGHT,
    _likelihoods,
)
from mrs_nav.slam.scan import BeamSplit, LaserScanData, split_beams

RES = 0.05


def random_grid(rng: np.random.Generator) -> LogOddsGrid:
    """A 6 m x 5 m grid with random walls: a few line segments of hits plus scattered single cells."""
    grid = LogOddsGrid(RES, (-3.0, -2.5, 3.0, 2.5), grows=False)
    logodds, hit_x, hit_y, hit_count = grid.dense()
    for _ in range(6):
        a, b = rng.uniform([-2.8, -2.3], [2.8, 2.3], size=(2, 2))
        t = rng.uniform(0.0, 1.0, 200)[:, None]
        hits = a + t * (b - a) + rng.normal(0.0, 0.01, (200, 2))
        ix, iy = grid.cell_of(hits[:, 0], hits[:, 1])
        inside = (ix >= 0) & (ix < grid.width) & (iy >= 0) & (iy < grid.height)
        ix, iy, hits = ix[inside], iy[inside], hits[inside]
        np.add.at(hit_x, (iy, ix), hits[:, 0] - (grid.origin_x + ix * RES))
        np.add.at(hit_y, (iy, ix), hits[:, 1] - (grid.origin_y + iy * RES))
        np.add.at(hit_count, (iy, ix), 1.0)
        logodds[iy, ix] = 2.0
    scattered = rng.integers(0, logodds.size, 60)
    logodds.ravel()[scattered] = rng.choice([-1.0, 1.0], 60)  # occupied without hits, or free
    grid.assign(logodds, hit_x, hit_y, hit_count)
    return grid


PAD = 8


def field_of(grid: LogOddsGrid, rng: np.random.Generator) -> DistanceField:
    x0, y0 = rng.uniform(-2.5, -1.0, 2)
    return DistanceField(grid, (x0, y0, x0 + rng.uniform(2.0, 4.0), y0 + rng.uniform(2.0, 3.5)), 0.5, PAD)


def distances(field: DistanceField) -> np.ndarray:
    """The field's truncated distances (m) over its window."""
    return field.distance_table[field.squared]


def cells(field: DistanceField, x: np.ndarray, y: np.ndarray):
    h, w = field.squared.shape
    ix = np.clip(np.floor((x - field.origin_x) / field.resolution).astype(np.int64), 0, w - 1)
    iy = np.clip(np.floor((y - field.origin_y) / field.resolution).astype(np.int64), 0, h - 1)
    return ix, iy


# --- numpy references -------------------------------------------------------------------------------------------


def reference_nearest_surface(field: DistanceField, x: np.ndarray, y: np.ndarray):
    grid = field.grid
    ix, iy = cells(field, x, y)
    niy, nix = field.near_iy[iy, ix], field.near_ix[iy, ix]
    inside = niy >= 0
    niy, nix = np.maximum(niy, 0), np.maximum(nix, 0)
    hx, hy = grid.mean_hits(niy, nix)
    offsets = np.arange(-NORMAL_RADIUS, NORMAL_RADIUS + 1)
    oy, ox = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
    gy = np.clip(niy[:, None] + oy[None, :], 0, grid.height - 1)
    gx = np.clip(nix[:, None] + ox[None, :], 0, grid.width - 1)
    logodds, _, _, hit_count = grid.dense()
    occupied = (logodds[gy, gx] > 0.0) & (hit_count[gy, gx] > 0)
    px, py = grid.mean_hits(gy, gx)
    w = occupied.astype(np.float64)
    count = w.sum(axis=1)
    safe = np.maximum(count, 1.0)
    cx = (w * px).sum(axis=1) / safe
    cy = (w * py).sum(axis=1) / safe
    dx, dy = px - cx[:, None], py - cy[:, None]
    sxx, syy, sxy = (w * dx * dx).sum(axis=1), (w * dy * dy).sum(axis=1), (w * dx * dy).sum(axis=1)
    normal = np.where(count >= 3, 0.5 * np.arctan2(2.0 * sxy, sxx - syy) + 0.5 * np.pi, np.nan)
    good = inside & np.isfinite(normal)
    nan = np.full(x.shape, np.nan)
    return np.where(good, hx, nan), np.where(good, hy, nan), np.where(good, normal, nan)


def reference_refine(field, points, start, *, prior, spread, iterations=10):
    prior_info = np.array([spread[0] ** -2, spread[0] ** -2, spread[1] ** -2])
    res = field.resolution
    x, y, yaw = start.x, start.y, start.yaw
    cutoff, huber = 4.0 * res, 0.5 * res
    for _ in range(iterations):
        c, s = math.cos(yaw), math.sin(yaw)
        wx = x + c * points[:, 0] - s * points[:, 1]
        wy = y + s * points[:, 0] + c * points[:, 1]
        mx, my, normal = reference_nearest_surface(field, wx, wy)
        use = np.isfinite(normal) & (np.hypot(wx - mx, wy - my) < cutoff)
        if int(use.sum()) < 3:
            break
        nx, ny = np.cos(normal[use]), np.sin(normal[use])
        r = nx * (wx[use] - mx[use]) + ny * (wy[use] - my[use])
        px, py = points[use, 0], points[use, 1]
        jac = np.stack([nx, ny, nx * (-s * px - c * py) + ny * (c * px - s * py)], axis=1)
        weight = np.where(np.abs(r) <= huber, 1.0, huber / np.maximum(np.abs(r), 1e-12))
        w = weight / ((POINT_SIGMA_CELLS * res) ** 2 * max(1.0, r.size / INDEPENDENT_POINTS))
        deviation = np.array([x - prior.x, y - prior.y, wrap_angle(yaw - prior.yaw)])
        info = prior_info / (1.0 + 0.5 * float(np.sum(prior_info * deviation**2)))
        hess = (jac * w[:, None]).T @ jac + np.diag(info)
        step = -np.linalg.solve(hess, (jac * w[:, None]).T @ r + info * deviation)
        x, y, yaw = x + step[0], y + step[1], yaw + step[2]
        if abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-5:
            break
    return Pose2D(x, y, wrap_angle(yaw))


def reference_table_means(field, table, points, prior, *, angles, offsets, base):
    res = field.resolution
    yaw = prior.yaw + angles
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    wx = prior.x + c * points[:, 0] - s * points[:, 1] + base[0] * res
    wy = prior.y + s * points[:, 0] + c * points[:, 1] + base[1] * res
    ix, iy = cells(field, wx, wy)
    h, w = table.shape
    cx = np.clip(ix[:, None, :] + offsets[None, :, None], 0, w - 1)
    cy = np.clip(iy[:, None, :] + offsets[None, :, None], 0, h - 1)
    return table[cy[:, None, :, :], cx[:, :, None, :]].mean(axis=3)


def reference_field_arrays(grid: LogOddsGrid, field: DistanceField, pad: int):
    """Distance (m) and nearest-cell grid indices of ``field``'s window, padded as the field pads them, by brute
    force: every cell against every occupied cell of the window. Of equally near cells the first in row order;
    none (-1, the truncation) where the nearest is not nearer than the field's cap."""
    y0 = round((field.origin_y - grid.origin_y) / RES) + pad
    x0 = round((field.origin_x - grid.origin_x) / RES) + pad
    h, w = field.squared.shape[0] - 2 * pad, field.squared.shape[1] - 2 * pad
    occupied = np.argwhere(grid.occupied()[y0 : y0 + h, x0 : x0 + w])  # row order
    rows, cols = (a.ravel() for a in np.indices((h, w)))
    squared = (rows[:, None] - occupied[None, :, 0]) ** 2 + (cols[:, None] - occupied[None, :, 1]) ** 2
    best = np.argmin(squared, axis=1)
    nearest = squared[np.arange(rows.size), best]
    within = nearest < math.ceil((field.max_distance / RES) ** 2) + 1  # the field's cap
    dist = np.where(within, np.minimum(np.sqrt(nearest) * RES, field.max_distance), field.max_distance)
    near_iy = np.where(within, occupied[best, 0] + y0, -1)
    near_ix = np.where(within, occupied[best, 1] + x0, -1)
    return (
        np.pad(dist.reshape(h, w), pad, constant_values=field.max_distance),
        np.pad(near_iy.reshape(h, w), pad, constant_values=-1),
        np.pad(near_ix.reshape(h, w), pad, constant_values=-1),
    )


def reference_integrate(grid: LogOddsGrid, sensor: Pose2D, beams: BeamSplit) -> None:
    res = grid.resolution
    angles = np.concatenate([beams.hit_angles, beams.free_angles]) + sensor.yaw
    ranges = np.concatenate([beams.hit_ranges, beams.free_ranges])
    cos, sin = np.cos(angles), np.sin(angles)
    ends_x, ends_y = sensor.x + ranges * cos, sensor.y + ranges * sin
    step = 0.5 * res
    n_hit = beams.hit_ranges.size
    lengths = ranges.copy()
    lengths[:n_hit] -= 0.5 * res
    counts = np.maximum(np.ceil(lengths / step).astype(np.int64), 0)
    beam = np.repeat(np.arange(ranges.size), counts)
    t = (np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)) * step
    free_ix, free_iy = grid.cell_of(sensor.x + t * cos[beam], sensor.y + t * sin[beam])
    occ_ix, occ_iy = grid.cell_of(ends_x[:n_hit], ends_y[:n_hit])
    keep = (occ_ix >= 0) & (occ_ix < grid.width) & (occ_iy >= 0) & (occ_iy < grid.height)
    occ_ix, occ_iy = occ_ix[keep], occ_iy[keep]
    logodds, hit_x, hit_y, hit_count = grid.dense()
    np.add.at(hit_x, (occ_iy, occ_ix), ends_x[:n_hit][keep] - (grid.origin_x + occ_ix * res))
    np.add.at(hit_y, (occ_iy, occ_ix), ends_y[:n_hit][keep] - (grid.origin_y + occ_iy * res))
    np.add.at(hit_count, (occ_iy, occ_ix), 1.0)
    keep = (free_ix >= 0) & (free_ix < grid.width) & (free_iy >= 0) & (free_iy < grid.height)
    free = np.zeros(logodds.shape, dtype=bool)
    free[free_iy[keep], free_ix[keep]] = True
    occ = np.zeros(logodds.shape, dtype=bool)
    occ[occ_iy, occ_ix] = True
    free &= ~occ
    logodds[free] -= grid.lfree
    logodds[occ] += grid.loccupied
    np.clip(logodds, -grid.lmax, grid.lmax, out=logodds)
    grid.assign(logodds, hit_x, hit_y, hit_count)


# --- the comparisons ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(5))
def test_nearest_surface_equals_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    field = field_of(random_grid(rng), rng)
    h, w = field.squared.shape
    # Over the window and a little beyond it (clipped into the padding, where no surface is)
    x = rng.uniform(field.origin_x - 0.2, field.origin_x + w * RES + 0.2, 2000)
    y = rng.uniform(field.origin_y - 0.2, field.origin_y + h * RES + 0.2, 2000)
    got = field.nearest_surface(x, y)
    want = reference_nearest_surface(field, x, y)
    assert np.isfinite(want[2]).sum() > 300  # many points have a surface (within the truncation), some not
    assert (~np.isfinite(want[2])).sum() > 10
    for g, w in zip(got, want, strict=True):
        np.testing.assert_allclose(g, w, rtol=0.0, atol=1e-9, equal_nan=True)


@pytest.mark.parametrize("seed", range(5))
def test_refine_equals_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    grid = random_grid(rng)
    field = DistanceField(grid, (-3.0, -2.5, 3.0, 2.5), 0.5, 8)
    # Points on the grid's walls seen from a pose, then matched from a start 5 cm / 2 degrees off.
    occupied = np.argwhere(grid.occupied() & (grid.dense()[3] > 0))
    hx, hy = grid.mean_hits(occupied[:, 0], occupied[:, 1])
    truth = Pose2D(*rng.uniform(-0.5, 0.5, 2), rng.uniform(-math.pi, math.pi))
    c, s = math.cos(truth.yaw), math.sin(truth.yaw)
    dx, dy = hx - truth.x, hy - truth.y
    points = np.ascontiguousarray(np.stack([c * dx + s * dy, -s * dx + c * dy], axis=1)[::4])
    start = Pose2D(truth.x + 0.05, truth.y - 0.03, truth.yaw + math.radians(2.0))
    prior = Pose2D(truth.x + 0.1, truth.y, truth.yaw)
    spread = (rng.uniform(0.02, 0.3), rng.uniform(0.01, 0.2))
    matcher = ScanMatcher(0.05, 0.3, 0.5)
    got = matcher.refine(field, points, start, prior=prior, spread=spread)
    want = reference_refine(field, points, start, prior=prior, spread=spread)
    assert math.hypot(want.x - start.x, want.y - start.y) > 0.01  # the refinement moved
    assert got.x == pytest.approx(want.x, abs=1e-9)
    assert got.y == pytest.approx(want.y, abs=1e-9)
    assert got.yaw == pytest.approx(want.yaw, abs=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_search_scores_equal_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    field = field_of(random_grid(rng), rng)
    values = np.exp(-(field.distance_table**2) / (2.0 * 0.05**2))
    table = values[field.squared]
    points = rng.uniform(-4.0, 4.0, (170, 2))  # some far enough to leave the table and be clipped
    prior = Pose2D(*rng.uniform(-1.0, 1.0, 2), rng.uniform(-math.pi, math.pi))
    angles = np.arange(-7, 8) * math.radians(1.0)
    offsets = np.arange(-2, 3) * COARSE
    base = (int(rng.integers(-8, 9)), int(rng.integers(-8, 9)))
    spread = (rng.uniform(0.02, 0.3), rng.uniform(0.01, 0.2))
    matcher = ScanMatcher(0.05, 0.3, 0.5)
    got = matcher._scores(
        field, (field.squared, values), points, prior, angles=angles, offsets=offsets, base=base, spread=spread
    )
    ox = (base[0] + offsets) * RES / spread[0]
    oy = (base[1] + offsets) * RES / spread[0]
    z2 = (angles[:, None, None] / spread[1]) ** 2 + ox[None, :, None] ** 2 + oy[None, None, :] ** 2
    penalty = PRIOR_WEIGHT * np.log1p(0.5 * z2)
    want = reference_table_means(field, table, points, prior, angles=angles, offsets=offsets, base=base) - penalty
    assert got.shape == (angles.size, offsets.size, offsets.size)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_distance_field_equals_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    grid = random_grid(rng)
    field = field_of(grid, rng)
    distance, near_iy, near_ix = reference_field_arrays(grid, field, PAD)
    got = distances(field)
    between = (got > 0.0) & (got < field.max_distance)
    assert got.min() == 0.0  # the window holds walls
    assert between.mean() > 0.1  # and open space near them
    np.testing.assert_allclose(got, distance, rtol=0.0, atol=1e-12)
    np.testing.assert_array_equal(field.near_iy, near_iy)
    np.testing.assert_array_equal(field.near_ix, near_ix)


@pytest.mark.parametrize("seed", range(3))
def test_likelihood_tables_equal_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    field = field_of(random_grid(rng), rng)
    sigma, sigma_coarse = 0.05, 0.1
    fine, coarse, pooled = _likelihoods(field.squared, field.distance_table, sigma, sigma_coarse, COARSE // 2)
    distance = distances(field)
    likelihood = np.exp(-(distance**2) / (2.0 * sigma**2))
    np.testing.assert_allclose(fine[field.squared], likelihood, rtol=1e-14, atol=0.0)
    wide = np.exp(-(distance**2) / (2.0 * sigma_coarse**2))
    reference = ndimage.maximum_filter(wide, size=COARSE + 1, mode="nearest")
    assert (reference > wide).mean() > 0.1  # the pooling changes many cells
    np.testing.assert_allclose(coarse[pooled], reference, rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("seed", range(5))
def test_integrate_equals_the_numpy_reference(seed):
    """Scans from random poses, some beams beyond the usable range, some leaving the fixed extent; the second
    pass over the same scans drives cells into the clamp."""
    rng = np.random.default_rng(seed)
    grid = LogOddsGrid(RES, (-4.0, -3.0, 4.0, 3.0), grows=False, lmax=1.5)
    reference = LogOddsGrid(RES, (-4.0, -3.0, 4.0, 3.0), grows=False, lmax=1.5)
    scans = []
    for _ in range(6):
        ranges = rng.uniform(0.05, 6.0, 360)
        ranges[rng.random(360) < 0.05] = np.nan
        scan = LaserScanData(-math.pi, 2.0 * math.pi / 360, 0.1, 8.0, ranges)
        sensor = Pose2D(*rng.uniform(-3.0, 3.0, 2), rng.uniform(-math.pi, math.pi))
        scans.append((sensor, split_beams(scan, 4.0)))
    for sensor, beams in scans + scans:
        grid.integrate(sensor, beams)
        reference_integrate(reference, sensor, beams)
    want = reference.dense()
    assert (want[0] == -1.5).sum() > 100  # clamped free cells
    assert (want[3] > 1).sum() > 100  # cells hit more than once
    for got_array, want_array in zip(grid.dense(), want, strict=True):  # log-odds, hit sums in x and y, counts
        np.testing.assert_array_equal(got_array, want_array)


def _tiles_of(grid: LogOddsGrid, rects: list[tuple[int, int, int, int]]) -> np.ndarray:
    covered = np.zeros(grid.stale.shape, dtype=np.int64)
    for ty0, ty1, tx0, tx1 in rects:
        covered[ty0:ty1, tx0:tx1] += 1
    return covered


@pytest.mark.parametrize("seed", range(3))
def test_a_grid_redrawn_piece_by_piece_equals_the_scans_integrated_into_a_cleared_grid(seed):
    """What a lazy rebuild relies on (mrs_nav.slam.grid module doc): after invalidate(), tiles drawn again in
    regions at different times, from the same scans, hold what integrating the scans into a cleared grid gives,
    to the bit (log-odds with clamping, hit sums and counts); a tile not yet drawn is unknown (invalidate clears
    the grid: such a tile is never read). More than 64 scans of 60 beams: the marks of a tile are reused."""
    rng = np.random.default_rng(seed)
    extent = (-4.0, -3.0, 4.0, 3.0)

    def scans(n):
        out = []
        for _ in range(n):
            ranges = rng.uniform(0.05, 6.0, 60)
            ranges[rng.random(60) < 0.05] = np.nan
            scan = LaserScanData(-math.pi, 2.0 * math.pi / 60, 0.1, 8.0, ranges)
            out.append((Pose2D(*rng.uniform(-3.0, 3.0, 2), rng.uniform(-math.pi, math.pi)), split_beams(scan, 4.0)))
        return out

    grid = LogOddsGrid(RES, extent, grows=False, lmax=1.5)
    for sensor, beams in scans(20):  # what the map held before: to be replaced
        grid.integrate(sensor, beams)
    redraw = scans(300)
    reference = LogOddsGrid(RES, extent, grows=False, lmax=1.5)
    for sensor, beams in redraw:
        reference.integrate(sensor, beams)
    want = reference.dense()
    grid.invalidate()
    for _ in range(3):
        x, y = rng.uniform(-4.0, 4.0), rng.uniform(-3.0, 3.0)
        grid.redraw(grid.stale_regions((x - 1.0, y - 1.0, x + 1.5, y + 0.5)), redraw)
    assert 0 < grid.stale_tiles < grid.stale.size
    stale = np.kron(grid.stale, np.ones((8, 8), dtype=bool))[grid.shift_y :, grid.shift_x :][
        : grid.height, : grid.width
    ]
    for got, wanted in zip(grid.dense(), want, strict=True):
        np.testing.assert_array_equal(got[~stale], wanted[~stale])
        assert not got[stale].any()
    grid.redraw(grid.stale_regions(), redraw)
    assert grid.stale_tiles == 0
    assert (want[0] == -1.5).sum() > 100  # clamped free cells
    for got_array, want_array in zip(grid.dense(), want, strict=True):
        np.testing.assert_array_equal(got_array, want_array)


def test_stale_regions_cover_exactly_the_out_of_date_tiles_of_a_box():
    grid = LogOddsGrid(RES, (-10.0, -10.0, 10.0, 10.0))
    assert grid.stale_regions() == []
    grid.invalidate()
    # A region drawn before (a box), and the map's reach round the robot moved on: a box less a box
    grid.stale[10:20, 15:30] = False
    grid.stale_tiles = int(grid.stale.sum())
    box = (-6.0, -6.0, 2.0, 0.0)  # tiles 10-30 in x, 10-25 in y (0.4 m tiles from -10 m)
    rects = grid.stale_regions(box)
    covered = _tiles_of(grid, rects)
    assert covered.max() == 1  # disjoint
    inside = np.zeros_like(grid.stale)
    inside[10:26, 10:31] = True
    np.testing.assert_array_equal(covered == 1, grid.stale & inside)
    assert len(rects) == 3  # beside the drawn box (two), and below it
    assert grid.stale_regions((-9.9, -9.9, -9.5, -9.5)) == [(0, 2, 0, 2)]
    assert grid.stale_regions((20.0, 20.0, 30.0, 30.0)) == []
    # Scattered tiles: at most REDRAW_RECTANGLES, merged into the rectangle holding them all
    grid.stale[:] = False
    grid.stale[::3, ::3] = True
    grid.stale_tiles = int(grid.stale.sum())
    rects = grid.stale_regions()
    assert len(rects) == 1
    assert _tiles_of(grid, rects)[grid.stale].min() == 1
