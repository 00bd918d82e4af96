"""The navigation costmap under navigation.launch (office map, simulator in lockstep, sim time at max rate): marks
placed while the localisation was wrong go when the user gives the right 2D Pose Estimate, and
``/move_base/clear_costmaps`` (std_srvs/Empty, called as move_base users do, with ``rosservice call``) clears
marks the laser no longer sees.

The localisation is first told, confidently, a pose 1 m and 30 deg off the robot's true one (a 2D Pose Estimate
given in the wrong place): 30 scans are placed from there and mark diagonal walls across the corridor. Then the
right pose comes, with rviz's covariance: within 10 s of sim time the costmap holds no mark in the free space
of the map, and a goal along the corridor behind the phantom walls is reached. A goal reached while the
localisation is unsure waits for its update without motion, and is not reported as a success without it."""

from __future__ import annotations

import math
import subprocess
import threading
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from scipy import ndimage

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from tests.ros.navharness import TruthTrack, close_action_client
from tests.ros.test_localisation_node import initial_pose_msg
from tests.ros.test_move_base import target
from tests.rosharness import REPO, RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
START = Pose2D(-5.0, -5.0, 0.0)  # the south corridor (walls at y = -6 and -4), facing east along it
WRONG = Pose2D(-4.0, -5.0, math.pi / 6.0)  # 1 m and 30 deg off
CONFIDENT = (0.0025, 0.0025, 0.003)  # m^2, m^2, rad^2: a localisation sure of the wrong pose
RVIZ_ESTIMATE = (0.25, 0.25, 0.06853891945200942)  # what rviz's 2D Pose Estimate sends
GOAL = (-1.0, -5.0)  # along the corridor, behind the phantom walls
# A cell this far from every obstacle of the map is free space, where no mark may stay: beyond the band in which the
# localisation's own error of a few centimetres and hundredths of a radian puts returns of the walls (marked from
# 0.2 m off a wall, inflated by 0.205 m). The phantom walls of a pose 1 m / 30 deg off cross the corridor.
FREE_SPACE_M = 0.55


class Costmaps:
    """The latest ``/move_base/global_costmap/costmap`` and the scans seen since a given moment."""

    def __init__(self, rospy: Any) -> None:
        from nav_msgs.msg import OccupancyGrid as GridMsg
        from sensor_msgs.msg import LaserScan

        self._lock = threading.Lock()
        self.latest: Any = None
        self.received = 0
        self.scans = 0
        self.subs = [
            rospy.Subscriber("/move_base/global_costmap/costmap", GridMsg, self._on_costmap, queue_size=1),
            rospy.Subscriber("/scan", LaserScan, self._on_scan, queue_size=10),
        ]

    def _on_costmap(self, msg: Any) -> None:
        with self._lock:
            self.latest = msg
            self.received += 1

    def _on_scan(self, _msg: Any) -> None:
        with self._lock:
            self.scans += 1

    def occupied(self) -> np.ndarray:
        """The occupied cells of the latest costmap, ``(height, width)`` bool."""
        with self._lock:
            msg = self.latest
        return np.asarray(msg.data, dtype=np.int16).reshape(msg.info.height, msg.info.width) == 100

    def close(self) -> None:
        for sub in self.subs:
            sub.unregister()


@pytest.fixture(scope="module")
def office(
    ros_master: RosMaster, rospy_node: Any, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[dict[str, Any]]:
    import actionlib
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from move_base_msgs.msg import MoveBaseAction
    from rosgraph_msgs.msg import Log

    rospy = rospy_node
    grid = rasterize_world(load_world(REPO / "worlds" / "office.world"), 0.05, 0.5)
    map_file = save_map(grid, tmp_path_factory.mktemp("map") / "office.yaml")
    args = ("world:=office", "x:=-5.0", "y:=-5.0", "yaw:=0.0", "rviz:=false", "seed:=5", f"map_file:={map_file}")
    estimates: list[Any] = []
    amcl = rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, estimates.append, queue_size=10)
    poses = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=1)
    costmaps = Costmaps(rospy)
    said: list[str] = []  # the navigation's and the localisation's log lines: why a mark is there or not
    rosout = rospy.Subscriber(
        "/rosout",
        Log,
        lambda m: (
            said.append(f"{m.header.stamp.to_sec():.2f} {m.msg}") if m.name in ("/rrt_navigation", "/amcl") else None
        ),
        queue_size=100,
    )
    truth = TruthTrack(rospy, "office.world")
    with ros_master.launch("navigation.launch", *MAX_RATE, *args) as proc:
        client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        try:
            assert client.wait_for_server(rospy.Duration(90.0)), "no move_base action server"
            wait_for(lambda: estimates and poses.get_num_connections() > 0, 60.0, "the localisation")
            wait_for(lambda: costmaps.latest is not None, 60.0, "the costmap")
            yield {
                "rospy": rospy,
                "client": client,
                "poses": poses,
                "estimates": estimates,
                "costmaps": costmaps,
                "truth": truth,
                "grid": grid,
                "env": ros_master.env,
                "said": said,
            }
            assert proc.poll() is None, "a required node died"
        finally:
            close_action_client(client)
            amcl.unregister()
            rosout.unregister()
            poses.unregister()
            costmaps.close()
            truth.close()


def free_space(grid: OccupancyGrid) -> np.ndarray:
    """The cells of the map farther than FREE_SPACE_M from every occupied one."""
    return ndimage.distance_transform_edt(~grid.occupied_mask) * grid.resolution > FREE_SPACE_M


def phantoms(office: dict[str, Any]) -> int:
    """Occupied costmap cells in the free space of the map."""
    return int(np.count_nonzero(office["costmaps"].occupied() & free_space(office["grid"])))


def tell_pose(office: dict[str, Any], pose: Pose2D, variances: tuple[float, float, float]) -> float:
    """Publish ``pose`` on /initialpose and wait for the localisation's /amcl_pose near it; the sim time sent."""
    rospy, estimates = office["rospy"], office["estimates"]
    sent = rospy.get_time()
    office["poses"].publish(initial_pose_msg(rospy, pose, variances))

    def taken() -> bool:
        p = estimates[-1].pose.pose.position
        return estimates[-1].header.stamp.to_sec() >= sent and math.hypot(p.x - pose.x, p.y - pose.y) < 0.3

    wait_for(taken, 60.0, f"/amcl_pose at ({pose.x}, {pose.y})")
    return sent


def track(office: dict[str, Any], since: float) -> list[str]:
    """The localisation's estimates since sim time ``since``: stamp, position, 1-sigma of x, y and yaw."""
    out = []
    for m in office["estimates"]:
        if m.header.stamp.to_sec() >= since:
            p, c = m.pose.pose.position, m.pose.covariance
            sigmas = " ".join(f"{c[i] ** 0.5:.2f}" for i in (0, 7, 35))
            out.append(f"{m.header.stamp.to_sec():.1f}: ({p.x:.2f}, {p.y:.2f}) {sigmas}")
    return out


def wait_costmap_after(office: dict[str, Any], t: float) -> None:
    """Wait until the latest costmap holds what the node had at sim time ``t``: it publishes a changed costmap at
    most once a second (sim), so the last one received 2 s later is at least that recent."""
    rospy = office["rospy"]
    wait_for(lambda: rospy.get_time() > t + 2.0, 60.0, f"sim time {t + 2.0:.1f} s")


def test_marks_placed_at_a_wrong_pose_go_with_the_right_pose_estimate(office: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy, client, costmaps, truth = office["rospy"], office["client"], office["costmaps"], office["truth"]
    tell_pose(office, WRONG, CONFIDENT)
    scans = costmaps.scans
    wait_for(lambda: costmaps.scans >= scans + 30, 60.0, "30 scans at the wrong pose")
    wait_costmap_after(office, rospy.get_time())
    marked = phantoms(office)
    assert marked > 50, (f"only {marked} cells marked at the wrong pose: the test injects nothing", office["said"][-8:])

    corrected = tell_pose(office, START, RVIZ_ESTIMATE)
    wait_costmap_after(office, corrected + 10.0)
    left = phantoms(office)
    assert left == 0, (
        f"{left} of {marked} phantom cells left 10 s after the pose estimate",
        office["said"][-8:],
        track(office, corrected),
    )

    client.send_goal(target(rospy, *GOAL, 0.0))
    wait_for(lambda: client.get_state() not in (0, 1), 150.0, "the goal to end")
    assert client.get_state() == GoalStatus.SUCCEEDED, client.get_goal_status_text()
    _, x, y = truth.last()
    assert math.hypot(x - GOAL[0], y - GOAL[1]) < 0.15


def test_clear_costmaps_through_rosservice_clears_marks_out_of_sight(office: dict[str, Any]) -> None:
    """A box put 1.5 m ahead in the corridor is marked; driven away 4 m, the laser no longer reaches it and its
    marks stay (as costmap_2d's do) until ``rosservice call /move_base/clear_costmaps``."""
    from actionlib_msgs.msg import GoalStatus
    from visualization_msgs.msg import Marker

    rospy, client = office["rospy"], office["client"]
    box = Marker(type=Marker.CUBE, ns="box_in_the_corridor")
    box.pose.position.x, box.pose.position.y, box.pose.position.z = 0.5, -4.5, 0.25
    box.pose.orientation.w = 1.0
    box.scale.x, box.scale.y, box.scale.z = 0.3, 0.3, 0.5
    add = rospy.Publisher("/simulator/add_box", Marker, queue_size=1, latch=True)
    try:
        wait_for(lambda: add.get_num_connections() > 0, 20.0, "the simulator's add_box")
        add.publish(box)
        wait_costmap_after(office, rospy.get_time() + 2.0)
        assert phantoms(office) > 0, ("the box was not marked", office["said"][-5:])
        client.send_goal(target(rospy, -4.0, -5.0, 0.0))
        wait_for(lambda: client.get_state() not in (0, 1), 150.0, "the goal to end")
        assert client.get_state() == GoalStatus.SUCCEEDED, client.get_goal_status_text()
        wait_costmap_after(office, rospy.get_time() + 1.0)
        assert phantoms(office) > 0, "the box's marks went without a clear"
        result = subprocess.run(
            ["rosservice", "call", "/move_base/clear_costmaps"],
            env=office["env"],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        wait_costmap_after(office, rospy.get_time() + 1.0)
        assert phantoms(office) == 0
    finally:
        add.unregister()


def unsure_report(office: dict[str, Any]) -> Any:
    """The localisation's last estimate with a wide covariance (2 m, 1 rad), stamped now: one that lost track."""
    report = office["estimates"][-1]
    report.header.stamp = office["rospy"].Time.now()
    report.pose.covariance = [4.0 if i in (0, 7) else 1.0 if i == 35 else 0.0 for i in range(36)]
    return report


def goal_ahead(office: dict[str, Any], report: Any, distance: float) -> Any:
    """A goal ``distance`` m straight ahead of the pose of ``report``, with its heading."""
    p, q = report.pose.pose.position, report.pose.pose.orientation
    yaw = 2.0 * math.atan2(q.z, q.w)
    return target(office["rospy"], p.x + distance * math.cos(yaw), p.y + distance * math.sin(yaw), yaw)


def test_a_goal_reached_while_the_localisation_is_unsure_waits_for_its_update_without_motion(
    office: dict[str, Any],
) -> None:
    """The same unsure report as below, but the localisation is fine: the robot waits at the goal, the navigation
    node asks the localisation for an update without motion (request_nomotion_update), whose confident estimate
    ends the goal SUCCEEDED."""
    from actionlib_msgs.msg import GoalStatus
    from geometry_msgs.msg import PoseWithCovarianceStamped

    rospy, client = office["rospy"], office["client"]
    unsure = rospy.Publisher("/amcl_pose", PoseWithCovarianceStamped, queue_size=1)
    try:
        wait_for(lambda: unsure.get_num_connections() > 1, 30.0, "the navigation node on /amcl_pose")
        report = unsure_report(office)
        unsure.publish(report)
        said = len(office["said"])
        client.send_goal(goal_ahead(office, report, 0.15))
        wait_for(lambda: client.get_state() not in (0, 1), 150.0, "the goal to end")
        assert client.get_state() == GoalStatus.SUCCEEDED, client.get_goal_status_text()
        lines = office["said"][said:]
        assert any("reached by the estimate; waiting up to 5.0 s" in line for line in lines), lines
        assert any("asked the localisation for an update without motion" in line for line in lines), lines
    finally:
        unsure.unregister()


def test_a_goal_reached_while_the_localisation_is_unsure_is_aborted_not_succeeded(office: dict[str, Any]) -> None:
    """The localisation reports its pose with a wide covariance (2 m, 1 rad; published here on /amcl_pose, as a
    localisation that lost track does) and the robot drives 0.15 m to a goal, less than the localisation's update
    distance, so no estimate of its own replaces that report. The navigation node asks for an update without motion
    while it waits at the goal; a localisation that lost track answers with another unsure estimate, which this test
    plays: it takes the name request_nomotion_update over (the master keeps the last provider of a service; the
    last test of the module, as the real localisation is no longer found by it after). ABORTED with the reason after
    the wait, not SUCCEEDED."""
    from actionlib_msgs.msg import GoalStatus
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from std_srvs.srv import Empty, EmptyResponse

    rospy, client = office["rospy"], office["client"]
    unsure = rospy.Publisher("/amcl_pose", PoseWithCovarianceStamped, queue_size=1)
    asked: list[float] = []

    def still_unsure(_request: Any) -> Any:
        asked.append(rospy.get_time())
        unsure.publish(unsure_report(office))
        return EmptyResponse()

    lost = rospy.Service("/request_nomotion_update", Empty, still_unsure)
    try:
        wait_for(lambda: unsure.get_num_connections() > 1, 30.0, "the navigation node on /amcl_pose")
        report = unsure_report(office)
        unsure.publish(report)
        client.send_goal(goal_ahead(office, report, 0.15))
        wait_for(lambda: client.get_state() not in (0, 1), 150.0, "the goal to end")
        assert client.get_state() == GoalStatus.ABORTED, client.get_goal_status_text()
        assert "reached by the estimate" in client.get_goal_status_text()
        assert "the localisation is not confident (1 sigma 2.00 m, 1.00 rad" in client.get_goal_status_text()
        assert "(waited 5." in client.get_goal_status_text()  # 5 s, or to the first tick past it
        assert len(asked) >= 3, asked  # about once a second of the 5 s wait
    finally:
        lost.shutdown()
        unsure.unregister()
