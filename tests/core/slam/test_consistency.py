"""The revisit spread: end points of scans taken far apart in time, placed by a trajectory, and how far apart
the same wall lands."""

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.consistency import REVISIT_GAP, revisit_spread

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
