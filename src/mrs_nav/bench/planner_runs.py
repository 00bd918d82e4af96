"""The runs the planner benchmarks count: our RRT and RRT* on one query, timed in CPU seconds, and the table helpers
the sections share.
"""

from __future__ import annotations

import gc
import math
import statistics
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.trees import arcs
from mrs_nav.trees.rrt import RRTConfig, grow_rrt
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.scenarios import COURSE_GOAL, COURSE_START, OFFICE_GOALS
from mrs_nav.trees.tree import NoPathInTreeError, Search

ARENA_START = COURSE_START
ARENA_GOAL = COURSE_GOAL
#: Every time and budget here is CPU time of this process: the machines are shared, and wall time would measure
#: the other jobs as much as the planners.
CLOCK = time.process_time
OFFICE_GOAL = np.array(OFFICE_GOALS[0])


@dataclass(frozen=True)
class Run:
    """One planner run: success, first-solution time (s), final length (m), time to the target (s or inf)."""

    success: bool
    first_s: float
    length: float
    to_target_s: float
    iterations: int


@dataclass(frozen=True)
class Attempt:
    """One tree search as the benchmarks count it: the search when it found a path (else None) and what it
    spent either way."""

    search: Search | None
    iterations: int
    nodes: int

    @property
    def first_s(self) -> float:
        """CPU seconds to the first path; inf when there was none."""
        return self.search.result.first_solution_s or math.inf if self.search is not None else math.inf

    @property
    def length(self) -> float:
        """Length (m) of the path found; 0 when there was none."""
        return self.search.result.length_m if self.search is not None else 0.0


def attempt(grow: Callable[..., Search], *args: Any, **kwargs: Any) -> Attempt:
    """``grow(*args, **kwargs)`` (RRT or RRT*) with a search that found no path counted, not raised."""
    try:
        search = grow(*args, **kwargs)
    except NoPathInTreeError as err:
        return Attempt(None, err.iterations, err.nodes)
    return Attempt(search, search.result.iterations, len(search.tree))


def run_rrt_star(grid: OccupancyGrid, start: Pose2D, goal: Any, *, budget: float, target: float, seed: int) -> Run:
    r = attempt(
        grow_rrt_star, start, goal, grid, RRTStarConfig(time_budget=budget), np.random.default_rng(seed), clock=CLOCK
    )
    history = r.search.history if r.search is not None else ()
    to_target = next((t for _, t, length in history if length <= target), math.inf)
    return Run(r.search is not None, r.first_s, r.length, to_target, r.iterations)


def run_rrt(grid: OccupancyGrid, start: Pose2D, goal: Any, seed: int) -> Run:
    config = RRTConfig(iterations=None, time_budget=10.0)
    r = attempt(grow_rrt, start, goal, grid, config, np.random.default_rng(seed), clock=CLOCK)
    return Run(r.search is not None, r.first_s, r.length, math.inf, r.iterations)


def clearance(path: Any, obstacles: Obstacles) -> float:
    """Least distance (m) from the arcs of ``path`` (sampled every 5 mm) to the exact world geometry."""
    pieces = arcs.connect(path[:-1, :2], path[:-1, 2], path[1:, :2])
    dense, _ = arcs.sample(pieces, 0.005, with_yaw=False)
    return float(obstacles.signed_distance(dense[:, :2]).min())


def median(values: list[float]) -> float:
    return statistics.median(values) if values else math.nan


def p90(values: list[float]) -> float:
    return float(np.percentile(values, 90)) if values else math.nan


def fmt_ms(seconds: float) -> str:
    """Milliseconds with one decimal, two below 1 ms (first paths of a few tens of microseconds); '-' for none."""
    if not math.isfinite(seconds):
        return "-"
    return f"{seconds * 1000:.2f}" if seconds < 1e-3 else f"{seconds * 1000:.1f}"


def ratio(a: float, b: float) -> str:
    return "-" if not (math.isfinite(a) and math.isfinite(b) and b > 0) else f"{a / b:.2f}"


def peak_memory(fn: Callable[[], object]) -> float:
    """Peak traced allocation of ``fn()`` in MiB (a separate run: tracing slows it down)."""
    gc.collect()
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20


def search_peak_mib(start: Pose2D, goal: Any, grid: OccupancyGrid, config: RRTStarConfig, seed: int = 0) -> float:
    """Peak traced MiB of one RRT* search (:func:`peak_memory`)."""
    return peak_memory(partial(attempt, grow_rrt_star, start, goal, grid, config, np.random.default_rng(seed)))
