"""The TurtleBot3 flow end to end under real roslaunch: map the office with SLAM (rrt_navigation.launch, two goals
along the corridors), save the live map with map_saver, then navigation.launch on the saved map (map server +
localisation + RRT* navigation, a fresh simulator): three goals in other rooms are reached without a contact."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path
from typing import Any

import pytest

from tests.ros.navharness import FOOTPRINT_RADIUS, StatusLog, TruthTrack
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
OFFICE = ("world:=office", "x:=-5.0", "y:=-5.0", "yaw:=0.0", "rviz:=false", "seed:=5")
MAPPING_GOALS = ((5.0, -5.0), (5.0, 3.0))  # along the south and east corridors
# South-east room (door at x = 5 in the wall y = -6), east room (door at y = -3 in the wall x = 6), the core's
# south room (door at x = 2 in the wall y = -4).
ROOM_GOALS = ((5.0, -7.5), (7.5, -3.0), (2.0, -2.0))


def _go(rospy: Any, goals: tuple[tuple[float, float], ...], truth: TruthTrack, timeout: float) -> None:
    from geometry_msgs.msg import PoseStamped

    pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
    status = StatusLog(rospy, "/rrt_navigation/status")
    try:
        wait_for(lambda: pub.get_num_connections() > 0, 60.0, "the navigation node on the goal topic")
        for x, y in goals:
            done = len(status.messages)
            goal = PoseStamped()
            goal.header.frame_id = "map"
            goal.pose.position.x, goal.pose.position.y = x, y
            goal.pose.orientation.w = 1.0
            pub.publish(goal)

            def finished(done: int = done) -> bool:
                return any(m.startswith(("reached:", "failed:", "refused:")) for m in status.messages[done:])

            wait_for(finished, timeout, f"goal ({x}, {y})")
            assert any(m.startswith("reached:") for m in status.messages[done:]), status.messages[done:]
            _, tx, ty = truth.last()  # type: ignore[misc]
            assert math.hypot(tx - x, ty - y) <= 0.3
    finally:
        pub.unregister()
        status.close()


def test_slam_then_saved_map_then_goals_in_other_rooms(ros_master: RosMaster, rospy_node: Any, tmp_path: Path) -> None:
    rospy = rospy_node
    saved = tmp_path / "office"
    truth = TruthTrack(rospy, "office.world")
    try:
        from nav_msgs.msg import OccupancyGrid

        maps: list[Any] = []
        map_sub = rospy.Subscriber("/map", OccupancyGrid, maps.append, queue_size=1)
        with ros_master.launch("rrt_navigation.launch", *MAX_RATE, *OFFICE) as proc:
            wait_for(lambda: proc.poll() is not None or maps, 90.0, "the first SLAM map")
            assert proc.poll() is None, "roslaunch exited"
            map_sub.unregister()
            first_map = rospy.get_time()
            wait_for(lambda: rospy.get_time() > first_map + 3.0, 30.0, "the navigation node to have the map too")
            _go(rospy, MAPPING_GOALS, truth, 300.0)
            result = subprocess.run(
                ["rosrun", "mrs_nav", "map_saver", "-f", str(saved)],
                env=ros_master.env,
                capture_output=True,
                text=True,
                timeout=60,
                check=False,
            )
            assert result.returncode == 0, result.stderr
        assert truth.contacts == 0
    finally:
        truth.close()

    truth = TruthTrack(rospy, "office.world")  # a new simulator: contacts count from zero again
    try:
        from geometry_msgs.msg import PoseWithCovarianceStamped

        estimates: list[Any] = []
        amcl = rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, estimates.append, queue_size=10)
        with ros_master.launch("navigation.launch", f"map_file:={saved}.yaml", *MAX_RATE, *OFFICE) as proc:
            wait_for(lambda: proc.poll() is not None or estimates, 90.0, "the first /amcl_pose on the saved map")
            assert proc.poll() is None, "roslaunch exited"
            amcl.unregister()
            _go(rospy, ROOM_GOALS, truth, 300.0)
            assert proc.poll() is None, "a required node died"
        assert truth.contacts == 0
        assert truth.min_clearance() > FOOTPRINT_RADIUS
    finally:
        truth.close()
