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
from mrs_nav.maps.wavefront import Wavefront, wavefront
from mrs_nav.trees import kernels

# Draws per guided target (the first one in free space is kept).
_TRIES = 8


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
        self._frontier = float(self.to_go[0])
        # Nodes reported since the frontier was last read: looked up in one batch when it is needed.
        self._pending: list[FloatArray] = []
        self._grid_args = kernels.grid_args(wave.grid)

    @classmethod
    def towards(
        cls, grid: OccupancyGrid, start: FloatArray, goal: FloatArray, *, cell_m: float, lookahead: float, spread: float
    ) -> CorridorSampler | None:
        """The sampler of the corridor from ``start`` to ``goal`` on ``grid`` coarsened to ``cell_m`` metres, or
        None when neither coarse grid (the conservative one, then the optimistic one that keeps passages
        narrower than a coarse cell open) connects them."""
        for optimistic in (False, True):
            wave = wavefront(grid, goal, cell_m, optimistic)
            try:
                path = wave.corridor(start)
            except NoPathFoundError:
                continue
            return cls(wave, path, lookahead=lookahead, spread=spread)
        return None

    def reached(self, position: FloatArray) -> None:
        """Note a new tree node: it moves the frontier when it is geodesically closer to the goal."""
        self._pending.append(position)

    @property
    def frontier(self) -> float:
        """The least distance to go (m) among the nodes reported so far (the corridor's start before any)."""
        if self._pending:
            self._frontier = min(self._frontier, float(self.wave.at(np.array(self._pending)).min()))
            self._pending.clear()
        return self._frontier

    def sample(self, rng: np.random.Generator) -> FloatArray:
        """A target near the corridor point ``U(0, lookahead)`` metres beyond the frontier, in a free cell whose
        neighbours are free too when one of a few draws is (a target in a wall only wastes an iteration)."""
        to_go = self.frontier - rng.random(_TRIES) * self.lookahead
        k = np.minimum(np.searchsorted(-self.to_go, -to_go), len(self.path) - 1)
        points = self.path[k] + rng.normal(0.0, self.spread, (_TRIES, 2))
        free = kernels.lookup(points, self._grid_args[0], self._grid_args)
        out: FloatArray = points[int(np.argmax(free))]
        return out
