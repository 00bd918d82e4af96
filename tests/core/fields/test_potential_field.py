"""The velocity fields of assignment 1a-1c and the course-arena run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.fields.potential_field import FieldMode, PotentialField, cap, trace
from mrs_nav.fields.scenarios import course_arena
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.robot import BURGER_RADIUS


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


@pytest.mark.parametrize("goal_fade", [0.0, 0.3])
def test_field_is_minus_the_gradient_of_the_potential(goal_fade: float) -> None:
    obstacles = Obstacles(circles=np.array([[0.3, 0.2, 0.3]]), boxes=np.array([[0.0, 2.05, 0.0, 2.1, 0.05]]))
    field = PotentialField((1.5, 1.5), obstacles, v_max=10.0, decay=0.08, max_speed=1e9, goal_fade=goal_fade)
    rng = np.random.default_rng(1)
    points = rng.uniform(-1.5, 1.9, (200, 2))
    points = points[obstacles.signed_distance(points) > 0.01]
    h = 1e-6
    grad = np.column_stack(
        [(field.potential(points + d) - field.potential(points - d)) / (2 * h) for d in (np.array([h, 0]), [0, h])]
    )
    np.testing.assert_allclose(field.velocity(points), -grad, atol=1e-4)


def _corner_goal(goal_fade: float) -> PotentialField:
    """The course arena's goal (1.5, 1.5) for a Burger: its corner walls grown by the robot's radius."""
    scenario = course_arena()
    return PotentialField.build(
        scenario.goal, scenario.obstacles.inflated(BURGER_RADIUS), (-2.1, -2.1, 2.1, 2.1), goal_fade=goal_fade
    )


def test_goal_beside_walls_is_the_field_minimum_only_with_the_goal_fade() -> None:
    """Ge and Cui's GNRON: the walls hold the course's field off the goal; with the fade the goal is the global
    minimum of the potential, and the field's trace ends on it."""
    bare, faded = _corner_goal(0.0), _corner_goal(0.2)
    start = course_arena().start
    assert math.dist(trace(bare, start, duration=30.0)[-1], bare.goal) > 0.05
    path = trace(faded, start, duration=30.0)
    assert math.dist(path[-1], faded.goal) < 1e-3
    assert faded.obstacles.path_free(path)
    xs, ys = np.meshgrid(np.linspace(-2.0, 2.0, 201), np.linspace(-2.0, 2.0, 201))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    assert faded.potential([faded.goal])[0] == 0.0
    assert faded.potential(grid[np.hypot(*(grid - faded.goal).T) > 1e-9]).min() > 0.0


def test_the_goal_fade_leaves_the_field_away_from_the_goal_as_it_was() -> None:
    bare, faded = _corner_goal(0.0), _corner_goal(0.2)
    points = np.random.default_rng(2).uniform(-2.0, 2.0, (500, 2))
    far = points[np.hypot(*(points - bare.goal).T) > 3 * 0.2]
    np.testing.assert_allclose(faded.velocity(far), bare.velocity(far), atol=1e-3 * bare.max_speed)


def test_cap_limits_the_speed_and_keeps_the_direction() -> None:
    capped = cap([(3.0, 4.0), (0.1, 0.0), (0.0, 0.0)], 0.5)
    np.testing.assert_allclose(capped, [(0.3, 0.4), (0.1, 0.0), (0.0, 0.0)])


def test_bad_field_parameters_are_refused() -> None:
    obstacles = Obstacles.from_circles([[0.0, 0.0, 0.3]])
    with pytest.raises(InvalidInputError, match="positive"):
        PotentialField((1.0, 1.0), obstacles, v_max=1.0, decay=0.0)
    with pytest.raises(InvalidInputError, match="finite"):
        PotentialField((math.nan, 1.0), obstacles, v_max=1.0)
    with pytest.raises(InvalidInputError, match="goal_fade >= 0"):
        PotentialField((1.0, 1.0), obstacles, v_max=1.0, goal_fade=-0.1)
    with pytest.raises(InvalidInputError, match="exceed 1"):
        PotentialField.build((1.0, 1.0), obstacles, (-2, -2, 2, 2), vmax_factor=0.5)
