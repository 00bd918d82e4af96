"""Figures 1-7 of the assignment: the potential-field method, its traps and their fixes.

1. attractive field only: straight to the goal, through the cylinder;
2. repulsive field only, with the field: pushed away from the obstacles;
3. combined field: around the cylinder to the goal;
4. cylinder at the origin: noise-free descent stuck at the saddle point, and the noisy descent (1e);
5. two-cylinder local minimum: the trajectory with its random-walk steps (1f);
6. the simplification algorithm: forward shortcuts and back-tracking on a small case, then on Figure 5's path;
7. the simplified trajectory against the true shortest path.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.fields.path_simplification import simplify_path
from mrs_nav.fields.potential_field import FieldMode, PotentialField, trace
from mrs_nav.fields.randomized_potential_field import EscapeSettings, Rollout, planned_points, roll_out
from mrs_nav.fields.scenarios import Scenario, course_arena, symmetric_trap, two_cylinder_trap
from mrs_nav.fields.shortest_path import shortest_path
from mrs_nav.figures.drawing import Limits, draw_field, draw_obstacles, grid, new_axes, new_panels, save
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.planning import path_length

ARENA_LIMITS = (-2.2, -2.2, 2.2, 2.2)
TRAP_LIMITS = (-2.0, -1.5, 2.0, 1.5)


def _scene(title: str, scenario: Scenario, limits: Limits) -> tuple[Any, Any]:
    fig, ax = new_axes(title, limits)
    draw_obstacles(ax, scenario.obstacles)
    ax.plot(*scenario.start, "o", color="tab:green", label="start", zorder=4)
    ax.plot(*scenario.goal, "*", color="tab:red", markersize=12, label="goal", zorder=4)
    return fig, ax


def _with_field(ax: Any, field: PotentialField, mode: FieldMode, limits: Limits) -> None:
    points = grid(limits)
    points = points[~field.obstacles.contains(points)]
    draw_field(ax, points, field.velocity(points, mode))


def _field_figure(out: Path, number: int, title: str, mode: FieldMode, slug: str) -> Path:
    scenario = course_arena()
    field = scenario.field()
    fig, ax = _scene(f"Figure {number}: {title}", scenario, ARENA_LIMITS)
    _with_field(ax, field, mode, ARENA_LIMITS)
    path = trace(field, scenario.start, mode=mode)
    ax.plot(path[:, 0], path[:, 1], color="tab:orange", linewidth=2, label="trajectory", zorder=3)
    ax.legend(loc="lower right", fontsize=8)
    return save(fig, out / f"figure{number}_{slug}_field.png")


def _rollout(scenario: Scenario, seed: int, settings: EscapeSettings) -> Rollout:
    (rollout,) = roll_out(scenario.field(), scenario.start, [seed], settings)
    return rollout


def _figure4(out: Path, seed: int) -> Path:
    scenario = symmetric_trap()
    field = scenario.field()
    fig, ax = _scene("Figure 4: obstacle at the origin; noise on the attractive field", scenario, ARENA_LIMITS)
    _with_field(ax, field, FieldMode.COMBINED, ARENA_LIMITS)
    stuck = trace(field, scenario.start)
    ax.plot(stuck[:, 0], stuck[:, 1], "--", color="black", linewidth=1.5, label="no noise", zorder=5)
    ax.plot(*stuck[-1], "X", color="black", markersize=10, label="stuck at the saddle point", zorder=5)
    noisy = _rollout(scenario, seed, EscapeSettings(random_walk=False))
    ax.plot(*noisy.trajectory.T, color="tab:orange", linewidth=2, label=f"with noise (seed {noisy.seed})", zorder=3)
    ax.legend(loc="lower right", fontsize=8)
    return save(fig, out / "figure4_saddle_noise.png")


def _walk_rollout(seed: int) -> tuple[Scenario, Rollout]:
    scenario = two_cylinder_trap()
    return scenario, _rollout(scenario, seed, EscapeSettings())


def _figure5(out: Path, scenario: Scenario, rollout: Rollout) -> Path:
    fig, ax = _scene("Figure 5: random walk out of the local minimum", scenario, TRAP_LIMITS)
    _with_field(ax, scenario.field(), FieldMode.COMBINED, TRAP_LIMITS)
    path = rollout.trajectory
    ax.plot(path[:, 0], path[:, 1], color="tab:orange", linewidth=1.5, label="best-first steps", zorder=3)
    walk = np.flatnonzero(rollout.walking)
    segments = np.stack([path[walk], path[walk + 1]], axis=1)
    for k, seg in enumerate(segments):
        ax.plot(
            seg[:, 0], seg[:, 1], color="tab:purple", linewidth=1, label=None if k else "random-walk steps", zorder=4
        )
    ax.legend(loc="lower right", fontsize=8, title=f"seed {rollout.seed}, {rollout.walk_steps} walk steps")
    return save(fig, out / "figure5_random_walk.png")


def _plot_path(ax: Any, path: FloatArray, style: str, colour: str, label: str) -> None:
    ax.plot(path[:, 0], path[:, 1], style, color=colour, linewidth=2, label=f"{label}: {path_length(path):.3f} m")


def _figure6(out: Path, scenario: Scenario, rollout: Rollout) -> Path:
    fig, (left, right) = new_panels(
        ["Figure 6a: forward shortcuts, then back-tracking", "Figure 6b: the random-walk trajectory simplified"],
        [(-0.5, -0.5, 1.5, 2.5), TRAP_LIMITS],
    )
    # 6a: from A the forward pass stops at B (the disc hides C), goes on from B to D, and back-tracking then
    # finds that A sees D directly and drops B.
    disc = Obstacles.from_circles([[0.5, 0.5, 0.1]])
    draw_obstacles(left, disc)
    raw = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 2.0)])
    left.plot(raw[:, 0], raw[:, 1], "o-", color="tab:orange", label="trajectory")
    for name, point in zip("ABCD", raw, strict=True):
        left.annotate(name, point, textcoords="offset points", xytext=(6, 6))
    _plot_path(left, simplify_path(raw, disc.segments_free, backtrack=False), "--", "tab:blue", "forward pass")
    _plot_path(left, simplify_path(raw, disc.segments_free), "-", "tab:red", "with back-tracking")
    left.legend(loc="upper right", fontsize=8)

    draw_obstacles(right, scenario.obstacles)
    trajectory = planned_points(scenario.field(), rollout, simplify=False)
    right.plot(*trajectory.T, color="tab:orange", linewidth=0.8, alpha=0.6, label="raw trajectory")
    _plot_path(right, planned_points(scenario.field(), rollout), "s-", "tab:red", "simplified")
    right.legend(loc="lower right", fontsize=8)
    return save(fig, out / "figure6_simplification_steps.png")


def _figure7(out: Path, scenario: Scenario, rollout: Rollout) -> Path:
    fig, ax = _scene("Figure 7: random walk escape after simplification", scenario, TRAP_LIMITS)
    raw = rollout.trajectory
    ax.plot(raw[:, 0], raw[:, 1], color="tab:orange", linewidth=0.8, alpha=0.4, label="raw trajectory")
    _plot_path(ax, planned_points(scenario.field(), rollout), "-", "tab:red", "simplified")
    best = shortest_path(scenario.start, scenario.goal, scenario.obstacles)
    _plot_path(ax, best.points, ":", "black", "true shortest")
    ax.legend(loc="lower right", fontsize=8)
    return save(fig, out / "figure7_simplified.png")


def make_figures(out_dir: Path, seed: int) -> list[Path]:
    """Write Figures 1-7 as PNGs into ``out_dir``; the random ones use ``seed``. Returns the files."""
    written = [
        _field_figure(out_dir, 1, "attractive field only", FieldMode.ATTRACTIVE, "attractive"),
        _field_figure(out_dir, 2, "repulsive field only", FieldMode.REPULSIVE, "repulsive"),
        _field_figure(out_dir, 3, "combined field", FieldMode.COMBINED, "combined"),
        _figure4(out_dir, seed),
    ]
    scenario, rollout = _walk_rollout(seed)
    written += [_figure5(out_dir, scenario, rollout), _figure6(out_dir, scenario, rollout)]
    written.append(_figure7(out_dir, scenario, rollout))
    return written


def draw_plan(
    out: Path, obstacles: Obstacles, limits: Limits, *, start: FloatArray, goal: FloatArray, path: FloatArray
) -> Path:
    """A PNG of one potential-field plan (``mrs-nav plan --png``): obstacles, start, goal and path (metres)."""
    fig, ax = new_axes("potential field", limits)
    draw_obstacles(ax, obstacles)
    ax.plot(path[:, 0], path[:, 1], color="tab:orange", linewidth=2, label=f"path {path_length(path):.2f} m", zorder=3)
    ax.plot(start[0], start[1], "o", color="tab:green", label="start", zorder=4)
    ax.plot(goal[0], goal[1], "*", color="tab:red", markersize=12, label="goal", zorder=4)
    ax.legend(loc="lower right", fontsize=8)
    return save(fig, out)
