"""Property-based fuzzing of the ``mrs-nav`` option parser: any command line parses into checked values or is
one usage error (:class:`InvalidInputError`, exit 1), never an argparse exit 2 or a traceback."""

from __future__ import annotations

import argparse
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrs_nav.cli.main import build_parser, main
from mrs_nav.errors import InvalidInputError
from mrs_nav.limits import MAX_BUDGET_S, MAX_ITERATIONS, MAX_ROBOT_RADIUS_M, MAX_SEED
from tests.core.fuzzing import attempt

COMMANDS = ["plan", "demo", "replay", "figures", "bench", "carmen2bag", "monitor", "nope", ""]
OPTIONS = ["--seed", "--iterations", "--time-budget", "--robot-radius", "--resolution", "--max-steps",
           "--goal-timeout", "--plan-iterations", "--start", "--goal", "--goals", "--world", "--map", "--circles",
           "--planner", "--min-turning-radius", "--out", "--json", "--slam", "-x", "--", "-"]  # fmt: skip
VALUES = ["-1", "0", "1", "1e308", "-1e308", "nan", "inf", "18446744073709551616", "9" * 5000, "1.5", "-5,-5,0",
          "0,0", "x", "", "0_2", "2", "10", "rrt", "rrt_star", "simple", "/dev/null", "[[0, 0, 1]]"]  # fmt: skip

argvs = st.tuples(st.sampled_from(COMMANDS), st.lists(st.sampled_from(OPTIONS + VALUES), max_size=8)).map(
    lambda t: [t[0], *t[1]] if t[0] else t[1]
)


def _parse(argv: list[str]) -> argparse.Namespace:
    return build_parser().parse_args(argv)


@given(argvs)
@settings(max_examples=200)
def test_any_command_line_parses_or_is_one_usage_error(argv: list[str]) -> None:
    args = attempt(lambda: _parse(argv), InvalidInputError)
    if isinstance(args, str):
        assert "\n" not in args
        return
    # Whatever got through is within the stated limits.
    for name, low, high in (
        ("seed", 0, MAX_SEED),
        ("iterations", 1, MAX_ITERATIONS),
        ("max_steps", 1, MAX_ITERATIONS),
        ("plan_iterations", 1, MAX_ITERATIONS),
        ("time_budget", 1e-3, MAX_BUDGET_S),
        ("goal_timeout", 1e-3, MAX_BUDGET_S),
        ("robot_radius", 0.0, MAX_ROBOT_RADIUS_M),
    ):
        value = getattr(args, name, None)
        if value is not None:
            assert math.isfinite(value)
            assert low <= value <= high, (name, value)


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "--bogus"],
        ["nope"],
        ["plan", "--world", "w", "--start", "0,0", "--goal", "1,1", "--seed", "-1"],
        ["demo", "--seed", "18446744073709551616"],
        ["bench", "nope"],
    ],
)
def test_usage_errors_exit_1_with_one_error_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith("ERROR: mrs-nav")
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("circles", "message"),
    [
        ("x" * 5000, "--circles: not valid JSON"),  # too long to be a file name: text
        ("[" * 100_000 + "]" * 100_000, "--circles: JSON nested too deeply"),
        ("[[" + "9" * 5000 + ", 0, 1]]", "--circles: not valid JSON"),
        ("[[1e400, 0, 1]]", "has a non-finite value"),
        ("[[2000, 0, 1]]", "lies more than 1000 m from the origin"),
    ],
)
def test_bad_circles_are_one_error_line(circles: str, message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--circles", circles, "--start", "0,0", "--goal", "1,1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert message in err
