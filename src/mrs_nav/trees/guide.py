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

#: Draws per guided target (the first one in free space is kept).
TRIES = 8


class CorridorSampler:
    """Targets along the corridor ``path`` ``(K, 2)`` of ``wave``, ahead of the frontier of the tree's nodes; see
    the module docstring (metres). Build it with :meth:`towards`; the targets are drawn in compiled code
    (:func:`mrs_nav.trees.guide_kernels.guided_target`, called by :mod:`mrs_nav.trees.search_kernels`) from the
    random numbers of :meth:`draw`."""

    def __init__(self, wave: Wavefront, path: FloatArray, *, lookahead: float, spread: float) -> None:
        self.wave = wave
        self.path = path
        self.spread = spread
        # Metres still to go at each corridor point, decreasing from the start to 0 at the goal.
        x, y = path[:, 0], path[:, 1]
        to_go = np.zeros(len(path))
        to_go[-2::-1] = np.cumsum(np.hypot(x[-1:0:-1] - x[-2::-1], y[-1:0:-1] - y[-2::-1]))
        #: The least distance to go (m) among the tree's nodes so far (the corridor's start before any).
        self.frontier = float(to_go[0])
        #: The corridor as the compiled search takes it (:data:`mrs_nav.trees.search_kernels.GuideArgs`).
        self.kernel_args = (lookahead, to_go, np.ascontiguousarray(path), wave.distance, wave.factor)

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

    def draw(self, rng: np.random.Generator, count: int) -> tuple[FloatArray, FloatArray]:
        """The random numbers of ``count`` guided targets: ``(count, TRIES)`` fractions of the lookahead and
        ``(count, TRIES, 2)`` noise (m); each target is the first free one of its ``TRIES`` candidates."""
        return rng.random((count, TRIES)), rng.normal(0.0, self.spread, (count, TRIES, 2))
