import gzip
import math

import pytest

from mrs_nav.bag.carmen import parse_flaser, read_flaser
from mrs_nav.errors import InvalidInputError

LINE = "FLASER 4 1.0 2.0 81.83 3.5 0.5 -0.25 0.1 0.6 -0.2 0.11 12.5 pippo 12.5"


def test_flaser_line_fields():
    scan = parse_flaser(LINE)
    assert scan.ranges.tolist() == [1.0, 2.0, 81.83, 3.5]
    assert (scan.pose.x, scan.pose.y, scan.pose.yaw) == (0.5, -0.25, 0.1)
    assert (scan.odom.x, scan.odom.y) == (0.6, -0.2)
    assert scan.timestamp == 12.5
    assert scan.angle_min == pytest.approx(-math.pi / 2)
    assert scan.angle_increment == pytest.approx(math.pi / 4)


@pytest.mark.parametrize(
    ("line", "match"),
    [("FLASER 4 1.0 2.0", "only"), ("FLASER x 1", "malformed"), ("ODOM 0 0 0", "not a FLASER"), ("FLASER 0", "only")],
)
def test_bad_lines_name_the_place(line, match):
    with pytest.raises(InvalidInputError, match=f"log:3: .*{match}"):
        parse_flaser(line, "log:3")


def test_reads_gzip_and_skips_other_records(tmp_path):
    path = tmp_path / "x.log.gz"
    with gzip.open(path, "wt") as f:
        f.write("# comment\nODOM 0 0 0 0 0 0 1 h 1\n" + LINE + "\n" + LINE + "\n")
    assert len(list(read_flaser(path))) == 2


def test_unreadable_log(tmp_path):
    with pytest.raises(InvalidInputError, match="cannot read CARMEN log"):
        list(read_flaser(tmp_path / "missing.log"))
