"""The assignment's potential-field scenarios, shared by the figures, the tests and the benchmark.

- ``course_arena``: ``worlds/simple.world`` (walls with inner faces at +-2.0 m, 0.1 m thick; a cylinder of
  radius 0.3 m at (0.3, 0.2)), start (-1.5, -1.5), goal (1.5, 1.5).
- ``symmetric_trap``: the same arena with the cylinder moved to the origin, on the line from start to goal,
  which puts a saddle point of the potential in front of it (1d).
- ``two_cylinder_trap``: two overlapping cylinders of radius 0.3 m at (0, 0.25) and (0, -0.25), start
  (-1.5, 0), goal (1.5, 0); the notch between them is a true local minimum (1f).
"""

from __future__ import annotations

import math
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

    def field(self, decay: float = DEFAULT_DECAY, robot_radius: float = 0.0) -> PotentialField:
        """The field around the obstacles grown by ``robot_radius`` (m), so that the point stands for the robot."""
        return PotentialField.build(self.goal, self.obstacles.inflated(robot_radius), self.bounds, decay=decay)


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


# ---- concave traps (start (-1.5, 0), goal (1.5, 0) in the trap's own frame) ----------------------------------

TRAP_START = (-1.5, 0.0)
TRAP_GOAL = (1.5, 0.0)


def _placed(obstacles: Obstacles, angle: float, shift: tuple[float, float]) -> Obstacles:
    """``obstacles`` rotated by ``angle`` (rad) about the origin, then moved by ``shift`` (m)."""
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    circles = obstacles.circles.copy()
    circles[:, :2] = circles[:, :2] @ rot.T + shift
    boxes = obstacles.boxes.copy()
    boxes[:, :2] = boxes[:, :2] @ rot.T + shift
    boxes[:, 2] += angle
    return Obstacles(circles=circles, boxes=boxes)


def _trap(name: str, obstacles: Obstacles, angle: float, shift: tuple[float, float]) -> Scenario:
    placed = _placed(obstacles, angle, shift)
    return Scenario(name, placed, TRAP_START, TRAP_GOAL, workspace_bounds(placed, TRAP_START, TRAP_GOAL))


def cylinder_cup(
    count: int, arc_radius: float = 0.5, gap: float = 0.1, angle: float = 0.0, shift: tuple[float, float] = (0.0, 0.0)
) -> Scenario:
    """``count`` cylinders on a half circle of ``arc_radius`` m opening towards the start, ``gap`` m apart (too
    narrow for the robot), rotated by ``angle`` and moved by ``shift``."""
    theta = np.linspace(-math.pi / 2, math.pi / 2, count)
    chord = 2.0 * arc_radius * math.sin(math.pi / (2 * (count - 1)))
    radius = (chord - gap) / 2.0
    cup = Obstacles(
        circles=np.column_stack([arc_radius * np.cos(theta), arc_radius * np.sin(theta), np.full(count, radius)])
    )
    return _trap(f"cup of {count} cylinders (r {arc_radius:.2g} m, {math.degrees(angle):.0f} deg)", cup, angle, shift)


def box_u(
    width: float = 1.0,
    depth: float = 0.8,
    thickness: float = 0.1,
    angle: float = 0.0,
    shift: tuple[float, float] = (0.0, 0.0),
) -> Scenario:
    """A U of three boxes, inner ``width`` x ``depth`` m, its back towards the goal and its mouth towards the
    start, rotated by ``angle`` and moved by ``shift``."""
    half_w, t = width / 2.0, thickness / 2.0
    boxes = [
        [depth / 2.0 + t, 0.0, 0.0, t, half_w + thickness],
        [0.0, half_w + t, 0.0, depth / 2.0 + t, t],
        [0.0, -(half_w + t), 0.0, depth / 2.0 + t, t],
    ]
    return _trap(
        f"U of boxes ({width:.2g} x {depth:.2g} m, {math.degrees(angle):.0f} deg)",
        Obstacles(boxes=np.array(boxes)),
        angle,
        shift,
    )


def wall_with_gap(
    gap: float = 0.45,
    *,
    length: float = 2.4,
    offset: float = 0.5,
    thickness: float = 0.1,
    angle: float = 0.0,
    shift: tuple[float, float] = (0.0, 0.0),
) -> Scenario:
    """A wall ``length`` m long across the line from start to goal with one ``gap`` m wide opening ``offset`` m
    off that line, rotated by ``angle`` and moved by ``shift``."""
    lo, hi = -length / 2.0, length / 2.0
    a, b = offset - gap / 2.0, offset + gap / 2.0
    boxes = [
        [0.0, (lo + a) / 2.0, 0.0, thickness / 2.0, (a - lo) / 2.0],
        [0.0, (b + hi) / 2.0, 0.0, thickness / 2.0, (hi - b) / 2.0],
    ]
    return _trap(
        f"wall with a {gap:.2g} m gap ({math.degrees(angle):.0f} deg)", Obstacles(boxes=np.array(boxes)), angle, shift
    )


def room_with_door(
    door: float = 0.45, *, half_size: float = 0.5, thickness: float = 0.1, angle: float = 0.0
) -> Scenario:
    """A square room round the goal, inner half side ``half_size`` m, its only opening a ``door`` m wide in the
    wall facing the start, the room turned by ``angle`` about the goal. With a door narrower than the robot the
    goal cannot be reached at all: the right answer is "no path"."""
    h, t = half_size + thickness / 2.0, thickness / 2.0
    side = (h + t - door / 2.0) / 2.0  # half length of each piece of the door's wall
    boxes = [
        [h, 0.0, 0.0, t, h + t],
        [0.0, h, 0.0, h + t, t],
        [0.0, -h, 0.0, h + t, t],
        [-h, door / 2.0 + side, 0.0, t, side],
        [-h, -(door / 2.0 + side), 0.0, t, side],
    ]
    placed = _placed(Obstacles(boxes=np.array(boxes)), angle, TRAP_GOAL)
    name = f"room round the goal, {door:.2g} m door ({math.degrees(angle):.0f} deg)"
    return Scenario(name, placed, TRAP_START, TRAP_GOAL, workspace_bounds(placed, TRAP_START, TRAP_GOAL))


def trap_gallery() -> list[Scenario]:
    """The traps ``tests/core/fields/test_traps.py`` holds the planner to (>= 99 of 100 seeds), all passable."""
    return [
        cylinder_cup(3),
        cylinder_cup(4, arc_radius=0.6, angle=0.4),
        cylinder_cup(5, arc_radius=0.45, angle=-0.3, shift=(0.1, 0.2)),
        box_u(),
        box_u(width=0.7, depth=1.0, angle=0.5, shift=(0.0, -0.2)),
        box_u(width=1.4, depth=0.6, angle=-0.35),
        wall_with_gap(0.45),
        wall_with_gap(0.5, offset=-0.8, angle=0.3),
        wall_with_gap(0.15, length=2.0),  # too narrow for the robot: it must go round
        room_with_door(0.45, angle=1.2),  # the door turned away from the start: through it or nowhere
    ]


def random_traps(rng: np.random.Generator) -> list[Scenario]:
    """One trap of each kind (cup of 3-5 cylinders, U of boxes, wall with one gap, room with a door the robot
    fits through) with size, orientation and place drawn from ``rng``."""
    angle, shift = rng.uniform(-0.6, 0.6, 3), rng.uniform(-0.3, 0.3, (3, 2))
    return [
        cylinder_cup(int(rng.integers(3, 6)), arc_radius=rng.uniform(0.4, 0.7), angle=angle[0], shift=tuple(shift[0])),
        box_u(width=rng.uniform(0.6, 1.4), depth=rng.uniform(0.5, 1.1), angle=angle[1], shift=tuple(shift[1])),
        wall_with_gap(rng.uniform(0.3, 0.6), offset=rng.uniform(-0.9, 0.9), angle=angle[2], shift=tuple(shift[2])),
        room_with_door(rng.uniform(0.4, 0.6), half_size=rng.uniform(0.4, 0.6), angle=rng.uniform(-math.pi, math.pi)),
    ]
