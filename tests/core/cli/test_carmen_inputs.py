"""carmen2bag and replay on small CARMEN logs made at test time: real odometry, odometry gaps, broken stamps,
bad lines, an existing bag."""

import dataclasses
import itertools
import json
import math

import numpy as np
import pytest

from mrs_nav.bag.io import BagWriter, read_messages
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, laser_scan_message, odometry_message
from mrs_nav.cli.main import main
from mrs_nav.slam.eval.consistency import BROKEN_FRACTION, DUPLICATED_LINE
from tests.core.bag.carmen_fixture import drive, log_lines, write_log
from tests.core.slam.synthetic import ROOM, ROOM_WITH_DOOR, cast, far_drive, person

EVERY_SCAN = ["--param", "linearUpdate=0", "--param", "angularUpdate=0"]


def replay(bag, out, capsys, *params):
    code = main(["replay", str(bag), "--slam", "--out", str(out), "--json", *EVERY_SCAN, *params])
    captured = capsys.readouterr()
    return code, (json.loads(captured.out) if code == 0 else None), captured.err


def test_real_odometry_is_the_default_and_slam_beats_it(tmp_path, capsys):
    poses = drive()
    log = write_log(tmp_path / "a.log", log_lines(poses, seed=1))
    bag = tmp_path / "a.bag"
    assert main(["carmen2bag", str(log), str(bag), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["odometry"] == "log"
    odom = {t: m.pose.pose.position.x for _, t, m in read_messages(bag, ["/odom"])}
    truth = {t: m.pose.pose.position.x for _, t, m in read_messages(bag, ["/ground_truth/odom"])}
    # One odometry message per ODOM line: the fixture's line halfway between scans, and one at each scan.
    assert len(odom) == 2 * len(poses) - 1
    assert set(truth) <= set(odom)
    odom = [odom[t] for t in truth]
    truth = list(truth.values())
    assert max(abs(a - b) for a, b in zip(odom, truth, strict=True)) > 0.05  # the log's noisy odometry
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["scans"] == len(poses)
    assert summary["ate_rmse_m"] < 0.03


def test_a_turn_without_odometry_is_survived(tmp_path, capsys):
    lines = log_lines(drive(), seed=2)
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    del lines[flaser[20] + 2 : flaser[21]]  # scan 21 ends a 0.3 rad turn; its wheel odometry is lost
    bag = tmp_path / "gap.bag"
    assert main(["carmen2bag", str(write_log(tmp_path / "gap.log", lines)), str(bag)]) == 0
    assert "NOTE: " in capsys.readouterr().err
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["ate_rmse_m"] < 0.03


def test_a_log_whose_odom_lines_only_repeat_the_scans_poses_gets_synthetic_odometry(tmp_path, capsys):
    # As Orebro's corrected log: after each scan one ODOM line at that scan's pose, no wheel odometry between.
    lines = [line for line in log_lines(drive(), seed=7) if not line.startswith("ODOM") or line.endswith(" 0 host 0")]
    bag = tmp_path / "o.bag"
    assert main(["carmen2bag", str(write_log(tmp_path / "o.log", lines)), str(bag), "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["odometry"] == "synthetic"
    assert "have no odometry since the previous scan (the ODOM lines only repeat" in captured.err
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["ate_rmse_m"] < 0.03


@pytest.mark.parametrize("kind", ["constant", "two-valued", "backwards", "wrapped"])
def test_broken_stamps_are_repaired_with_a_note(kind, tmp_path, capsys):
    poses = drive()
    n = len(poses)
    stamps = {
        "constant": [100.0] * n,
        "two-valued": [100.0] * (n // 2) + [200.0] * (n - n // 2),
        "backwards": [10.0 + 0.5 * i - (0.8 if i == 30 else 0.0) for i in range(n)],
        # As the MIT Infinite Corridor log: -0.45 s, then times wrapped at 2^32 s printed to six digits.
        "wrapped": [-0.446] + [4294970000.0] * (n - 1),
    }[kind]
    bag = tmp_path / "b.bag"
    assert main(["carmen2bag", str(write_log(tmp_path / "b.log", log_lines(poses, stamps=stamps))), str(bag)]) == 0
    broken = sum(b <= a for a, b in itertools.pairwise(stamps))
    assert f"NOTE: {tmp_path / 'b.log'}: {broken} of {n} scans were stamped at or before" in capsys.readouterr().err
    scan_stamps = [t for _, t, _ in read_messages(bag, ["/scan"])]
    assert all(b > a for a, b in itertools.pairwise(scan_stamps))
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["scans"] == n
    assert summary["ate_rmse_m"] < 0.03


def test_a_quarter_turn_without_odometry_is_found_again(tmp_path, capsys):
    # As in the Seattle log: the scans and the odometry of most of a turn are missing, so the next scan comes
    # after a 1.5 rad turn that odometry never saw, far outside the matcher's usual +-0.5 rad.
    poses = drive()
    lines = log_lines(poses, seed=2)
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    assert abs(poses[25].yaw - poses[20].yaw) == pytest.approx(1.5)
    del lines[flaser[20] + 2 : flaser[25]]
    bag = tmp_path / "turn.bag"
    assert main(["carmen2bag", str(write_log(tmp_path / "turn.log", lines)), str(bag)]) == 0
    capsys.readouterr()
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["ate_rmse_m"] < 0.03
    assert summary["free_endpoint_fraction"] < 0.01


def test_negative_stamps_are_shifted_and_a_glitched_odom_stamp_left_out(tmp_path, capsys):
    # As in public logs: time counted from just before the first scan, and one ODOM line stamped far back.
    poses = drive()
    stamps = [-1.0 + 0.5 * i for i in range(len(poses))]
    lines = log_lines(poses, seed=5, stamps=stamps)
    glitch = [i for i, line in enumerate(lines) if line.startswith("ODOM") and not line.endswith(" 0 host 0")][30]
    fields = lines[glitch].split()
    fields[7] = fields[9] = "-14.4854"
    lines[glitch] = " ".join(fields)
    bag = tmp_path / "n.bag"
    assert main(["carmen2bag", str(write_log(tmp_path / "n.log", lines)), str(bag)]) == 0
    assert "every stamp shifted by +1 s" in capsys.readouterr().err
    scan_stamps = [t for _, t, _ in read_messages(bag, ["/scan"])]  # ns
    assert scan_stamps[0] == 0
    assert all(b - a == 500_000_000 for a, b in itertools.pairwise(scan_stamps))
    odom_stamps = [t for _, t, _ in read_messages(bag, ["/odom"])]
    assert all(b > a for a, b in itertools.pairwise(odom_stamps))
    assert len(odom_stamps) == 2 * len(poses) - 2  # the glitched line is not published; its pose still counts
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["ate_rmse_m"] < 0.03


def test_no_return_readings_spread_over_a_band_are_no_return(tmp_path, capsys):
    # As Seattle's SICK: "no return" logged as 81.83, 81.87 or 81.91 m. None of them may become a wall.
    poses = drive()
    lines = log_lines(poses, seed=6)
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    for i in flaser:  # the last three beams (left of the robot) see nothing
        fields = lines[i].split()
        fields[2 + 177 : 2 + 180] = ["81.83", "81.87", "81.91"]
        lines[i] = " ".join(fields)
    bag = tmp_path / "r.bag"
    assert main(["carmen2bag", str(write_log(tmp_path / "r.log", lines)), str(bag)]) == 0
    assert "taken as 'no return': range_max 81.83 m" in capsys.readouterr().err
    scans = [m for _, _, m in read_messages(bag, ["/scan"])]
    assert all(m.range_max == pytest.approx(81.83) for m in scans)
    assert sum(r >= m.range_max for m in scans for r in m.ranges) == 3 * len(scans)
    code, summary, _ = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["ate_rmse_m"] < 0.03
    assert summary["free_endpoint_fraction"] < 0.01


def test_a_broken_map_is_said_to_be_broken(tmp_path, capsys):
    # Scans whose beams are declared 20 % wider apart than they were cast: no pose makes two of them agree, as
    # with a laser's geometry set wrong, so the walls of the map come out doubled.
    bag = tmp_path / "wide.bag"
    with BagWriter(bag) as writer:
        for i, pose in enumerate(drive()):
            t = 5.0 + 0.5 * i
            scan = cast(pose)
            scan = dataclasses.replace(scan, angle_increment=1.2 * scan.angle_increment)
            writer.write("/scan", LASER_SCAN, round(t * 1e9), laser_scan_message(scan, t, "base_scan"))
            writer.write("/odom", ODOMETRY, round(t * 1e9), odometry_message(pose, t, "odom", "base_footprint"))
    code, summary, err = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["map_broken"] is True
    assert summary["doubled_wall_fraction"] > BROKEN_FRACTION
    assert summary["free_endpoint_fraction"] > 0.05
    assert f"WARNING: bag {bag}: the SLAM map is likely broken" in err


def test_a_place_mapped_twice_is_said_to_be_broken(tmp_path, capsys):
    # The drive out of a room and back 4 m and 14 degrees off (tests/core/slam/test_loop_closure.py) with loop
    # closure off: the room is drawn again beside itself, turned, where the first copy never reached. Few end
    # points land on free cells, but the second visit's scans fit the first copy: the place is in the map twice.
    bag = tmp_path / "twice.bag"
    truth, odom = far_drive()
    with BagWriter(bag) as writer:
        for i, (pose, reading) in enumerate(zip(truth, odom, strict=True)):
            t = 5.0 + 0.5 * i
            scan = cast(pose, walls=ROOM_WITH_DOOR)
            writer.write("/scan", LASER_SCAN, round(t * 1e9), laser_scan_message(scan, t, "base_scan"))
            writer.write("/odom", ODOMETRY, round(t * 1e9), odometry_message(reading, t, "odom", "base_footprint"))
    code, summary, err = replay(bag, tmp_path / "out", capsys, "--param", "loop_closure=false")
    assert code == 0
    assert summary["doubled_wall_fraction"] <= BROKEN_FRACTION
    assert summary["duplicated_place_fraction"] > DUPLICATED_LINE
    assert summary["map_broken"] is True
    assert f"WARNING: bag {bag}: the SLAM map is likely broken" in err
    assert "of the places checked are in the map twice" in err
    # Closed by place (loop closure on, as shipped), the room is drawn once.
    code, summary, err = replay(bag, tmp_path / "closed", capsys)
    assert code == 0
    assert summary["duplicated_place_fraction"] == 0.0
    assert summary["map_broken"] is False


def test_people_walking_with_the_robot_are_no_broken_map(tmp_path, capsys):
    # Two people walk round the room with the robot: their end points land on floor the robot saw free before
    # and after, as many of them as a doubled map's, but in pieces no longer than a person.
    bag = tmp_path / "people.bag"
    with BagWriter(bag) as writer:
        for i, pose in enumerate(drive()):
            t = 5.0 + 0.5 * i
            people = [person(xy) for xy in pose.apply(np.array([[1.0, 0.7], [-0.8, -0.9]]))]
            scan = cast(pose, walls=np.vstack([ROOM, *people]))
            writer.write("/scan", LASER_SCAN, round(t * 1e9), laser_scan_message(scan, t, "base_scan"))
            writer.write("/odom", ODOMETRY, round(t * 1e9), odometry_message(pose, t, "odom", "base_footprint"))
    code, summary, err = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    assert summary["free_endpoint_fraction"] > 0.05
    assert summary["doubled_wall_fraction"] < BROKEN_FRACTION
    assert summary["map_broken"] is False
    assert "WARNING" not in err


def test_the_reference_figure_says_when_the_scene_itself_draws_doubled_walls(tmp_path, capsys):
    # A car stands in the room while the robot drives the first leg and is gone when it drives back (an 8 m
    # laser sees through where it stood): its side is on free cells of the map, at the true poses as much as at
    # the SLAM's, and --reference says so.
    car = np.array([[-1.0, 0.0, 1.0, 0.0]])
    bag = tmp_path / "car.bag"
    with BagWriter(bag) as writer:
        for i, pose in enumerate(drive()):
            t = 5.0 + 0.5 * i
            scan = cast(pose, max_range=8.0, walls=np.vstack([ROOM, car]) if i < 21 else ROOM)
            writer.write("/scan", LASER_SCAN, round(t * 1e9), laser_scan_message(scan, t, "base_scan"))
            writer.write("/odom", ODOMETRY, round(t * 1e9), odometry_message(pose, t, "odom", "base_footprint"))
            truth = odometry_message(pose, t, "map", "base_footprint")
            writer.write("/ground_truth/odom", ODOMETRY, round(t * 1e9), truth)
    code = main(["replay", str(bag), "--slam", "--out", str(tmp_path / "out"), "--json", "--reference", *EVERY_SCAN])
    captured = capsys.readouterr()
    assert code == 0
    summary = json.loads(captured.out)
    assert summary["map_broken"] is True
    assert summary["doubled_wall_fraction_at_truth"] > BROKEN_FRACTION
    assert "the map the scans make at the bag's ground-truth poses reads" in captured.err
    code, summary, err = replay(bag, tmp_path / "plain", capsys)  # not asked for: not computed
    assert "doubled_wall_fraction_at_truth" not in summary
    assert "ground-truth poses" not in err


@pytest.mark.parametrize("odom_constant", [False, True])
def test_replay_refuses_scans_that_cannot_be_paired(odom_constant, tmp_path, capsys):
    bag = tmp_path / "c.bag"
    with BagWriter(bag) as writer:
        for i, pose in enumerate(drive()[:30]):
            scan_t = 5.0 + 0.5 * i if odom_constant else 5.0
            odom_t = 5.0 if odom_constant else 5.0 + 0.5 * i
            writer.write("/scan", LASER_SCAN, round(scan_t * 1e9), laser_scan_message(cast(pose), scan_t, "base_scan"))
            msg = odometry_message(pose, odom_t, "odom", "base_footprint")
            writer.write("/odom", ODOMETRY, round(odom_t * 1e9), msg)
    code, _, err = replay(bag, tmp_path / "out", capsys)
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1
    assert "cannot be paired with distinct odometry" in lines[0]
    assert lines[0].startswith(f"ERROR: bag {bag}: 29 of 30 ")


def test_carmen2bag_replaces_an_existing_bag(tmp_path, capsys):
    log = write_log(tmp_path / "a.log", log_lines(drive()[:10]))
    bag = tmp_path / "a.bag"
    bag.write_bytes(b"an older file")
    assert main(["carmen2bag", str(log), str(bag)]) == 0
    assert len(list(read_messages(bag, ["/scan"]))) == 10
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    assert main(["carmen2bag", str(log), str(bag)]) == 0


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda lines, i: lines.insert(i, "FLASER"), "FLASER line without a beam count"),
        (lambda lines, i: lines.__setitem__(i, lines[i].replace("FLASER 180", "FLASER 179")), "does not fit"),
        (lambda lines, i: lines.__setitem__(i, lines[i].replace("FLASER 180", "FLASER 190")), "does not fit"),
        (lambda lines, i: lines.__setitem__(i, lines[i].replace(" host ", " nan host ", 1)), "FLASER"),
    ],
)
def test_a_bad_line_is_one_error_naming_file_and_line(edit, match, tmp_path, capsys):
    lines = log_lines(drive()[:10])
    index = [i for i, line in enumerate(lines) if line.startswith("FLASER")][3]
    edit(lines, index)
    log = write_log(tmp_path / "bad.log", lines)
    bag = tmp_path / "bad.bag"
    bag.write_bytes(b"kept")
    assert main(["carmen2bag", str(log), str(bag)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"ERROR: {log}:{index + 1}: ")
    assert match in err[0]
    assert bag.read_bytes() == b"kept"  # nothing written over the old bag on a refused log


def _odom_steps(bag):
    """Distance and turn between consecutive /odom messages at the scans' stamps."""
    scans = {t for _, t, _ in read_messages(bag, ["/scan"])}
    poses = [m.pose.pose for _, t, m in read_messages(bag, ["/odom"]) if t in scans]
    out = []
    for a, b in itertools.pairwise(poses):
        turn = 2.0 * (math.atan2(b.orientation.z, b.orientation.w) - math.atan2(a.orientation.z, a.orientation.w))
        out.append(
            (math.hypot(b.position.x - a.position.x, b.position.y - a.position.y), math.remainder(turn, math.tau))
        )
    return out


def test_odom_scale_multiplies_the_logs_increments(tmp_path, capsys):
    log = write_log(tmp_path / "a.log", log_lines(drive()[:30], seed=5))
    plain, scaled = tmp_path / "plain.bag", tmp_path / "scaled.bag"
    assert main(["carmen2bag", str(log), str(plain)]) == 0
    assert main(["carmen2bag", str(log), str(scaled), "--odom-scale", "1.1,0.9"]) == 0
    capsys.readouterr()
    pairs = list(zip(_odom_steps(plain), _odom_steps(scaled), strict=True))
    assert sum(d for (d, _), _ in pairs) > 2.0  # it drives
    assert sum(abs(t) for (_, t), _ in pairs) > 1.0  # and turns
    for (d, t), (ds, ts) in pairs:
        assert ds == pytest.approx(1.1 * d, abs=1e-6)
        assert ts == pytest.approx(0.9 * t, abs=1e-6)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--odom-scale", "3,1"], "odometry scale (3.0, 1.0): each factor must be in 0.5..2"),
        (["--odom-scale", "1"], "--odom-scale: expected 2 numbers"),
        (["--odom-scale", "1.1,1", "--odom", "synthetic"], "applies to the log's odometry only"),
    ],
)
def test_a_bad_odom_scale_is_one_error_line(args, match, tmp_path, capsys):
    log = write_log(tmp_path / "a.log", log_lines(drive()[:5]))
    assert main(["carmen2bag", str(log), str(tmp_path / "a.bag"), *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert match in err[0]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        # a device was read as one endless line until the process ran out of memory
        (["carmen2bag", "/dev/zero", "x.bag"], "/dev/zero: cannot read CARMEN log: not a regular file"),
        (["replay", "{bag}", "--slam", "--relations", "/dev/zero"], "cannot read relations file: not a regular file"),
        # alphas of 1e308 overflowed the synthetic odometry to infinity, and the error named neither the option
        # nor a line
        (
            ["carmen2bag", "{log}", "y.bag", "--odom", "synthetic", "--odom-noise", "1e308,0,0,0"],
            "--odom-noise: odometry noise alphas must be in 0..10",
        ),
    ],
)
def test_unreadable_inputs_and_overflowing_noise_are_one_error_line(args, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    log = write_log(tmp_path / "a.log", log_lines(drive()[:20]))
    bag = tmp_path / "a.bag"
    assert main(["carmen2bag", str(log), str(bag)]) == 0
    capsys.readouterr()
    assert main([a.format(log=log, bag=bag) for a in args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("ERROR: ")
    assert message in err[0]


@pytest.mark.parametrize("topic", ["/odom", "/ground_truth/odom"])
def test_an_odometry_message_with_a_nan_is_skipped_with_a_note(topic, tmp_path, capsys):
    bag = tmp_path / "nan.bag"
    with BagWriter(bag) as writer:
        for i, pose in enumerate(drive()):
            t = 5.0 + 0.5 * i
            writer.write("/scan", LASER_SCAN, round(t * 1e9), laser_scan_message(cast(pose), t, "base_scan"))
            odom = odometry_message(pose, t, "odom", "base_footprint")
            truth = odometry_message(pose, t, "map", "base_footprint")
            if i == 10:
                (odom if topic == "/odom" else truth).pose.pose.position.x = math.nan
            writer.write("/odom", ODOMETRY, round(t * 1e9), odom)
            writer.write("/ground_truth/odom", ODOMETRY, round(t * 1e9), truth)
    code, summary, err = replay(bag, tmp_path / "out", capsys)
    assert code == 0
    note = f"NOTE: skipped 1 odometry or ground-truth messages with non-finite values (first: {topic} at 10.000 s"
    assert note in err
    assert summary["scans"] == len(drive())
    assert summary["ate_rmse_m"] < 0.05
