"""The saved-map navigation bench's closed loop (filter + navigator + simulator, no ROS) on the office as a
mapping drive round the ring corridor leaves it: a 2D Pose Estimate near the truth, then the goal."""

from __future__ import annotations

from mrs_nav.bench.localisation_saved_map import STARTS, given_pose
from mrs_nav.bench.navigation_saved_map import REACHED_WITHIN, navigate
from tests.core.localisation.test_filter import corridor_map, office


def test_a_goal_from_a_pose_estimate_near_the_truth_is_reached_within_10_cm() -> None:
    world, _ = office()
    start = STARTS[-1]  # (2, -5, 0): 5 m east of the goal along the south corridor
    run = navigate(world, corridor_map(), start, given_pose(start, 1), seed=1, budget=0.25)
    assert run.reached, run.outcome
    assert run.distance <= REACHED_WITHIN
