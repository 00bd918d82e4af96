"""The SLAM node under a real roslaunch (slam.launch with the simulator at maximum rate, no rviz): while the
robot drives, /map is published, map->odom is on tf, and map->base_footprint tracks the ground truth; corrupt
scans and scans without odometry never kill it."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def slam_sim(ros_master: RosMaster, rospy_node: Any) -> Iterator[tuple[Any, Any]]:
    args = ["real_time_factor:=0", "rviz:=false", "x:=-1.5", "y:=-1.5", "yaw:=0"]
    with ros_master.launch("slam.launch", *args) as proc:
        wait_for(lambda: proc.poll() is not None or rospy_node.get_time() > 1.0, 60.0, "/clock from the simulator")
        assert proc.poll() is None, "roslaunch exited"
        yield rospy_node, proc


class Latest:
    """The latest message of a topic."""

    def __init__(self, rospy: Any, topic: str, msg_type: Any) -> None:
        self.lock = threading.Lock()
        self.msg: Any = None
        self.count = 0
        self.sub = rospy.Subscriber(topic, msg_type, self._on, queue_size=1)

    def _on(self, msg: Any) -> None:
        with self.lock:
            self.msg = msg
            self.count += 1


def test_map_and_pose_while_driving(slam_sim: tuple[Any, Any]) -> None:
    rospy, proc = slam_sim
    import tf2_ros
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import OccupancyGrid, Odometry
    from sensor_msgs.msg import LaserScan

    from mrs_nav.geometry import wrap_angle, yaw_from_quaternion

    grid = Latest(rospy, "/map", OccupancyGrid)
    truth = Latest(rospy, "/ground_truth/odom", Odometry)
    buffer = tf2_ros.Buffer(cache_time=rospy.Duration(60.0))
    listener = tf2_ros.TransformListener(buffer)
    cmd = rospy.Publisher("/cmd_vel", Twist, queue_size=10)
    bad_scans = rospy.Publisher("/scan", LaserScan, queue_size=10)
    try:
        wait_for(lambda: grid.msg is not None, 60.0, "/map (latched) from the slam node")
        assert grid.msg.header.frame_id == "map"
        assert grid.msg.info.resolution == pytest.approx(0.05)
        assert grid.msg.info.width * grid.msg.info.height == len(grid.msg.data)
        wait_for(lambda: buffer.can_transform("map", "odom", rospy.Time(0)), 30.0, "map->odom on tf")

        # Corrupt scans between the simulator's: wrong length, NaN/inf, empty, and one far in the future.
        for ranges, stamp_offset in (
            ([1.0] * 17, 0.0),
            ([math.nan, math.inf] * 180, 0.0),
            ([], 0.0),
            ([1.0] * 360, 50.0),
        ):
            bad = LaserScan()
            bad.header.stamp = rospy.Time.from_sec(rospy.get_time() + stamp_offset)
            bad.header.frame_id = "base_scan"
            bad.angle_min, bad.angle_increment = 0.0, 2 * math.pi / 360
            bad.angle_max = bad.angle_min + 359 * bad.angle_increment
            bad.range_min, bad.range_max = 0.12, 3.5
            bad.ranges = ranges
            bad_scans.publish(bad)

        # Drive a slow arc in the arena for 8 s of sim time.
        twist = Twist()
        twist.linear.x, twist.angular.z = 0.15, 0.25
        t_end = rospy.get_time() + 8.0

        def driven() -> bool:
            cmd.publish(twist)
            time.sleep(0.005)
            return bool(rospy.get_time() > t_end)

        wait_for(driven, 120.0, "8 s of driving", period=0.0)
        cmd.publish(Twist())
        assert proc.poll() is None, "a node died"
        count_before = grid.count
        wait_for(lambda: grid.count > count_before, 60.0, "a map update while driving")

        errors = []
        for _ in range(5):
            wait_for(lambda: truth.msg is not None, 10.0, "/ground_truth/odom")
            gt = truth.msg
            tf = buffer.lookup_transform("map", "base_footprint", gt.header.stamp, rospy.Duration(5.0))
            t, q = tf.transform.translation, tf.transform.rotation
            p, o = gt.pose.pose.position, gt.pose.pose.orientation
            yaw_err = wrap_angle(yaw_from_quaternion(q.x, q.y, q.z, q.w) - yaw_from_quaternion(o.x, o.y, o.z, o.w))
            errors.append((math.hypot(t.x - p.x, t.y - p.y), abs(yaw_err)))
            time.sleep(0.1)
        assert max(e[0] for e in errors) < 0.05, errors
        assert max(e[1] for e in errors) < math.radians(2.0), errors
        occupied = sum(1 for v in grid.msg.data if v == 100)
        assert occupied > 100  # the arena's walls and the cylinder
        assert proc.poll() is None
    finally:
        cmd.publish(Twist())
        for thing in (grid.sub, truth.sub, cmd, bad_scans):
            thing.unregister()
        listener.unregister()


def test_a_scan_in_another_frame_never_resets_the_map(slam_sim: tuple[Any, Any]) -> None:
    """Issue 12: one /scan whose frame_id is not the laser's used to start a new map. Now a frame tf knows is
    mapped with its own mounting, an unknown one is dropped with a warning; only ~reset starts a new map."""
    rospy, proc = slam_sim
    from nav_msgs.msg import OccupancyGrid
    from rosgraph_msgs.msg import Log
    from sensor_msgs.msg import LaserScan
    from std_srvs.srv import Empty

    grid = Latest(rospy, "/map", OccupancyGrid)
    scans = Latest(rospy, "/scan", LaserScan)
    logs: list[str] = []
    rosout = rospy.Subscriber("/rosout_agg", Log, lambda m: logs.append(m.msg) if m.name == "/slam" else None)
    publisher = rospy.Publisher("/scan", LaserScan, queue_size=10)
    try:
        wait_for(lambda: grid.msg is not None and scans.msg is not None, 60.0, "/map and /scan")
        known_before = sum(1 for v in grid.msg.data if v >= 0)
        assert known_before > 1000
        for frame in ("base_link", "no_such_frame") * 5:
            with scans.lock:
                scan = scans.msg
            scan.header.frame_id = frame
            scan.header.stamp = rospy.Time.from_sec(rospy.get_time())
            publisher.publish(scan)
            time.sleep(0.05)
        count = grid.count
        # Two more map publications (scans keep coming through temporalUpdate while the robot stands).
        wait_for(lambda: grid.count >= count + 2, 60.0, "map updates after the foreign-frame scans")
        assert proc.poll() is None, "a node died"
        known_after = sum(1 for v in grid.msg.data if v >= 0)
        assert known_after >= 0.95 * known_before, (known_before, known_after)

        # naming the frames tf does have, so a misnamed frame is told from tf that never arrived
        def warnings() -> list[str]:
            return [m for m in logs if "'no_such_frame'" in m and "frames on tf: " in m]

        wait_for(lambda: bool(warnings()), 30.0, "the warning")
        frames, statics = warnings()[0].split("frames on tf: ")[1].rstrip(")").split("; ")
        assert {"base_footprint", "base_scan", "odom"} <= set(frames.split(", "))
        assert statics == "/tf_static publishers connected: 1"  # robot_state_publisher's

        rospy.wait_for_service("/slam/reset", timeout=30.0)
        rospy.ServiceProxy("/slam/reset", Empty)()
        wait_for(lambda: any("reset requested" in m for m in logs), 30.0, "the reset logged")
        assert proc.poll() is None
    finally:
        for thing in (grid.sub, scans.sub, rosout, publisher):
            thing.unregister()


def test_dynamic_map_serves_the_map_as_gmapping_does(slam_sim: tuple[Any, Any]) -> None:
    """gmapping's ``dynamic_map`` (nav_msgs/GetMap): the map as of the call, in the map frame, the same grid as
    the latched /map (the robot stands still: nothing was mapped since)."""
    rospy, _proc = slam_sim
    from nav_msgs.msg import OccupancyGrid
    from nav_msgs.srv import GetMap

    latched = Latest(rospy, "/map", OccupancyGrid)
    try:
        wait_for(lambda: latched.msg is not None, 60.0, "/map (latched) from the slam node")
        rospy.wait_for_service("/dynamic_map", 30.0)
        served = rospy.ServiceProxy("/dynamic_map", GetMap)().map
    finally:
        latched.sub.unregister()
    assert served.header.frame_id == "map"
    assert served.header.stamp >= latched.msg.header.stamp
    assert (served.info.width, served.info.height) == (latched.msg.info.width, latched.msg.info.height)
    assert served.info.resolution == pytest.approx(latched.msg.info.resolution)
    occupied = sum(1 for cell in served.data if cell > 50)
    assert occupied > 100  # the arena's walls seen from the start
