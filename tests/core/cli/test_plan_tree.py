"""``mrs-nav plan`` with the tree planners: JSON output, exit codes, PNG, and one-line errors on bad queries."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.cli.main import main
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid

REPO = Path(__file__).resolve().parents[3]
MAP = str(REPO / "maps" / "simple.yaml")


@pytest.mark.parametrize("planner", ["rrt", "rrt_star"])
def test_plan_prints_the_json_result(planner: str, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    png = tmp_path / "plan.png"
    code = main(
        [
            "plan",
            "--map",
            MAP,
            "--planner",
            planner,
            "--start",
            "-1.5,-1.5,0",
            "--goal",
            "1.5,1.5",
            "--iterations",
            "300",
            "--seed",
            "2",
            "--json",
            "--png",
            str(png),
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) >= {"success", "length_m", "time_s", "first_solution_s", "iterations", "nodes", "path"}
    assert out["success"]
    assert 4.29 < out["length_m"] < 7.0
    assert out["path"][0] == [-1.5, -1.5, 0.0]
    assert png.stat().st_size > 10_000


def test_plan_on_a_world_file_rasterises_it(capsys: pytest.CaptureFixture[str]) -> None:
    world = str(REPO / "worlds" / "simple.world")
    code = main(["plan", "--world", world, "--planner", "rrt", "--start", "-1.5,-1.5", "--goal", "1.5,1.5"])
    assert code == 0
    assert "goal reached" in capsys.readouterr().out


def test_no_path_within_budget_exits_2_and_still_draws_the_tree(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    png = tmp_path / "tree.png"
    values = np.zeros((60, 60), dtype=np.int8)
    values[40:50, 40] = values[40:50, 50] = values[40, 40:51] = values[50, 40:51] = OCCUPIED  # a closed box
    boxed = tmp_path / "boxed.yaml"
    save_map(OccupancyGrid(values, 0.05, (0.0, 0.0, 0.0)), boxed)
    code = main(
        [
            "plan",
            "--map",
            str(boxed),
            "--planner",
            "rrt_star",
            "--start",
            "0.5,0.5,3.14",
            "--goal",
            "2.25,2.25",  # inside the box
            "--iterations",
            "5",
            "--png",
            str(png),
        ]
    )
    assert code == 2
    captured = capsys.readouterr()
    assert captured.err.strip() == "ERROR: goal not reached: no path found: iteration budget used up"
    assert captured.out.startswith("rrt_star: no path found: iteration budget used up in ")
    assert png.stat().st_size > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--start", "0.3,0.2", "--goal", "1.5,1.5"], "start (0.300, 0.200) is in an obstacle"),
        (["--start", "-1.5,-1.5", "--goal", "9,9"], "goal (9.000, 9.000) is outside the map"),
        (["--start", "-1.5,-1.5", "--goal", "1.5,inf"], "--goal: numbers must be finite"),
        (["--start", "-1.5,-1.5", "--goal", "1.5,1.5", "--robot-radius", "-1"], "--robot-radius: must be"),
        (["--start", "-1.5,-1.5", "--goal", "1.5,1.5", "--time-budget", "nan"], "--time-budget: must be"),
    ],
)
def test_bad_queries_exit_1_with_one_line(args: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--map", MAP, "--planner", "rrt_star", *args]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert message in err


def test_unreadable_map_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: [\n")
    assert main(["plan", "--map", str(bad), "--planner", "rrt", "--start", "0,0", "--goal", "1,1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "bad.yaml: malformed YAML" in err
