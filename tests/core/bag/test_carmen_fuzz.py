"""Property-based fuzzing of the CARMEN log reader: any line or file gives scans or an InvalidInputError.

Lines are built from the shape of a FLASER record (``FLASER n r1..rn x y th ox oy oth stamp host logstamp``)
with hostile tokens in every field: missing or bad counts, NaN, negative and huge values, too few fields.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrs_nav.bag.carmen import parse_flaser, read_flaser
from mrs_nav.errors import InvalidInputError
from tests.core.fuzzing import attempt

TOKENS = st.sampled_from(
    ["0", "1", "-1", "3", "180", "0.5", "nan", "inf", "-inf", "1e308", "1e400", "-5", "x", "", "0_2", "1e-300",
     "99999999999999999999", "\u0661"]
)  # fmt: skip


@st.composite
def flaser_lines(draw: st.DrawFn) -> str:
    count = draw(st.one_of(TOKENS, st.integers(-2, 6).map(str)))
    fields = draw(st.lists(TOKENS, max_size=16))
    head = draw(st.sampled_from(["FLASER", "FLASER ", "flaser", "ODOM", "FLASER\t"]))
    return " ".join([head, count, *fields]) if draw(st.integers(0, 9)) else head


@given(flaser_lines())
@settings(max_examples=400)
def test_any_flaser_line_parses_or_is_an_invalid_input_error(line: str) -> None:
    scan = attempt(lambda: parse_flaser(line, "log:1"), InvalidInputError)
    if isinstance(scan, str):
        assert scan.startswith("log:1")
        return
    assert scan.ranges.size >= 1


@given(st.lists(flaser_lines(), max_size=6), st.booleans(), st.binary(max_size=30))
@settings(max_examples=150)
def test_any_log_file_reads_or_is_an_invalid_input_error(
    tmp_path_factory: pytest.TempPathFactory, lines: list[str], compressed: bool, junk: bytes
) -> None:
    folder = tmp_path_factory.mktemp("carmen")
    body = "\n".join(lines).encode() + b"\n" + junk
    path = folder / ("log.gz" if compressed else "log")
    path.write_bytes(gzip.compress(body)[: len(body) // 2 + 10] if compressed and junk else body)
    scans = attempt(lambda: list(read_flaser(path)), InvalidInputError)
    if isinstance(scans, str):
        assert str(path) in scans
        return
    assert all(scan.ranges.size >= 1 for scan in scans)


def test_a_folder_is_an_invalid_input_error(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match="cannot read CARMEN log"):
        list(read_flaser(tmp_path))
