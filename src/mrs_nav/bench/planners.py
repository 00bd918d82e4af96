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
import math
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.bench.ompl_peer import OmplPlanner
from mrs_nav.bench.planner_queries import building_section, drawn_section, query_section
from mrs_nav.bench.planner_runs import (
    ARENA_GOAL,
    ARENA_START,
    CLOCK,
    Run,
    attempt,
    clearance,
    fmt_ms,
    median,
    p90,
    ratio,
    run_rrt,
    run_rrt_star,
)
from mrs_nav.bench.planner_scaling import scaling_section
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.options import budget_option, length_option, runs_option
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.tables import markdown_table
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.scenarios import OFFICE_GOALS, OFFICE_START, course_grid


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seeds", type=runs_option, default=50, help="seeds per planner (default 50)")
    parser.add_argument("--budget", type=budget_option, default=0.5, help="RRT* time budget in seconds (default 0.5)")
    parser.add_argument("--target", type=length_option, default=4.44, help="length target in metres (default 4.44)")
    parser.add_argument("--no-ompl", action="store_true", help="skip the OMPL comparison")
    parser.add_argument("--no-scaling", action="store_true", help="skip the map-size and iteration scaling")
    parser.add_argument("--no-building", action="store_true", help="skip the 100 m and 200 m buildings")
    parser.add_argument("--no-queries", action="store_true", help="skip the first path per query against OMPL")
    parser.add_argument("--query-seeds", type=runs_option, default=10, help="seeds per query (default 10)")
    parser.add_argument(
        "--first-seeds", type=runs_option, default=30, help="seeds of the first-path table (default 30)"
    )
    parser.add_argument("--compare-seeds", type=runs_option, default=3, help="seeds per world against OMPL (default 3)")
    parser.add_argument("--building-seeds", type=runs_option, default=10, help="seeds per building (default 10)")
    parser.add_argument(
        "--office",
        type=Path,
        default=WORLDS_DIR / "office.world",
        help="20 m x 20 m world for the scaling runs (a synthetic grid is used when missing)",
    )


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
                fmt_ms(median([r.first_s for r in ok])),
                fmt_ms(p90([r.first_s for r in ok])),
                f"{median([r.length for r in ok]):.3f}{length_note}",
                f"{max((r.length for r in ok), default=math.nan):.3f}",
                fmt_ms(median([r.to_target_s for r in runs])),
                f"{median([float(r.iterations) for r in runs]):.0f}",
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
    ours_first = median([r.first_s for r in star])
    ours_target = median([r.to_target_s for r in star])
    lines.append(
        f"Ratios (median time; > 1 means mrs_nav RRT* is faster): RRT first path / RRT* first path "
        f"{ratio(median([r.first_s for r in plain]), ours_first)}; RRT length / RRT* length "
        f"{ratio(median([r.length for r in plain]), median([r.length for r in star]))}"
    )
    if ompl_first:
        lines.append(
            f"; OMPL RRT* first path / ours {ratio(median(ompl_first), ours_first)}; "
            f"OMPL RRT* time to <= {args.target:g} m / ours {ratio(median(ompl_target), ours_target)}."
        )
    verdict = _verdict(star, args)
    return markdown_table(header, rows) + "\n\n" + "".join(lines) + "\n\n" + verdict


def _verdict(star: list[Run], args: argparse.Namespace) -> str:
    success = sum(r.success for r in star) == len(star)
    first = median([r.first_s for r in star])
    length = median([r.length for r in star])
    checks = [
        f"success 100%: {'yes' if success else 'NO'}",
        f"first path median <= 20 ms: {'yes' if first <= 0.020 else 'NO'} ({first * 1000:.1f} ms)",
        f"length median <= {args.target:g} m after {args.budget:g} s: {'yes' if length <= args.target else 'NO'} "
        f"({length:.3f} m)",
    ]
    return "Targets: " + "; ".join(checks) + "."


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
        ok = len(found) == len(first) and median(first) <= 0.020 and p90(first) <= 0.060
        rows.append(
            [name, f"{len(found)}/{len(first)}", fmt_ms(median(first)), fmt_ms(p90(first)), "yes" if ok else "NO"]
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
    medians = [median([run[k] for run in by_budget]) for k in range(len(BUDGETS))]
    done = sum(math.isfinite(run[-1]) for run in by_budget)
    rows.append([label, f"{done}/{len(by_budget)}", fmt_ms(median(first)), *(f"{m:.2f}" for m in medians)])
    return [*medians, median(first)]


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
                clear.append(clearance(tried.search.result.path, obstacles))
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
                ratio(ours[-1], best_d[-1]),
                *(ratio(ours[k], best_d[k]) for k in range(len(BUDGETS))),
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
    if not args.no_queries:
        parts.append(query_section(args.query_seeds))
        parts.append(drawn_section(args.query_seeds))
    if not args.no_building:
        parts.append(building_section(args.building_seeds))
    if not args.no_scaling:
        parts.append(scaling_section(args))
    return "\n\n".join(parts)
