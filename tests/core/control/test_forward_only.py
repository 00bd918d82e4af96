"""TurtleBot3's move_forward_only:=true holds for every mrs_nav navigation: its path follower and goal approach,
as rrt_navigation configures them, never command a negative linear speed (launch files document it so)."""

from __future__ import annotations

import itertools
import math

import numpy as np

from mrs_nav.control.goal_approach import ApproachConfig, GoalApproach
from mrs_nav.control.path_following import FollowerConfig, PathFollower
from mrs_nav.geometry import Pose2D

POSES = [
    Pose2D(x, y, yaw)
    for x, y, yaw in itertools.product(
        np.linspace(-1.0, 1.0, 9), np.linspace(-1.0, 1.0, 9), np.linspace(-math.pi, math.pi, 16)
    )
]


def test_the_path_follower_turns_on_the_spot_rather_than_reverse() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    for pose in POSES:
        assert PathFollower(path, FollowerConfig()).command(pose).u >= 0.0, pose


def test_the_goal_approach_never_reverses() -> None:
    for pose in POSES:
        approach = GoalApproach(0.3, -0.2, 1.0, ApproachConfig())
        assert approach.command(pose, 0.0).u >= 0.0, pose
