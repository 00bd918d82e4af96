"""Concave traps for the potential field, sized for the robot: cups of cylinders, U-shapes of boxes, walls with
one gap, a room with one door, in several sizes, orientations and places, plus variants drawn at random.

10 seeds per trap keep the run short; `mrs-nav bench potential-field` measures 100 seeds on the same traps and on
traps drawn from a generator seed these tests do not use.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import NoPathFoundError
from mrs_nav.fields.randomized_potential_field import (
    NO_PATH,
    EscapeSettings,
    navigation_guide,
    plan_potential_field,
    planned_points,
    roll_out,
)
from mrs_nav.fields.scenarios import (
    Scenario,
    box_u,
    cylinder_cup,
    random_traps,
    room_with_door,
    trap_gallery,
    wall_with_gap,
)
from mrs_nav.fields.shortest_path import shortest_path
from mrs_nav.planning import path_length
from mrs_nav.robot import BURGER_RADIUS

SEEDS = range(10)
ASSIGNMENT = EscapeSettings(guide_after_walks=None)  # best first + random walk alone


def _check(scenario: Scenario, *, field_path_near_shortest: bool) -> None:
    field = scenario.field(robot_radius=BURGER_RADIUS)
    guide = navigation_guide(field, scenario.start)
    rollouts = roll_out(field, scenario.start, SEEDS, guide=guide)
    assert all(r.reached for r in rollouts), [(r.seed, r.reason) for r in rollouts if not r.reached]
    best = shortest_path(scenario.start, scenario.goal, field.obstacles).length_m  # exact, among the grown shapes
    own = []
    for r in rollouts:
        # The robot's disc clear of the true obstacles: every trajectory point at least the radius from them
        # (exact distances to circles and boxes), every segment of the plan too (checked against the obstacles
        # grown by the radius with square corners, which holds more than the exact rounded growth).
        assert float(scenario.obstacles.signed_distance(r.trajectory).min()) >= BURGER_RADIUS
        plan = planned_points(field, r, guide=guide)
        assert scenario.obstacles.path_free(plan, clearance=BURGER_RADIUS - 1e-9)
        np.testing.assert_array_equal(plan[[0, -1]], [scenario.start, scenario.goal])
        assert path_length(plan) <= 1.15 * best
        own.append(path_length(planned_points(field, r)) / best)
    if field_path_near_shortest:
        # The field's own simplified trajectory, before the guide's corridor may replace it, is near shortest too.
        assert float(np.median(own)) <= 1.15


@pytest.mark.parametrize("scenario", trap_gallery(), ids=lambda s: s.name)
def test_the_field_escapes_the_trap_without_touching_it_on_a_near_shortest_path(scenario: Scenario) -> None:
    _check(scenario, field_path_near_shortest=True)


@pytest.mark.parametrize("draw", range(2))
def test_traps_drawn_at_random_are_escaped_too(draw: int) -> None:
    for scenario in random_traps(np.random.default_rng(1000 + draw)):
        _check(scenario, field_path_near_shortest=False)


def test_the_gallery_holds_every_kind_in_several_sizes_and_orientations() -> None:
    names = [s.name for s in trap_gallery()]
    for kind in ("cup of 3", "cup of 4", "cup of 5", "U of boxes", "gap", "door"):
        assert any(kind in name for name in names), kind
    assert len({name.split("(")[-1] for name in names}) >= 5  # orientations


def test_the_random_walk_alone_is_held_by_a_cup_and_a_u() -> None:
    """The problem the navigation function solves: without it, most seeds stay in these traps."""
    for scenario in (cylinder_cup(5), box_u()):
        rollouts = roll_out(scenario.field(robot_radius=BURGER_RADIUS), scenario.start, range(20), ASSIGNMENT)
        assert sum(r.reached for r in rollouts) <= 5


def test_a_wall_gap_narrower_than_the_robot_is_not_taken() -> None:
    scenario = wall_with_gap(0.15, length=2.0)
    field = scenario.field(robot_radius=BURGER_RADIUS)
    for r in roll_out(field, scenario.start, SEEDS):
        assert r.reached
        # The wall spans |y| <= 1 m at x = 0; the gap is at y = 0.5 m. Crossings happen beyond the wall's ends.
        cross = np.flatnonzero(np.diff(np.sign(r.trajectory[:, 0])) != 0)
        assert all(abs(r.trajectory[k, 1]) > 1.0 for k in cross)
        assert not math.isclose(r.trajectory[-1, 0], 0.0)


def test_a_goal_behind_a_door_narrower_than_the_robot_is_refused_cleanly() -> None:
    scenario = room_with_door(0.15)
    field = scenario.field(robot_radius=BURGER_RADIUS)
    with pytest.raises(NoPathFoundError) as caught:
        roll_out(field, scenario.start, SEEDS)
    assert caught.value.reason == NO_PATH
    with pytest.raises(NoPathFoundError, match=r"^no path: the obstacles, grown by the robot radius, close"):
        plan_potential_field(field, (*scenario.start, 0.0), seed=0)
    # A point (no robot radius) fits through the same door: the refusal is the robot's size, not the planner.
    result = plan_potential_field(scenario.field(), (*scenario.start, 0.0), seed=0)
    np.testing.assert_array_equal(result.path[-1, :2], scenario.goal)


def test_a_door_the_robot_just_fits_through_is_taken() -> None:
    scenario = room_with_door(0.3)  # 4.5 cm to spare on each side
    field = scenario.field(robot_radius=BURGER_RADIUS)
    for r in roll_out(field, scenario.start, range(3)):
        assert r.reached
        assert float(scenario.obstacles.signed_distance(r.trajectory).min()) >= BURGER_RADIUS
