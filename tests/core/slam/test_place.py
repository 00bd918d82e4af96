"""Place signatures (mrs_nav.slam.place): the same whatever the laser's heading; nearer for scans taken half a
metre apart in one room than for scans taken 4 m or more apart, or in another room."""

import math

import numpy as np

from mrs_nav.geometry import Pose2D
from mrs_nav.slam.matcher import thin_points
from mrs_nav.slam.place import differences, signature
from tests.core.slam.synthetic import ROOM, cast

OTHER_ROOM = np.array([[-4.0, -4.0, 4.0, -4.0], [4.0, -4.0, 4.0, 1.0], [4.0, 1.0, -4.0, 1.0], [-4.0, 1.0, -4.0, -4.0]])


def signature_at(pose: Pose2D, walls: np.ndarray = ROOM) -> np.ndarray:
    """The signature of a scan from ``pose`` that sees the whole room, of its end points as the SLAM thins them."""
    scan = cast(pose, walls=walls, max_range=12.0)
    finite = np.isfinite(scan.ranges)
    angles, ranges = scan.angles[finite], scan.ranges[finite]
    out = signature(thin_points(np.stack([ranges * np.cos(angles), ranges * np.sin(angles)], axis=1), 0.05))
    assert out is not None
    return out


def test_a_signature_does_not_change_when_the_laser_turns():
    scan = cast(Pose2D(-2.0, 0.5, 0.0))
    finite = np.isfinite(scan.ranges)
    points = np.stack(
        [scan.ranges[finite] * np.cos(scan.angles[finite]), scan.ranges[finite] * np.sin(scan.angles[finite])], axis=1
    )
    turn = 2.1
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    here, turned = signature(points), signature(points @ rotation.T)
    assert here is not None
    assert turned is not None
    assert differences(here, turned[None, :])[0] < 1e-3


def test_scans_half_a_metre_apart_are_nearer_by_signature_than_scans_far_apart_or_elsewhere():
    here = signature_at(Pose2D(-2.0, 0.5, 0.0))
    near = np.stack([signature_at(Pose2D(-1.6, 0.2, 1.0)), signature_at(Pose2D(-2.0, 0.0, -0.5))])
    far = np.stack(
        [signature_at(pose) for pose in (Pose2D(2.0, 1.0, 0.0), Pose2D(-3.0, -1.0, 2.0), Pose2D(3.0, 0.0, 0.0))]
    )
    elsewhere = np.stack([signature_at(Pose2D(x, y, 0.0), OTHER_ROOM) for x, y in ((0.0, -1.5), (-2.0, -2.0))])
    assert differences(here, near).max() < min(differences(here, far).min(), differences(here, elsewhere).min())


def test_too_few_points_have_no_signature():
    assert signature(np.zeros((2, 2))) is None
