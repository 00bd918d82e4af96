"""``mrs-nav plan`` with the potential field: JSON output, exit codes and one-line errors."""

from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.cli.main import main
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world
from tests.rosharness import REPO

TRAP = "[[0, 0.25, 0.3], [0, -0.25, 0.3]]"


def test_plan_in_the_course_world_prints_the_path_as_json(
    simple_world: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["plan", "--world", str(simple_world), "--start", "-1.5,-1.5,0.5", "--goal", "1.5,1.5", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert out["success"] is True
    assert out["path"][0] == [-1.5, -1.5, 0.5]
    assert out["path"][-1][:2] == [1.5, 1.5]
    assert out["length_m"] == pytest.approx(sum(math.dist(a[:2], b[:2]) for a, b in itertools.pairwise(out["path"])))
    assert {"time_s", "first_solution_s", "iterations", "nodes", "reason"} <= out.keys()


@pytest.mark.parametrize("radius", [0.105, 0.2])
def test_potential_field_path_keeps_the_robot_radius_from_every_obstacle(
    radius: float, simple_world: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The field is planned around the obstacles grown by --robot-radius, and the goal in the arena's corner is
    still reached (the goal fade)."""
    argv = ["plan", "--world", str(simple_world), "--start", "-1.5,-1.5", "--goal", "1.5,1.5", "--json"]
    assert main([*argv, "--robot-radius", str(radius)]) == 0
    path = np.array(json.loads(capsys.readouterr().out)["path"])[:, :2]
    dense = np.concatenate([np.linspace(a, b, 200) for a, b in itertools.pairwise(path)])
    assert Obstacles.from_world(load_world(simple_world)).signed_distance(dense).min() >= radius - 1e-9
    assert math.dist(path[-1], (1.5, 1.5)) < 0.05


def test_plan_around_circles_from_a_file_is_seeded(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    circles = tmp_path / "trap.json"
    circles.write_text(TRAP)
    argv = ["plan", "--circles", str(circles), "--start", "-1.5,0", "--goal", "1.5,0", "--seed", "4", "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert first["path"] == again["path"]
    assert first["length_m"] < 1.15 * 3.2


def test_goal_not_reached_exits_2_with_the_reason(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["plan", "--circles", TRAP, "--start", "-1.5,0", "--goal", "1.5,0", "--max-steps", "20", "--json"]
    assert main(argv) == 2
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["success"] is False
    assert out["path"] == []  # no partial trajectory passed off as a plan
    assert out["iterations"] == 20
    assert captured.err.startswith("ERROR: goal not reached: step budget used up")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--circles", TRAP, "--start", "0,0.3", "--goal", "1.5,0"], "start (0.0, 0.3) is inside an obstacle"),
        (["--circles", TRAP, "--start", "-1.5,0", "--goal", "0,-0.3"], "goal (0.0, -0.3) is inside an obstacle"),
        (["--circles", "[]", "--start", "-1.5,0", "--goal", "1.5,0"], "--circles: the obstacle list is empty"),
        (["--circles", "[[0, 0, -1]]", "--start", "-1.5,0", "--goal", "1.5,0"], "positive size"),
        (["--circles", "[[0, 0]", "--start", "-1.5,0", "--goal", "1.5,0"], "not valid JSON"),
        (["--circles", TRAP, "--start", "nan,0", "--goal", "1.5,0"], "--start: numbers must be finite"),
        (["--circles", TRAP, "--start", "-1.5,0", "--goal", "1.5"], "--goal: expected 2 numbers"),
        (["--world", "WORLD", "--start", "3,0", "--goal", "1.5,1.5"], "start (3.0, 0.0) is outside the world"),
        (["--world", "WORLD", "--start", "2.05,0", "--goal", "1.5,1.5"], "inside an obstacle"),
        (
            ["--circles", TRAP, "--start", "-0.35,0.25", "--goal", "1.5,0"],
            "start (-0.35, 0.25) is within --robot-radius 0.105 m of an obstacle",
        ),
        (["--circles", TRAP, "--start", "-1.5,0", "--goal", "1.5,0", "--goal-fade", "-1"], "--goal-fade"),
    ],
)
def test_bad_input_prints_one_line_and_exits_1(
    args: list[str], message: str, simple_world: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = [str(simple_world) if a == "WORLD" else a for a in args]
    assert main(["plan", *args]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("ERROR: ")
    assert message in err


def test_command_line_entry_point_reports_bad_input_in_one_line() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "mrs_nav", "plan", "--circles", "[[0, 0, NaN]]", "--start", "-1,0", "--goal", "1,0"],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": f"{REPO / 'src'}:{os.environ.get('PYTHONPATH', '')}".rstrip(":")},
        timeout=60,
        check=False,
    )
    assert done.returncode == 1
    assert done.stderr == "ERROR: --circles: circle 0 has a non-finite value: [0.0, 0.0, nan]\n"
    assert done.stdout == ""
