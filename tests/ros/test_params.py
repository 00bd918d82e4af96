"""Private parameters are read as the type of their default, and a wrong kind names the parameter."""

from __future__ import annotations

import math

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.ros.params import _convert


def test_numbers_come_as_the_defaults_type() -> None:
    assert _convert("rate", 10, 1.0) == 10.0
    assert isinstance(_convert("rate", 10, 1.0), float)
    assert math.isnan(_convert("goal_x", "nan", math.nan))  # roslaunch's value="nan" arrives as text
    assert _convert("seed", 3, -1) == 3
    assert _convert("lockstep", True, False) is True
    assert _convert("frame", "map", "odom") == "map"


@pytest.mark.parametrize(
    ("value", "default", "match"),
    [
        ("fast", 1.0, "~p: expected a number"),
        (1.5, 0, "~p: expected int"),
        (1, False, "~p: expected bool"),
        (True, 0, "~p: expected int"),
        ("nan", 1.0, "~p: expected a number, got NaN"),
        (3, "odom", "~p: expected str"),
    ],
)
def test_a_wrong_kind_names_the_parameter(value: object, default: object, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        _convert("p", value, default)  # type: ignore[type-var]
