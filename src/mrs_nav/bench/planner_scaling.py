"""How RRT*'s cost grows with the map (the course arena, a 20 m x 20 m office) and with the iteration count:
first-path time, iteration rate and peak traced memory, in CPU seconds.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mrs_nav.bench.planner_runs import (
    ARENA_GOAL,
    ARENA_START,
    CLOCK,
    OFFICE_GOAL,
    attempt,
    fmt_ms,
    median,
    search_peak_mib,
)
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OCCUPIED, OccupancyGrid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.tables import markdown_table
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.scenarios import OFFICE_START, course_grid


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


def _prepared(raw: OccupancyGrid) -> tuple[OccupancyGrid, float, float]:
    """The inflated grid with its lookup masks built, the seconds that took and the MiB the masks hold."""
    t0 = CLOCK()
    grid = raw.inflate(BURGER_RADIUS)
    held = grid.values.nbytes + grid.free_mask.nbytes + grid.conservative_free_mask.nbytes
    return grid, CLOCK() - t0, held / 2**20


def scaling_section(args: argparse.Namespace) -> str:
    """Markdown: RRT* against the map size (arena, office) and against the iteration count (arena)."""
    office_raw, office_start, office_goal, office_note = _office(args.office)
    arena_raw = course_grid()
    rows = [
        _size_row("arena 4 m", arena_raw, ARENA_START, ARENA_GOAL),
        _size_row("office 20 m", office_raw, office_start, office_goal),
    ]
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
    iter_table = _iteration_table(arena_raw.inflate(BURGER_RADIUS))
    return (
        f"### Scaling with map size\n\nOffice: {office_note}; 10 seeds, 2 s budget.\n\n"
        f"{size_table}\n\n### Scaling with iterations (arena, seed 1)\n\n{iter_table}\n"
    )


def _office(path: Path) -> tuple[OccupancyGrid, Pose2D, FloatArray, str]:
    """The office world at ``path`` rasterised (or :func:`synthetic_office` when it is missing), its start, goal and
    a note saying which."""
    if path.is_file():
        note = f"`{path.name}`, start (-5, -5, 0), goal (5, 5)"
        return rasterize_world(load_world(path), 0.05), OFFICE_START, OFFICE_GOAL, note
    note = (
        "a synthetic 20 m x 20 m grid of 4 x 4 rooms with 1 m doors (office world file not found), "
        "start (-7.5, -7.5, 0), goal (7.5, 7.5)"
    )
    return synthetic_office(), Pose2D(-7.5, -7.5, 0.0), np.array([7.5, 7.5]), note


def _size_row(name: str, raw: OccupancyGrid, start: Pose2D, goal: FloatArray) -> list[object]:
    """RRT* on ``raw`` (inflated here): 10 seeds of 2 s each, and the peak memory of 2000 iterations."""
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
    memory = search_peak_mib(start, goal, grid, RRTStarConfig(iterations=2000, time_budget=None))
    return [
        name,
        f"{grid.width} x {grid.height}",
        fmt_ms(prep_s),
        f"{grid_mib:.2f}",
        f"{found}/10",
        fmt_ms(median(first)),
        f"{median(rate):.0f}",
        f"{memory:.1f}",
    ]


def _iteration_table(arena: OccupancyGrid) -> str:
    """RRT* on the inflated ``arena`` (seed 1) for growing iteration counts: nodes, CPU time, memory, length."""
    rows: list[list[object]] = []
    for count in (500, 1000, 2000, 4000, 8000):
        config = RRTStarConfig(iterations=count, time_budget=None)
        t0 = CLOCK()
        tried = attempt(grow_rrt_star, ARENA_START, ARENA_GOAL, arena, config, np.random.default_rng(1))
        spent = CLOCK() - t0
        memory = search_peak_mib(ARENA_START, ARENA_GOAL, arena, config, seed=1)
        rows.append(
            [
                count,
                tried.nodes,
                f"{spent:.3f}",
                f"{spent / count * 1e6:.0f}",
                f"{memory:.1f}",
                f"{tried.length:.3f}",
            ]
        )
    return markdown_table(["iterations", "nodes", "CPU time [s]", "CPU us / iteration", "peak MiB", "length [m]"], rows)
