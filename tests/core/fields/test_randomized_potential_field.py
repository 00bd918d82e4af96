"""Traps of the potential field (1d-1f): the problem shown, and the fixes measured over 100 seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.fields.randomized_potential_field import EscapeSettings, plan_potential_field, planned_points, roll_out
from mrs_nav.fields.scenarios import symmetric_trap, two_cylinder_trap
from mrs_nav.fields.shortest_path import shortest_path
from mrs_nav.planning import path_length

SEEDS = range(100)
NOTHING = EscapeSettings(noise_std=0.0, random_walk=False)


def test_without_noise_the_descent_stalls_at_the_saddle_in_front_of_a_cylinder_at_the_origin() -> None:
    scenario = symmetric_trap()
    (rollout,) = roll_out(scenario.field(), scenario.start, [0], NOTHING)
    assert not rollout.reached
    assert "stalled" in rollout.reason
    end = rollout.trajectory[-1]
    assert end[0] == pytest.approx(end[1])  # still on the diagonal through start, cylinder and goal
    assert math.dist(end, (0.0, 0.0)) < 0.5  # in front of the cylinder


def test_noise_on_the_attractive_field_gets_at_least_99_of_100_seeds_past_the_saddle() -> None:
    scenario = symmetric_trap()
    rollouts = roll_out(scenario.field(), scenario.start, SEEDS, EscapeSettings(random_walk=False))
    assert sum(r.reached for r in rollouts) >= 99
    assert all(scenario.obstacles.path_free(r.trajectory) for r in rollouts)


def test_full_escape_reaches_the_goal_in_the_symmetric_trap_for_at_least_99_of_100_seeds() -> None:
    scenario = symmetric_trap()
    rollouts = roll_out(scenario.field(), scenario.start, SEEDS)
    assert sum(r.reached for r in rollouts) >= 99


def test_noise_alone_stays_caught_in_the_two_cylinder_local_minimum() -> None:
    scenario = two_cylinder_trap()
    rollouts = roll_out(scenario.field(), scenario.start, range(10), EscapeSettings(random_walk=False))
    assert not any(r.reached for r in rollouts)
    for r in rollouts:
        assert "stalled" in r.reason
        assert -0.5 < r.trajectory[-1][0] < -0.16  # in the notch in front of the pair


def test_random_walk_escapes_the_local_minimum_and_the_simplified_path_is_near_shortest() -> None:
    scenario = two_cylinder_trap()
    field = scenario.field()
    rollouts = roll_out(field, scenario.start, SEEDS)
    reached = [r for r in rollouts if r.reached]
    assert len(reached) >= 99
    assert sum(r.walk_steps > 0 for r in rollouts) >= 99  # the escape was needed, not a lucky descent
    best = shortest_path(scenario.start, scenario.goal, scenario.obstacles).length_m
    for r in reached:
        assert scenario.obstacles.path_free(r.trajectory)
        simple = planned_points(field, r)
        assert scenario.obstacles.path_free(simple)
        np.testing.assert_array_equal(simple[[0, -1]], [scenario.start, scenario.goal])
        assert path_length(simple) <= 1.15 * best


def test_a_seed_gives_the_same_trajectory_alone_or_in_a_batch() -> None:
    scenario = two_cylinder_trap()
    batch = roll_out(scenario.field(), scenario.start, [5, 6, 7])
    (alone,) = roll_out(scenario.field(), scenario.start, [6])
    np.testing.assert_array_equal(alone.trajectory, batch[1].trajectory)
    assert not np.array_equal(batch[0].trajectory[:200], batch[1].trajectory[:200])


def test_plan_returns_a_simplified_path_with_headings() -> None:
    scenario = two_cylinder_trap()
    result = plan_potential_field(scenario.field(), (-1.5, 0.0, 0.3), seed=1)
    assert result.reason == "goal reached"
    np.testing.assert_array_equal(result.path[-1, :2], scenario.goal)
    assert result.path.shape[1] == 3
    assert result.path[0, 2] == 0.3
    step = np.diff(result.path[:, :2], axis=0)
    np.testing.assert_allclose(result.path[1:-1, 2], np.arctan2(step[1:, 1], step[1:, 0]))
    assert result.length_m == pytest.approx(path_length(result.path))
    assert result.iterations > result.nodes
    assert result.first_solution_s == result.time_s


def test_budget_exhaustion_is_a_failure_with_a_reason() -> None:
    scenario = two_cylinder_trap()
    with pytest.raises(NoPathFoundError, match=r"^step budget used up \(50 steps of 0.01 s\)") as caught:
        plan_potential_field(scenario.field(), (-1.5, 0.0, 0.0), seed=1, settings=EscapeSettings(max_steps=50))
    assert caught.value.iterations == 50


def test_bad_requests_are_refused() -> None:
    scenario = two_cylinder_trap()
    with pytest.raises(InvalidInputError, match="inside an obstacle"):
        roll_out(scenario.field(), (0.0, 0.3), [0])
    with pytest.raises(InvalidInputError, match="seeds"):
        roll_out(scenario.field(), scenario.start, [-1])
    with pytest.raises(InvalidInputError, match="dt must be"):
        EscapeSettings(dt=0.0)
    with pytest.raises(InvalidInputError, match="max_steps"):
        EscapeSettings(max_steps=0)
    with pytest.raises(InvalidInputError, match="guide_patience"):
        EscapeSettings(guide_patience=0)
