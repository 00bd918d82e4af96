"""Bags as other robots' users have them: /scan and /tf only, their own frame names, a 270-degree laser with
decreasing angles and out-of-range readings for no return (tests/core/replay/foreign_bags.py)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.bag.io import TF_MESSAGE, BagWriter
from mrs_nav.bag.messages import LASER_SCAN, laser_scan_message, tf_message
from mrs_nav.cli.main import main
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.scan import LaserScanData
from tests.core.replay.foreign_bags import Drive, simulate, trajectory, write_foreign_bag, write_package_bag


@pytest.fixture(scope="module")
def drive() -> Drive:
    return simulate()


@pytest.fixture(scope="module")
def package_replay(drive: Drive, tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("package")
    bag = write_package_bag(drive, folder / "package.bag")
    assert main(["replay", str(bag), "--slam", "--out", str(folder / "out")]) == 0
    return folder / "out"


def _same_trajectory(mine: Path, theirs: Path) -> float:
    """The largest distance (m) between two replays' poses, which must be at the same scans."""
    a, b = trajectory(mine), trajectory(theirs)
    assert a.shape == b.shape
    assert len(a) > 20
    assert np.array_equal(a[:, 0], b[:, 0])
    assert np.max(np.abs(np.angle(np.exp(1j * (a[:, 3] - b[:, 3]))))) < math.radians(1.0)
    return float(np.max(np.hypot(a[:, 1] - b[:, 1], a[:, 2] - b[:, 2])))


def test_a_gmapping_tutorial_bag_replays_as_the_package_own(drive, package_replay, tmp_path, capsys):
    """The number: /scan + /tf only, base_link/laser, 270 degrees in 1080 beams, angles decreasing: the same
    trajectory within 1 cm as the same drive in mrs_nav's frames and conventions."""
    bag = write_foreign_bag(drive, tmp_path / "tutorial.bag")
    assert main(["replay", str(bag), "--slam", "--out", str(tmp_path / "out")]) == 0
    assert "NOTE: odometry from tf odom -> base_link (no /odom topic)" in capsys.readouterr().err
    assert _same_trajectory(tmp_path / "out", package_replay) < 0.01


def test_a_laser_mounted_upside_down_maps_the_right_way_round(drive, package_replay, tmp_path):
    bag = write_foreign_bag(drive, tmp_path / "upside_down.bag", upside_down=True)
    assert main(["replay", str(bag), "--slam", "--out", str(tmp_path / "out")]) == 0
    assert _same_trajectory(tmp_path / "out", package_replay) < 0.01


def test_topics_and_frames_are_options_with_gmappings_names(drive, package_replay, tmp_path):
    bag = write_foreign_bag(drive, tmp_path / "renamed.bag", scan_topic="/base_scan", odom_frame="odom_combined")
    out = tmp_path / "out"
    golden = tmp_path / "renamed.golden.json"
    # as gmapping's parameters are often written: a relative topic, a tf1 frame name
    options = ["--scan-topic", "base_scan", "--odom-frame", "odom_combined", "--base-frame", "/base_link"]
    assert main(["replay", str(bag), "--slam", *options, "--out", str(out), "--write-golden", str(golden)]) == 0
    assert _same_trajectory(out, package_replay) < 0.01
    recorded = json.loads(golden.read_text())["options"]
    assert recorded == ["--slam", "--scan-topic=/base_scan", "--base-frame=base_link", "--odom-frame=odom_combined"]
    # a folder replay holds the bag to its golden file with those options
    assert main(["replay", str(tmp_path), "--out", str(tmp_path / "batch"), "--workers", "1"]) == 0


def test_a_base_frame_above_or_below_the_odometry_child_uses_the_fixed_transform(drive, package_replay, tmp_path):
    bag = write_package_bag(drive, tmp_path / "package.bag")
    out = tmp_path / "out"
    # /odom moves base_footprint; base_link sits 1 cm above it, the same planar pose
    assert main(["replay", str(bag), "--slam", "--base-frame", "base_link", "--out", str(out)]) == 0
    assert _same_trajectory(out, package_replay) < 1e-3


def test_tf_that_never_links_the_laser_to_the_base_is_one_error_line(drive, tmp_path, capsys):
    bag = write_foreign_bag(drive, tmp_path / "unlinked.bag", mount_frame="hokuyo")
    assert main(["replay", str(bag), "--slam", "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"ERROR: bag {bag}: tf never links the laser frame 'laser' (of /scan) to the base frame ")
    assert "'base_link'" in err[0]


def test_a_missing_odom_frame_names_it(drive, tmp_path, capsys):
    bag = write_foreign_bag(drive, tmp_path / "tutorial.bag")
    assert main(["replay", str(bag), "--slam", "--odom-frame", "odometry", "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("ERROR: ")
    assert "odometry frame 'odometry'" in err
    assert "\n" not in err


def test_scans_with_inconsistent_angles_are_one_error_line_naming_topic_and_frame(tmp_path, capsys):
    bag = tmp_path / "bad.bag"
    with BagWriter(bag) as writer:
        writer.write("/tf", TF_MESSAGE, 0, tf_message(Pose2D(0.0, 0.0, 0.0), 0.0, "base_link", "laser"))
        for i in range(10):
            t = 1.0 + 0.1 * i
            pose = Pose2D(0.01 * i, 0.0, 0.0)
            writer.write("/tf", TF_MESSAGE, round(t * 1e9), tf_message(pose, t, "odom", "base_link"))
            scan = LaserScanData(-2.0, 0.01, 0.1, 10.0, np.full(300, 2.0))
            message = laser_scan_message(scan, t, "laser")
            message.angle_max = 2.0  # 401 beams' worth of angles for 300 ranges
            writer.write("/scan", LASER_SCAN, round(t * 1e9), message)
    assert main(["replay", str(bag), "--slam", "--out", str(tmp_path / "out")]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("ERROR")]
    assert len(err) == 1
    assert "scan on /scan (frame 'laser')" in err[0]
    assert "300 ranges" in err[0]
