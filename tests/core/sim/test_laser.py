"""The laser against analytic distances (the course arena, a turned box, another robot), what its height lets it
see, REP 117 readings and the noise model."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.world import Box, World, load_world
from mrs_nav.sim import LaserParams, MultiRobotSimulator, Simulator, SimulatorConfig
from mrs_nav.sim.laser import cast_rays

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


EXACT = SimulatorConfig(laser=LaserParams(noise_sigma=0.0))


def test_a_box_turned_45_degrees_is_seen_as_a_diamond() -> None:
    # a 0.4 m square turned 45 degrees, centred 2 m ahead: its near corner is on beam 0, and a beam at angle
    # theta > 0 meets the face x - y = cx - d (d = half the diagonal) at t = (cx - d - ox) / (cos - sin)
    cx, d = 2.0, 0.2 * math.sqrt(2.0)
    box = Box("diamond", cx, 0.0, 0.5, math.pi / 4.0, 0.4, 0.4, 1.0)
    sim = Simulator(World("diamond", (box,), ()), EXACT, Pose2D(0.0, 0.0, 0.0))
    ranges = sim.scan_now().ranges
    ox = EXACT.laser.mount_x
    theta = EXACT.laser.angles()[1:8]
    expected = (cx - d - ox) / (np.cos(theta) - np.sin(theta))
    assert ranges[0] == pytest.approx(cx - d - ox, abs=1e-3)
    np.testing.assert_allclose(ranges[1:8], expected, atol=1e-3)
    assert np.isinf(ranges[20:340]).all()  # nothing else in the world


def test_another_robot_in_front_is_a_circle_of_its_radius() -> None:
    # the second robot 1.5 m ahead, turned: its chassis is the upright cylinder of radius 0.105 m around its
    # base_footprint, whatever its heading
    fleet = MultiRobotSimulator(World("empty", (), ()), EXACT, [Pose2D(0.0, 0.0, 0.0), Pose2D(1.5, 0.2, 1.0)])
    ranges = fleet.robots[0].scan_now().ranges
    ox, r = EXACT.laser.mount_x, 0.105
    angles = EXACT.laser.angles()
    dx, dy = np.cos(angles), np.sin(angles)
    b = (ox - 1.5) * dx + (0.0 - 0.2) * dy
    disc = b * b - ((ox - 1.5) ** 2 + 0.2**2 - r * r)
    hit = (disc >= 0.0) & (b < 0.0)  # the line through the beam meets the circle, ahead of the scanner
    expected = np.where(hit, -b - np.sqrt(np.maximum(disc, 0.0)), np.inf)
    assert hit.sum() >= 5
    assert np.array_equal(np.isfinite(ranges), hit)
    np.testing.assert_allclose(ranges[hit], expected[hit], atol=1e-3)


def test_only_shapes_spanning_the_scanner_height_are_seen() -> None:
    # a low box (top at 0.15 m, below the scanner at 0.182 m) and a floating one (bottom at 0.2 m) are invisible
    low = Box("low", 1.0, 0.0, 0.075, 0.0, 0.3, 0.3, 0.15)
    high = Box("high", 0.0, 1.0, 0.5, 0.0, 0.3, 0.3, 0.6)
    tall = Box("tall", -1.0, 0.0, 0.5, 0.0, 0.3, 0.3, 1.0)
    sim = Simulator(World("heights", (low, high, tall), ()), EXACT, Pose2D(0.0, 0.0, 0.0))
    ranges = sim.scan_now().ranges
    assert np.isinf(ranges[0])
    assert np.isinf(ranges[90])
    assert ranges[180] == pytest.approx(1.0 - 0.15 + EXACT.laser.mount_x, abs=1e-9)


def test_a_ray_starting_inside_a_shape_reports_its_exit_as_ode_does() -> None:
    dx, dy = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    none = np.zeros((0, 5))
    circle = np.array([[0.1, 0.0, 0.5]])
    np.testing.assert_allclose(cast_rays(0.0, 0.0, dx, dy, circle, none, 3.5), [0.6, math.sqrt(0.24)])
    square = np.array([[0.0, 0.0, 0.0, 0.3, 0.2]])
    np.testing.assert_allclose(cast_rays(0.0, 0.0, dx, dy, np.zeros((0, 3)), square, 3.5), [0.3, 0.2])
    # beyond range_max: no hit
    assert np.isinf(cast_rays(0.0, 0.0, dx, dy, np.array([[5.0, 0.0, 0.5]]), none, 3.5)).all()
