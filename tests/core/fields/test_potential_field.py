"""The velocity fields of assignment 1a-1c and the course-arena run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.fields.potential_field import FieldMode, PotentialField, cap, trace
from mrs_nav.fields.scenarios import course_arena
from mrs_nav.maps.obstacles import Obstacles


def test_combined_field_reaches_the_goal_in_the_course_arena_without_touching_an_obstacle() -> None:
    scenario = course_arena()
    path = trace(scenario.field(), scenario.start, duration=20.0)
    assert math.dist(path[-1], scenario.goal) < 0.1
    assert scenario.obstacles.signed_distance(path).min() > 0.05
    assert scenario.obstacles.path_free(path)


def test_attractive_field_alone_drives_straight_through_the_cylinder() -> None:
    scenario = course_arena()
    path = trace(scenario.field(), scenario.start, mode=FieldMode.ATTRACTIVE)
    assert math.dist(path[-1], scenario.goal) < 0.01
    assert scenario.obstacles.contains(path).any()


def test_v_max_beats_the_farthest_attraction_by_the_factor() -> None:
    scenario = course_arena()
    field = scenario.field()
    corners = np.array([(-2.1, -2.1), (-2.1, 2.1), (2.1, -2.1), (2.1, 2.1)])
    farthest = np.hypot(*(corners - scenario.goal).T).max()
    assert field.v_max == pytest.approx(2.0 * farthest)


def test_repulsion_is_v_max_at_the_surface_halves_every_lambda_ln2_and_is_zero_inside() -> None:
    field = PotentialField((10.0, 0.0), Obstacles.from_circles([[0.0, 0.0, 0.5]]), v_max=3.0, decay=0.1)
    lam = field.decay
    points = [(0.5 + 1e-12, 0.0), (0.0, 0.5 + lam * math.log(2.0)), (0.2, 0.1)]
    rep = field.repulsive(points)
    np.testing.assert_allclose(rep[0], [3.0, 0.0], rtol=1e-9)
    np.testing.assert_allclose(rep[1], [0.0, 1.5], rtol=1e-9)
    np.testing.assert_array_equal(rep[2], [0.0, 0.0])


def test_field_is_minus_the_gradient_of_the_potential() -> None:
    obstacles = Obstacles(circles=np.array([[0.3, 0.2, 0.3]]), boxes=np.array([[0.0, 2.05, 0.0, 2.1, 0.05]]))
    field = PotentialField((1.5, 1.5), obstacles, v_max=10.0, decay=0.08, max_speed=1e9)
    rng = np.random.default_rng(1)
    points = rng.uniform(-1.5, 1.9, (200, 2))
    points = points[obstacles.signed_distance(points) > 0.01]
    h = 1e-6
    grad = np.column_stack(
        [(field.potential(points + d) - field.potential(points - d)) / (2 * h) for d in (np.array([h, 0]), [0, h])]
    )
    np.testing.assert_allclose(field.velocity(points), -grad, atol=1e-4)


def test_cap_limits_the_speed_and_keeps_the_direction() -> None:
    capped = cap([(3.0, 4.0), (0.1, 0.0), (0.0, 0.0)], 0.5)
    np.testing.assert_allclose(capped, [(0.3, 0.4), (0.1, 0.0), (0.0, 0.0)])


def test_bad_field_parameters_are_refused() -> None:
    obstacles = Obstacles.from_circles([[0.0, 0.0, 0.3]])
    with pytest.raises(InvalidInputError, match="positive"):
        PotentialField((1.0, 1.0), obstacles, v_max=1.0, decay=0.0)
    with pytest.raises(InvalidInputError, match="finite"):
        PotentialField((math.nan, 1.0), obstacles, v_max=1.0)
    with pytest.raises(InvalidInputError, match="exceed 1"):
        PotentialField.build((1.0, 1.0), obstacles, (-2, -2, 2, 2), vmax_factor=0.5)
