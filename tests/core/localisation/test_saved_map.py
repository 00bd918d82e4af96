"""Localisation on a map that knows only what a mapping drive saw (issue 38): the office with every cell off
the ring corridor unknown, as a SLAM run round the corridor leaves it. The estimate must not jump into unknown
space, recovery must not scatter particles there or far away while the estimate is confident, the estimate is
one cluster's mean, and its covariance owns up to its error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.geometry import Pose2D
from mrs_nav.localisation import LocalisationConfig, ParticleFilter
from mrs_nav.localisation.sim_drive import LocalisationRun, beam_scan, drive_and_localise
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.world import World
from mrs_nav.sim import Simulator, SimulatorConfig
from mrs_nav.sim.scripted_drive import OFFICE_CORRIDOR_LOOP
from tests.core.localisation.test_filter import START, corridor_map, office

EAST = Pose2D(5.0, 2.0, math.pi / 2.0)  # the east corridor, where the robot was put down
RVIZ_COVARIANCE = (0.25, 0.25, (math.pi / 12.0) ** 2)


def _scan(world: World, pose: Pose2D):  # type: ignore[no-untyped-def]
    return beam_scan(Simulator(world, SimulatorConfig(), pose).scan_now())


def _cloud(pf: ParticleFilter, particles: np.ndarray, weights: np.ndarray) -> None:
    """Put a given weighted cloud into the filter (as after a resampling of it)."""
    pf.set_pose(Pose2D(*particles[0]), np.diag([0.01, 0.01, 0.01]))  # the reset bookkeeping
    pf.particles = particles.copy()
    pf._log_weights = np.log(weights)  # private: a cloud no public call makes
    pf._estimate = pf._compute_estimate()


def drive_from_east(given: Pose2D, seed: int, duration: float, spin_turns: float = 0.0) -> LocalisationRun:
    """The robot put down at :data:`EAST` and the filter told ``given`` with rviz's spread, on the corridor map;
    ``spin_turns`` in place, then round the ring corridor for ``duration`` s of sim time (seeded)."""
    return drive_and_localise(
        office()[0],
        corridor_map(),
        EAST,
        OFFICE_CORRIDOR_LOOP,
        duration,
        config=LocalisationConfig(seed=seed),
        initial=given,
        initial_covariance=RVIZ_COVARIANCE,
        sim_config=SimulatorConfig(odom_noise=0.01, seed=seed),
        spin_turns=spin_turns,
    )


def test_spinning_in_place_after_a_pose_estimate_holds_the_pose() -> None:
    # Before: the estimate jumped 2.3 m along the corridor during the spin (seed 1), as in the issue.
    given = Pose2D(EAST.x + 0.2, EAST.y - 0.2, EAST.yaw + math.radians(12.0))
    for seed in (1, 2):
        run = drive_from_east(given, seed, 19.0, spin_turns=3.0)
        late = run.times >= 5.0
        assert run.position_errors[late].max() <= 0.15, (seed, run.position_errors.max())
        assert run.within_sigmas(3.0, 5.0) >= 0.95
        assert np.all(run.confident[late])


def test_a_pose_in_unknown_space_does_not_outscore_the_true_one() -> None:
    # Before: beams ending in unknown cells scored as perfect hits, so a pose in a room the map does not know,
    # whose beams all end there, beat the true pose in the corridor.
    world, _ = office()
    pf = ParticleFilter(corridor_map(), LocalisationConfig(seed=0, min_particles=200, max_particles=200))
    room = Pose2D(2.0, 2.0, math.pi / 2.0)  # unknown in the map
    particles = np.array([[EAST.x, EAST.y, EAST.yaw]] * 100 + [[room.x, room.y, room.yaw]] * 100)
    _cloud(pf, particles, np.full(200, 1.0 / 200))
    pf.update(Pose2D(0.0, 0.0, 0.0), _scan(world, EAST))
    estimate = pf.estimate()
    assert math.hypot(estimate.pose.x - EAST.x, estimate.pose.y - EAST.y) < 0.1
    assert estimate.share > 0.99


def test_recovery_stays_near_a_confident_estimate_in_known_free_space() -> None:
    # A scan that fits badly (taken elsewhere) calls in random particles. Before: anywhere on the map's free
    # cells, so a distant look-alike could take over; now within recovery_radius of the confident estimate.
    world, _ = office()
    grid = corridor_map()
    config = LocalisationConfig(seed=3, recovery_alpha_fast=0.5)
    pf = ParticleFilter(grid, config)
    pf.set_pose(EAST, np.diag([0.0025, 0.0025, 0.0003]))
    pf.update(Pose2D(0.0, 0.0, 0.0), _scan(world, EAST))
    # the scan stops fitting (taken 0.6 m off): the fast average falls below the slow one
    pf.update(Pose2D(0.25, 0.0, 0.0), _scan(world, Pose2D(EAST.x - 0.6, EAST.y + 0.25, EAST.yaw)))
    odom = 0.25
    assert pf.recovery_fraction > 0.0
    xy = pf.particles[:, :2]
    centre = np.array([EAST.x, EAST.y + odom])
    assert np.all(np.hypot(*(xy - centre).T) <= 1.0 + 0.6)  # recovery_radius (default 1 m) + the cloud
    assert np.all(grid.is_free(xy) | (np.hypot(*(xy - centre).T) < 0.3))  # random ones in known free cells


def test_the_estimate_is_the_heaviest_heading_mode_not_the_mean_of_two() -> None:
    _, grid = office()
    pf = ParticleFilter(grid, LocalisationConfig(seed=0, min_particles=100, max_particles=100))
    rng = np.random.default_rng(0)
    particles = np.column_stack([rng.normal(-5.0, 0.02, 100), rng.normal(-5.0, 0.02, 100), np.zeros(100)])
    particles[60:, 2] = math.pi / 2.0  # 40 % of the weight turned a quarter
    _cloud(pf, particles, np.full(100, 0.01))
    estimate = pf.estimate()
    assert abs(estimate.pose.yaw) < 0.01  # before: 34 deg, between the two
    assert estimate.share == pytest.approx(0.6)
    assert not estimate.confident  # the best cluster holds too little of the weight


def test_confidence_follows_the_cloud() -> None:
    world, grid = office()
    pf = ParticleFilter(grid, LocalisationConfig(seed=0))
    pf.global_localisation()
    assert not pf.estimate().confident
    pf.set_pose(Pose2D(-5.0, -5.0, 0.0), np.diag(RVIZ_COVARIANCE))
    pf.update(Pose2D(0.0, 0.0, 0.0), _scan(world, Pose2D(-5.0, -5.0, 0.0)))
    assert pf.estimate().confident


def _known_west_of(x: float) -> OccupancyGrid:
    """:func:`corridor_map` with everything east of ``x`` unknown too: the south corridor leaves the map."""
    grid = corridor_map()
    xs = grid.origin[0] + (np.arange(grid.width) + 0.5) * grid.resolution
    values = grid.values.copy()
    values[:, xs > x] = -1
    return OccupancyGrid(values, grid.resolution, grid.origin)


@pytest.mark.parametrize("seed", [1, 3])
def test_driving_out_of_the_known_map_does_not_pull_the_estimate_back(seed: int) -> None:
    # The robot drives 7 m along the south corridor beyond the part of it the map knows, then turns north. Before:
    # beams ending in unknown cells scored a fixed 0.61 of a hit, so particles lagging behind the robot, whose
    # beams still ended on known walls, won: 0.41 m and 0.37 m behind with the covariance claiming 0.17 m (seed
    # 3: 19 % of the updates outside 3 sigma). Now the estimate follows the odometry there and its spread grows.
    world, _ = office()
    run = drive_and_localise(
        world,
        _known_west_of(-2.0),
        START,
        [(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0)],
        40.0,
        config=LocalisationConfig(seed=seed),
        initial=START,
        sim_config=SimulatorConfig(odom_noise=0.01, seed=seed),
    )
    assert run.position_errors.max() < 0.3
    assert run.within_sigmas(3.0) == 1.0
    assert np.all(run.confident)
