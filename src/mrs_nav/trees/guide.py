"""Corridor-guided sampling for the tree planners: targets along a wavefront path just ahead of the tree.

A uniform sample in a building is almost always far from the tree and behind walls from it: the step towards
it fails, and the tree creeps. The wavefront (:mod:`mrs_nav.maps.wavefront`) gives, for the price of one
Dijkstra run over a coarse grid, the geodesic distance to the goal and a corridor of cells from the start down
to it. The tree's *frontier* is the least geodesic distance to go among its nodes; a guided target is the
corridor point up to ``lookahead`` metres beyond the frontier, plus Gaussian noise of ``spread`` metres. The
tree thus grows along the corridor one step at a time, with arcs chosen and checked exactly as for any other
sample, and finds a way through doors that a straight step cannot aim at. Guided targets are one part of a
mixture with the goal and uniform samples, so the planner still samples the whole free space (asymptotic
optimality is kept); with no corridor (the coarse grids see no way) the planner samples as before.
"""

from __future__ import annotations

import numpy as np

from mrs_nav.errors import NoPathFoundError
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.wavefront import Wavefront, goal_field
from mrs_nav.trees import guide_kernels, kernels

# Draws per guided target (the first one in free space is kept).
_TRIES = 8
# Guided targets whose random numbers are drawn together.
_BLOCK = 64


class CorridorSampler:
    """Targets along the corridor ``path`` ``(K, 2)`` of ``wave``, ahead of the frontier of the nodes reported
    through :meth:`reached`; see the module docstring (metres). Build it with :meth:`towards`."""

    def __init__(self, wave: Wavefront, path: FloatArray, *, lookahead: float, spread: float) -> None:
        self.wave = wave
        self.path = path
        self.lookahead = lookahead
        self.spread = spread
        # Metres still to go at each corridor point, decreasing from the start to 0 at the goal.
        steps = np.hypot(*np.diff(path, axis=0).T)
        self.to_go = np.append(np.cumsum(steps[::-1])[::-1], 0.0)
        #: The least distance to go (m) among the nodes reported so far (the corridor's start before any).
        self.frontier = float(self.to_go[0])
        self._grid_args = kernels.grid_args(wave.grid)
        # Random numbers of the next guided targets (see sample); none drawn yet.
        self._ahead = np.zeros((_BLOCK, _TRIES))
        self._noise = np.zeros((_BLOCK, _TRIES, 2))
        self._next = _BLOCK

    @classmethod
    def towards(
        cls, grid: OccupancyGrid, start: FloatArray, goal: FloatArray, *, cell_m: float, lookahead: float, spread: float
    ) -> CorridorSampler | None:
        """The sampler of the corridor from ``start`` to ``goal`` on ``grid`` coarsened to ``cell_m`` metres, or
        None when neither coarse grid (the conservative one, then the optimistic one that keeps passages
        narrower than a coarse cell open) connects them."""
        for optimistic in (False, True):
            wave = goal_field(grid, goal, start, cell_m, optimistic)
            try:
                path = wave.corridor(start)
            except NoPathFoundError:
                continue
            return cls(wave, path, lookahead=lookahead, spread=spread)
        return None

    def reached(self, position: FloatArray) -> None:
        """Note a new tree node: it moves the frontier when it is geodesically closer to the goal."""
        here = guide_kernels.field_at(
            float(position[0]), float(position[1]), self.wave.distance, self.wave.factor, self._grid_args
        )
        self.frontier = min(self.frontier, here)

    def sample(self, rng: np.random.Generator) -> FloatArray:
        """A target near the corridor point ``U(0, lookahead)`` metres beyond the frontier, in a free cell whose
        neighbours are free too when one of a few draws is (a target in a wall only wastes an iteration).

        The random numbers are drawn for ``_BLOCK`` targets at a time (seeded determinism is kept: the same
        generator gives the same blocks) and each target is one compiled call."""
        if self._next == _BLOCK:
            self._ahead = rng.random((_BLOCK, _TRIES))
            self._noise = rng.normal(0.0, self.spread, (_BLOCK, _TRIES, 2))
            self._next = 0
        i = self._next
        self._next += 1
        x, y = guide_kernels.guided_target(
            self._ahead[i], self._noise[i], self.frontier, self.lookahead, self.to_go, self.path, self._grid_args
        )
        return np.array([x, y])
