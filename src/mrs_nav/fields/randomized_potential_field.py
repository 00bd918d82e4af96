"""Potential-field planning with randomised escapes (assignment 1.1, parts 1d-1f).

The point moves by explicit Euler steps ``x[t + dt] = x[t] + v dt`` in one of two modes:

- **best first** (gradient descent): ``v = cap(V_a(x) + w + V_r(x))`` with ``w ~ N(0, sigma^2 I)`` Gaussian
  noise on the attractive part. The noise is the fix (1e) for the saddle point in front of an obstacle lying
  on the straight line to the goal: there the field points exactly at the goal and only a perturbation
  across the line lets the descent slide off.
- **random walk** (1f): entered at a local minimum, recognised as a field weaker than ``stall_speed`` while
  the goal is farther than ``stall_distance`` (closer in, a weak field just means the goal is near). The
  point moves at ``V_max`` along a heading that follows a Markov chain
  ``theta[t + dt] ~ N(theta[t], walk_angle_std^2)`` (``walk_angle_std = pi`` as in the assignment). It
  returns to best first when the step it just took goes down the potential, i.e. has a positive component
  along the field, ``(x[t + dt] - x[t]) . V(x[t + dt]) > 0``; that test starts only after ``min_walk_steps``
  steps, so that one lucky step does not drop the point straight back into the basin it is leaving.

- **navigation function** (optional, ``guide_after_walks``; not in the assignment, it is this project's answer to
  traps a random walk rarely leaves, such as cups and U-shapes): once a point has made ``guide_after_walks``
  random walks (and stalls again, so they failed to escape), the next stall hands it to the wavefront of
  :mod:`mrs_nav.fields.navigation_function`: it heads at ``max_speed`` for a point a few cells down the geodesic
  distance to the goal, which has no local minimum, and returns to best first once that distance is
  ``guide_margin`` below the distance at the worst trap so far *and* the goal is in straight sight. The guide
  never passes a gap the (grown) obstacles close; when it says the goal cannot be reached from the start at all
  (e.g. behind a door narrower than the robot), :func:`roll_out` raises :class:`NoPathFoundError` with the reason
  :data:`NO_PATH` before any step.

Steps that would enter an obstacle are refused (the point stays and, in a walk, draws a new heading), so
the trajectory never crosses an obstacle even where the random walk's speed exceeds the field's.

Each seed owns a ``numpy.random.Generator``; its draws are made up front, so a batch of seeds simulated
together (vectorised over seeds, as the tests and the benchmark do) gives exactly the trajectories of the
seeds run one by one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.fields.navigation_function import NavigationFunction
from mrs_nav.fields.path_simplification import simplify_path
from mrs_nav.fields.potential_field import PotentialField, cap, workspace_bounds
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.admissible import obstacles_refusal
from mrs_nav.maps.obstacles import BoolArray
from mrs_nav.maps.occupancy_grid import IntArray
from mrs_nav.planning import PlanResult, headings_along, path_length

REACHED = "goal reached"
NO_PATH = (
    "no path: the obstacles, grown by the robot radius, close the goal off from the start "
    "(a gap narrower than the robot counts as closed)"
)


@dataclass(frozen=True)
class EscapeSettings:
    """Integration and escape parameters.

    ``dt`` (s) Euler step; ``max_steps`` step budget; ``goal_tolerance`` (m) success radius; ``noise_std``
    (m/s) standard deviation of the attractive-field noise (0 turns the 1e fix off); ``random_walk`` turns
    the 1f escape on; ``stall_speed`` (m/s) and ``stall_distance`` (m) define a local minimum; ``stall_steps``
    how many stalled steps end a plan when the random walk is off; ``min_walk_steps`` the shortest walk;
    ``walk_angle_std`` (rad) the heading noise of the walk; ``guide_after_walks`` how many random walks a point
    makes before the navigation function takes over at its next stall (``None``: never, the assignment's method), and
    ``guide_margin`` (m) how much closer to the goal than the trap the guide leads before best first resumes, and
    ``guide_patience`` how many guided steps without getting 1 mm closer end the guided phase in a random walk.
    """

    dt: float = 0.01
    max_steps: int = 10000
    goal_tolerance: float = 0.05
    noise_std: float = 0.05
    random_walk: bool = True
    stall_speed: float = 0.05
    stall_distance: float = 0.2
    stall_steps: int = 300
    min_walk_steps: int = 20
    walk_angle_std: float = math.pi
    guide_after_walks: int | None = 1
    guide_margin: float = 0.5
    guide_patience: int = 100

    def __post_init__(self) -> None:
        if self.guide_after_walks is not None and self.guide_after_walks < 0:
            raise InvalidInputError(f"guide_after_walks must be >= 0 or None, got {self.guide_after_walks}")
        for name in ("dt", "goal_tolerance", "noise_std", "stall_speed", "stall_distance", "walk_angle_std"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0 or (name == "dt" and value == 0.0):
                raise InvalidInputError(
                    f"{name} must be a finite number {'> 0' if name == 'dt' else '>= 0'}, got {value}"
                )
        for name in ("max_steps", "stall_steps", "min_walk_steps", "guide_patience"):
            value = getattr(self, name)
            if value < (0 if name == "min_walk_steps" else 1):
                raise InvalidInputError(f"{name} must be {'>= 0' if name == 'min_walk_steps' else '>= 1'}, got {value}")


@dataclass(frozen=True)
class Rollout:
    """One seed's trajectory ``(K, 2)`` (not simplified), whether it reached the goal and why it stopped.

    A rollout is the simulated descent, kept whole for figures and benchmarks even when it ends short of the goal;
    the planner (:func:`plan_potential_field`) turns one that did not reach it into :class:`NoPathFoundError`.

    ``walking[k]`` tells whether step ``k -> k + 1`` was an escape step, random walk or guided (``(K - 1,)``).
    """

    seed: int
    trajectory: FloatArray
    walking: BoolArray
    reached: bool
    reason: str
    steps: int
    walk_steps: int


def navigation_guide(field: PotentialField, start: tuple[float, float]) -> NavigationFunction:
    """The wavefront guide to the field's goal over the workspace spanned by ``start``, goal and obstacles."""
    return NavigationFunction(field.obstacles, field.goal, workspace_bounds(field.obstacles, start, field.goal))


def roll_out(
    field: PotentialField,
    start: tuple[float, float],
    seeds: Sequence[int],
    settings: EscapeSettings = EscapeSettings(),
    guide: NavigationFunction | None = None,
) -> list[Rollout]:
    """Simulate the randomised descent from ``start`` once per seed, vectorised over the seeds.

    ``guide`` (built from ``field`` and ``start`` when not given) is used only when ``settings`` turn it on.
    Raises :class:`NoPathFoundError` (:data:`NO_PATH`) when the guide says the goal cannot be reached from
    ``start`` at all.
    """
    if any(seed < 0 for seed in seeds):
        raise InvalidInputError(f"seeds must be >= 0, got {min(seeds)}")
    start_xy = np.asarray(start, dtype=np.float64)
    why = obstacles_refusal(field.obstacles, start[0], start[1])
    if why:
        raise InvalidInputError(f"start ({start[0]}, {start[1]}) is {why}")
    if settings.guide_after_walks is None:
        guide = None
    elif guide is None:
        guide = navigation_guide(field, start)
    if guide is not None and not guide.reaches_goal(start_xy[None, :])[0]:
        # Refused before any step: no walk could get there, and the descent must not squeeze through.
        raise NoPathFoundError(NO_PATH)
    descent = _Descent(field, guide, settings, start_xy, seeds)
    for k in range(settings.max_steps):
        if not descent.active.any():
            break
        descent.step(k)
    return descent.rollouts(seeds)


class _Descent:
    """The seeds of one :func:`roll_out` (every array holds one entry per seed) and the Euler step of the active ones.

    Each seed's random draws are made up front, in the same order whatever the batch, so a seed's trajectory does
    not depend on the others.
    """

    def __init__(
        self,
        field: PotentialField,
        guide: NavigationFunction | None,
        settings: EscapeSettings,
        start_xy: FloatArray,
        seeds: Sequence[int],
    ) -> None:
        s = settings
        self.field, self.guide, self.s = field, guide, s
        self.goal = np.asarray(field.goal, dtype=np.float64)
        n = len(seeds)
        self.noise = np.empty((s.max_steps, n, 2))
        self.turns = np.empty((s.max_steps, n))
        self.heading = np.empty(n)
        for i, seed in enumerate(seeds):
            rng = np.random.default_rng(seed)
            self.heading[i] = rng.uniform(-math.pi, math.pi)
            self.noise[:, i] = rng.normal(0.0, s.noise_std, (s.max_steps, 2)) if s.noise_std > 0 else 0.0
            self.turns[:, i] = rng.normal(0.0, s.walk_angle_std, s.max_steps)
        self.guiding = np.zeros(n, dtype=bool)
        self.walks = np.zeros(n, dtype=np.int64)
        self.trap = np.full(n, math.inf)
        self.guide_best = np.full(n, math.inf)  # the nearest to the goal (guide's distance) in the current guided phase
        self.guide_idle = np.zeros(n, dtype=np.int64)  # guided steps since that improved
        self.path = np.empty((s.max_steps + 1, n, 2))
        self.path[0] = start_xy
        self.walked = np.zeros((s.max_steps, n), dtype=bool)
        self.x = np.repeat(start_xy[None, :], n, axis=0)
        self.active = np.hypot(*(self.x - self.goal).T) > s.goal_tolerance
        self.finished = np.where(self.active, -1, 0)
        self.walking = np.zeros(n, dtype=bool)
        self.walk_age = np.zeros(n, dtype=np.int64)
        self.slow_for = np.zeros(n, dtype=np.int64)
        self.reasons = ["" if a else REACHED for a in self.active]

    def step(self, k: int) -> None:
        """Euler step ``k`` of every active seed: pick its mode, move it unless the step enters an obstacle, and
        end it at the goal or (random walk off) after a long stall."""
        s, field = self.s, self.field
        idx = np.flatnonzero(self.active)
        here = self.x[idx]
        uncapped = field.attractive(here) + field.repulsive(here)
        clean = cap(uncapped, field.max_speed)
        self._switch_modes(idx, here, clean)
        walk = self.walking[idx]
        led = self.guiding[idx]
        self.heading[idx[walk]] += self.turns[k, idx[walk]]
        v = cap(uncapped + self.noise[k, idx], field.max_speed) if s.noise_std > 0 else clean
        v[walk] = field.v_max * np.column_stack([np.cos(self.heading[idx[walk]]), np.sin(self.heading[idx[walk]])])
        if self.guide is not None and led.any():
            v[led] = self._guided_velocity(self.guide, here[led])
        proposed = here + s.dt * v
        ok = field.obstacles.segments_free(here, proposed)
        new = np.where(ok[:, None], proposed, here)
        self.x[idx] = new
        self.path[k + 1] = self.x

        self.walked[k, idx[walk | led]] = True
        self.walk_age[idx[walk]] += 1
        if self.guide is not None and led.any():
            self._end_guided_phases(self.guide, idx[led], new[led])
        if walk.any():
            moved = new[walk] - here[walk]
            downhill = np.einsum("ij,ij->i", moved, field.velocity(new[walk])) > 0.0
            leave = downhill & (self.walk_age[idx[walk]] > s.min_walk_steps)
            self.walking[idx[walk][leave]] = False
        self._finish(k, idx, new)

    def _switch_modes(self, idx: IntArray, here: FloatArray, clean: FloatArray) -> None:
        """Count stalls; hand a fresh stall to the guide (after enough walks) or to a random walk."""
        s = self.s
        stalled = (np.hypot(clean[:, 0], clean[:, 1]) < s.stall_speed) & (
            np.hypot(*(here - self.goal).T) > s.stall_distance
        )
        self.slow_for[idx] = np.where(stalled, self.slow_for[idx] + 1, 0)
        fresh = stalled & ~self.walking[idx] & ~self.guiding[idx]
        if self.guide is not None and s.guide_after_walks is not None:
            handed = fresh & (self.walks[idx] >= s.guide_after_walks)
            self.guiding[idx[handed]] = True
            self.guide_best[idx[handed]], self.guide_idle[idx[handed]] = math.inf, 0
            self.trap[idx[handed]] = np.minimum(self.trap[idx[handed]], self.guide.distance(here[handed]))
            fresh &= ~handed
        if s.random_walk:
            self.walking[idx[fresh]] = True
            self.walk_age[idx[fresh]] = 0
            self.walks[idx[fresh]] += 1

    def _guided_velocity(self, guide: NavigationFunction, here: FloatArray) -> FloatArray:
        """Towards the wavefront target; where that step is blocked (a corner it would cut), towards the cell the
        point sees down the distance, and where even that is blocked, with the obstacles' push added, so that the
        point slides along the obstacle."""
        s, field = self.s, self.field
        ahead = cap((guide.downhill(here) - here) / s.dt, field.max_speed)
        direct = field.obstacles.segments_free(here, here + s.dt * ahead)
        near = cap((guide.downhill(here, 0) - here) / s.dt, field.max_speed)
        near_ok = field.obstacles.segments_free(here, here + s.dt * near)
        pushed = cap(ahead + field.repulsive(here), field.max_speed)
        out: FloatArray = np.where(direct[:, None], ahead, np.where(near_ok[:, None], near, pushed))
        return out

    def _end_guided_phases(self, guide: NavigationFunction, ids: IntArray, new: FloatArray) -> None:
        """Back to best first once well past the trap with the goal in sight; to a walk when no longer gaining."""
        s = self.s
        left = guide.distance(new)
        closer = left < self.trap[ids] - s.guide_margin
        sight = self.field.obstacles.segments_free(new, np.repeat(self.goal[None, :], len(ids), axis=0))
        self.guiding[ids[closer & sight]] = False
        # A guided point that stops getting closer (it dithers at a corner where the step to the target and the
        # slide along the obstacle are both blocked, or sits in a gap narrower than the cells resolve, where the
        # distance is unknown) would stay for good: it walks off and is guided at its next stall.
        gained = left < self.guide_best[ids] - 1e-3
        self.guide_best[ids] = np.where(gained, left, self.guide_best[ids])
        self.guide_idle[ids] = np.where(gained, 0, self.guide_idle[ids] + 1)
        lost = ids[self.guiding[ids] & (self.guide_idle[ids] > s.guide_patience)]
        self.guiding[lost] = False
        self.walking[lost] = s.random_walk
        self.walk_age[lost] = 0
        self.walks[lost] += 1

    def _finish(self, k: int, idx: IntArray, new: FloatArray) -> None:
        """End the seeds that arrived, and (random walk off) those stalled for ``stall_steps``."""
        s = self.s
        arrived = np.hypot(*(new - self.goal).T) <= s.goal_tolerance
        for j in idx[arrived]:
            self.reasons[j] = REACHED
        stuck = ~arrived & (self.slow_for[idx] >= s.stall_steps) & (not s.random_walk)
        for j in idx[stuck]:
            self.reasons[j] = (
                f"stalled at ({self.x[j, 0]:.3f}, {self.x[j, 1]:.3f}): the field vanishes away from the goal "
                "(saddle point or local minimum)"
            )
        done = arrived | stuck
        self.finished[idx[done]] = k + 1
        self.active[idx[done]] = False

    def rollouts(self, seeds: Sequence[int]) -> list[Rollout]:
        """Each seed's :class:`Rollout`, cut where it ended."""
        s = self.s
        results = []
        for i, seed in enumerate(seeds):
            steps = int(self.finished[i]) if self.finished[i] >= 0 else s.max_steps
            reason = (
                self.reasons[i] or f"step budget used up ({s.max_steps} steps of {s.dt} s) before reaching the goal"
            )
            results.append(
                Rollout(
                    int(seed),
                    self.path[: steps + 1, i].copy(),
                    self.walked[:steps, i].copy(),
                    reason == REACHED,
                    reason,
                    steps,
                    int(self.walked[:steps, i].sum()),
                )
            )
        return results


def planned_points(
    field: PotentialField, rollout: Rollout, *, simplify: bool = True, guide: NavigationFunction | None = None
) -> FloatArray:
    """The ``(K, 2)`` waypoints a plan hands on: the rollout's trajectory, ended on the goal when it succeeded
    (the descent stops ``goal_tolerance`` short of it), then simplified against the field's obstacles.

    With a ``guide`` and a successful rollout, the guide's corridor from the start, simplified the same way, is
    handed on instead when it is collision free and shorter: the descent can take the long way round an obstacle
    without ever stalling (along a tilted wall past its gap, round the far side of a room), which shortcuts
    along its own trajectory cannot undo.
    """
    points = rollout.trajectory
    goal = np.asarray(field.goal, dtype=np.float64)
    if rollout.reached and field.obstacles.segments_free(points[-1:], goal[None, :])[0]:
        points = np.vstack([points, goal])
    if not simplify:
        return points
    path = simplify_path(points, field.obstacles.segments_free)
    if guide is None or not rollout.reached:
        return path
    try:
        corridor = guide.corridor(points[0])
    except NoPathFoundError:
        return path
    shortcut = simplify_path(corridor, field.obstacles.segments_free)
    if field.obstacles.path_free(shortcut) and path_length(shortcut) < path_length(path):
        return shortcut
    return path


def plan_potential_field(
    field: PotentialField,
    start: tuple[float, float, float],
    seed: int,
    settings: EscapeSettings = EscapeSettings(),
    *,
    simplify: bool = True,
) -> PlanResult:
    """One potential-field plan from ``start`` ``(x, y, yaw)`` to the field's goal.

    The waypoints are :func:`planned_points` of the rollout (with the guide when ``settings`` use one), each
    with the heading of the segment leaving it; the first keeps the start's yaw and the last the heading of the
    segment reaching it. Raises :class:`NoPathFoundError` with the reason when the goal is not reached (the
    step budget used up, a stall, or no way through the obstacles).
    """
    began = time.perf_counter()
    guide = navigation_guide(field, (start[0], start[1])) if settings.guide_after_walks is not None else None
    (rollout,) = roll_out(field, (start[0], start[1]), [seed], settings, guide)
    if not rollout.reached:
        raise NoPathFoundError(
            rollout.reason,
            time_s=time.perf_counter() - began,
            iterations=rollout.steps,
            nodes=int(rollout.trajectory.shape[0]),
        )
    path = headings_along(planned_points(field, rollout, simplify=simplify, guide=guide))
    path[0, 2] = start[2]
    elapsed = time.perf_counter() - began
    return PlanResult(
        path=path,
        length_m=path_length(path),
        time_s=elapsed,
        first_solution_s=elapsed,
        iterations=rollout.steps,
        nodes=int(path.shape[0]),
        reason=rollout.reason,
    )
