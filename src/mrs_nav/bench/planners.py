"""RRT and RRT* (arc edges) on the course arena against OMPL's RRT*, and how their cost grows with map and tree size.

The problem: ``worlds/simple.world`` rasterised at 0.05 m (the shipped ``maps/simple.yaml``), inflated by the
Burger's 0.105 m, start (-1.5, -1.5, 0), goal (1.5, 1.5). For each seed: our RRT* for a time budget (first
solution time, length at the end of the budget, time until the path is at most the target length), our RRT
(first and only path) and OMPL's RRT* (PyPI ``ompl``) on the same grid with the same collision test (a state is
valid when its cell is free in the same conservative mask our arc checks read; motions checked every 0.05 m).
OMPL plans in R^2 with straight edges, a relaxation of our problem (no heading, no arcs), so its lengths can be
shorter than any arc path. Scaling: first-solution time, iteration rate and peak memory (tracemalloc) on the
arena and on a 20 m x 20 m office, and RRT* time and memory against the iteration count.
"""

from __future__ import annotations

import argparse
import gc
import math
import statistics
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid, planning_grid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.options import budget_option, length_option, runs_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.tables import markdown_table
from mrs_nav.trees import arcs
from mrs_nav.trees.rrt import RRTConfig, grow_rrt
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.scenarios import COURSE_GOAL, COURSE_START, OFFICE_GOALS, OFFICE_START, building_grid, course_grid
from mrs_nav.trees.tree import NoPathInTreeError, Search

ARENA_START = COURSE_START
ARENA_GOAL = COURSE_GOAL
#: Every time and budget here is CPU time of this process: the machines are shared, and wall time would measure
#: the other jobs as much as the planners.
CLOCK = time.process_time
OFFICE_GOAL = np.array(OFFICE_GOALS[0])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seeds", type=runs_option, default=50, help="seeds per planner (default 50)")
    parser.add_argument("--budget", type=budget_option, default=0.5, help="RRT* time budget in seconds (default 0.5)")
    parser.add_argument("--target", type=length_option, default=4.44, help="length target in metres (default 4.44)")
    parser.add_argument("--no-ompl", action="store_true", help="skip the OMPL comparison")
    parser.add_argument("--no-scaling", action="store_true", help="skip the map-size and iteration scaling")
    parser.add_argument("--no-building", action="store_true", help="skip the 100 m building")
    parser.add_argument(
        "--first-seeds", type=runs_option, default=30, help="seeds of the first-path table (default 30)"
    )
    parser.add_argument("--compare-seeds", type=runs_option, default=3, help="seeds per world against OMPL (default 3)")
    parser.add_argument("--building-seeds", type=runs_option, default=20, help="seeds in the building (default 20)")
    parser.add_argument(
        "--office",
        type=Path,
        default=WORLDS_DIR / "office.world",
        help="20 m x 20 m world for the scaling runs (a synthetic grid is used when missing)",
    )


def synthetic_office(resolution: float = 0.05) -> OccupancyGrid:
    """A 20 m x 20 m stand-in: outer walls and a 4 x 4 grid of rooms with 1 m doorways (deterministic)."""
    n = round(20.0 / resolution)
    values = np.zeros((n, n), dtype=np.int8)
    wall = max(1, round(0.15 / resolution))
    values[:wall, :] = values[-wall:, :] = values[:, :wall] = values[:, -wall:] = OCCUPIED
    door = round(1.0 / resolution)
    for k in range(1, 4):
        c = k * n // 4
        values[:, c : c + wall] = OCCUPIED
        values[c : c + wall, :] = OCCUPIED
        for m in range(4):
            mid = m * n // 4 + n // 8
            values[mid : mid + door, c : c + wall] = 0
            values[c : c + wall, mid : mid + door] = 0
    return OccupancyGrid(values, resolution, (-10.0, -10.0, 0.0))


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


class OmplPlanner:
    """An OMPL planner on ``grid``: validity = the cell of the state is free in the conservative mask.

    ``turning_radius`` None plans in R^2 with straight edges; a radius plans in OMPL's Dubins space (forward
    arcs and lines of at least that radius; the goal is the state at ``goal`` heading along start -> goal,
    within 0.05 of OMPL's SE(2) distance, since OMPL needs a goal state where ours leaves the final yaw free).
    ``planner`` names an ``ompl.geometric`` class (RRTstar, InformedRRTstar, BITstar).
    """

    def __init__(
        self, grid: OccupancyGrid, start: Pose2D, goal: Any, *, turning_radius: float | None = None, planner: str
    ) -> None:
        from ompl import base as ob  # noqa: PLC0415 - optional peer, imported only when benchmarking against it
        from ompl import geometric as og  # noqa: PLC0415
        from ompl import util as ou  # noqa: PLC0415

        ou.setLogLevel(ou.LogLevel.LOG_NONE)
        self.ob, self.planner = ob, getattr(og, planner)
        dubins = turning_radius is not None
        space = ob.DubinsStateSpace(turning_radius) if dubins else ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        x0, y0, x1, y1 = grid.extent
        bounds.setLow(0, x0)
        bounds.setLow(1, y0)
        bounds.setHigh(0, x1)
        bounds.setHigh(1, y1)
        space.setBounds(bounds)
        self.setup = og.SimpleSetup(space)
        free = grid.conservative_free_mask.ravel().tolist()
        width, height, inv = grid.width, grid.height, 1.0 / grid.resolution

        def valid(state: Any) -> bool:
            # The same lookup as OccupancyGrid.lookup, scalar: OMPL calls back one state at a time.
            x, y = (state.getX(), state.getY()) if dubins else (state[0], state[1])
            col = math.floor((x - x0) * inv)
            row = math.floor((y - y0) * inv)
            return 0 <= col < width and 0 <= row < height and bool(free[row * width + col])

        self.setup.setStateValidityChecker(valid)
        si = self.setup.getSpaceInformation()
        si.setStateValidityCheckingResolution(grid.resolution / space.getMaximumExtent())
        s, g = space.allocState(), space.allocState()
        if dubins:
            s.setX(start.x)
            s.setY(start.y)
            s.setYaw(start.yaw)
            g.setX(float(goal[0]))
            g.setY(float(goal[1]))
            g.setYaw(math.atan2(float(goal[1]) - start.y, float(goal[0]) - start.x))
        else:
            s[0], s[1], g[0], g[1] = start.x, start.y, float(goal[0]), float(goal[1])
        self.setup.setStartAndGoalStates(s, g, 0.05 if dubins else 0.01)
        self.objective = ob.PathLengthOptimizationObjective(si)
        self.setup.setOptimizationObjective(self.objective)
        self.si = si
        # A start or goal state that fails the cell test: OMPL's planners then wait (BIT* sleeps in nextGoal) for
        # a valid goal until the condition ends, which a CPU-time condition never does. Such a query has no path.
        self.solvable = bool(si.isValid(s) and si.isValid(g))

    def solve(self, seconds: float, threshold: float) -> tuple[float, float]:
        """Plan until a path of at most ``threshold`` m or ``seconds`` of CPU; (CPU seconds, length or inf)."""
        if not self.solvable:
            return math.inf, math.inf
        self.setup.clear()
        self.objective.setCostThreshold(self.ob.Cost(threshold))
        self.setup.setPlanner(self.planner(self.si))
        t0 = CLOCK()
        end = t0 + seconds
        # The budget in CPU seconds too, like ours: OMPL polls this condition between iterations.
        condition = self.ob.PlannerTerminationCondition(lambda: CLOCK() > end)
        self.setup.solve(condition)
        elapsed = CLOCK() - t0
        del condition
        if not self.setup.haveExactSolutionPath():
            return math.inf, math.inf
        return elapsed, float(self.setup.getSolutionPath().length())


def _median(values: list[float]) -> float:
    return statistics.median(values) if values else math.nan


def _p90(values: list[float]) -> float:
    return float(np.percentile(values, 90)) if values else math.nan


def _fmt_ms(seconds: float) -> str:
    return "-" if not math.isfinite(seconds) else f"{seconds * 1000:.1f}"


def _ratio(a: float, b: float) -> str:
    return "-" if not (math.isfinite(a) and math.isfinite(b) and b > 0) else f"{a / b:.2f}"


def _arena_section(args: argparse.Namespace, grid: OccupancyGrid) -> str:
    seeds = range(args.seeds)
    star = [run_rrt_star(grid, ARENA_START, ARENA_GOAL, budget=args.budget, target=args.target, seed=s) for s in seeds]
    plain = [run_rrt(grid, ARENA_START, ARENA_GOAL, s) for s in seeds]
    rows: list[list[object]] = []
    lines: list[str] = []

    def row(name: str, runs: list[Run], length_note: str) -> None:
        ok = [r for r in runs if r.success]
        rows.append(
            [
                name,
                f"{len(ok)}/{len(runs)}",
                _fmt_ms(_median([r.first_s for r in ok])),
                _fmt_ms(_p90([r.first_s for r in ok])),
                f"{_median([r.length for r in ok]):.3f}{length_note}",
                f"{max((r.length for r in ok), default=math.nan):.3f}",
                _fmt_ms(_median([r.to_target_s for r in runs])),
                f"{_median([float(r.iterations) for r in runs]):.0f}",
            ]
        )

    row("mrs_nav RRT* (arcs)", star, f" after {args.budget:g} s")
    row("mrs_nav RRT (arcs)", plain, " (first path)")
    ompl_first: list[float] = []
    ompl_target: list[float] = []
    if not args.no_ompl:
        ompl = OmplPlanner(grid, ARENA_START, ARENA_GOAL, planner="RRTstar")
        runs = []
        for _ in seeds:
            first_s, _first_len = ompl.solve(5.0, math.inf)
            _, length = ompl.solve(args.budget, 0.0)
            target_s, _ = ompl.solve(5.0, args.target)
            runs.append(Run(math.isfinite(first_s), first_s, length, target_s, 0))
            ompl_first.append(first_s)
            ompl_target.append(target_s)
        row("OMPL RRT* (R^2, straight edges)", runs, f" after {args.budget:g} s")
        rows[-1][-1] = "-"
    header = [
        "planner",
        "success",
        "first path median [ms]",
        "first path p90 [ms]",
        "length median [m]",
        "length max [m]",
        f"time to <= {args.target:g} m median [ms]",
        "iterations",
    ]
    ours_first = _median([r.first_s for r in star])
    ours_target = _median([r.to_target_s for r in star])
    lines.append(
        f"Ratios (median time; > 1 means mrs_nav RRT* is faster): RRT first path / RRT* first path "
        f"{_ratio(_median([r.first_s for r in plain]), ours_first)}; RRT length / RRT* length "
        f"{_ratio(_median([r.length for r in plain]), _median([r.length for r in star]))}"
    )
    if ompl_first:
        lines.append(
            f"; OMPL RRT* first path / ours {_ratio(_median(ompl_first), ours_first)}; "
            f"OMPL RRT* time to <= {args.target:g} m / ours {_ratio(_median(ompl_target), ours_target)}."
        )
    verdict = _verdict(star, args)
    return markdown_table(header, rows) + "\n\n" + "".join(lines) + "\n\n" + verdict


def _verdict(star: list[Run], args: argparse.Namespace) -> str:
    success = sum(r.success for r in star) == len(star)
    first = _median([r.first_s for r in star])
    length = _median([r.length for r in star])
    checks = [
        f"success 100%: {'yes' if success else 'NO'}",
        f"first path median <= 20 ms: {'yes' if first <= 0.020 else 'NO'} ({first * 1000:.1f} ms)",
        f"length median <= {args.target:g} m after {args.budget:g} s: {'yes' if length <= args.target else 'NO'} "
        f"({length:.3f} m)",
    ]
    return "Targets: " + "; ".join(checks) + "."


def _peak_memory(fn: Callable[[], object]) -> float:
    """Peak traced allocation of ``fn()`` in MiB (a separate run: tracing slows it down)."""
    gc.collect()
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20


def _prepared(raw: OccupancyGrid) -> tuple[OccupancyGrid, float, float]:
    """The inflated grid with its lookup masks built, the seconds that took and the MiB the masks hold."""
    t0 = CLOCK()
    grid = raw.inflate(BURGER_RADIUS)
    held = grid.values.nbytes + grid.free_mask.nbytes + grid.conservative_free_mask.nbytes
    return grid, CLOCK() - t0, held / 2**20


def _scaling_section(args: argparse.Namespace) -> str:
    office_start, office_goal = OFFICE_START, OFFICE_GOAL
    office_note = f"`{args.office.name}`, start (-5, -5, 0), goal (5, 5)"
    if args.office.is_file():
        office_raw = rasterize_world(load_world(args.office), 0.05)
    else:
        office_raw = synthetic_office()
        office_start, office_goal = Pose2D(-7.5, -7.5, 0.0), np.array([7.5, 7.5])
        office_note = (
            "a synthetic 20 m x 20 m grid of 4 x 4 rooms with 1 m doors (office world file not found), "
            "start (-7.5, -7.5, 0), goal (7.5, 7.5)"
        )
    cases = [
        ("arena 4 m", course_grid(), ARENA_START, ARENA_GOAL),
        ("office 20 m", office_raw, office_start, office_goal),
    ]
    rows: list[list[object]] = []
    for name, raw, start, goal in cases:
        grid, prep_s, grid_mib = _prepared(raw)
        first, rate, found = [], [], 0
        for seed in range(10):
            t0 = CLOCK()
            tried = attempt(
                grow_rrt_star,
                start,
                goal,
                grid,
                RRTStarConfig(iterations=None, time_budget=2.0),
                np.random.default_rng(seed),
                clock=CLOCK,
            )
            spent = CLOCK() - t0
            found += tried.search is not None
            first.append(tried.first_s)
            rate.append(tried.iterations / spent)
        memory = _peak_memory(
            partial(
                attempt,
                grow_rrt_star,
                start,
                goal,
                grid,
                RRTStarConfig(iterations=2000, time_budget=None),
                np.random.default_rng(0),
            )
        )
        rows.append(
            [
                name,
                f"{grid.width} x {grid.height}",
                _fmt_ms(prep_s),
                f"{grid_mib:.2f}",
                f"{found}/10",
                _fmt_ms(_median(first)),
                f"{_median(rate):.0f}",
                f"{memory:.1f}",
            ]
        )
    size_table = markdown_table(
        [
            "map",
            "cells",
            "inflate + masks [ms]",
            "grid MiB",
            "RRT* success in 2 s",
            "first path median [ms]",
            "iterations / s",
            "search peak MiB (2000 it.)",
        ],
        rows,
    )
    arena = cases[0][1].inflate(BURGER_RADIUS)
    iter_rows: list[list[object]] = []
    for count in (500, 1000, 2000, 4000, 8000):
        config = RRTStarConfig(iterations=count, time_budget=None)
        t0 = CLOCK()
        tried = attempt(grow_rrt_star, ARENA_START, ARENA_GOAL, arena, config, np.random.default_rng(1))
        spent = CLOCK() - t0
        memory = _peak_memory(
            partial(attempt, grow_rrt_star, ARENA_START, ARENA_GOAL, arena, config, np.random.default_rng(1))
        )
        iter_rows.append(
            [
                count,
                tried.nodes,
                f"{spent:.3f}",
                f"{spent / count * 1e6:.0f}",
                f"{memory:.1f}",
                f"{tried.length:.3f}",
            ]
        )
    iter_table = markdown_table(
        ["iterations", "nodes", "CPU time [s]", "CPU us / iteration", "peak MiB", "length [m]"], iter_rows
    )
    return (
        f"### Scaling with map size\n\nOffice: {office_note}; 10 seeds, 2 s budget.\n\n"
        f"{size_table}\n\n### Scaling with iterations (arena, seed 1)\n\n{iter_table}\n"
    )


#: OMPL planners side by side: (label, ompl.geometric class, Dubins turning radius or None for R^2).
OMPL_PEERS = (
    ("Dubins RRT* r 0.2", "RRTstar", 0.2),
    ("Dubins Informed RRT* r 0.2", "InformedRRTstar", 0.2),
    ("Dubins BIT* r 0.2", "BITstar", 0.2),
    ("Dubins RRT* r 0.1", "RRTstar", 0.1),
    ("Dubins Informed RRT* r 0.1", "InformedRRTstar", 0.1),
    ("Dubins BIT* r 0.1", "BITstar", 0.1),
    ("R^2 Informed RRT*", "InformedRRTstar", None),
)
BUDGETS = (0.05, 0.2, 0.5, 2.0)
CLUTTERED_START = Pose2D(-3.5, -3.5, 0.0)
# every goal free in the conservative cell mask, so that OMPL (which checks its goal state) can take each one
CLUTTERED_GOALS = ((3.5, 3.5), (3.4, -3.0), (-3.0, 3.5))


def _worlds() -> list[tuple[str, str, Pose2D, tuple[tuple[float, float], ...]]]:
    return [
        ("arena", "simple.world", ARENA_START, ((float(ARENA_GOAL[0]), float(ARENA_GOAL[1])),)),
        ("office", "office.world", OFFICE_START, OFFICE_GOALS),
        ("cluttered", "cluttered.world", CLUTTERED_START, CLUTTERED_GOALS),
    ]


def _length_at(history: tuple[tuple[int, float, float], ...], budget: float) -> float:
    return min((length for _, t, length in history if t <= budget), default=math.inf)


def _clearance(path: Any, obstacles: Obstacles) -> float:
    """Least distance (m) from the arcs of ``path`` (sampled every 5 mm) to the exact world geometry."""
    pieces = arcs.connect(path[:-1, :2], path[:-1, 2], path[1:, :2])
    dense, _ = arcs.sample(pieces, 0.005, with_yaw=False)
    return float(obstacles.signed_distance(dense[:, :2]).min())


def _first_paths(grid: OccupancyGrid, start: Pose2D, goals: Any, seeds: int, budget: float) -> list[float]:
    """First-path CPU times (inf = none within ``budget``) of our RRT* over ``seeds``, goals in turn."""
    out = []
    for seed in range(seeds):
        config = RRTStarConfig(time_budget=budget, stop_at_first=True)
        goal = np.array(goals[seed % len(goals)])
        tried = attempt(grow_rrt_star, start, goal, grid, config, np.random.default_rng(seed), clock=CLOCK)
        out.append(tried.search.result.first_solution_s if tried.search is not None else math.inf)
    return out


def _first_path_section(args: argparse.Namespace) -> str:
    rows: list[list[object]] = []
    for name, world, start, goals in _worlds():
        grid = planning_grid(rasterize_world(load_world(WORLDS_DIR / world), 0.05))
        first = _first_paths(grid, start, goals, args.first_seeds, 0.3)
        found = [t for t in first if math.isfinite(t)]
        ok = len(found) == len(first) and _median(first) <= 0.020 and _p90(first) <= 0.060
        rows.append(
            [name, f"{len(found)}/{len(first)}", _fmt_ms(_median(first)), _fmt_ms(_p90(first)), "yes" if ok else "NO"]
        )
    table = markdown_table(
        ["world", "path within 0.3 s", "first path median [ms]", "first path p90 [ms]", "<= 20 / 60 ms, 100 %"], rows
    )
    return (
        f"### First path, mrs_nav RRT* (arcs, corridor-guided)\n\n{args.first_seeds} seeds, goals in turn; CPU time "
        f"(`stop_at_first`, 0.3 s budget).\n\n{table}\n"
    )


def _comparison_row(
    rows: list[list[object]], label: str, by_budget: list[list[float]], first: list[float]
) -> list[float]:
    """Append a table row; return the median lengths at each budget and the median first-path time."""
    medians = [_median([run[k] for run in by_budget]) for k in range(len(BUDGETS))]
    done = sum(math.isfinite(run[-1]) for run in by_budget)
    rows.append([label, f"{done}/{len(by_budget)}", _fmt_ms(_median(first)), *(f"{m:.2f}" for m in medians)])
    return [*medians, _median(first)]


def _comparison_section(args: argparse.Namespace) -> str:
    parts = []
    for name, world_file, start, goals in _worlds():
        world = load_world(WORLDS_DIR / world_file)
        grid = planning_grid(rasterize_world(world, 0.05))
        obstacles = Obstacles.from_world(world)
        seeds = range(args.compare_seeds)
        lengths: dict[str, list[list[float]]] = {}
        firsts: dict[str, list[float]] = {}
        ours_l, ours_f, clear = [], [], []
        for seed in seeds:
            goal = np.array(goals[seed % len(goals)])
            config = RRTStarConfig(time_budget=BUDGETS[-1])
            tried = attempt(grow_rrt_star, start, goal, grid, config, np.random.default_rng(seed), clock=CLOCK)
            ours_l.append([_length_at(tried.search.history if tried.search else (), b) for b in BUDGETS])
            ours_f.append(tried.first_s)
            if tried.search is not None:
                clear.append(_clearance(tried.search.result.path, obstacles))
            for label, planner, radius in OMPL_PEERS:
                ompl = OmplPlanner(grid, start, goal, turning_radius=radius, planner=planner)
                firsts.setdefault(label, []).append(ompl.solve(BUDGETS[-1], math.inf)[0])
                lengths.setdefault(label, []).append([ompl.solve(b, 0.0)[1] for b in BUDGETS])
        rows: list[list[object]] = []

        ours = _comparison_row(rows, "mrs_nav RRT* (arcs)", ours_l, ours_f)
        peers = {label: _comparison_row(rows, label, lengths[label], firsts[label]) for label, _, _ in OMPL_PEERS}
        dubins = [v for label, v in peers.items() if label.startswith("Dubins")]
        best_d = [min(v[k] for v in dubins) for k in range(len(BUDGETS) + 1)]
        rows.append(
            [
                "ratio mrs_nav / best OMPL Dubins",
                "",
                _ratio(ours[-1], best_d[-1]),
                *(_ratio(ours[k], best_d[k]) for k in range(len(BUDGETS))),
            ]
        )
        table = markdown_table(
            ["planner", "path at 2 s", "first path median [ms]", *(f"length at {b:g} s [m]" for b in BUDGETS)], rows
        )
        parts.append(
            f"#### {name}\n\n{table}\n\nmrs_nav least clearance to the exact world geometry over the runs: "
            f"{min(clear, default=math.nan):.4f} m (robot radius {BURGER_RADIUS} m).\n"
        )
    return (
        f"### Side by side with OMPL\n\n{args.compare_seeds} seeds per world (goals in turn), CPU time; lengths are "
        "medians of the best path at each budget ('inf': the median run had none); OMPL's length is its own "
        "(Dubins curves / straight lines), ours the arcs sampled every cell. OMPL plans with the same conservative "
        "cell test; the Dubins goal is a state (heading start -> goal, threshold 0.05), ours a position.\n\n"
        + "\n".join(parts)
    )


def _building_section(args: argparse.Namespace) -> str:
    t0 = CLOCK()
    raw = building_grid()
    grid = planning_grid(raw)
    _ = grid.conservative_free_mask
    prep = CLOCK() - t0
    size = raw.width * raw.resolution
    tile = raw.width // 5 * raw.resolution
    goal = np.array([5.0 + 4 * tile, 5.0 + 4 * tile])
    first = []
    for seed in range(args.building_seeds):
        config = RRTStarConfig(time_budget=1.0, stop_at_first=True)
        tried = attempt(grow_rrt_star, OFFICE_START, goal, grid, config, np.random.default_rng(seed), clock=CLOCK)
        first.append(tried.search.result.first_solution_s if tried.search is not None else math.inf)
    memory = _peak_memory(
        partial(
            attempt,
            grow_rrt_star,
            OFFICE_START,
            goal,
            grid,
            RRTStarConfig(time_budget=1.0, stop_at_first=True),
            np.random.default_rng(0),
        )
    )
    within = sum(t <= 1.0 for t in first)
    held = (grid.values.nbytes + grid.free_mask.nbytes + grid.conservative_free_mask.nbytes) / 2**20
    return (
        f"### Building\n\nThe office tiled 5 x 5 with 1 m doors between tiles ({size:.0f} m square, "
        f"{raw.width} x {raw.height} cells at {raw.resolution} m), start (-5, -5, 0) in the south-west office, goal "
        f"({goal[0]:.1f}, {goal[1]:.1f}) in the north-east one. First path within 1 s (CPU): {within}/{len(first)} "
        f"seeds (target >= 95 %); median {_fmt_ms(_median(first))} ms, p90 {_fmt_ms(_p90(first))} ms. Grid "
        f"preparation (inflate + masks) {prep:.2f} s, {held:.0f} MiB; search peak traced memory {memory:.1f} MiB "
        "(the wavefront graph is built on the first query and kept with the grid).\n"
    )


def run(args: argparse.Namespace) -> str:
    arena = course_grid().inflate(BURGER_RADIUS)
    arena_text = _arena_section(args, arena)
    parts = [
        f"Course arena, start (-1.5, -1.5, 0), goal (1.5, 1.5), robot radius {BURGER_RADIUS} m, "
        f"{args.seeds} seeds (0..{args.seeds - 1}); RRT* budget {args.budget:g} s. All times and budgets are CPU "
        "time of the benchmark process (time.process_time), so other jobs on the machine do not inflate them. "
        "OMPL plans in R^2 with straight edges (no heading constraint: a relaxed problem) with the same "
        "cell-validity test, called back from C++ per state. Time-to-target is the first improvement at or "
        "below the target within the budget (OMPL: cost threshold, 5 s cap); '-' = not reached by the median run.",
        arena_text,
    ]
    parts.append(_first_path_section(args))
    if not args.no_ompl:
        parts.append(_comparison_section(args))
    if not args.no_building:
        parts.append(_building_section(args))
    if not args.no_scaling:
        parts.append(_scaling_section(args))
    return "\n\n".join(parts)
