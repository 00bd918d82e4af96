"""The TurtleBot3 flow end to end under real roslaunch: map the office with SLAM (slam.launch, the test drives
along the south and east corridors), save the live map with map_saver, then navigation.launch on the saved map
(map server + localisation + RRT* navigation, a fresh simulator): three goals in other rooms are reached without
a contact. The saved map knows those rooms only from glimpses through their doors: the navigation node marks the
walls its laser sees in unknown cells (``mark_unknown``), or RRT* keeps planning through a room's unmapped wall."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mrs_nav.maps.map_world import saved_world
from mrs_nav.resources import WORLDS_DIR
from tests.ros.driveharness import Drive
from tests.ros.navharness import FOOTPRINT_RADIUS, StatusLog, TruthTrack
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
OFFICE = ("world:=office", "x:=-5.0", "y:=-5.0", "yaw:=0.0", "rviz:=false", "seed:=5")
MAPPING_DRIVE = ((-5.0, -5.0), (5.0, -5.0), (5.0, 3.0))  # along the south and east corridors
# The south-west room (door at x = -5 in the wall y = -6), then the two southern west rooms (doors at y = -4 and
# y = 0 in the wall x = -6): each through the corridor and two doors, rooms the mapping drive only glimpsed.
ROOM_GOALS = ((-4.5, -7.3), (-7.5, -4.0), (-7.0, -1.0))


def _go(
    rospy: Any, goals: tuple[tuple[float, float], ...], truth: TruthTrack, timeout: float, watch: Drive | None = None
) -> None:
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
            localisation = "" if watch is None else _localisation_errors(watch)
            assert any(m.startswith("reached:") for m in status.messages[done:]), (
                localisation,
                status.messages[done:][-4:],
            )
            _, tx, ty = truth.last()  # type: ignore[misc]
            assert math.hypot(tx - x, ty - y) <= 0.3
    finally:
        pub.unregister()
        status.close()


def _localisation_errors(watch: Drive) -> str:
    pairs = watch.since(0.0)
    if pairs.size == 0:
        return "no /amcl_pose paired with ground truth"
    worst = int(np.argmax(pairs[:, 1]))
    return (
        f"localisation: {len(pairs)} estimates, RMS {np.sqrt(np.mean(pairs[:, 1] ** 2)):.3f} m, "
        f"worst {pairs[worst, 1]:.3f} m at {pairs[worst, 0]:.1f} s"
    )


# Failed from 27 Nov until issue 38's fix (third goal reached by the estimate with the robot 0.33-0.55 m off, the
# first 1.6 m off at load 7), for two reasons found by recording the runs: the drive began before the SLAM node
# had started (the map then began metres down the corridor and lacked the western rooms' glimpses), and the
# localisation's fixed middle score for beams ending in unknown cells pulled the estimate towards the known part
# of the map: along the west corridor beyond it the estimate fell 0.35 m behind the robot while the cloud stayed
# narrow (mrs_nav.localisation.likelihood_field says how unknown beams score now).
def test_slam_then_saved_map_then_goals_in_other_rooms(ros_master: RosMaster, rospy_node: Any, tmp_path: Path) -> None:
    rospy = rospy_node
    saved = tmp_path / "office"
    truth = TruthTrack(rospy, "office.world")
    try:
        from nav_msgs.msg import OccupancyGrid

        maps: list[Any] = []
        map_sub = rospy.Subscriber("/map", OccupancyGrid, maps.append, queue_size=1)
        # 4x real time, not lockstep: the test's 10 Hz commands keep up and SLAM sees every scan
        with ros_master.launch("slam.launch", "real_time_factor:=4", *OFFICE) as proc:
            # The drive starts once SLAM has taken its first scan (it publishes /map at once), not as soon as the
            # simulator's clock runs: the SLAM node's start-up takes seconds more than the simulator's on a
            # loaded machine, at 4x real time a drive of metres, and a map begun metres down the corridor lacks
            # the start and the glimpses into the western rooms the goals are in (the robot was then lost there).
            wait_for(lambda: proc.poll() is not None or bool(maps), 120.0, "the SLAM node's first map")
            map_sub.unregister()
            assert proc.poll() is None, "roslaunch exited"
            drive = Drive(rospy, MAPPING_DRIVE, loop=False)
            try:
                drive.drive(110.0, 120.0)
            finally:
                drive.close()
            result = subprocess.run(
                ["rosrun", "mrs_nav", "map_saver", "-f", str(saved)],
                env=ros_master.env,
                capture_output=True,
                text=True,
                timeout=150,  # a Python node starting took 25 s at load 14 with two CPU hogs beside it
                check=False,
            )
            assert result.returncode == 0, result.stderr
        assert truth.contacts == 0
        # the map names the world it was made in: navigation.launch without world:= simulates that one
        assert saved_world(saved.with_suffix(".yaml")) == WORLDS_DIR / "office.world"
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
            watch = Drive(rospy)  # never switched on: only pairs /amcl_pose with the ground truth
            try:
                _go(rospy, ROOM_GOALS, truth, 300.0, watch)
                errors = watch.since(0.0)
                print(_localisation_errors(watch))  # shown with -rA: how close to the 0.1 m bound the run came
            finally:
                watch.close()
            assert proc.poll() is None, "a required node died"
        assert truth.contacts == 0
        assert truth.min_clearance() > FOOTPRINT_RADIUS
        # Localised on the saved SLAM map all along (lost, as before the fix, was 5-10 m). Not the 3 cm of tracking
        # on the whole office: beyond the doors the saved map is unknown, so along a corridor and inside the rooms
        # the scans hardly fix the position; in-process on such maps the filter is 8-16 cm RMS off the truth on
        # this route (1.5 cm on the rasterised world), under navigation.launch 6-13 cm (worst single 0.3 m).
        assert np.sqrt(np.mean(errors[:, 1] ** 2)) < 0.2
    finally:
        truth.close()
