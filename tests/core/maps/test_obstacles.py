"""Obstacles: validation of user input, the world's walls as boxes, distances and segment checks."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.fields.scenarios import course_arena
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[]", "empty"),
        ("[[0, 0, -0.3]]", "circle 0 must have a positive size"),
        ("[[0, 0, 0.3], [1, NaN, 0.2]]", "circle 1 has a non-finite value"),
        ("[[0, 0, Infinity]]", "non-finite"),
        ("[[0, 0]]", r"circle 0 must be \[x, y, r\]"),
        ('[[0, 0, "r"]]', r"circle 0 must be \[x, y, r\]"),
        ('[{"x": 0, "y": 1}]', r"circle 0 must be \[x, y, r\]"),
        ('{"x": 0}', "expected a JSON list"),
        ("[[0, 0, 0.3]", "not valid JSON"),
        ("[[true, 0, 0.3]]", "circle 0"),
    ],
)
def test_bad_circle_lists_are_refused_with_a_clear_message(text: str, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match) as err:
        Obstacles.from_json(text, "--circles")
    assert str(err.value).startswith("--circles: ")
    assert "\n" not in str(err.value)


def test_circles_as_objects_or_rows_are_the_same() -> None:
    rows = Obstacles.from_json("[[0, 0.25, 0.3], [0, -0.25, 0.3]]")
    objects = Obstacles.from_json('[{"x": 0, "y": 0.25, "r": 0.3}, {"x": 0, "y": -0.25, "r": 0.3}]')
    np.testing.assert_array_equal(rows.circles, objects.circles)


def test_obstacles_are_read_only() -> None:
    obstacles = Obstacles.from_circles([[0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="read-only"):
        obstacles.circles[0, 2] = 0.0


def test_course_world_gives_the_cylinder_and_the_four_walls_as_boxes(simple_world: Path) -> None:
    from_file = Obstacles.from_world(load_world(simple_world))
    expected = course_arena().obstacles
    np.testing.assert_allclose(from_file.circles, expected.circles)
    key = np.lexsort(from_file.boxes.T)
    np.testing.assert_allclose(from_file.boxes[key], expected.boxes[np.lexsort(expected.boxes.T)], atol=1e-12)
    # the wall's inner face at x = 2.0 m is the surface: 0.1 m from (1.9, 0), 0.5 m from the goal corner.
    assert from_file.signed_distance([(1.9, 0.0)])[0] == pytest.approx(0.1)
    assert from_file.signed_distance([(1.5, 1.5)])[0] == pytest.approx(0.5)
    assert from_file.contains([(2.05, 0.0)])[0]


def test_signed_distance_of_a_rotated_box_inside_outside_and_at_a_corner() -> None:
    box = Obstacles(boxes=np.array([[1.0, 1.0, math.pi / 2, 0.5, 0.2]]))  # 0.4 wide in x, 1.0 tall in y
    dist, normal = box.surface([(1.0, 2.0), (1.5, 1.0), (1.0, 1.0), (1.5, 2.0)])
    np.testing.assert_allclose(dist[:, 0], [0.5, 0.3, -0.2, math.hypot(0.3, 0.5)], atol=1e-12)
    np.testing.assert_allclose(normal[0, 0], [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(normal[1, 0], [1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(normal[2, 0], [0.0, 0.0])  # inside: no push


def test_segment_checks_for_circles_and_boxes() -> None:
    obstacles = Obstacles(circles=np.array([[0.0, 0.0, 1.0]]), boxes=np.array([[5.0, 0.0, 0.0, 0.05, 1.0]]))
    starts = np.array([[-2.0, 1.01], [-2.0, 0.99], [4.0, 0.0], [4.0, 2.0], [3.0, -3.0], [-2.0, 0.0]])
    ends = np.array([[2.0, 1.01], [2.0, 0.99], [6.0, 0.0], [6.0, 2.0], [7.0, 3.0], [-1.5, 0.0]])
    np.testing.assert_array_equal(obstacles.segments_free(starts, ends), [True, False, False, True, False, True])
    # a grazing tangent is free only when contact is tolerated
    assert not obstacles.segments_free([(-2.0, 1.0)], [(2.0, 1.0)])[0]
    assert obstacles.segments_free([(-2.0, 1.0)], [(2.0, 1.0)], clearance=-1e-9)[0]
    assert not obstacles.segments_free([(-2.0, 1.05)], [(2.0, 1.05)], clearance=0.1)[0]


def test_inflation_grows_every_obstacle() -> None:
    obstacles = Obstacles(circles=np.array([[0.0, 0.0, 0.3]]), boxes=np.array([[2.0, 0.0, 0.0, 0.1, 0.1]]))
    grown = obstacles.inflated(0.1)
    assert grown.signed_distance([(0.5, 0.0)])[0] == pytest.approx(0.1)
    assert grown.signed_distance([(1.7, 0.0)])[0] == pytest.approx(0.1)
    with pytest.raises(InvalidInputError, match="margin"):
        obstacles.inflated(-0.1)
