"""The exact shortest path among circles and boxes (tangent graph), the yardstick of the simplified paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.fields.shortest_path import shortest_path
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.planning import path_length


def test_around_one_circle_it_matches_the_closed_form() -> None:
    # two tangents of length sqrt(d^2 - r^2) and the arc between the tangent points, r (pi - 2 acos(r / d))
    d, r = math.hypot(1.5, 1.5), 0.3
    expected = 2.0 * math.sqrt(d * d - r * r) + r * (math.pi - 2.0 * math.acos(r / d))
    result = shortest_path((-1.5, -1.5), (1.5, 1.5), Obstacles.from_circles([[0.0, 0.0, r]]))
    assert result.length_m == pytest.approx(expected, rel=1e-12)
    assert expected <= path_length(result.points) <= expected * 1.001  # arcs outlined from outside
    assert Obstacles.from_circles([[0.0, 0.0, r]]).path_free(result.points, clearance=-1e-9)


def test_unobstructed_is_the_straight_line() -> None:
    result = shortest_path((-1.5, 0.0), (1.5, 0.0), Obstacles.from_circles([[0.0, 1.0, 0.3]]))
    assert result.length_m == pytest.approx(3.0)


def test_overlapping_pair_goes_over_the_outer_boundary() -> None:
    obstacles = Obstacles.from_circles([[0.0, 0.25, 0.3], [0.0, -0.25, 0.3]])
    result = shortest_path((-1.5, 0.0), (1.5, 0.0), obstacles)
    # by symmetry: tangents from the endpoints to the top circle and the arc over it
    d = math.hypot(1.5, 0.25)
    tangent = math.sqrt(d * d - 0.09)
    arc = 0.3 * (math.pi - 2 * math.acos(0.3 / d) + 2 * math.atan2(0.25, 1.5))
    assert result.length_m == pytest.approx(2 * tangent + arc, rel=1e-9)
    assert obstacles.path_free(result.points, clearance=-1e-6)


def test_many_random_circles_give_a_free_path_no_longer_than_any_free_detour() -> None:
    rng = np.random.default_rng(7)
    circles = np.column_stack([rng.uniform(-1.0, 1.0, (15, 2)), rng.uniform(0.05, 0.25, 15)])
    obstacles = Obstacles.from_circles(circles)
    start, goal = (-1.6, 0.1), (1.6, -0.1)
    result = shortest_path(start, goal, obstacles)
    assert obstacles.path_free(result.points, clearance=-1e-6)
    around = np.array([start, (-1.6, 1.5), (1.6, 1.5), goal])  # a free detour above everything
    assert obstacles.path_free(around)
    assert result.length_m <= path_length(around)
    assert result.length_m >= math.dist(start, goal)


def test_enclosed_goal_and_bad_endpoints_are_errors() -> None:
    ring = [[math.cos(a), math.sin(a), 0.3] for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)]
    with pytest.raises(NoPathFoundError):
        shortest_path((3.0, 0.0), (0.0, 0.0), Obstacles.from_circles(ring))
    with pytest.raises(InvalidInputError, match="start"):
        shortest_path((1.0, 0.0), (3.0, 0.0), Obstacles.from_circles(ring))
    room = Obstacles(boxes=np.array([[0.0, 1.0, 0.0, 1.1, 0.1], [0.0, -1.0, 0.0, 1.1, 0.1], [1.0, 0.0, 0.0, 0.1, 1.1]]))
    with pytest.raises(NoPathFoundError):
        shortest_path((0.0, 0.0), (3.0, 0.0), Obstacles(boxes=np.vstack([room.boxes, [[-1.0, 0.0, 0.0, 0.1, 1.1]]])))
    with pytest.raises(InvalidInputError, match="goal"):
        shortest_path((3.0, 0.0), (1.0, 0.5), room)


def test_around_a_box_it_follows_the_near_side_between_two_corners() -> None:
    box = Obstacles(boxes=np.array([[0.0, 0.0, 0.0, 0.5, 0.5]]))
    result = shortest_path((-1.5, 0.0), (1.5, 0.0), box)
    assert result.length_m == pytest.approx(2.0 * math.hypot(1.0, 0.5) + 1.0, rel=1e-12)
    assert box.path_free(result.points, clearance=-1e-6)
    assert path_length(result.points) == pytest.approx(result.length_m)


def test_a_rotated_box_is_passed_over_its_corner() -> None:
    diamond = Obstacles(boxes=np.array([[0.0, 0.0, math.pi / 4, 0.5, 0.5]]))
    result = shortest_path((-1.5, 0.0), (1.5, 0.0), diamond)
    assert result.length_m == pytest.approx(2.0 * math.hypot(1.5, 0.5 * math.sqrt(2.0)), rel=1e-9)


def test_a_u_of_boxes_with_a_cylinder_beside_it_gives_a_free_path_no_longer_than_a_free_detour() -> None:
    u = np.array([[0.45, 0.0, 0.0, 0.05, 0.6], [0.0, 0.55, 0.0, 0.5, 0.05], [0.0, -0.55, 0.0, 0.5, 0.05]])
    obstacles = Obstacles(circles=np.array([[0.0, 0.9, 0.2]]), boxes=u)
    start, goal = (0.0, 0.0), (1.5, 0.0)  # from inside the U out to behind its back
    result = shortest_path(start, goal, obstacles)
    assert obstacles.path_free(result.points, clearance=-1e-6)
    around = np.array([start, (-0.7, 0.0), (-0.7, -0.8), (1.5, -0.8), goal])
    assert obstacles.path_free(around)
    assert result.length_m <= path_length(around)
    # it has to leave by the mouth (x < -0.5) and come round a corner of the U
    assert result.points[:, 0].min() <= -0.5 + 1e-9
    assert result.length_m >= 2.0 * 0.5 + 1.5
