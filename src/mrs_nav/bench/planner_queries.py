"""First path and length per query against OMPL's best planners (issue 42's targets), and the tiled buildings.

Queries: the course arena (its reference query and two more, one starting with the goal behind), the office world
(its four reference goals and two queries from other rooms) and the cluttered world (three goals). For each, over
the seeds: our RRT* with a 2 s CPU budget (the first path, and the best length at 0.5 s and 2 s), OMPL's R^2
planners (Informed RRT*, RRT-Connect: straight edges, no heading, a relaxed problem) and Dubins planners (RRT*,
Informed RRT*, BIT* at r 0.2 and 0.1 m) to their first path (2 s cap). The buildings: the office tiled 5 x 5
(100 m) and 10 x 10 (200 m), corner to corner, first path within 0.5 s, with the grid's preparation (inflation,
masks, the route's coarse mask and landmarks: once per map) timed apart.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mrs_nav.bench.ompl_peer import OmplPlanner
from mrs_nav.bench.planner_runs import CLOCK, attempt, clearance, fmt_ms, median, p90, ratio
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.occupancy_grid import OccupancyGrid, planning_grid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.wavefront import route_landmarks
from mrs_nav.maps.world import load_world
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.tables import markdown_table
from mrs_nav.trees.rrt import sample_random_position
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.scenarios import OFFICE_GOALS, OFFICE_START, building_grid

#: (label, world file, start, goal)
QUERIES: tuple[tuple[str, str, Pose2D, tuple[float, float]], ...] = (
    ("arena 1", "simple.world", Pose2D(-1.5, -1.5, 0.0), (1.5, 1.5)),
    ("arena 2", "simple.world", Pose2D(1.5, -1.5, math.pi / 2), (-1.5, 1.5)),
    ("arena 3, goal behind", "simple.world", Pose2D(0.0, -1.6, -math.pi / 2), (0.0, 1.6)),
    *((f"office {k + 1}", "office.world", OFFICE_START, goal) for k, goal in enumerate(OFFICE_GOALS)),
    ("office 5", "office.world", Pose2D(8.0, 8.0, math.pi), (-8.0, -8.0)),
    ("office 6", "office.world", Pose2D(0.0, 0.0, math.pi / 2), (8.0, -8.0)),
    ("cluttered 1", "cluttered.world", Pose2D(-3.5, -3.5, 0.0), (3.5, 3.5)),
    ("cluttered 2", "cluttered.world", Pose2D(-3.5, -3.5, 0.0), (3.4, -3.0)),
    ("cluttered 3", "cluttered.world", Pose2D(-3.5, 3.5, 0.0), (3.5, -3.5)),
)
# RRT-Connect: OMPL's quickest first path in R^2 (AORRTC keeps optimising to the end of its budget and reports
# no first path before it).
R2_PEERS = ("InformedRRTstar", "RRTConnect")
DUBINS_PEERS = tuple((name, r) for r in (0.2, 0.1) for name in ("RRTstar", "InformedRRTstar", "BITstar"))
_CAP = 2.0
# The seed of the drawn queries (fixed, so that every run draws the same ones).
DRAWN_SEED = 42


def ours(grid: OccupancyGrid, start: Pose2D, goal: Any, seeds: int, obstacles: Obstacles) -> dict[str, float]:
    """Our RRT* over ``seeds``: medians of the first path (s, from runs that stop there, one after the other as
    OMPL's first paths are timed) and of the best length at 0.5 s and 2 s of a 2 s CPU budget (m, inf when the
    median run had none), runs with a path by 0.5 s, least clearance (m).

    The first path (:func:`first_paths`) is timed apart because a query timed right after a 2 s run starts with
    the processor's caches full of that run (about 0.15 ms against 0.05 ms for the arena's one-arc path)."""
    at_half, at_end, clear = [], [], []
    goal_xy = np.array(goal)
    first = first_paths(grid, start, goal_xy, seeds)
    for seed in range(seeds):
        config = RRTStarConfig(time_budget=_CAP)
        tried = attempt(grow_rrt_star, start, goal_xy, grid, config, np.random.default_rng(seed), clock=CLOCK)
        history = tried.search.history if tried.search is not None else ()
        at_half.append(min((length for _, t, length in history if t <= 0.5), default=math.inf))
        at_end.append(min((length for _, _, length in history), default=math.inf))
        if tried.search is not None:
            clear.append(clearance(tried.search.result.path, obstacles))
    return {
        "first": median(first),
        "half": median(at_half),
        "end": median(at_end),
        "by_half": sum(math.isfinite(v) for v in at_half),
        "clearance": min(clear, default=math.nan),
    }


def first_paths(grid: OccupancyGrid, start: Pose2D, goal: Any, seeds: int) -> list[float]:
    """Our first path (CPU s, inf when none within 0.5 s) for seeds ``0..seeds-1``, runs one after the other."""
    config = RRTStarConfig(time_budget=0.5, stop_at_first=True)
    goal_xy = np.asarray(goal, dtype=np.float64)
    return [
        attempt(grow_rrt_star, start, goal_xy, grid, config, np.random.default_rng(seed), clock=CLOCK).first_s
        for seed in range(seeds)
    ]


def _ompl_first(
    grid: OccupancyGrid, start: Pose2D, goal: Any, seeds: int, *, planner: str, radius: float | None
) -> float:
    ompl = OmplPlanner(grid, start, goal, turning_radius=radius, planner=planner)
    return median([ompl.solve(_CAP, math.inf)[0] for _ in range(seeds)])


def _prepared(world_file: str) -> tuple[OccupancyGrid, Obstacles]:
    """The planning grid of a world with what is paid once per map already paid (as in the buildings' table: the
    lookup masks and the route's landmarks), and the world's exact geometry."""
    world = load_world(WORLDS_DIR / world_file)
    grid = planning_grid(rasterize_world(world, 0.05))
    _ = grid.conservative_free_mask
    route_landmarks(grid, RRTStarConfig().guide_cell)
    return grid, Obstacles.from_world(world)


def query_section(seeds: int) -> str:
    """Markdown: per query, our first path and lengths against the best OMPL R^2 and Dubins first paths."""
    rows: list[list[object]] = []
    loaded: dict[str, tuple[OccupancyGrid, Obstacles]] = {}
    for label, world_file, start, goal in QUERIES:
        if world_file not in loaded:
            loaded[world_file] = _prepared(world_file)
        grid, obstacles = loaded[world_file]
        mine = ours(grid, start, goal, seeds, obstacles)
        r2 = {name: _ompl_first(grid, start, goal, seeds, planner=name, radius=None) for name in R2_PEERS}
        dubins = min(_ompl_first(grid, start, goal, seeds, planner=name, radius=r) for name, r in DUBINS_PEERS)
        best_r2 = min(r2.values())
        rows.append(
            [
                label,
                f"({start.x:g}, {start.y:g}, {math.degrees(start.yaw):.0f} deg) -> ({goal[0]:g}, {goal[1]:g})",
                f"{mine['by_half']}/{seeds}",
                fmt_ms(mine["first"]),
                *(fmt_ms(r2[name]) for name in R2_PEERS),
                fmt_ms(dubins),
                ratio(mine["first"], best_r2),
                ratio(mine["first"], dubins),
                f"{mine['half']:.2f}",
                f"{mine['end']:.2f}",
                f"{mine['clearance']:.3f}",
            ]
        )
    header = [
        "query",
        "start -> goal",
        "path by 0.5 s",
        "first path median [ms]",
        "OMPL R^2 Informed RRT* [ms]",
        "OMPL R^2 RRT-Connect [ms]",
        "best OMPL Dubins [ms]",
        "ours / best R^2",
        "ours / best Dubins",
        "length at 0.5 s [m]",
        "length at 2 s [m]",
        "least clearance [m]",
    ]
    return (
        f"### First path per query\n\n{seeds} seeds per query, CPU time; medians. Ours: RRT* (arcs), the first "
        "path from runs that stop there (0.5 s budget), one after the other as OMPL's are timed, the lengths from "
        f"runs with a {_CAP:g} s budget; OMPL: first path ({_CAP:g} s cap, '-': the median run had none), same "
        "conservative cell test; best Dubins is the least median of RRT*, Informed RRT*, BIT* at r 0.2 and 0.1 m. "
        "Targets: ours / best R^2 <= 1.5 and ours / best Dubins <= 1 on every query. Each map's preparation (lookup "
        "masks, the route's landmarks) is paid before the queries, as in the buildings' table. Least clearance: our "
        f"paths' arcs (every 5 mm) to the exact world geometry, over the seeds; the robot radius {BURGER_RADIUS} m is "
        "the floor."
        f"\n\n{markdown_table(header, rows)}\n"
    )


def drawn_queries(grid: OccupancyGrid, count: int, seed: int) -> list[tuple[Pose2D, FloatArray]]:
    """``count`` queries nobody chose: start and goal uniform over the free space of ``grid`` where OMPL's validity
    test (the conservative mask: a free cell with free neighbours) accepts them too, at least a third of the map's
    width apart, the start's heading uniform."""
    rng = np.random.default_rng(seed)
    apart = grid.width * grid.resolution / 3.0
    out: list[tuple[Pose2D, FloatArray]] = []
    while len(out) < count:
        ends = np.array([sample_random_position(grid, rng), sample_random_position(grid, rng)])
        heading = float(rng.uniform(-math.pi, math.pi))
        if grid.lookup(grid.conservative_free_mask, ends).all() and float(np.hypot(*(ends[1] - ends[0]))) >= apart:
            out.append((Pose2D(float(ends[0, 0]), float(ends[0, 1]), heading), ends[1]))
    return out


def drawn_section(seeds: int, per_world: int = 5) -> str:
    """Markdown: our first path against OMPL's R^2 planners on queries drawn at random in each world."""
    rows: list[list[object]] = []
    met = compared = 0
    for world_file in dict.fromkeys(world for _, world, _, _ in QUERIES):
        grid, _ = _prepared(world_file)
        for k, (start, goal) in enumerate(drawn_queries(grid, per_world, DRAWN_SEED)):
            mine = median(first_paths(grid, start, goal, seeds))
            r2 = {name: _ompl_first(grid, start, goal, seeds, planner=name, radius=None) for name in R2_PEERS}
            best = min(r2.values())
            compared += math.isfinite(best)
            met += math.isfinite(best) and mine <= 1.5 * best
            rows.append(
                [
                    f"{world_file.removesuffix('.world')} {k + 1}",
                    f"({start.x:.2f}, {start.y:.2f}, {math.degrees(start.yaw):.0f} deg) -> "
                    f"({goal[0]:.2f}, {goal[1]:.2f})",
                    fmt_ms(mine),
                    *(fmt_ms(r2[name]) for name in R2_PEERS),
                    ratio(mine, best),
                ]
            )
    header = ["query", "start -> goal", "ours [ms]", *(f"OMPL R^2 {n} [ms]" for n in R2_PEERS), "ours / best R^2"]
    return (
        f"### First path on drawn queries\n\n{per_world} queries per world that nobody chose (start and goal uniform "
        f"over the free space, at least a third of the map's width apart, heading uniform; `drawn_queries`, seed "
        f"{DRAWN_SEED}), {seeds} seeds each, CPU time, medians; first paths timed as in the table above. Ours within "
        f"1.5x OMPL's best R^2 planner on {met} of the {compared} where OMPL found a path within its cap."
        f"\n\n{markdown_table(header, rows)}\n"
    )


def building_section(seeds: int, tiles: tuple[int, ...] = (5, 10)) -> str:
    """Markdown: first path corner to corner in the office tiled ``tiles x tiles``, preparation timed apart."""
    rows: list[list[object]] = []
    for n in tiles:
        t0 = CLOCK()
        raw = building_grid(n)
        grid = planning_grid(raw)
        _ = grid.conservative_free_mask
        inflate_s = CLOCK() - t0
        t0 = CLOCK()
        route_landmarks(grid, RRTStarConfig().guide_cell)
        route_s = CLOCK() - t0
        tile = raw.width // n * raw.resolution
        goal = np.array([5.0 + (n - 1) * tile, 5.0 + (n - 1) * tile])
        first = []
        for seed in range(seeds):
            config = RRTStarConfig(time_budget=0.5, stop_at_first=True)
            tried = attempt(grow_rrt_star, OFFICE_START, goal, grid, config, np.random.default_rng(seed), clock=CLOCK)
            first.append(tried.first_s)
        target = 0.030 if n <= 5 else 0.100
        within = sum(t <= 0.5 for t in first)
        ok = within == seeds and median(first) <= target
        rows.append(
            [
                f"{raw.width * raw.resolution:.0f} m ({n} x {n} offices)",
                f"{raw.width} x {raw.height}",
                f"{inflate_s:.2f}",
                f"{route_s:.2f}",
                f"{within}/{seeds}",
                fmt_ms(median(first)),
                fmt_ms(p90(first)),
                f"<= {target * 1000:.0f} ms, 100 %: {'yes' if ok else 'NO'}",
            ]
        )
    header = [
        "building",
        "cells",
        "inflate + masks [s]",
        "route preparation [s]",
        "path within 0.5 s",
        "first path median [ms]",
        "first path p90 [ms]",
        "target",
    ]
    return (
        "### Buildings\n\nThe office tiled with 1 m doors between tiles (`building_grid`), start (-5, -5, 0) in the "
        f"south-west office, goal in the north-east one; {seeds} seeds, CPU time, `stop_at_first`, 0.5 s budget. "
        "Preparation is paid once per map and not counted in the first path: inflation and lookup masks, then the "
        "route's coarse mask and landmark distances (`mrs_nav.maps.wavefront.route_landmarks`).\n\n"
        f"{markdown_table(header, rows)}\n"
    )
