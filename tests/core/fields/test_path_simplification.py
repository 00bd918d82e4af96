"""Shortcut simplification with back-tracking (assignment Figure 6)."""

from __future__ import annotations

import numpy as np

from mrs_nav.fields.path_simplification import simplify_path
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.planning import path_length


def test_without_obstacles_a_wiggly_path_becomes_its_endpoints() -> None:
    t = np.linspace(0.0, 1.0, 200)
    wiggle = np.column_stack([t, 0.1 * np.sin(20 * t)])
    simple = simplify_path(wiggle, Obstacles().segments_free)
    np.testing.assert_array_equal(simple, wiggle[[0, -1]])


def test_simplified_path_is_free_shorter_and_keeps_the_endpoints() -> None:
    obstacles = Obstacles.from_circles([[0.0, 0.0, 0.5], [1.5, 0.6, 0.4]])
    rng = np.random.default_rng(3)
    # a noisy path around the first circle's top and under the second one
    angles = np.linspace(np.pi, 0.0, 100)
    arc = np.column_stack([0.8 * np.cos(angles), 0.8 * np.sin(angles)])
    tail = np.column_stack([np.linspace(0.8, 3.0, 50), np.linspace(0.0, 0.0, 50)])
    raw = np.vstack([[(-2.0, 0.0)], arc, tail]) + rng.normal(0.0, 0.02, (151, 2))
    raw[0], raw[-1] = (-2.0, 0.0), (3.0, 0.0)
    assert obstacles.path_free(raw)
    simple = simplify_path(raw, obstacles.segments_free)
    assert obstacles.path_free(simple)
    np.testing.assert_array_equal(simple[[0, -1]], raw[[0, -1]])
    assert path_length(simple) < 0.8 * path_length(raw)
    assert len(simple) <= 6


def test_back_tracking_drops_corners_the_forward_pass_had_to_keep() -> None:
    # From A the forward pass stops at B (a small circle hides C), jumps from B to D, and only the back-tracking
    # sees that A reaches D directly.
    obstacles = Obstacles.from_circles([[0.5, 0.5, 0.1]])
    raw = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 2.0)])
    forward = simplify_path(raw, obstacles.segments_free, backtrack=False)
    np.testing.assert_array_equal(forward, raw[[0, 1, 3]])
    np.testing.assert_array_equal(simplify_path(raw, obstacles.segments_free), raw[[0, 3]])


def test_a_blocked_input_segment_is_kept_as_it_is() -> None:
    blocked = Obstacles.from_circles([[0.5, 0.0, 0.1], [1.5, 0.0, 0.1]])
    raw = np.array([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
    np.testing.assert_array_equal(simplify_path(raw, blocked.segments_free), raw)
