"""The map-consistency figures: end points on doubled walls (a person walking beside the robot is none, a map of
scans that cannot agree has them), and the revisit spread: end points of scans taken far apart in time, placed by
a trajectory, and how far apart the same wall lands."""

import dataclasses
import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam import Slam, SlamConfig
from mrs_nav.slam.eval.consistency import (
    BROKEN_FRACTION,
    REVISIT_GAP,
    doubled_wall_fraction,
    doubled_wall_fraction_at,
    free_endpoint_fraction,
    revisit_spread,
    revisit_spread_by_distance,
)
from mrs_nav.slam.scan import LaserScanData, split_beams
from tests.core.bag.carmen_fixture import drive
from tests.core.slam.synthetic import ROOM, cast, person

# A wall at x = 2 m in the world, sampled at the centres of 5 cm cells (thinning keeps them as they are).
WALL = np.stack([np.full(40, 2.025), -0.975 + 0.05 * np.arange(40)], axis=1)
SECOND = Pose2D(0.5, 0.0, 0.0)  # where the robot sees the wall again


def _scans(gap: int) -> list[np.ndarray]:
    """The wall seen from the origin by the first scan and from SECOND by scan ``gap``; nothing in between."""
    seen_again = WALL - np.array([SECOND.x, SECOND.y])
    return [WALL] + [np.zeros((0, 2))] * (gap - 1) + [seen_again]


def _poses(gap: int, second: Pose2D) -> list[Pose2D]:
    return [Pose2D(0.0, 0.0, 0.0)] * gap + [second]


def test_a_revisit_placed_right_lands_on_the_same_wall():
    assert revisit_spread(_poses(REVISIT_GAP, SECOND), _scans(REVISIT_GAP)) == pytest.approx(0.0, abs=1e-9)


def test_a_revisit_placed_3_cm_off_leaves_the_wall_3_cm_apart():
    off = Pose2D(SECOND.x + 0.03, SECOND.y, SECOND.yaw)
    assert revisit_spread(_poses(REVISIT_GAP, off), _scans(REVISIT_GAP)) == pytest.approx(0.03, abs=1e-9)


def test_scans_close_in_time_are_no_revisit_and_bad_input_is_named():
    assert math.isnan(revisit_spread(_poses(REVISIT_GAP - 1, SECOND), _scans(REVISIT_GAP - 1)))
    with pytest.raises(InvalidInputError, match="2 poses for 1 scans"):
        revisit_spread([SECOND, SECOND], [WALL])


def test_a_stretched_building_shows_between_scans_taken_far_apart_only():
    # A wall across the x axis at x = 12 m, seen from x = 0, 1 and 10 m (scans REVISIT_GAP apart in time).
    far_wall = np.stack([np.full(40, 12.025), -0.975 + 0.05 * np.arange(40)], axis=1)
    taken = np.array([0.0, 1.0, 10.0])
    scans = [np.zeros((0, 2))] * (2 * REVISIT_GAP + 1)
    positions = np.zeros((len(scans), 2))
    for k, x in enumerate(taken):
        scans[k * REVISIT_GAP] = far_wall - np.array([x, 0.0])
        positions[k * REVISIT_GAP, 0] = x
    bands = [(0.0, 2.0), (2.0, 20.0)]

    def placed(stretch: float) -> list[Pose2D]:
        return [Pose2D(stretch * x, 0.0, 0.0) for x in positions[:, 0]]

    (near, near_points), (far, far_points) = revisit_spread_by_distance(placed(1.0), scans, positions, bands)
    assert (near, far) == (pytest.approx(0.0, abs=1e-9), pytest.approx(0.0, abs=1e-9))
    assert (near_points, far_points) == (80, 120)  # x = 0 and 1 m see each other; 10 m sees both, both see it
    # Stretched by 0.5 % along x: 5 mm off between the scans 1 m apart, 4.5-5 cm between those 9-10 m apart.
    (near, _), (far, _) = revisit_spread_by_distance(placed(1.005), scans, positions, bands)
    assert near == pytest.approx(0.005, abs=1e-9)
    assert 0.045 - 1e-9 <= far <= 0.05 + 1e-9
    with pytest.raises(InvalidInputError, match="2 positions for"):
        revisit_spread_by_distance(placed(1.0), scans, positions[:2], bands)


def _mapped(scans: list[LaserScanData]) -> Slam:
    """SLAM over ``scans`` taken along :func:`drive` (exact odometry), every scan processed."""
    slam = Slam(SlamConfig(linearUpdate=0.0, angularUpdate=0.0))
    for i, (pose, scan) in enumerate(zip(drive(), scans, strict=True)):
        slam.add_scan(pose, scan, float(i))
    slam.finish()
    return slam


def test_people_walking_with_the_robot_are_no_broken_map():
    # Two people walk round the room with the robot, one ahead and to its left, one behind and to its right:
    # everywhere they pass, the robot sees free floor before and after, so their end points land on free cells
    # of the final map.
    scans = []
    for pose in drive():
        people = [person(xy) for xy in pose.apply(np.array([[1.0, 0.7], [-0.8, -0.9]]))]
        scans.append(cast(pose, walls=np.vstack([ROOM, *people])))
    slam = _mapped(scans)
    assert free_endpoint_fraction(slam) > 0.1  # as many as a doubled map's: the raw figure cannot tell them apart
    assert doubled_wall_fraction(slam) < BROKEN_FRACTION / 10


def test_doubled_walls_are_a_broken_map_and_an_empty_room_is_not():
    # Scans whose beams are declared 20 % wider apart than they were cast: no pose makes two of them agree (a
    # laser's geometry set wrong), so the walls come out doubled.
    wide = [dataclasses.replace(s, angle_increment=1.2 * s.angle_increment) for s in map(cast, drive())]
    assert doubled_wall_fraction(_mapped(wide)) > 2 * BROKEN_FRACTION
    assert doubled_wall_fraction(_mapped([cast(pose) for pose in drive()])) == 0.0


def test_a_car_gone_on_the_way_back_draws_on_the_line_in_a_map_at_the_true_poses_too():
    # A 2 m car in the middle of the room while the robot drives the first leg, gone when it drives back (an 8 m
    # laser: the way back sees the far wall through where it stood): its side is on free cells of any map of these
    # scans, the true poses' as much as a SLAM's. The figure at reference poses says so; the room without the car,
    # or with a car that stays, reads nothing.
    car = np.array([[-1.0, 0.0, 1.0, 0.0]])
    poses = drive()
    config = SlamConfig()

    def at_truth(with_car: int) -> float:
        def scans():
            for k, pose in enumerate(poses):
                scan = cast(pose, max_range=8.0, walls=np.vstack([ROOM, car]) if k < with_car else ROOM)
                yield pose, split_beams(scan, config.usable_range(scan.range_max), config.maxRange)

        return doubled_wall_fraction_at(config, scans)

    assert at_truth(with_car=21) > BROKEN_FRACTION  # the first leg's scans
    assert at_truth(with_car=0) == 0.0
    assert at_truth(with_car=len(poses)) == 0.0
