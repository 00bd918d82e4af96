"""The whole stack under one real roslaunch (`rrt_navigation.launch`: simulator + SLAM + RRT* navigation):
the course arena goal across the map, mapped by SLAM on the way."""

from __future__ import annotations

import math
from typing import Any

import pytest

from tests.ros.navharness import FOOTPRINT_RADIUS, StatusLog, TruthTrack, wait_for_move_base
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

# Sim time at max rate, in lockstep: the simulator never runs more than one control period past the last
# /cmd_vel, so the 10 Hz controller (and the simulator's 0.3 s command watchdog) keeps up however fast the machine is.
MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
SIM_TIME_BOUND = 90.0  # s; the offline demo takes 25-30 s of sim time for this trip


def test_the_arena_goal_is_reached_on_the_slam_map_without_contact(ros_master: RosMaster, rospy_node: Any) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import OccupancyGrid, Path

    truth = TruthTrack(rospy, "simple.world")
    status = StatusLog(rospy, "/rrt_navigation/status")
    maps: list[Any] = []
    paths: list[Any] = []
    map_sub = rospy.Subscriber("/map", OccupancyGrid, maps.append, queue_size=1)
    path_sub = rospy.Subscriber("/path", Path, paths.append, queue_size=10)
    goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
    try:
        with ros_master.launch(
            "rrt_navigation.launch", *MAX_RATE, "rviz:=false", "seed:=5", "x:=-1.5", "y:=-1.5"
        ) as proc:
            wait_for(lambda: proc.poll() is not None or (maps and goal_pub.get_num_connections() > 0), 60.0, "a map")
            assert proc.poll() is None, "roslaunch exited"
            wait_for_move_base(rospy)
            goal = PoseStamped()
            goal.header.frame_id = "map"
            goal.pose.position.x, goal.pose.position.y = 1.5, 1.5
            goal.pose.orientation.w = 1.0
            started = rospy.get_time()
            goal_pub.publish(goal)
            wait_for(
                lambda: any(status.has(s) for s in ("reached", "failed", "refused")), 150.0, "the goal to be reached"
            )
            finished = rospy.get_time()
        assert status.has("reached"), status.messages
        _, x, y = truth.last()
        assert math.hypot(x - 1.5, y - 1.5) <= 0.2
        assert truth.min_clearance() > FOOTPRINT_RADIUS
        assert truth.contacts == 0
        assert finished - started < SIM_TIME_BOUND
        assert paths
        assert paths[-1].header.frame_id == "map"
    finally:
        for topic in (map_sub, path_sub, goal_pub):
            topic.unregister()
        truth.close()
        status.close()
