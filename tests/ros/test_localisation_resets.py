"""The localisation node (navigation.launch sim:=false, office map) after a reset of its belief takes no scan
stamped before the reset, and a scan in a frame tf lacks is skipped with a warning that names the frames tf has.
The test is the clock, the odometry and the laser, so which scans exist is certain.

A node behind on its scans still holds some from before a ``global_localization`` call or a 2D Pose Estimate;
weighed against the new cloud they describe where the robot was (a teleported robot: the CI failures of the
global-localisation test followed a first attempt whose 10 000 particles had left the node behind)."""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import World, load_world
from mrs_nav.sim import Simulator, SimulatorConfig
from tests.ros.test_localisation_node import initial_pose_msg
from tests.rosharness import REPO, RosMaster, robot_state_publisher, wait_for

pytestmark = pytest.mark.ros

WORLD = REPO / "worlds" / "office.world"
START = Pose2D(-5.0, -5.0, 0.0)
ELSEWHERE = Pose2D(5.0, 0.0, math.pi / 2.0)
TICK = 0.01  # s of sim time per clock message


class StillRobot:
    """/clock, and odom -> base_footprint at the origin, from this test: a robot standing still."""

    def __init__(self, rospy: Any, start: float) -> None:
        from rosgraph_msgs.msg import Clock
        from tf2_msgs.msg import TFMessage

        from mrs_nav.ros.conversions import clock_msg, transform_stamped

        self._clock_msg, self._transform = clock_msg, transform_stamped
        self._clock = rospy.Publisher("/clock", Clock, queue_size=10)
        self._tf = rospy.Publisher("/tf", TFMessage, queue_size=10)
        self._tf_msg = TFMessage
        self.now = start
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="still-robot", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(TICK):
            self.now += TICK
            self._clock.publish(self._clock_msg(self.now))
            self._tf.publish(self._tf_msg([self._transform(Pose2D(0.0, 0.0, 0.0), self.now, "odom", "base_footprint")]))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        self._clock.unregister()
        self._tf.unregister()


@functools.cache
def office() -> World:
    return load_world(WORLD)


def scan_at(pose: Pose2D, stamp: float) -> Any:
    """The simulated laser's scan of the office from ``pose``, stamped ``stamp``."""
    from mrs_nav.ros.conversions import laser_scan_msg, to_ros_time

    sim = Simulator(office(), SimulatorConfig(seed=0), pose)
    sim.run(0.5)
    assert sim.last_scan is not None
    msg = laser_scan_msg(sim.last_scan, "base_scan")
    msg.header.stamp = to_ros_time(stamp)
    return msg


@dataclass(frozen=True)
class NodeUnderTest:
    """The test's side of the launch: its clock and odometry, its /scan and /initialpose publishers, and what
    the node said (the stamps of its /amcl_pose messages, its /rosout lines)."""

    rospy: Any
    robot: StillRobot
    scans: Any
    poses: Any
    estimates: list[float]
    logged: list[str]


@pytest.fixture(scope="module")
def node(ros_master: RosMaster, rospy_node: Any, tmp_path_factory: pytest.TempPathFactory) -> Iterator[NodeUnderTest]:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from rosgraph_msgs.msg import Log
    from sensor_msgs.msg import LaserScan

    map_file = save_map(rasterize_world(office(), 0.05, 0.5), tmp_path_factory.mktemp("map") / "office.yaml")
    rospy = rospy_node
    robot = StillRobot(rospy, max(rospy.get_time(), 0.0) + 10.0)  # ahead of any clock an earlier module left
    estimates: list[float] = []
    logged: list[str] = []  # the node's log lines, from /rosout
    subs = [
        rospy.Subscriber(
            "/amcl_pose", PoseWithCovarianceStamped, lambda m: estimates.append(m.header.stamp.to_sec()), queue_size=10
        ),
        rospy.Subscriber("/rosout", Log, lambda m: logged.append(m.msg) if m.name == "/amcl" else None, queue_size=100),
    ]
    scans = rospy.Publisher("/scan", LaserScan, queue_size=10)
    poses = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=1)
    args = ["sim:=false", "rviz:=false", "navigation:=false", f"map_file:={map_file}", "x:=-5.0", "y:=-5.0"]
    try:
        # sim:=false: the robot (this test's clock and odometry, and its robot_state_publisher) already runs
        with robot_state_publisher(ros_master), ros_master.launch("navigation.launch", *args) as proc:
            rospy.wait_for_service("/global_localization", 60.0)
            up = robot.now  # the node's tf listener has the odometry from here on
            wait_for(lambda: robot.now > up + 1.0, 30.0, "a second of the clock")
            wait_for(lambda: scans.get_num_connections() > 0 and poses.get_num_connections() > 0, 30.0, "subscribers")
            yield NodeUnderTest(rospy, robot, scans, poses, estimates, logged)
            assert proc.poll() is None, "a required node died"
    finally:
        for sub in subs:
            sub.unregister()
        scans.unregister()
        poses.unregister()
        robot.close()


def _stale_scan_unused_then_fresh_used(node: NodeUnderTest, reset_at: float) -> None:
    estimates = node.estimates
    stale = reset_at - 0.5
    node.scans.publish(scan_at(ELSEWHERE, stale))  # taken before the reset, somewhere else
    fresh = node.robot.now
    node.scans.publish(scan_at(START, fresh))
    # the first scan after a reset updates the filter whether or not the robot moved: one of the two makes one
    wait_for(lambda: _has(estimates, fresh) or _has(estimates, stale), 30.0, "an /amcl_pose after the reset")
    assert not _has(estimates, stale), "the scan stamped before the reset was used"
    assert _has(estimates, fresh)


def _has(stamps: list[float], stamp: float) -> bool:
    return any(abs(s - stamp) < 1e-6 for s in stamps)


def test_a_scan_from_before_global_localization_is_not_used(node: NodeUnderTest) -> None:
    from std_srvs.srv import Empty

    reset_at = node.robot.now
    node.rospy.ServiceProxy("/global_localization", Empty)()
    _stale_scan_unused_then_fresh_used(node, reset_at)


def test_a_scan_from_before_a_pose_estimate_is_not_used(node: NodeUnderTest) -> None:
    reset_at = node.robot.now
    msg = initial_pose_msg(node.rospy, START, (0.01, 0.01, 0.01))
    msg.header.stamp = node.rospy.Time.from_sec(reset_at)
    node.poses.publish(msg)
    # /initialpose and /scan are separate connections: the pose must be in before the stale scan is sent
    wait_for(lambda: any(m.startswith("localisation: initial pose") for m in node.logged), 30.0, "the pose taken")
    _stale_scan_unused_then_fresh_used(node, reset_at)


def test_a_scan_in_a_frame_tf_lacks_is_skipped_naming_the_frames_tf_has(node: NodeUnderTest) -> None:
    scan = scan_at(START, node.robot.now)
    scan.header.frame_id = "laser"  # a typo for base_scan
    node.scans.publish(scan)
    wait_for(lambda: any("frames on tf:" in m for m in node.logged), 30.0, "the warning")
    warning = next(m for m in node.logged if "frames on tf:" in m)
    assert "skipping scan" in warning
    for frame in ("base_footprint", "base_scan", "odom"):
        assert frame in warning.rsplit("frames on tf:", 1)[1]
    assert not _has(node.estimates, scan.header.stamp.to_sec())


def test_a_pose_estimate_off_the_map_is_refused_with_one_short_warning(node: NodeUnderTest) -> None:
    # accepted, it put every particle at (1e300, 1e300): /amcl_pose then read 0, 0 with covariance 0
    node.poses.publish(initial_pose_msg(node.rospy, Pose2D(1e300, 1e300, 0.0), (0.25, 0.25, 0.07)))
    wait_for(lambda: any("ignoring initial pose" in m for m in node.logged), 30.0, "the warning")
    warning = next(m for m in node.logged if "ignoring initial pose" in m)
    assert "(1e+300, 1e+300) m lies off the map" in warning
    assert len(warning) < 200
    assert not any(m.startswith("localisation: initial pose (1e+300") for m in node.logged)


def test_scans_in_frames_tf_cannot_name_give_one_throttled_warning(node: NodeUnderTest) -> None:
    """A frame ``""`` or ``"/base_scan"`` (tf2 takes neither): skipped with a warning, never an error per scan."""
    from rosgraph_msgs.msg import Log

    rospy = node.rospy
    lines: list[tuple[int, str]] = []
    sub = rospy.Subscriber(
        "/rosout", Log, lambda m: lines.append((m.level, m.msg)) if m.name == "/amcl" else None, queue_size=100
    )
    begun = node.robot.now
    wait_for(lambda: node.robot.now > begun + 6.0, 30.0, "the throttle of earlier warnings to pass")
    for frame in ("", "/base_scan") * 3:
        scan = scan_at(START, node.robot.now)
        scan.header.frame_id = frame
        node.scans.publish(scan)
        sent = node.robot.now
        wait_for(lambda sent=sent: node.robot.now > sent + 0.2, 30.0, "0.2 s between scans")
    last = node.robot.now
    wait_for(lambda: any("skipping scan" in m for _, m in lines), 30.0, "the warning")
    wait_for(lambda: node.robot.now > last + 1.0, 30.0, "a second more")
    sub.unregister()
    assert [m for level, m in lines if level >= Log.ERROR] == []
    warnings = [m for level, m in lines if level == Log.WARN and "skipping scan" in m]
    assert len(warnings) == 1, warnings
