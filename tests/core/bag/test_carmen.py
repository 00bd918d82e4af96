import gzip
import itertools
import math

import pytest

from mrs_nav.bag.carmen import carmen_angle_increment, parse_flaser, read_flaser, read_log
from mrs_nav.errors import InvalidInputError
from tests.core.bag.carmen_fixture import drive, log_lines, write_log

LINE = "FLASER 4 1.0 2.0 81.83 3.5 0.5 -0.25 0.1 0.6 -0.2 0.11 12.5 pippo 12.5"


def test_flaser_line_fields():
    scan = parse_flaser(LINE)
    assert scan.ranges.tolist() == [1.0, 2.0, 81.83, 3.5]
    assert (scan.pose.x, scan.pose.y, scan.pose.yaw) == (0.5, -0.25, 0.1)
    assert (scan.odom.x, scan.odom.y) == (0.6, -0.2)
    assert scan.timestamp == 12.5
    assert scan.angle_min == pytest.approx(-math.pi / 2)
    # CARMEN's guess for an unusual beam count: 180 degrees over n - 1 steps.
    assert scan.angle_increment == pytest.approx(math.pi / 3)


@pytest.mark.parametrize(("beams", "degrees"), [(180, 1.0), (181, 1.0), (360, 0.5), (361, 0.5), (401, 0.25), (5, 45.0)])
def test_carmen_beam_angles(beams, degrees):
    assert math.degrees(carmen_angle_increment(beams)) == pytest.approx(degrees)


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("FLASER", "without a beam count"),
        ("FLASER 4 1.0 2.0", "has 4 fields"),
        ("FLASER x 1", "beam count 'x' is not an integer"),
        ("FLASER 0", "beam count 0 is not in"),
        ("FLASER -3 1 2", "beam count -3 is not in"),
        ("FLASER 99999999 1", "beam count 99999999 is not in"),
        ("ODOM 0 0 0", "not a FLASER"),
        (LINE.replace("2.0", "nan", 1), "range 1 is nan"),
        (LINE.replace("2.0", "-2.0", 1), "range 1 is -2.0"),
        (LINE.replace("2.0", "1e9", 1), "range 1 is 1000000000.0"),
        (LINE.replace(" 12.5 pippo", " nan pippo"), "timestamp nan"),
        (LINE.replace(" 12.5 pippo", " -5e12 pippo"), "timestamp -5000000000000.0"),
        (LINE.replace(" 12.5 pippo", " 1e300 pippo"), r"timestamp 1e\+300"),
        (LINE.replace("0.5 -0.25", "1e300 -0.25"), "FLASER pose"),
        (LINE.replace("0.5 -0.25", "inf -0.25"), "FLASER pose"),
        (LINE.replace("3.5", "abc"), "malformed FLASER range"),
    ],
)
def test_bad_lines_name_the_place(line, match):
    with pytest.raises(InvalidInputError, match=f"log:3: .*{match}"):
        parse_flaser(line, "log:3")


def test_bad_odom_line_names_the_place(tmp_path):
    path = write_log(tmp_path / "x.log", [LINE, "ODOM 1 2 nan 0 0 0 13 h 13", LINE.replace("12.5", "14")])
    with pytest.raises(InvalidInputError, match=r"x\.log:2: ODOM pose"):
        read_log(path)


def test_reads_gzip_and_skips_other_records(tmp_path):
    path = tmp_path / "x.log.gz"
    with gzip.open(path, "wt") as f:
        f.write("# comment\nODOM 0 0 0 0 0 0 1 h 1\nFLASERX 1 2\n" + LINE + "\n" + LINE + "\n")
    assert len(list(read_flaser(path))) == 2


def test_unreadable_log(tmp_path):
    with pytest.raises(InvalidInputError, match="cannot read CARMEN log"):
        list(read_flaser(tmp_path / "missing.log"))


def test_odometry_increments_are_the_logged_wheel_odometry(tmp_path):
    poses = drive()
    log = read_log(write_log(tmp_path / "a.log", log_lines(poses, seed=4)))
    assert len(log.scans) == len(poses)
    assert log.gaps == 0
    # The fixture's noisy increment is rebuilt from its ODOM lines: recompute it the same way.
    lines = [line for line in log_lines(poses, seed=4) if line.startswith("ODOM") and not line.endswith(" 0 host 0")]
    ends = lines[1::2]  # the line stamped at each scan
    for k, line in enumerate(ends, start=1):
        x, y, yaw = (float(v) for v in line.split()[1:4])
        expected_end = poses[k - 1].compose(log.increments[k])  # type: ignore[arg-type]
        assert (expected_end.x, expected_end.y) == pytest.approx((x, y), abs=2e-6)
        assert math.remainder(expected_end.yaw - yaw, 2 * math.pi) == pytest.approx(0.0, abs=2e-6)
    # Noisy, not the corrected poses' own increments.
    exact = [b.relative_to(a) for a, b in itertools.pairwise(poses)]
    assert any(abs(inc.x - e.x) > 1e-4 for inc, e in zip(log.increments[1:], exact, strict=True))  # type: ignore[union-attr]


def test_a_scan_without_odometry_lines_is_a_gap(tmp_path):
    lines = log_lines(drive())
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    # Drop the wheel odometry before the 22nd scan (a turn), keeping the re-anchoring line after scan 21.
    del lines[flaser[20] + 2 : flaser[21]]
    log = read_log(write_log(tmp_path / "gap.log", lines))
    assert log.gaps == 1
    assert log.increments[21] is None
