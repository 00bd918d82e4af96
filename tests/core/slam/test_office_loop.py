"""Loop closure on a seeded 47 m drive round the office's ring corridor with the core simulator (its wheel
odometry and laser noise, no ROS): the loop closes and the trajectory ends within 1 cm of the truth; with a
noisier laser and wheels, in the seeds where scan matching alone drifts, closing the loop is what makes the map
consistent again, and in the others it changes nothing for the worse.

"Before the closure" is the same seeded drive (same odometry, same scans) with loop closure off: the map and
trajectory the SLAM would have had without it."""

import dataclasses
from pathlib import Path

import numpy as np

from mrs_nav.maps.occupancy_grid import OCCUPIED, UNKNOWN
from mrs_nav.maps.world import load_world
from mrs_nav.sim.laser import LaserParams
from mrs_nav.sim.simulator import SimulatorConfig
from mrs_nav.slam.eval.consistency import BROKEN_FRACTION, doubled_wall_fraction, free_endpoint_fraction
from mrs_nav.slam.eval.sim_drive import (
    OFFICE_LOOP_WAYPOINTS,
    OFFICE_START,
    SIM_SLAM_CONFIG,
    DriveResult,
    drive_with_slam,
)

OFFICE = Path(__file__).resolve().parents[3] / "worlds" / "office.world"
DRIFTED = 0.045  # m of ATE without loop closure: the loop drifted


def loop(sim: SimulatorConfig, *, loop_closure: bool) -> DriveResult:
    config = dataclasses.replace(SIM_SLAM_CONFIG, loop_closure=loop_closure)
    return drive_with_slam(load_world(OFFICE), OFFICE_START, OFFICE_LOOP_WAYPOINTS, slam_config=config, sim_config=sim)


def test_the_office_loop_closes_within_1_cm() -> None:
    # The simulator's defaults: 1 cm laser range noise, here with 1 % wheel odometry noise.
    result = loop(SimulatorConfig(odom_noise=0.01, seed=1), loop_closure=True)
    assert result.slam.processed[-1].travelled >= 45.0
    assert result.slam.loop_closer.closed >= 1
    assert result.errors.ate_rmse_m <= 0.01  # 3.3 mm measured
    assert doubled_wall_fraction(result.slam) < BROKEN_FRACTION
    assert free_endpoint_fraction(result.slam) < 0.05  # nothing moves here: every stray end point is the map's
    assert result.iou >= 0.9


def test_closing_the_loop_makes_a_drifted_map_consistent_and_leaves_the_others_alone() -> None:
    # A laser with 5 cm range noise (the LDS-01's specified accuracy is 5 % of range beyond 0.5 m) and 5 % wheel
    # odometry noise: over the loop scan matching alone drifts by 2-7 cm depending on the seed. Where it drifted
    # (ATE >= DRIFTED), the second pass through the south corridor maps its walls beside the first pass's and
    # closing the loop must put them back; where it did not, the closure must not make things worse.
    drifted = []
    for seed in range(1, 6):
        sim = SimulatorConfig(odom_noise=0.05, seed=seed, laser=LaserParams(noise_sigma=0.05))
        before = loop(sim, loop_closure=False)
        after = loop(sim, loop_closure=True)
        assert after.slam.loop_closer.closed >= 1
        assert after.slam.loop_closer.rejected == 0
        stray_before, stray_after = free_endpoint_fraction(before.slam), free_endpoint_fraction(after.slam)
        assert after.errors.ate_rmse_m <= before.errors.ate_rmse_m + 0.005
        assert stray_after <= stray_before + 0.001
        if before.errors.ate_rmse_m >= DRIFTED:
            drifted.append(seed)
            assert after.slam.loop_closer.solved >= 1  # the drift went into the graph, not into one step
            assert after.errors.ate_rmse_m <= 0.5 * before.errors.ate_rmse_m
            assert after.errors.ate_rmse_m <= 0.03
            assert stray_after < stray_before
            assert after.iou > before.iou
    # Seeds 2 and 5 drift: ATE 0.053 / 0.068 m without the closure, 0.017 / 0.020 m with it; end points on free
    # cells 0.019 / 0.019 without, 0.016 / 0.017 with it. Seeds 1, 3 and 4 end at 0.021-0.044 m either way.
    assert len(drifted) >= 2, drifted


def test_a_rebuilt_map_keeps_the_scans_between_nodes() -> None:
    # A sparse laser (90 beams, 5 cm range noise): 171 of the loop's 410 processed scans are nodes. Rebuilt from
    # the nodes' scans alone, this map lost 23 % of its occupied cells (3162 -> 2424) and 4.6 % of its known cells
    # changed; with the scans kept beside the nodes, 1.6 % and 0.3 %. No closure here: the rebuild should
    # reproduce the map the scans made as they came.
    sim = SimulatorConfig(odom_noise=0.05, seed=1, laser=LaserParams(noise_sigma=0.05, beams=90))
    slam = loop(sim, loop_closure=False).slam
    assert len(slam.nodes) <= 0.5 * len(slam.processed)
    before = slam.grid.to_occupancy().copy()
    slam.rebuild_map()
    after = slam.grid.to_occupancy()
    assert after.shape == before.shape
    assert np.count_nonzero(after == OCCUPIED) >= 0.97 * np.count_nonzero(before == OCCUPIED)
    known = (before != UNKNOWN) | (after != UNKNOWN)
    assert np.mean(before[known] != after[known]) <= 0.01
