"""`mrs-nav bench slam-sweep`: logs x parameter grid fanned out to local workers give the serial run's figures."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from mrs_nav.bench.slam_sweep import combinations, grid_option
from mrs_nav.cli.main import main
from tests.core.bag.carmen_fixture import drive, log_lines, write_log

# Columns of a row that do not depend on where or how fast the job ran (all but the timings).
FIGURES = slice(0, 10)


def _rows(section: str, columns: slice = FIGURES) -> list[list[str]]:
    lines = [line for line in section.splitlines() if line.startswith("| ") and not line.startswith("| log")]
    return [[cell.strip() for cell in line.strip("|").split("|")][columns] for line in lines]


def _sweep(tmp_path: Path, capsys: pytest.CaptureFixture[str], workers: int) -> str:
    tmp_path.mkdir()
    logs = [write_log(tmp_path / f"room{seed}.log", log_lines(drive(), seed=seed)) for seed in (1, 2)]
    args = ["bench", "slam-sweep", "--no-write", "--workers", str(workers), "--grid", "delta=0.05,0.1"]
    assert main([*args, "--log", str(logs[0]), "--log", str(logs[1])]) == 0
    return capsys.readouterr().out


def test_two_logs_by_two_values_in_parallel_equal_the_serial_sweep(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    serial_section = _sweep(tmp_path / "serial", capsys, 1)
    serial = _rows(serial_section)
    parallel = _rows(_sweep(tmp_path / "parallel", capsys, 2))
    # Each job ran in a process of its own: its peak memory is a process's (over 50 MB), not the pytest one's.
    peaks = [float(row[0]) for row in _rows(serial_section, slice(12, 13))]
    assert len(peaks) == 4
    assert all(50.0 < peak < 2000.0 for peak in peaks)
    # The cost along the log (issue 40): the tenths' medians, their ratio, the tail, the area and the verdict
    for first_last, growth, tail, area, per_m2, held, lines in _rows(serial_section, slice(13, 20)):
        first, last = (float(v) for v in first_last.split(" / "))
        assert float(growth) == pytest.approx(last / first, rel=0.01, abs=0.01)
        assert float(tail) >= 1.0
        assert 10.0 < float(area) < 400.0  # the synthetic room's floor, a few metres a side, and what its walls hide
        assert float(per_m2) >= 0.0
        assert float(held) > 4.0 / 0.05**2 / 1000.0  # kB/m^2: 4 bytes of log-odds a cell seen, at least
        assert lines == "PASS" or lines.startswith("FAIL: ")
    assert [row[:2] for row in serial] == [
        ["room1", "delta=0.05"],
        ["room1", "delta=0.1"],
        ["room2", "delta=0.05"],
        ["room2", "delta=0.1"],
    ]
    assert parallel == serial
    for row in serial:
        scans, ate, doubled, at_truth = int(row[2]), float(row[4]), float(row[6]), float(row[7])
        twice, verdict = float(row[8]), row[9]
        assert scans > 50
        assert ate < 0.1, row  # the synthetic room's drive is mapped, not broken
        assert doubled == 0.0, row
        assert at_truth == 0.0, row  # nor is it at the log's corrected poses
        assert twice == 0.0, row
        assert verdict == "ok"


def test_grid_values_are_checked_as_slam_parameters() -> None:
    assert grid_option("delta=0.05, 0.1") == ("delta", ("0.05", "0.1"))
    assert combinations([("a", ("1", "2")), ("b", ("x",))]) == [("a=1", "b=x"), ("a=2", "b=x")]
    with pytest.raises(argparse.ArgumentTypeError, match=re.escape("delta must be in")):
        grid_option("delta=0.05,-1")
    with pytest.raises(argparse.ArgumentTypeError, match="expected NAME=V1,V2"):
        grid_option("delta")


def test_a_bad_grid_is_one_error_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "slam-sweep", "--no-write", "--grid", "nosuch=1,2"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "nosuch" in err[0]
