"""The relations metric (Kummerle et al. 2009) on fixtures with a known answer."""

import json
import math

import pytest

from mrs_nav.cli.main import main
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.replay.pose_track import PoseTrack
from mrs_nav.slam.eval.relations import Relation, bridged, choose_offset, load_relations, relation_errors
from tests.core.bag.carmen_fixture import drive, log_lines, write_log

OFFSET = 976052857.337


def trajectory():
    stamps = [10.0 + 0.5 * i + 0.1 * math.sin(i * i) for i in range(40)]
    poses = [Pose2D(0.3 * i, math.sin(0.2 * i), 0.15 * i) for i in range(40)]
    return stamps, poses


def exact_track(stamps, poses):
    track = PoseTrack()
    for t, p in zip(stamps, poses, strict=True):
        track.add(t, p)
    return track


def test_known_errors_and_offset():
    stamps, poses = trajectory()
    track = exact_track(stamps, poses)
    relations = []
    for i in range(36):
        j = i + 1 + i % 4
        truth = poses[j].relative_to(poses[i])
        # Even relations: the reference is 0.1 m off along its x; odd ones: 0.02 rad off. Known answer:
        # translational errors 0.1 and 0 (mean 0.05, std 0.05), rotational 0 and 0.02 rad.
        wrong = Pose2D(0.1, 0.0, 0.0) if i % 2 == 0 else Pose2D(0.0, 0.0, 0.02)
        relations.append(Relation(stamps[i] + OFFSET, stamps[j] + OFFSET, truth.compose(wrong)))
    trajectory_ = bridged(stamps, poses, track, poses)
    found = choose_offset(relations, trajectory_)
    assert found.rule == "geometry"
    assert found.offset_s == pytest.approx(OFFSET, abs=1e-3)
    errors = relation_errors(relations, trajectory_, choose_offset(relations, trajectory_, OFFSET))
    assert errors.scored == 36
    assert errors.trans_mean_m == pytest.approx(0.05)
    assert errors.trans_std_m == pytest.approx(0.05)
    assert errors.rot_mean_deg == pytest.approx(math.degrees(0.01))
    assert errors.rot_std_deg == pytest.approx(math.degrees(0.01))
    assert errors.as_dict()["relations_offset_rule"] == "given"
    # A wrong offset given finds no stamps to bridge.
    with pytest.raises(InvalidInputError, match="no relation falls"):
        relation_errors(relations, trajectory_, choose_offset(relations, trajectory_, OFFSET + 1e4))


def test_relation_ends_between_poses_are_bridged_by_odometry():
    stamps, poses = trajectory()
    track = exact_track(stamps, poses)
    # Trajectory only every 4th pose; relation ends at the others are bridged with the (exact) odometry.
    sparse = slice(0, None, 4)
    relations = [Relation(stamps[i] + 5.0, stamps[i + 3] + 5.0, poses[i + 3].relative_to(poses[i])) for i in range(30)]
    trajectory_ = bridged(stamps[sparse], poses[sparse], track, poses[sparse])
    errors = relation_errors(relations, trajectory_, choose_offset(relations, trajectory_, 5.0))
    assert errors.scored == 30
    assert errors.trans_mean_m == pytest.approx(0.0, abs=1e-9)
    assert errors.rot_mean_deg == pytest.approx(0.0, abs=1e-7)


def test_offset_the_geometry_cannot_single_out_is_refused():
    stamps, poses = trajectory()
    track = exact_track(stamps, poses)
    # Relations that fit the trajectory at no offset.
    relations = [Relation(stamps[i] + 7.0, stamps[i + 1] + 7.0, Pose2D(-2.0, 1.0, 2.0)) for i in range(30)]
    with pytest.raises(InvalidInputError, match=r"does not single out a clock offset.*--relations-offset SECONDS"):
        choose_offset(relations, bridged(stamps, poses, track, poses))
    # A straight drive at constant speed: the relations fit equally well at every shift along it.
    even = [10.0 + 0.5 * i for i in range(80)]
    line = [Pose2D(0.2 * i, 0.0, 0.0) for i in range(80)]
    relations = [Relation(even[i] + 7.0, even[i + 2] + 7.0, Pose2D(0.4, 0.0, 0.0)) for i in range(1, 70)]
    with pytest.raises(InvalidInputError, match="does not single out a clock offset"):
        choose_offset(relations, bridged(even, line, exact_track(even, line), line))


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("1 2 3\n", ":1: a relation needs 8 numbers"),
        ("0 1 0 0 0 0 0 0\n1 2 x 0 0 0 0 0\n", ":2: malformed"),
        ("1 2 nan 0 0 0 0 0\n", ":1: relation values must be finite"),
        ("", "holds no relation"),
    ],
)
def test_bad_relations_file(text, match, tmp_path):
    path = tmp_path / "r.relations"
    path.write_text(text)
    with pytest.raises(InvalidInputError, match=match):
        load_relations(path)


def replay_with_relations(tmp_path, capsys, log, lines):
    """``mrs-nav replay --slam --relations`` of the log converted to a bag, every scan processed: its summary."""
    relations = tmp_path / "a.relations"
    relations.write_text("\n".join(lines) + "\n")
    bag = tmp_path / "a.bag"
    assert main(["carmen2bag", str(log), str(bag)]) == 0
    capsys.readouterr()
    args = ["replay", str(bag), "--slam", "--out", str(tmp_path / "out"), "--json", "--relations", str(relations)]
    assert main([*args, "--param", "linearUpdate=0", "--param", "angularUpdate=0"]) == 0
    return json.loads(capsys.readouterr().out)


def test_replay_scores_relations_on_a_converted_log(tmp_path, capsys):
    poses = drive()
    # Irregular intervals, as real logs have: evenly spaced stamps would leave the offset ambiguous.
    stamps = [10.0 + 0.5 * i + 0.1 * math.sin(i * i) for i in range(len(poses))]
    log = write_log(tmp_path / "a.log", log_lines(poses, seed=3, stamps=stamps))
    lines = []
    for i in range(0, len(poses) - 5, 2):
        for j in (i + 1, i + 5):
            d = poses[j].relative_to(poses[i])
            lines.append(f"{stamps[i] + OFFSET:.6f} {stamps[j] + OFFSET:.6f} {d.x:.6f} {d.y:.6f} 0 0 0 {d.yaw:.6f}")
    summary = replay_with_relations(tmp_path, capsys, log, lines)
    assert summary["relations_offset_s"] == pytest.approx(OFFSET, abs=1e-3)
    assert summary["relations_scored"] == len(lines)
    assert summary["relations_reference_trans_mean_m"] < 1e-5  # the truth itself scores (nearly) zero
    assert summary["relations_trans_mean_m"] < 0.02


def test_replay_finds_the_offset_where_the_stamp_vote_was_fooled(tmp_path, capsys):
    """As on Freiburg 079: the relation ends are scans, but their stamps differ from the bag's by a few ms, so no
    difference is shared by most ends; a few relations whose ends match scan stamps exactly at a wrong offset
    (here 3 s off) won the most common difference, and a good trajectory was scored metres off, exit 0."""
    poses = drive()
    stamps = [10.0 + 0.5 * i + 0.1 * math.sin(i * i) for i in range(len(poses))]
    log = write_log(tmp_path / "a.log", log_lines(poses, seed=3, stamps=stamps))
    jitter = [0.03 * math.sin(7.0 * i) for i in range(len(poses))]  # ends stamped a few ms to 30 ms off
    lines = []
    for i in range(0, len(poses) - 5, 2):
        for j in (i + 1, i + 5):
            d = poses[j].relative_to(poses[i])
            t1, t2 = stamps[i] + OFFSET + jitter[i], stamps[j] + OFFSET + jitter[j]
            lines.append(f"{t1:.6f} {t2:.6f} {d.x:.6f} {d.y:.6f} 0 0 0 {d.yaw:.6f}")
    decoy = OFFSET + 3.0
    lines += [f"{stamps[k] + decoy:.6f} {stamps[k + 1] + decoy:.6f} 1 0 0 0 0 0" for k in (3, 9, 15, 21)]
    summary = replay_with_relations(tmp_path, capsys, log, lines)
    assert summary["relations_offset_s"] == pytest.approx(OFFSET, abs=0.03)  # within the stamps' own jitter
    assert summary["relations_offset_rule"] == "geometry"
    assert summary["relations_scored"] == len(lines)
    assert summary["relations_offset_support"] >= 2 * summary["relations_offset_runner_up_support"]
    assert summary["relations_reference_trans_mean_m"] < 0.1  # the 30 ms jitter costs a few cm
