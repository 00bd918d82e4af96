"""``mrs-nav demo``: bad input is one error line; a refused goal fails the run without motion."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from mrs_nav.cli.main import build_parser, main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--goals", "1,nan"], "--goals: numbers must be finite"),
        (["--goals", "1"], "--goals: expected 2 numbers"),
        (["--world", "nowhere"], "no such file or shipped world"),
        (["--start", "0,0"], "--start: expected 3 numbers"),
    ],
)
def test_bad_arguments_give_one_error_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["demo", "--out", str(tmp_path), *argv]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("ERROR: ")
    assert message in err[0]


def test_a_goal_in_the_cylinder_is_refused_and_the_run_fails(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["demo", "--out", str(tmp_path), "--goals", "0.1,0.0", "--no-bag", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == 2
    assert summary["goals_reached"] == 0
    assert summary["outcomes"][0]["state"] == "refused"
    assert summary["collisions"] == 0
    assert summary["outcomes"][0]["distance_m"] == pytest.approx(math.hypot(1.6, 1.5), abs=0.02)  # it stayed put
    assert (tmp_path / "map.yaml").is_file()
    assert (tmp_path / "demo.png").is_file()


def test_a_negative_start_is_a_value_not_an_option() -> None:
    assert build_parser().parse_args(["demo", "--world", "office", "--start", "-5,-5,0"]).start == "-5,-5,0"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--start", "9,9,0"], "--start (9.0, 9.0) is outside the world"),
        (["--start", "0.3,0.2,0"], "--start (0.3, 0.2) is inside an obstacle"),
        (["--seed", "-1"], "argument --seed: must be an integer in [0, 4294967295], got -1"),
        (["--goal-timeout", "1e308"], "argument --goal-timeout: must be a finite number in [0.001, 3600]"),
        (["--world", "FAR"], "exceeds the limit of 2e+07 cells"),
    ],
)
def test_bad_input_fails_before_the_run(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    far = tmp_path / "far.world"
    far.write_text(
        '<sdf version="1.6"><world name="far">'
        + "".join(
            f'<model name="m{i}"><static>true</static><pose>{x} {y} 0.25 0 0 0</pose><link name="l"><collision '
            'name="c"><geometry><box><size>1 1 0.5</size></box></geometry></collision></link></model>'
            for i, (x, y) in enumerate([(-900, -900), (900, 900)])
        )
        + "</world></sdf>"
    )
    argv = [
        "demo",
        "--out",
        str(tmp_path / "out"),
        "--goals",
        "1,1",
        *[far.as_posix() if a == "FAR" else a for a in args],
    ]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert message in err
    assert not (tmp_path / "out" / "map.yaml").exists()
