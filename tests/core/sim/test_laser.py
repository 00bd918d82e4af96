"""The laser against the analytic distances in the course arena, REP 117 readings and the noise model."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.sim import LaserParams, Simulator, SimulatorConfig

ARENA = Path(__file__).resolve().parents[3] / "worlds" / "simple.world"
HALF = 2.0  # inner wall faces at +-2 m
CYL = (0.3, 0.2, 0.3)


def analytic_ranges(origin: Pose2D, angles: FloatArray) -> FloatArray:
    """Distance along each beam to the first of: the four inner wall faces, the cylinder."""
    dx, dy = np.cos(angles + origin.yaw), np.sin(angles + origin.yaw)
    with np.errstate(divide="ignore"):
        tx = np.where(dx > 0, (HALF - origin.x) / dx, (-HALF - origin.x) / dx)
        ty = np.where(dy > 0, (HALF - origin.y) / dy, (-HALF - origin.y) / dy)
    walls = np.minimum(np.abs(tx), np.abs(ty))
    # ray-circle: |o + t d - c|^2 = r^2
    ox, oy = origin.x - CYL[0], origin.y - CYL[1]
    b = ox * dx + oy * dy
    disc = b * b - (ox * ox + oy * oy - CYL[2] ** 2)
    t_cyl = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0.0)), np.inf)
    t_cyl = np.where(t_cyl > 0, t_cyl, np.inf)
    return np.asarray(np.minimum(walls, t_cyl), dtype=np.float64)


@pytest.mark.parametrize("base", [Pose2D(-1.5, -1.5, 0.0), Pose2D(1.2, -0.4, 2.0), Pose2D(-0.6, 1.1, -1.0)])
def test_scans_match_the_analytic_distances_within_three_sigma(base: Pose2D) -> None:
    sigma = 0.01
    sim = Simulator(load_world(ARENA), SimulatorConfig(laser=LaserParams(noise_sigma=sigma)), base)
    params = sim.config.laser
    scanner = base.compose(Pose2D(params.mount_x, params.mount_y, 0.0))
    expected = analytic_ranges(scanner, params.angles())
    in_range = expected <= params.range_max
    residuals = []
    for _ in range(5):
        ranges = sim.scan_now().ranges
        assert np.array_equal(np.isinf(ranges), ~in_range)  # +inf exactly where nothing is within 3.5 m
        assert np.all(ranges[~in_range] > 0)
        residuals.append(ranges[in_range] - expected[in_range])
    res = np.concatenate(residuals)
    assert np.mean(np.abs(res) < 3 * sigma) > 0.99  # Gaussian: 99.7 % within 3 sigma
    assert np.all(np.abs(res) < 5 * sigma)
    assert abs(res.mean()) < 3 * sigma / math.sqrt(res.size) * 2
    assert res.std() == pytest.approx(sigma, rel=0.15)


def test_noise_free_scan_is_exact_and_laid_out_as_the_lds() -> None:
    base = Pose2D(0.5, -1.0, 0.7)
    sim = Simulator(load_world(ARENA), SimulatorConfig(laser=LaserParams(noise_sigma=0.0)), base)
    params = sim.config.laser
    scanner = base.compose(Pose2D(params.mount_x, params.mount_y, 0.0))
    ranges = sim.scan_now().ranges
    expected = analytic_ranges(scanner, params.angles())
    finite = expected <= params.range_max
    assert ranges.shape == (360,)
    assert np.allclose(ranges[finite], expected[finite], atol=1e-9)
    assert params.angle_increment == pytest.approx(math.radians(1.0))
    assert (params.range_min, params.range_max, params.rate) == (0.12, 3.5, 5.0)


def test_a_wall_closer_than_range_min_reads_minus_inf() -> None:
    # backed up against the east wall: the scanner (0.032 m behind the axle) is 0.07 m from it
    sim = Simulator(load_world(ARENA), start=Pose2D(2.0 - 0.106, -1.0, math.pi))
    ranges = sim.scan_now().ranges
    assert ranges[180] == -math.inf  # beam 180 looks backwards, at the wall
    assert np.all(np.isfinite(ranges[150:210]) | np.isneginf(ranges[150:210]))
    assert ranges[0] == math.inf  # straight ahead the west wall is 3.93 m away: beyond range_max
