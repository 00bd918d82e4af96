import math

import numpy as np
import pytest

from mrs_nav.bag.io import BagWriter, bag_topics, read_messages
from mrs_nav.bag.messages import (
    LASER_SCAN,
    ODOMETRY,
    laser_scan_message,
    odometry_message,
    pose_from_odometry,
    scan_from_message,
    stamp_of,
)
from mrs_nav.errors import BagError, InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.scan import LaserScanData


def test_scan_and_odometry_round_trip(tmp_path):
    bag = tmp_path / "a.bag"
    scan = LaserScanData(-1.0, 0.5, 0.1, 5.0, np.array([1.0, math.inf, math.nan, 2.5, 0.3]))
    with BagWriter(bag) as writer:
        writer.write("/scan", LASER_SCAN, 1_500_000_000, laser_scan_message(scan, 1.5, "base_scan"))
        writer.write("/odom", ODOMETRY, 2_000_000_000, odometry_message(Pose2D(1, 2, 3), 2.0, "odom", "base_footprint"))
    assert bag_topics(bag) == {"/scan": LASER_SCAN, "/odom": ODOMETRY}
    got = list(read_messages(bag, ["/scan", "/odom"]))
    assert [t for t, _, _ in got] == ["/scan", "/odom"]
    back = scan_from_message(got[0][2])
    assert back.angle_min == pytest.approx(-1.0)
    np.testing.assert_allclose(back.ranges, scan.ranges, rtol=1e-6)
    assert stamp_of(got[1][2]) == pytest.approx(2.0)
    pose = pose_from_odometry(got[1][2])
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((1, 2, 3))


@pytest.mark.ros
def test_debian_rosbag_reads_every_message_we_write(tmp_path):
    rosbag = pytest.importorskip("rosbag")  # Debian's python3-rosbag, which users open our bags with
    bag = tmp_path / "ours.bag"
    with BagWriter(bag) as writer:
        for i in range(50):
            pose = Pose2D(0.01 * i, 0.0, 0.0)
            writer.write("/odom", ODOMETRY, 10**9 + i * 10**7, odometry_message(pose, 1.0 + 0.01 * i, "odom", "base"))
    with rosbag.Bag(str(bag)) as theirs:
        xs = [msg.pose.pose.position.x for _, msg, _ in theirs.read_messages(topics=["/odom"])]
    assert xs == pytest.approx([0.01 * i for i in range(50)])


def test_missing_topic_names_bag_and_topic(tmp_path):
    bag = tmp_path / "b.bag"
    with BagWriter(bag) as writer:
        writer.write("/odom", ODOMETRY, 1, odometry_message(Pose2D(0, 0, 0), 0.0, "odom", "base_footprint"))
    with pytest.raises(BagError, match=r"b\.bag has no /scan topic \(topics: /odom\)"):
        list(read_messages(bag, ["/scan"], required=["/scan"]))


def test_not_a_bag(tmp_path):
    path = tmp_path / "c.bag"
    path.write_bytes(b"nonsense")
    with pytest.raises(BagError, match=r"cannot read bag .*c\.bag"):
        list(read_messages(path, ["/scan"]))


def test_scan_with_inconsistent_length_is_rejected():
    scan = LaserScanData(-1.0, 0.5, 0.1, 5.0, np.ones(5))
    msg = laser_scan_message(scan, 0.0, "base_scan")
    msg.ranges = np.ones(3, dtype=np.float32)
    with pytest.raises(InvalidInputError, match="3 ranges"):
        scan_from_message(msg)


def test_an_interrupted_recording_keeps_what_it_wrote_and_a_failed_one_leaves_nothing(tmp_path):
    kept, failed = tmp_path / "kept.bag", tmp_path / "failed.bag"

    def record_then(bag, error):
        with BagWriter(bag) as writer:
            writer.write("/odom", ODOMETRY, 1_000_000_000, odometry_message(Pose2D(1, 2, 3), 1.0, "odom", "base"))
            raise error

    for bag, error in ((kept, KeyboardInterrupt), (failed, RuntimeError)):
        with pytest.raises(error):
            record_then(bag, error)
    assert [stamp_of(message) for _, _, message in read_messages(kept, ["/odom"])] == [pytest.approx(1.0)]
    assert not failed.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.bag"]  # no temporary file left either
