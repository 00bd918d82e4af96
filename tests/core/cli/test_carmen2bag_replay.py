"""carmen2bag and replay --slam end to end on an excerpt of the Intel log (made at test time)."""

import gzip
import json
from pathlib import Path

import pytest

from mrs_nav.cli.main import main

# The shared data folder beside the checkout (or beside the folder of worktrees).
SHARED = [p / "shared" / "data" for p in Path(__file__).resolve().parents if (p / "shared").is_dir()]
INTEL = (SHARED[0] if SHARED else Path()) / "intel-corrected.log.gz"
SCANS = 120


@pytest.fixture(scope="module")
def excerpt(tmp_path_factory):
    if not INTEL.is_file():
        pytest.skip(f"Intel log not found at {INTEL}")
    path = tmp_path_factory.mktemp("intel") / "intel_excerpt.log"
    lines, scans = [], 0
    with gzip.open(INTEL, "rt") as f:
        for line in f:
            lines.append(line)
            scans += line.startswith("FLASER")
            if scans == SCANS:
                break
    path.write_text("".join(lines))
    return path


def test_carmen2bag_then_replay(excerpt, tmp_path, capsys):
    bag = tmp_path / "intel.bag"
    assert main(["carmen2bag", str(excerpt), str(bag), "--seed", "3", "--json"]) == 0
    converted = json.loads(capsys.readouterr().out)
    assert converted["scans"] == SCANS
    out = tmp_path / "out"
    args = ["replay", str(bag), "--slam", "--out", str(out), "--json"]
    args += ["--param", "maxUrange=30", "--param", "linearUpdate=0", "--param", "angularUpdate=0"]
    assert main(args) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary) == {
        "scans",
        "scans_skipped",
        "scans_in_doubt",
        "loops_closed",
        "loops_rejected",
        "loops_solved",
        "free_endpoint_fraction",
        "doubled_wall_fraction",
        "duplicated_place_fraction",
        "map_broken",
        "ms_per_scan_median",
        "ms_per_scan_p95",
        "ms_per_scan_first_tenth_median",
        "ms_per_scan_last_tenth_median",
        "ms_per_scan_growth",
        "ms_per_scan_p95_over_median",
        "mapped_area_m2",
        "slam_held_bytes",
        "realtime_factor",
        "ate_rmse_m",
        "ate_rmse_deg",
        "rpe_trans_mean_m",
        "rpe_rot_mean_deg",
        "map_yaml",
        "metrics",
    }
    assert summary["scans"] == SCANS
    assert summary["rpe_trans_mean_m"] < 0.07
    assert summary["realtime_factor"] > 15
    assert summary["ms_per_scan_growth"] == pytest.approx(
        summary["ms_per_scan_last_tenth_median"] / summary["ms_per_scan_first_tenth_median"]
    )
    assert 0.0 < summary["mapped_area_m2"] < 2500.0  # the excerpt maps part of a 30 m x 30 m floor
    assert summary["slam_held_bytes"] > 4 * summary["mapped_area_m2"] / 0.05**2  # 4 bytes a cell seen, at least
    assert Path(summary["map_yaml"]).is_file()
    assert (out / "slam_map.pgm").is_file()
    assert (out / "slam_map.png").is_file()
    assert len((out / "trajectory.csv").read_text().splitlines()) == SCANS + 1


def test_odometry_noise_is_seeded(excerpt, tmp_path):
    a, b, c = (tmp_path / f"{n}.bag" for n in "abc")
    synthetic = ["--odom", "synthetic"]
    assert main(["carmen2bag", str(excerpt), str(a), "--seed", "1", *synthetic]) == 0
    assert main(["carmen2bag", str(excerpt), str(b), "--seed", "1", *synthetic]) == 0
    assert main(["carmen2bag", str(excerpt), str(c), "--seed", "2", *synthetic]) == 0
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["carmen2bag", "missing.log", "x.bag"], "missing.log: cannot read CARMEN log: No such file"),
        (["carmen2bag", "{log}", "x.bag", "--odom-noise", "1,2"], "--odom-noise: expected 4 numbers"),
        (["carmen2bag", "{log}", "x.bag", "--odom-noise", "0,0,0,0"], "--odom-noise applies to --odom synthetic"),
        (["replay", "missing.bag", "--slam"], "bag missing.bag does not exist"),
        (["replay", "{bag}", "--slam", "--param", "delta=-1"], "delta must be in 0.01..1"),
        (["replay", "{bag}", "--slam"], "has no /scan topic"),
    ],
)
def test_bad_input_is_one_error_line(args, message, excerpt, tmp_path, capsys, monkeypatch):  # noqa: PLR0917
    monkeypatch.chdir(tmp_path)
    bag = tmp_path / "odom_only.bag"
    from mrs_nav.bag.io import BagWriter
    from mrs_nav.bag.messages import ODOMETRY, odometry_message
    from mrs_nav.geometry import Pose2D

    with BagWriter(bag) as writer:
        writer.write("/odom", ODOMETRY, 1, odometry_message(Pose2D(0, 0, 0), 0.0, "odom", "base_footprint"))
    args = [a.format(log=excerpt, bag=bag) for a in args]
    assert main(args) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("ERROR: ")
    assert message in err[0]
