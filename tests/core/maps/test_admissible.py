"""The one start/goal admissibility check: each refusal names why, for grids and for circles and boxes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.maps.admissible import NOT_FINITE, grid_refusal, obstacles_refusal
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid


def _room() -> tuple[OccupancyGrid, OccupancyGrid]:
    """A 4 m x 4 m map at 0.1 m: a wall at x in [2.0, 2.1), an unknown pocket enclosed by walls round (0.55, 0.55),
    and unknown space open to the map's edge at y >= 3.5; and the same map inflated by 0.2 m."""
    values = np.zeros((40, 40), dtype=np.int8)
    values[:, 20] = OCCUPIED
    values[3:9, 3:9] = OCCUPIED
    values[4:8, 4:8] = UNKNOWN
    values[35:, :] = UNKNOWN
    raw = OccupancyGrid(values, 0.1)
    return raw, raw.inflate(0.2)


@pytest.mark.parametrize(
    ("x", "y", "why"),
    [
        (math.nan, 1.0, NOT_FINITE),
        (1.0, math.inf, NOT_FINITE),
        (5.0, 1.0, "outside the map"),
        (2.05, 1.0, "inside an obstacle"),
        (1.9, 1.0, "within 0.200 m (robot radius + margin) of an obstacle"),
        (1.0, 3.8, "in unknown space and allow_unknown is off"),
        (1.0, 1.5, None),
    ],
)
def test_grid_refusal_names_why(x: float, y: float, why: str | None) -> None:
    raw, grid = _room()
    assert grid_refusal(grid, x, y, raw=raw, inflation_m=0.2, unknown_hint=" and allow_unknown is off") == why


def test_without_the_raw_map_an_obstacle_and_its_clearance_read_alike() -> None:
    _, grid = _room()
    assert (
        grid_refusal(grid, 2.05, 1.0)
        == grid_refusal(grid, 1.9, 1.0)
        == "in an obstacle (or within the robot radius of one)"
    )


def test_unknown_space_enclosed_by_obstacles_is_refused_even_where_unknown_is_allowed() -> None:
    raw, _ = _room()
    values = raw.inflate(0.0).values.copy()
    values[values == UNKNOWN] = 0  # unknown made free, as planning with allow_unknown does
    assert grid_refusal(OccupancyGrid(values, 0.1), 0.55, 0.55, raw=raw).startswith("in unknown space enclosed")
    assert grid_refusal(OccupancyGrid(values, 0.1), 1.0, 3.8, raw=raw) is None  # open to the edge: just unseen


@pytest.mark.parametrize(
    ("x", "y", "why"),
    [
        (math.nan, 0.0, NOT_FINITE),
        (3.0, 0.0, "outside the world [-2, 2] x [-2, 2]"),
        (0.0, 0.3, "inside an obstacle"),
        (0.0, 0.6, "within --robot-radius 0.105 m of an obstacle: the robot would overlap it"),
        (0.0, 1.0, None),
    ],
)
def test_obstacles_refusal_names_why(x: float, y: float, why: str | None) -> None:
    circle = Obstacles.from_json("[[0, 0, 0.5]]", "test")
    refusal = obstacles_refusal(
        circle, x, y, bounds=(-2.0, -2.0, 2.0, 2.0), clearance_m=0.105, clearance_name="--robot-radius"
    )
    assert refusal == why
