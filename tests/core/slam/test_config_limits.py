"""One set of SLAM defaults (config/slam.yaml) for the node and replay; stated limits on every parameter and on
the map's size; bad values in bags give one clear line, never a MemoryError or OverflowError."""

import json
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml

from mrs_nav.bag.io import BagWriter
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, laser_scan_message, odometry_message
from mrs_nav.cli.main import main
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.resources import CHECKOUT, CONFIG_DIR
from mrs_nav.slam import LaserScanData, Slam, SlamConfig
from mrs_nav.slam.config import LIMITS
from tests.core.slam.synthetic import cast


def test_node_and_replay_read_the_same_defaults():
    shipped = yaml.safe_load((CONFIG_DIR / "slam.yaml").read_text())
    config = SlamConfig()
    for name in LIMITS:
        assert getattr(config, name) == pytest.approx(shipped[name]), name
    assert config.map_grows == shipped["map_grows"]
    assert config.loop_closure == shipped["loop_closure"]
    # The node gets its parameters from that same file: slam.launch loads it into the slam node's namespace.
    launch = ET.parse(CHECKOUT / "launch" / "slam.launch").getroot()
    node = next(n for n in launch.iter("node") if n.get("type") == "slam")
    assert node.find("rosparam").get("file") == "$(find mrs_nav)/config/slam.yaml"
    # The node's reading (from_mapping of the ROS params) and replay's (no --param) agree.
    slam_keys = {*LIMITS, "map_grows", "loop_closure"}
    assert SlamConfig.from_mapping({k: v for k, v in shipped.items() if k in slam_keys}) == config
    assert SlamConfig.from_assignments([]) == config


def test_usable_range_follows_the_scan():
    config = SlamConfig()
    assert config.maxUrange == 30.0
    assert config.usable_range(3.5) == 3.5
    assert config.usable_range(81.83) == 30.0
    assert SlamConfig(maxUrange=0.0).usable_range(81.83) == 81.83


@pytest.mark.parametrize(
    ("param", "match"),
    [
        ("delta=1e-4", "delta must be in 0.01..1"),
        ("xmin=-1e6", "xmin must be in -100000..100000"),
        ("xmin=-99999", "needs 8.02e\\+08 cells, more than the limit"),
        ("search_linear=100", "search_linear must be in 0..2"),
        ("sigma=1e308", "sigma must be in"),
        ("lmax=inf", "lmax must be in"),
        ("maxUrange=nan", "maxUrange must be in"),
    ],
)
def test_extreme_replay_params_are_one_error_line(param, match, tmp_path, capsys):
    bag = tmp_path / "x.bag"
    bag.write_bytes(b"not read: the parameters are checked first")
    assert main(["replay", str(bag), "--slam", "--param", param]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("ERROR: SLAM ")
    assert re.search(match, err[0]), err[0]


def test_growth_past_the_cell_limit_is_refused_and_the_map_kept():
    slam = Slam(SlamConfig(linearUpdate=0.0, angularUpdate=0.0))
    scan = cast(Pose2D(0.0, 0.0, 0.0))
    slam.add_scan(Pose2D(0.0, 0.0, 0.0), scan, 0.0)
    before = slam.grid.dense()[0]
    with pytest.raises(InvalidInputError, match="more than the limit"):
        slam.add_scan(Pose2D(90_000.0, 0.0, 0.0), scan, 1.0)
    with pytest.raises(InvalidInputError, match="beyond 100000 m"):
        slam.add_scan(Pose2D(1e300, 0.0, 0.0), scan, 2.0)
    assert len(slam.processed) == 1
    assert np.array_equal(slam.grid.dense()[0], before)
    assert slam.add_scan(Pose2D(0.05, 0.0, 0.0), scan, 3.0) is not None


@pytest.mark.parametrize("angle_max", [math.nan, math.inf, 1e30])
def test_scan_angles_that_make_no_sense_are_refused(angle_max):
    with pytest.raises(InvalidInputError, match="laser scan angle"):
        LaserScanData.from_message_fields(
            angle_min=0.0, angle_max=angle_max, angle_increment=0.01, range_min=0.1, range_max=3.5, ranges=np.ones(10)
        )


def test_bag_with_bad_angles_and_far_odometry_replays_with_a_note(tmp_path, capsys):
    bag = tmp_path / "bad.bag"
    poses = [Pose2D(-2.0 + 0.1 * i, 0.0, 0.02 * i) for i in range(40)]
    with BagWriter(bag) as writer:
        for i, pose in enumerate(poses):
            t = 1.0 + 0.2 * i
            scan_msg = laser_scan_message(cast(pose), t, "base_scan")
            if i == 10:
                scan_msg.angle_max = math.nan
            if i == 11:
                scan_msg.angle_max = math.inf
            writer.write("/scan", LASER_SCAN, round(t * 1e9), scan_msg)
            far = {20: Pose2D(1e6, 0.0, 0.0), 30: Pose2D(1e300, 0.0, 0.0)}.get(i, pose)
            writer.write("/odom", ODOMETRY, round(t * 1e9), odometry_message(far, t, "odom", "base_footprint"))
            truth = odometry_message(pose, t, "map", "base_footprint")
            writer.write("/ground_truth/odom", ODOMETRY, round(t * 1e9), truth)
    args = ["replay", str(bag), "--slam", "--out", str(tmp_path / "out"), "--json"]
    assert main([*args, "--param", "linearUpdate=0", "--param", "angularUpdate=0"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["scans_skipped"] == 2
    assert summary["scans"] == 38
    assert summary["ate_rmse_m"] < 0.02
    note = captured.err.strip().splitlines()
    assert len(note) == 3
    assert note.pop(0).endswith("has no tf: the laser (frame 'base_scan') is taken at the origin of 'base_footprint'")
    assert note[0].startswith("NOTE: skipped 0 scans stamped at or before the previous scan and 2 scans")
    assert "angle_max must be finite" in note[0]
    assert note[1] == "NOTE: skipped 2 of 40 odometry messages farther than 100000 m from the origin"
