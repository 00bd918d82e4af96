"""Whole stack (simulator + SLAM + RRT* navigation) headless at max rate, over seeds, in the arena and the office.

Each run is :class:`mrs_nav.stack.demo.Demo` with one goal: the robot starts with no map, SLAM maps on the way and
the navigator plans through unknown space. A run succeeds when the navigator reports the goal reached, the
true pose is within 0.2 m of the goal and the robot never touched anything. Reported per world: success rate,
time to goal (sim s), distance travelled against the shortest collision-free path (the true map inflated by the
robot radius, Dijkstra on its cells then shortcut by line of sight), cross-track RMS (true position to the path
being followed), the SLAM pose error and the real-time factor of the whole stack.

Then (unless ``--ros-runs 0``) the same goals through the real ROS stack: a roscore on a free port,
``roslaunch mrs_nav rrt_navigation.launch real_time_factor:=0 lockstep:=true`` (simulator, SLAM, RRT*
navigation as separate processes) and :mod:`mrs_nav.ros.navigation_bench_peer` sending the goal; reported are
the outcome and the real-time factor achieved from the goal to its outcome.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from tqdm import tqdm

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import World, load_world
from mrs_nav.navigation.navigator import cell_centres, densify
from mrs_nav.planning import path_length
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.ros_processes import RosProcessError, process, read_clock, roscore, roslaunch_command
from mrs_nav.stack.demo import Demo, DemoConfig
from mrs_nav.tables import markdown_table

ROS_TARGET_RTF = 5.0  # the whole ROS stack at max rate, sim s per wall s (issue 6)


@dataclass(frozen=True)
class Scenario:
    world: str
    start: Pose2D
    goal: tuple[float, float]


SCENARIOS = {
    "arena": Scenario("simple.world", Pose2D(-1.5, -1.5, 0.0), (1.5, 1.5)),
    # from the corridor into the east core room, through its door on the corridor
    "office": Scenario("office.world", Pose2D(-5.0, -5.0, 0.0), (2.0, -2.0)),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seeds", type=int, default=20, help="runs per world (default 20)")
    parser.add_argument("--worlds", default="arena,office", help="comma-separated: " + ", ".join(SCENARIOS))
    parser.add_argument("--time-budget", type=float, default=0.25, help="planner budget per plan, wall s")
    parser.add_argument(
        "--ros-runs", type=int, default=3, help="runs per world through the ROS stack in lockstep (0 = none)"
    )


def ros_run(scenario: Scenario, seed: int) -> dict[str, float]:
    """One goal through ``rrt_navigation.launch`` at max rate in lockstep; the peer's JSON result."""
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_") as tmp:
        log_dir = Path(tmp)
        with roscore(log_dir) as env:
            launch = roslaunch_command(
                "rrt_navigation.launch",
                WORLDS_DIR / scenario.world,
                scenario.start,
                "real_time_factor:=0",
                "lockstep:=true",
                "rviz:=false",
                f"seed:={seed}",
            )
            out = log_dir / "result.json"
            peer = [sys.executable, "-m", "mrs_nav.ros.navigation_bench_peer", "--out", str(out), "--goal"]
            peer += [str(v) for v in scenario.goal]
            with process(launch, env, log_dir / "launch.log") as proc:
                read_clock(env, timeout=60.0)  # the launch is up and /use_sim_time set before the peer starts
                done = subprocess.run(peer, env=env, capture_output=True, text=True, timeout=600, check=False)
                if done.returncode != 0 or not out.is_file():
                    log = (log_dir / "launch.log").read_text()[-500:]
                    raise RosProcessError(f"navigation bench peer failed: {done.stderr.strip()[-300:]} {log}")
                if proc.poll() is not None:
                    raise RosProcessError(f"roslaunch exited early: {(log_dir / 'launch.log').read_text()[-500:]}")
            result: dict[str, float] = json.loads(out.read_text())
    return result


def ros_section(names: list[str], runs: int) -> str:
    """Markdown: the ROS stack in lockstep at max rate, ``runs`` goals per world."""
    rows, factors = [], []
    for name in names:
        scenario = SCENARIOS[name]
        results = [ros_run(scenario, seed) for seed in range(runs)]
        factors += [r["sim_s"] / r["wall_s"] for r in results]
        ok = [r for r in results if r["reached"] and r["final_error_m"] <= 0.2 and r["contacts"] == 0]
        rows.append(
            [
                name,
                runs,
                f"{len(ok)}/{runs}",
                sum(int(r["contacts"]) for r in results),
                _median([r["sim_s"] for r in ok]),
                _median([r["wall_s"] for r in ok]),
                _median([r["sim_s"] / r["wall_s"] for r in results]),
                min(r["sim_s"] / r["wall_s"] for r in results),
            ]
        )
    header = [
        "world",
        "runs",
        "success",
        "contacts",
        "time to goal median (sim s)",
        "(wall s)",
        "real-time factor median",
        "min",
    ]
    return (
        "The ROS stack at maximum rate in lockstep (`rrt_navigation.launch real_time_factor:=0 lockstep:=true`: "
        "simulator, SLAM and RRT* navigation nodes as separate processes, own roscore, seeds 0..; the simulator "
        "never more than 0.1 s of sim time past the last /cmd_vel). Real-time factor from sending the goal to "
        f"its outcome, while other jobs shared the two cores. Target >= {ROS_TARGET_RTF:.0f}x real time "
        f"(median): **{'meets' if statistics.median(factors) >= ROS_TARGET_RTF else 'MISSES'}**.\n\n"
        + markdown_table(header, rows)
    )


def shortest_path_length(
    world: World, start: Pose2D, goal: tuple[float, float], radius: float = BURGER_RADIUS
) -> float:
    """Length (m) of a near-shortest collision-free path for a disc of ``radius`` (8-connected Dijkstra on a
    0.05 m rasterisation, then shortcut by line of sight: within a few centimetres of the true shortest)."""
    grid = rasterize_world(world, 0.05, margin=0.5).inflate(radius)
    free = grid.free_mask
    h, w = free.shape
    index = np.arange(h * w).reshape(h, w)
    rows, cols, weights = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        lo, hi = max(0, -dc), w - max(0, dc)  # source columns whose neighbour (r + dr, c + dc) exists
        both = free[: h - dr, lo:hi] & free[dr:, lo + dc : hi + dc]
        rows.append(index[: h - dr, lo:hi][both])
        cols.append(index[dr:, lo + dc : hi + dc][both])
        weights.append(np.full(int(both.sum()), math.hypot(dr, dc) * grid.resolution))
    graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(h * w, h * w))
    (sr, gr), (sc, gc), inside = grid.cells_of(np.array([[start.x, start.y], goal]))
    if not (inside.all() and free[sr, sc] and free[gr, gc]):
        raise InvalidInputError("benchmark start or goal is not free in the world")
    _, predecessors = dijkstra(graph.tocsr(), directed=False, indices=int(index[sr, sc]), return_predecessors=True)
    node, cells = int(index[gr, gc]), []
    while node >= 0:
        cells.append(node)
        node = int(predecessors[node])
    if cells[-1] != index[sr, sc]:
        raise NoPathFoundError("no collision-free path between the benchmark start and goal")
    cells.reverse()
    points = cell_centres(grid, np.array(cells) // w, np.array(cells) % w)
    points[0], points[-1] = (start.x, start.y), goal
    return path_length(_shortcut(points, grid))


def _shortcut(points: FloatArray, grid: OccupancyGrid) -> FloatArray:
    """Greedy line-of-sight shortcutting: from each kept point jump to the farthest point visible from it."""
    kept, i = [points[0]], 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not np.all(grid.is_free(densify(points[[i, j]], grid.resolution / 2.0))):
            j -= 1
        kept.append(points[j])
        i = j
    return np.array(kept)


def run(args: argparse.Namespace) -> str:
    if args.seeds < 1:
        raise InvalidInputError(f"--seeds must be >= 1, got {args.seeds}")
    if args.ros_runs < 0:
        raise InvalidInputError(f"--ros-runs must be >= 0, got {args.ros_runs}")
    names = [n.strip() for n in args.worlds.split(",") if n.strip()]
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown or not names:
        raise InvalidInputError(
            f"--worlds: unknown {unknown or args.worlds!r}; expected some of {', '.join(SCENARIOS)}"
        )
    header = [
        "world",
        "runs",
        "success",
        "contacts",
        "time to goal median (sim s)",
        "(travelled + rest) / shortest median",
        "cross-track RMS median (m)",
        "final error median (m)",
        "SLAM ATE median (m)",
        "real-time factor median",
    ]
    rows = []
    bar = tqdm(total=args.seeds * len(names), unit="run", file=sys.stderr, disable=not sys.stderr.isatty())
    for name in names:
        scenario = SCENARIOS[name]
        world = load_world(WORLDS_DIR / scenario.world)
        shortest = shortest_path_length(world, scenario.start, scenario.goal)
        successes, contacts, times, ratios, cross, final, ate, rtf = 0, 0, [], [], [], [], [], []
        for seed in range(args.seeds):
            config = DemoConfig(
                start=scenario.start, goals=(scenario.goal,), seed=seed, plan_time_budget_s=args.time_budget
            )
            result = Demo(world, config).run()
            (outcome,) = result.outcomes
            ok = outcome.state == "reached" and outcome.distance_m <= 0.2 and result.collisions == 0
            successes += ok
            contacts += result.collisions
            final.append(outcome.distance_m)
            ate.append(result.ate_rmse_m)
            rtf.append(result.sim_time_s / result.wall_time_s)
            if outcome.state == "reached":
                times.append(outcome.time_s)
                # the robot stops up to 0.2 m short of the goal: count the rest as if driven straight
                ratios.append((outcome.travelled_m + outcome.distance_m) / shortest)
            if result.cross_track_m.size:
                cross.append(float(np.sqrt(np.mean(result.cross_track_m**2))))
            bar.update(1)
        rows.append(
            [
                f"{name} ({scenario.start.x:g}, {scenario.start.y:g}) -> {scenario.goal}, shortest {shortest:.2f} m",
                args.seeds,
                f"{successes}/{args.seeds}",
                contacts,
                _median(times),
                _median(ratios),
                _median(cross),
                _median(final),
                _median(ate),
                _median(rtf),
            ]
        )
    bar.close()
    return (
        "Whole stack in one process (`mrs_nav.stack.demo`): ODE simulator at 100 Hz with the 5 Hz laser, SLAM, RRT* "
        f"({args.time_budget} s per plan) through unknown space, path follower at 10 Hz; no map at the start. "
        "Success = navigator reports the goal reached, true pose within 0.2 m, no contact. "
        "Final error and ATE use the true pose (ATE: SLAM pose against ground truth in the shared map/world "
        "frame, no alignment). Path ratio: true distance travelled plus the straight rest to the goal, over the "
        "shortest collision-free path. Real-time factor: sim time / wall time of the whole run, measured while "
        "other jobs shared the two cores.\n\n"
        + markdown_table(header, rows)
        + ("\n\n" + ros_section(names, args.ros_runs) if args.ros_runs else "")
    )


def _median(values: list[float]) -> float:
    return float(statistics.median(values)) if values else math.nan
