"""``mrs-nav demo``: bad input is one error line; a refused goal fails the run without motion."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from mrs_nav.cli.main import main


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
