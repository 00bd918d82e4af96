"""Velocity fields of the potential-field method (assignment 1.1, parts 1a-1c).

Attractive field towards the goal ``x_g`` (from ``U_a = |x - x_g|^2 / 2``)::

    V_a(x) = x_g - x                                                         (m/s per m, i.e. 1/s gain)

Repulsive field of obstacle ``i``, from ``U_i = U_max exp(-d_i(x) / lambda)`` with ``d_i`` the distance from
``x`` to the obstacle's surface (``|x - x_i| - r_i`` for a circle) and ``n_i`` the outward unit normal::

    V_i(x) = V_max n_i(x) exp(-d_i(x) / lambda)     outside,     0 inside,     V_max = U_max / (2 lambda)

``lambda`` (m) sets the reach: every ``lambda ln 2`` of distance halves the push. (The exact derivative of
``U_i`` has ``U_max / lambda`` in place of ``2 V_max``; only ``V_max`` matters to the motion, so it is the
parameter here.) ``V_max`` must beat the
attraction right at an obstacle, ``V_max > max_x |x_g - x|`` over the workspace; :meth:`PotentialField.build`
takes ``V_max = factor * max_x |x_g - x|`` with ``factor = 2`` as the assignment found to work well.

The combined field ``V = V_a + V_r`` (``V_r = sum_i V_i``) is capped at ``max_speed``:
``cap(v) = v * min(1, max_speed / |v|)``.

Goal beside an obstacle (``goal_fade`` ``kappa`` > 0; 0, the default, is the course's field above). Near a wall
the push ``V_r`` does not vanish at the goal, so the field's equilibrium sits off the goal, farther the closer
the wall (Ge and Cui, "New potential functions for mobile robot path planning", IEEE T-RA 16(5), 2000: "goals
nonreachable with obstacles nearby"). As they do, the repulsive potential is multiplied by a factor that is 0 at
the goal, here ``g = 1 - exp(-rho^2 / kappa^2)`` with ``rho = |x - x_g|``, so ``U = U_a + g U_r`` is 0 at the
goal and positive elsewhere: the goal is the global minimum. Its velocity field, exactly ``-grad U``::

    V_r' = g V_r + (2 / kappa^2) exp(-rho^2 / kappa^2) U_r (x_g - x),     U_r = sum_i lambda V_max exp(-d_i / lambda)

Within about ``kappa`` of the goal the obstacles' push fades and an extra pull towards the goal appears; a few
``kappa`` away the field is the course's (``exp(-9)`` of the fade left at ``3 kappa``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.obstacles import Obstacles

# The course's 0.5 m/s speed cap. The course's 10 cm reach lets the arena's corner walls hold the point 6 cm
# off a goal at (1.5, 1.5); 8 cm keeps that under 2.5 cm, inside the 5 cm goal tolerance.
DEFAULT_MAX_SPEED = 0.5
DEFAULT_DECAY = 0.08
DEFAULT_VMAX_FACTOR = 2.0
# For a robot planning beside walls (mrs-nav plan): the fade reaches about 2.5 lambda, so a wall within 3.5
# lambda of the goal (its push there above 3 % of V_max) no longer holds the robot off it.
DEFAULT_GOAL_FADE = 0.2


class FieldMode(Enum):
    """Which part of the field to evaluate (the assignment's figures 1-3 show each)."""

    ATTRACTIVE = "attractive"
    REPULSIVE = "repulsive"
    COMBINED = "all"


Bounds = tuple[float, float, float, float]


def cap(velocities: npt.ArrayLike, max_speed: float) -> FloatArray:
    """Scale each row of ``velocities`` ``(P, 2)`` down to at most ``max_speed`` in norm, keeping its direction."""
    v = np.asarray(velocities, dtype=np.float64).reshape(-1, 2)
    speed = np.hypot(v[:, 0], v[:, 1])
    scale = np.divide(max_speed, speed, out=np.ones_like(speed), where=speed > max_speed)
    return np.asarray(v * scale[:, None], dtype=np.float64)


def workspace_bounds(obstacles: Obstacles, *points: npt.ArrayLike, margin: float = 0.5) -> Bounds:
    """The axis-aligned box holding all obstacles and ``points``, grown by ``margin`` metres."""
    rows = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in points]
    extent = obstacles.bounds()
    if extent is not None:
        rows.append(np.array([extent[:2], extent[2:]]))
    if not rows:
        raise InvalidInputError("workspace bounds need at least one obstacle or point")
    allp = np.vstack(rows)
    lo, hi = allp.min(axis=0) - margin, allp.max(axis=0) + margin
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


@dataclass(frozen=True)
class PotentialField:
    """The attractive + repulsive velocity field towards ``goal`` around ``obstacles``.

    ``v_max`` (m/s) is the repulsive speed at an obstacle's surface, ``decay`` (m) is ``lambda``,
    ``max_speed`` (m/s) caps the combined field and ``goal_fade`` (m) is ``kappa`` (0: no fade).
    """

    goal: tuple[float, float]
    obstacles: Obstacles
    v_max: float
    decay: float = DEFAULT_DECAY
    max_speed: float = DEFAULT_MAX_SPEED
    goal_fade: float = 0.0

    def __post_init__(self) -> None:
        values = (*self.goal, self.v_max, self.decay, self.max_speed, self.goal_fade)
        if not all(math.isfinite(v) for v in values):
            raise InvalidInputError(f"potential field parameters must be finite, got {values}")
        if self.v_max <= 0.0 or self.decay <= 0.0 or self.max_speed <= 0.0 or self.goal_fade < 0.0:
            raise InvalidInputError(
                f"v_max, decay and max_speed must be positive and goal_fade >= 0, got {self.v_max}, {self.decay}, "
                f"{self.max_speed}, {self.goal_fade}"
            )

    @classmethod
    def build(
        cls,
        goal: tuple[float, float],
        obstacles: Obstacles,
        bounds: Bounds,
        *,
        decay: float = DEFAULT_DECAY,
        vmax_factor: float = DEFAULT_VMAX_FACTOR,
        max_speed: float = DEFAULT_MAX_SPEED,
        goal_fade: float = 0.0,
    ) -> PotentialField:
        """The field with ``V_max = vmax_factor * max |x_g - x|`` over the workspace ``bounds``.

        The maximum of ``|x_g - x|`` over a rectangle is reached at one of its corners.
        """
        if vmax_factor <= 1.0:
            raise InvalidInputError(f"vmax_factor must exceed 1 so obstacles beat the goal, got {vmax_factor}")
        xmin, ymin, xmax, ymax = bounds
        corners = np.array([[xmin, ymin], [xmin, ymax], [xmax, ymin], [xmax, ymax]])
        farthest = float(np.max(np.hypot(*(corners - np.asarray(goal, dtype=np.float64)).T)))
        return cls(goal, obstacles, vmax_factor * farthest, decay, max_speed, goal_fade)

    def attractive(self, points: npt.ArrayLike) -> FloatArray:
        """``V_a = x_g - x`` at each point ``(P, 2)``."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        return np.asarray(np.asarray(self.goal, dtype=np.float64) - p, dtype=np.float64)

    def repulsive(self, points: npt.ArrayLike) -> FloatArray:
        """``V_r = sum_i V_max n_i exp(-d_i / lambda)`` over obstacles with the point outside, ``(P, 2)``; with a
        goal fade, ``V_r'`` (module doc)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        dist, normal = self.obstacles.surface(p)
        push = np.exp(-np.maximum(dist, 0.0) / self.decay)
        weight = np.where(dist > 0.0, self.v_max * push, 0.0)
        v = np.einsum("pk,pkj->pj", weight, normal)
        if self.goal_fade > 0.0:
            to_goal = np.asarray(self.goal, dtype=np.float64) - p
            near = np.exp(-np.sum(to_goal**2, axis=1) / self.goal_fade**2)
            u_r = self.decay * self.v_max * push.sum(axis=1)
            v = (1.0 - near)[:, None] * v + (2.0 / self.goal_fade**2 * near * u_r)[:, None] * to_goal
        return np.asarray(v, dtype=np.float64)

    def velocity(
        self,
        points: npt.ArrayLike,
        mode: FieldMode = FieldMode.COMBINED,
        attractive_noise: npt.ArrayLike | None = None,
    ) -> FloatArray:
        """The capped field ``cap(V_a + noise + V_r)`` at each point ``(P, 2)``.

        ``attractive_noise`` ``(P, 2)`` (m/s) is added to the attractive part: the assignment's fix (1e) for the
        saddle point in front of an obstacle lying on the line to the goal.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        v = np.zeros_like(p)
        if mode is not FieldMode.REPULSIVE:
            v += self.attractive(p)
            if attractive_noise is not None:
                v += np.asarray(attractive_noise, dtype=np.float64).reshape(-1, 2)
        if mode is not FieldMode.ATTRACTIVE:
            v += self.repulsive(p)
        return cap(v, self.max_speed)

    def potential(self, points: npt.ArrayLike) -> FloatArray:
        """``U = |x - x_g|^2 / 2 + g sum_i U_max exp(-d_i / lambda)`` at each point, ``(P,)`` (``g = 1`` without
        a goal fade).

        The exact derivative of ``U_max exp(-d / lambda)`` has magnitude ``U_max / lambda`` at the surface; the
        assignment's ``V_max = U_max / (2 lambda)`` carries an extra factor 1/2. Here ``U_max = lambda V_max``
        so that the uncapped field is exactly ``-grad U`` outside the obstacles.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        dist, _ = self.obstacles.surface(p)
        u_max = self.decay * self.v_max
        repulsive = (u_max * np.exp(-np.maximum(dist, 0.0) / self.decay)).sum(axis=1)
        attractive = 0.5 * np.sum((p - np.asarray(self.goal)) ** 2, axis=1)
        if self.goal_fade > 0.0:
            repulsive *= 1.0 - np.exp(-2.0 * attractive / self.goal_fade**2)
        return np.asarray(attractive + repulsive, dtype=np.float64)


def trace(
    field: PotentialField,
    start: tuple[float, float],
    *,
    dt: float = 0.01,
    duration: float = 20.0,
    mode: FieldMode = FieldMode.COMBINED,
) -> FloatArray:
    """Follow the (noise-free) field by explicit Euler steps ``x += V(x) dt`` for ``duration`` seconds.

    Nothing stops the point from crossing an obstacle: this is the bare field the assignment's figures 1-3
    draw. Returns the ``(steps + 1, 2)`` positions.
    """
    steps = round(duration / dt)
    out = np.empty((steps + 1, 2))
    out[0] = start
    for k in range(steps):
        out[k + 1] = out[k] + dt * field.velocity(out[k], mode)[0]
    return out
