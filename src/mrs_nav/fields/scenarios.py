"""The assignment's potential-field scenarios, shared by the figures, the tests and the benchmark.

- ``course_arena``: ``worlds/simple.world`` (walls with inner faces at +-2.0 m, 0.1 m thick; a cylinder of
  radius 0.3 m at (0.3, 0.2)), start (-1.5, -1.5), goal (1.5, 1.5).
- ``symmetric_trap``: the same arena with the cylinder moved to the origin, on the line from start to goal,
  which puts a saddle point of the potential in front of it (1d).
- ``two_cylinder_trap``: two overlapping cylinders of radius 0.3 m at (0, 0.25) and (0, -0.25), start
  (-1.5, 0), goal (1.5, 0); the notch between them is a true local minimum (1f).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrs_nav.fields.potential_field import DEFAULT_DECAY, Bounds, PotentialField, workspace_bounds
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.obstacles import Obstacles

ARENA_HALF_WIDTH = 2.0  # m, inner wall faces
WALL_THICKNESS = 0.1  # m
COURSE_START = (-1.5, -1.5)
COURSE_GOAL = (1.5, 1.5)


@dataclass(frozen=True)
class Scenario:
    """Obstacles, start and goal (m), and the workspace the field's ``V_max`` is sized for."""

    name: str
    obstacles: Obstacles
    start: tuple[float, float]
    goal: tuple[float, float]
    bounds: Bounds

    def field(self, decay: float = DEFAULT_DECAY) -> PotentialField:
        return PotentialField.build(self.goal, self.obstacles, self.bounds, decay=decay)


def arena_walls(half_width: float = ARENA_HALF_WIDTH, thickness: float = WALL_THICKNESS) -> FloatArray:
    """The four walls of a square arena as box rows ``(cx, cy, yaw, hx, hy)``, as in ``simple.world``."""
    centre = half_width + thickness / 2.0
    long_half, short_half = half_width + thickness, thickness / 2.0
    return np.array(
        [
            [0.0, centre, 0.0, long_half, short_half],
            [0.0, -centre, 0.0, long_half, short_half],
            [centre, 0.0, 0.0, short_half, long_half],
            [-centre, 0.0, 0.0, short_half, long_half],
        ]
    )


def _arena(name: str, cylinder: tuple[float, float, float]) -> Scenario:
    obstacles = Obstacles(circles=np.array([cylinder]), boxes=arena_walls())
    extent = obstacles.bounds()
    assert extent is not None
    return Scenario(name, obstacles, COURSE_START, COURSE_GOAL, extent)


def course_arena() -> Scenario:
    return _arena("course arena", (0.3, 0.2, 0.3))


def symmetric_trap() -> Scenario:
    return _arena("symmetric trap", (0.0, 0.0, 0.3))


def two_cylinder_trap() -> Scenario:
    obstacles = Obstacles.from_circles([[0.0, 0.25, 0.3], [0.0, -0.25, 0.3]])
    start, goal = (-1.5, 0.0), (1.5, 0.0)
    return Scenario("two-cylinder local minimum", obstacles, start, goal, workspace_bounds(obstacles, start, goal))
