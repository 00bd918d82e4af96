"""The local track: scans matched against the latest scans only, in a frame of their own."""

import itertools
import math

from mrs_nav.geometry import Pose2D
from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.local_track import SUBMAP_M, LocalTrack
from mrs_nav.slam.matcher import ScanMatcher, thin_points
from mrs_nav.slam.scan import split_beams
from tests.core.slam.synthetic import cast


def laps() -> list[Pose2D]:
    """Twice round an oval in the synthetic room (clear of its walls), 0.23 m steps: about 28 m, so submaps are
    begun and dropped."""
    poses = []
    for k in range(120):
        a = 2.0 * math.pi * k / 60.0
        poses.append(Pose2D(-0.5 + 3.0 * math.cos(a), 0.8 * math.sin(a), a + math.pi / 2))
    return poses


def test_the_track_follows_the_motion_where_odometry_is_5_percent_long():
    config = SlamConfig()
    track = LocalTrack(config, ScanMatcher(config.sigma, config.search_linear, config.search_angular))
    truth = laps()
    odom = [truth[0]]
    for a, b in itertools.pairwise(truth):
        step = b.relative_to(a)
        odom.append(odom[-1].compose(Pose2D(1.05 * step.x, 1.05 * step.y, step.yaw)))
    mount = Pose2D(0.0, 0.0, 0.0)
    track_poses = []
    for true_pose, odom_pose in zip(truth, odom, strict=True):
        beams = split_beams(cast(true_pose), config.usable_range(3.5), config.maxRange)
        points = thin_points(beams.hit_points, config.delta)
        track_poses.append(track.update(odom_pose, points, beams, mount=mount, spread=(0.05, 0.05)))
    assert track.travelled > 2.0 * SUBMAP_M
    # Its own frame starts at the first scan: compare 10-step chords (1.6-2.3 m), which odometry gets 5 % wrong.
    for i in range(0, len(truth) - 10, 10):
        true_step = truth[i + 10].relative_to(truth[i])
        step = track_poses[i + 10].relative_to(track_poses[i])
        odom_step = odom[i + 10].relative_to(odom[i])
        chord = math.hypot(true_step.x, true_step.y)
        assert math.hypot(odom_step.x - true_step.x, odom_step.y - true_step.y) > 0.04 * chord
        assert math.hypot(step.x - true_step.x, step.y - true_step.y) < 0.03
        assert abs(math.remainder(step.yaw - true_step.yaw, math.tau)) < math.radians(1.0)
