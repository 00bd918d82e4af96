"""bench contacts: the followers it runs and the row it reports per follower."""

from __future__ import annotations

import argparse
import math

import pytest

from mrs_nav.bench.contacts import _row, _run_line, run
from mrs_nav.errors import InvalidInputError


def test_an_unknown_follower_is_refused_before_any_run() -> None:
    with pytest.raises(InvalidInputError, match="--followers: unknown \\['dwa'\\]"):
        run(argparse.Namespace(runs=1, first_seed=0, followers="rrt,dwa"))


def test_a_touch_names_its_seed_and_counts_every_contact() -> None:
    def result(contacts: int, clearance: float | None, error: float = 0.05) -> dict[str, object]:
        return {
            "reached": True,
            "final_error_m": error,
            "contacts": contacts,
            "min_clearance_m": clearance,
            "sim_s": 30.0,
        }

    row = _row("potential-field", [result(0, 0.1), result(2, -0.01), result(0, None, error=0.5)])
    assert row[:5] == ["potential-field", 3, 2, 1, 2]  # runs, reached within 0.2 m, runs touching, contacts
    assert math.isclose(row[5], -0.01)  # the smallest clearance of all runs
    assert row[-1] == "1"  # the seed that touched
    assert _row("rrt", [result(1, 0.0)], first_seed=40)[-1] == "40"


def test_each_run_has_a_line_of_its_own_with_the_simulators_free_runs() -> None:
    result = {"reached": False, "final_error_m": 1.2346, "contacts": 1, "min_clearance_m": None, "sim_s": 61.04}
    result["sim_start"] = 3.25
    line = _run_line("rrt", 7, {**result, "free_run_log": ["[WARN] a", "[WARN] b"]})
    assert line == (
        "rrt seed 7: reached False, final error 1.235 m, contacts 1, min clearance - m, sim 61.0 s (goal at 3.2 s), "
        "lockstep free runs 2\n  [WARN] a\n  [WARN] b"
    )
