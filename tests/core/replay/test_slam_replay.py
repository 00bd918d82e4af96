"""replay_slam over a synthetic bag: scans before their odometry, a mounted laser, no ground truth."""

import json
import math

import numpy as np
import pytest

from mrs_nav.bag.io import BagWriter
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, laser_scan_message, odometry_message, tf_message
from mrs_nav.cli.main import main
from mrs_nav.geometry import Pose2D
from mrs_nav.replay.bag_frames import BagNames, resolve_frames
from mrs_nav.replay.slam_replay import replay_slam
from mrs_nav.slam import SlamConfig
from tests.core.slam.synthetic import cast

MOUNT = Pose2D(-0.032, 0.0, 0.0)


def write_bag(path, with_truth, truth_from=0):
    """30 scans; ground truth (when ``with_truth``) from scan ``truth_from`` on, as a recording started late."""
    truth = [Pose2D(-2.0 + 0.1 * i, 0.3 * math.sin(0.1 * i), 0.05 * i) for i in range(30)]
    rng = np.random.default_rng(0)
    with BagWriter(path) as writer:
        writer.write("/tf_static", "tf2_msgs/msg/TFMessage", 0, tf_message(MOUNT, 0.0, "base_footprint", "base_scan"))
        odom = Pose2D(truth[0].x, truth[0].y, truth[0].yaw)
        for i, gt in enumerate(truth):
            t = 1.0 + 0.2 * i
            if i:
                step = gt.relative_to(truth[i - 1])
                odom = odom.compose(Pose2D(step.x * 1.05, step.y, step.yaw + rng.normal(0.0, 0.01)))
            scan = cast(gt.compose(MOUNT))
            # The scan is written before the odometry of its instant: replay must wait for it, not drop it.
            writer.write("/scan", LASER_SCAN, round(t * 1e9), laser_scan_message(scan, t, "base_scan"))
            msg = odometry_message(odom, t, "odom", "base_footprint")
            writer.write("/odom", ODOMETRY, round(t * 1e9) + 1000, msg)
            if with_truth and i >= truth_from:
                writer.write(
                    "/ground_truth/odom", ODOMETRY, round(t * 1e9), odometry_message(gt, t, "map", "base_footprint")
                )
    return truth


def test_mounting_comes_from_tf_static(tmp_path):
    bag = tmp_path / "a.bag"
    write_bag(bag, with_truth=True)
    mount = resolve_frames(bag, BagNames()).mounting
    assert (mount.x, mount.y, mount.yaw) == pytest.approx((MOUNT.x, MOUNT.y, MOUNT.yaw))


def test_replay_pairs_every_scan_and_tracks_the_truth(tmp_path):
    bag = tmp_path / "a.bag"
    write_bag(bag, with_truth=True)
    result = replay_slam(bag, SlamConfig(linearUpdate=0.0, angularUpdate=0.0))
    assert result.scans_read == 30
    assert result.scans_rejected == 0
    assert len(result.estimate) == 30
    errors = result.errors()
    assert errors is not None
    assert errors.ate_rmse_m < 0.02
    assert errors.rpe_trans_mean_m < 0.01


def test_truth_that_starts_after_the_first_scans_still_measures_the_rest(tmp_path):
    bag = tmp_path / "late.bag"
    write_bag(bag, with_truth=True, truth_from=2)
    result = replay_slam(bag, SlamConfig(linearUpdate=0.0, angularUpdate=0.0))
    assert [t is None for t in result.truth[:3]] == [True, True, False]
    errors = result.errors()
    assert errors is not None
    assert errors.ate_rmse_m < 0.02


def test_truth_for_a_fragment_of_the_run_is_no_measure(tmp_path):
    bag = tmp_path / "fragment.bag"
    write_bag(bag, with_truth=True, truth_from=20)
    assert replay_slam(bag, SlamConfig(linearUpdate=0.0, angularUpdate=0.0)).errors() is None


def test_replay_without_ground_truth_gives_null_errors(tmp_path, capsys):
    bag = tmp_path / "b.bag"
    write_bag(bag, with_truth=False)
    out = tmp_path / "out"
    assert (
        main(
            [
                "replay",
                str(bag),
                "--slam",
                "--out",
                str(out),
                "--json",
                "--param",
                "linearUpdate=0.25",
                "--param",
                "angularUpdate=1",
            ]
        )
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    assert summary["ate_rmse_m"] is None
    assert summary["rpe_trans_mean_m"] is None
    assert 5 < summary["scans"] < 30  # the update gate skipped some scans
    assert (out / "slam_map.png").is_file()
    assert (out / "slam_map.yaml").read_text().startswith("image: slam_map.pgm")
