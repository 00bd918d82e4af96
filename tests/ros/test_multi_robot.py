"""Two robots in one simulated office under one real roslaunch (`multi_robot.launch robots:=2`: one simulator,
per robot SLAM, or localisation on a saved map, and RRT* navigation in its namespace), at max rate in lockstep:
crossing goals are reached without a contact, between the robots or with a wall; the navigation marks the other
robot from its laser like any obstacle."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from tests.ros.navharness import FOOTPRINT_RADIUS, StatusLog, TruthTrack, wait_for_move_base
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
# In the office's east core room (x 0..4, y -4..4, a pillar r = 0.25 at (2, 1)), both starting south and facing
# north: the straight lines from start to goal cross at (2.2, 0.6), 1.8 m along tb3_1's and 3.8 m along tb3_0's,
# so tb3_1 passes the crossing first with tb3_0 coming from its side.
STARTS = {"tb3_0": (1.0, -3.0, math.pi / 2.0), "tb3_1": (3.0, -1.0, math.pi / 2.0)}
GOALS = {"tb3_0": (3.0, 3.0), "tb3_1": (1.0, 3.0)}


def _closest_approach(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest distance (m) between two robots' centres at common sim times (samples matched by stamp)."""
    common, ia, ib = np.intersect1d(np.round(a[:, 0], 3), np.round(b[:, 0], 3), return_indices=True)
    assert common.size > 100, "too few ground-truth samples at common stamps"
    return float(np.min(np.hypot(*(a[ia, 1:] - b[ib, 1:]).T)))


@pytest.mark.parametrize("saved_map", [False, True], ids=["slam", "localisation on a saved map"])
def test_two_robots_with_crossing_goals_reach_them_without_contact(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path, saved_map: bool
) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
    from nav_msgs.msg import OccupancyGrid

    extra: tuple[str, ...] = ()
    if saved_map:
        world = load_world(Path(__file__).resolve().parents[2] / "worlds" / "office.world")
        extra = (f"map_file:={save_map(rasterize_world(world, 0.05, 0.5), tmp_path / 'office.yaml')}",)
    truths = {name: TruthTrack(rospy, "office.world", name) for name in STARTS}
    status = {name: StatusLog(rospy, f"/{name}/rrt_navigation/status") for name in STARTS}
    maps: dict[str, list[Any]] = {name: [] for name in STARTS}
    # on a saved map every robot navigates on map_server's /map, and the localisation says where it is
    ready_topic, ready_type = ("/{}/amcl_pose", PoseWithCovarianceStamped) if saved_map else ("/{}/map", OccupancyGrid)
    map_subs = [
        rospy.Subscriber(ready_topic.format(name), ready_type, maps[name].append, queue_size=1) for name in STARTS
    ]
    goal_pubs = {
        name: rospy.Publisher(f"/{name}/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        for name in STARTS
    }
    poses = [f"pose{i}:={x} {y} {yaw}" for i, (x, y, yaw) in enumerate(STARTS.values())]
    try:
        with ros_master.launch(
            "multi_robot.launch", "robots:=2", *poses, *MAX_RATE, "rviz:=false", "planner_seed:=5", *extra
        ) as proc:
            wait_for(
                lambda: (
                    proc.poll() is not None or all(maps[n] and goal_pubs[n].get_num_connections() > 0 for n in STARTS)
                ),
                90.0,
                "both robots' maps",
            )
            assert proc.poll() is None, "roslaunch exited"
            for name in STARTS:
                wait_for_move_base(rospy, f"/{name}")
            for name, (x, y) in GOALS.items():
                goal = PoseStamped()
                goal.header.frame_id = "map"
                goal.pose.position.x, goal.pose.position.y = x, y
                goal.pose.orientation.w = 1.0
                goal_pubs[name].publish(goal)
            wait_for(
                lambda: all(s.has("reached") or s.has("failed") or s.has("refused") for s in status.values()),
                300.0,
                "both goals to be reached",
            )
        # Reached as the robot's own SLAM estimate has it (0.05 m); the true position is further off by the SLAM
        # error (up to 0.26 m measured in these office runs).
        misses = {
            name: math.hypot(truths[name].last()[1] - x, truths[name].last()[2] - y) for name, (x, y) in GOALS.items()
        }
        for name in GOALS:
            assert status[name].has("reached"), (name, status[name].messages)
            assert misses[name] <= 0.3, misses
            assert truths[name].contacts == 0, name
            assert truths[name].min_clearance() > FOOTPRINT_RADIUS, name
        # the robots passed each other: their chassis never met
        gap = _closest_approach(truths["tb3_0"].array(), truths["tb3_1"].array())
        assert gap > 2.0 * FOOTPRINT_RADIUS, gap
    finally:
        for sub in map_subs:
            sub.unregister()
        for pub in goal_pubs.values():
            pub.unregister()
        for track in truths.values():
            track.close()
        for log in status.values():
            log.close()


def test_robot_poses_parameter_is_read_and_a_bad_pose_is_named() -> None:
    from mrs_nav.ros.simulator_node import parse_poses

    assert parse_poses("-5 -5 0; 5, -5, 3.14;", "~robots") == (Pose2D(-5.0, -5.0, 0.0), Pose2D(5.0, -5.0, 3.14))
    assert parse_poses("  ", "~robots") == ()
    with pytest.raises(InvalidInputError, match=r"~robots: pose 1 must be three finite numbers 'x y yaw', got '1 2'"):
        parse_poses("0 0 0; 1 2", "~robots")
    with pytest.raises(InvalidInputError, match="pose 0"):
        parse_poses("0 nan 0", "~robots")
