"""Whole stack (simulator + SLAM + RRT* navigation) headless at max rate, over seeds, in the arena and the office.

Each run is :class:`mrs_nav.stack.demo.Demo` with one goal: the robot starts with no map, SLAM maps on the way and
the navigator plans through unknown space. A run succeeds when the navigator reports the goal reached, the
true pose is within 0.2 m of the goal and the robot never touched anything. Reported per world: success rate,
time to goal (sim s), distance travelled against the shortest collision-free path (the true map inflated by the
robot radius, the library's wavefront on its cells then its shortcutting), cross-track RMS (true position to the path
being followed), the SLAM pose error and the real-time factor of the whole stack.

Then (unless ``--ros-runs 0``) the same goals through the real ROS stack: a roscore on a free port,
``roslaunch mrs_nav rrt_navigation.launch real_time_factor:=0 lockstep:=true`` (simulator, SLAM, RRT*
navigation as separate processes) and :mod:`mrs_nav.ros.navigation_bench_peer` sending the goal; reported are
the outcome and the real-time factor achieved from the goal to its outcome.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from mrs_nav.bench.localisation_saved_map import saved_office_map
from mrs_nav.bench.navigation_saved_map import saved_map_navigation_section
from mrs_nav.errors import InvalidInputError
from mrs_nav.fields.path_simplification import simplify_path
from mrs_nav.geometry import FloatArray, Pose2D, wrap_angle
from mrs_nav.maps.occupancy_grid import BoolArray, OccupancyGrid
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.wavefront import wavefront
from mrs_nav.maps.world import Box, World, load_world
from mrs_nav.navigation.navigator import GoalState, NavGoal, Navigator, NavigatorConfig, rrt_planner
from mrs_nav.navigation.obstacles import beam_ends
from mrs_nav.options import budget_option, optional_runs_option, runs_option
from mrs_nav.planning import path_length
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.ros_processes import process, roscore, roslaunch_command, run_peer
from mrs_nav.sim import Simulator, SimulatorConfig
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
    parser.add_argument("--seeds", type=runs_option, default=20, help="runs per world (default 20)")
    parser.add_argument("--worlds", default="arena,office", help="comma-separated: " + ", ".join(SCENARIOS))
    parser.add_argument("--time-budget", type=budget_option, default=0.25, help="planner budget per plan, wall s")
    parser.add_argument(
        "--ros-runs",
        type=optional_runs_option,
        default=3,
        help="runs per world through the ROS stack in lockstep (0 = none)",
    )
    parser.add_argument(
        "--accuracy-seeds",
        type=optional_runs_option,
        default=5,
        help="seeds of the office goals with headings (0 = none)",
    )
    parser.add_argument(
        "--obstacle-seeds",
        type=optional_runs_option,
        default=10,
        help="seeds of the arena box put in the way (0 = none)",
    )
    parser.add_argument(
        "--saved-map-seeds",
        type=optional_runs_option,
        default=20,
        help="seeds per start on the office's saved map, and of the wrong initial pose (0 = none; issue 38)",
    )
    parser.add_argument(
        "--office-obstacle-seeds",
        type=optional_runs_option,
        default=3,
        help="seeds of the office corridor box (0 = none)",
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
            with process(launch, env, log_dir / "launch.log") as proc:
                result: dict[str, float] = run_peer(proc, env, log_dir, ["--goal", *map(str, scenario.goal)])
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
    """Length (m) of a near-shortest collision-free path for a disc of ``radius``: the library's wavefront
    (8-connected Dijkstra on a 0.05 m rasterisation, a diagonal step only where both cells of the corner it cuts are
    free) then its shortcutting (:func:`~mrs_nav.fields.path_simplification.simplify_path`, segments checked every
    half cell); within a few centimetres of the true shortest."""
    grid = rasterize_world(world, 0.05, margin=0.5).inflate(radius)
    if not grid.is_free(np.array([[start.x, start.y], goal])).all():
        raise InvalidInputError("benchmark start or goal is not free in the world")
    corridor = wavefront(grid, goal, cell_m=grid.resolution).corridor([start.x, start.y])
    return path_length(simplify_path(corridor, partial(_segments_free, grid)))


def _segments_free(grid: OccupancyGrid, starts: FloatArray, ends: FloatArray) -> BoolArray:
    """Whether each straight segment ``starts[i] -> ends[i]`` crosses only free cells of ``grid`` (sampled at
    least every half cell, both ends included)."""
    step = grid.resolution / 2.0
    counts = np.maximum(np.ceil(np.hypot(*(ends - starts).T) / step).astype(np.intp), 1) + 1
    segment = np.repeat(np.arange(len(starts)), counts)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    t = (np.arange(int(counts.sum())) - first[segment]) / (counts[segment] - 1)
    points = starts[segment] + t[:, None] * (ends - starts)[segment]
    out: BoolArray = np.logical_and.reduceat(grid.is_free(points), first)
    return out


def run(args: argparse.Namespace) -> str:
    names = _world_names(args)
    stack = stack_section(names, args.seeds, args.time_budget) if args.seeds else ""
    goals = []
    if args.accuracy_seeds:
        goals.append(goal_accuracy_section(args.accuracy_seeds, args.time_budget))
    if args.obstacle_seeds or args.office_obstacle_seeds:
        goals.append(obstacle_section(args.obstacle_seeds, args.office_obstacle_seeds, args.time_budget))
    if args.saved_map_seeds:
        world = load_world(WORLDS_DIR / "office.world")
        grid = saved_office_map(world)
        goals.append(saved_map_navigation_section(world, grid, args.saved_map_seeds, args.time_budget))
    ros = ros_section(names, args.ros_runs) if args.ros_runs else ""
    return "\n\n".join(part for part in (stack, *goals, ros) if part)


def _world_names(args: argparse.Namespace) -> list[str]:
    """The worlds of ``--worlds``, after checking every count option is >= 0."""
    for option in ("seeds", "ros_runs", "accuracy_seeds", "obstacle_seeds", "office_obstacle_seeds", "saved_map_seeds"):
        if getattr(args, option) < 0:
            raise InvalidInputError(f"--{option.replace('_', '-')} must be >= 0, got {getattr(args, option)}")
    names = [n.strip() for n in args.worlds.split(",") if n.strip()]
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown or not names:
        raise InvalidInputError(
            f"--worlds: unknown {unknown or args.worlds!r}; expected some of {', '.join(SCENARIOS)}"
        )
    return names


def stack_section(names: list[str], seeds: int, time_budget: float) -> str:
    """Markdown: the whole stack in one process, ``seeds`` runs per world."""
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
    bar = tqdm(total=seeds * len(names), unit="run", file=sys.stderr, disable=not sys.stderr.isatty())
    rows = [_stack_row(name, seeds, time_budget, bar) for name in names]
    bar.close()
    return (
        "Whole stack in one process (`mrs_nav.stack.demo`): ODE simulator at 100 Hz with the 5 Hz laser, SLAM, "
        f"RRT* ({time_budget} s per plan) through unknown space, path follower at 10 Hz; no map at the start. "
        "Success = navigator reports the goal reached, true pose within 0.2 m, no contact. "
        "Final error and ATE use the true pose (ATE: SLAM pose against ground truth in the shared map/world "
        "frame, no alignment). Path ratio: true distance travelled plus the straight rest to the goal, over the "
        "shortest collision-free path. Real-time factor: sim time / wall time of the whole run, measured while "
        "other jobs shared the two cores.\n\n" + markdown_table(header, rows)
    )


def _stack_row(name: str, seeds: int, time_budget: float, bar: tqdm[Any]) -> list[object]:
    """One world's row of :func:`stack_section`."""
    scenario = SCENARIOS[name]
    world = load_world(WORLDS_DIR / scenario.world)
    shortest = shortest_path_length(world, scenario.start, scenario.goal)
    successes, contacts = 0, 0
    times: list[float] = []
    ratios: list[float] = []
    cross: list[float] = []
    final: list[float] = []
    ate: list[float] = []
    rtf: list[float] = []
    for seed in range(seeds):
        config = DemoConfig(start=scenario.start, goals=(scenario.goal,), seed=seed, plan_time_budget_s=time_budget)
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
    return [
        f"{name} ({scenario.start.x:g}, {scenario.start.y:g}) -> {scenario.goal}, shortest {shortest:.2f} m",
        seeds,
        f"{successes}/{seeds}",
        contacts,
        _median(times),
        _median(ratios),
        _median(cross),
        _median(final),
        _median(ate),
        _median(rtf),
    ]


def _median(values: list[float]) -> float:
    return float(statistics.median(values)) if values else math.nan


# -- goals as move_base users mean them, and a box the map does not have (in-process, on the known map) ---------

XY_TOLERANCE, YAW_TOLERANCE = 0.05, 0.17  # m, rad: the navigator's defaults (TurtleBot3's move_base values)
# Office goals with headings, visited in turn from the start (-5, -5, 0) in the south-west corridor corner.
ACCURACY_GOALS = ((-3.0, -5.0, math.pi / 2), (-5.0, -3.0, math.pi), (-4.6, -4.6, -math.pi / 4), (-5.0, -5.0, 0.0))


@dataclass(frozen=True)
class BoxCase:
    """A box put in the way after the map was made, and the trip whose direct route it blocks."""

    world: str
    box: Box
    start: Pose2D
    goal: tuple[float, float, float]
    detour: str


BOX_CASES = {
    # from the south wall to the cylinder: round the north of the cylinder instead (about 7 m)
    "arena": BoxCase(
        "simple.world",
        Box("south_block", 0.0, -1.0, 0.25, 0.0, 0.2, 2.0, 0.5),
        Pose2D(-1.5, -1.5, 0.0),
        (1.5, -1.5, 0.0),
        "north of the cylinder",
    ),
    # across the south corridor (wall faces at y = -5.925 and -4.075): round the ring corridor (about 35 m)
    "office": BoxCase(
        "office.world",
        Box("corridor_block", -2.0, -5.0, 0.25, 0.0, 0.2, 1.85, 0.5),
        Pose2D(-5.0, -5.0, 0.0),
        (0.0, -5.0, 0.0),
        "round the ring corridor",
    ),
}


@dataclass(frozen=True)
class PoseOutcome:
    """One goal of :func:`known_map_run`: how it ended, the true position and heading errors, sim time taken."""

    state: str
    distance_m: float
    heading_rad: float
    time_s: float


def known_map_run(
    world: World,
    start: Pose2D,
    goals: tuple[tuple[float, float, float], ...],
    *,
    seed: int,
    time_budget: float,
    box: Box | None = None,
    goal_timeout_s: float = 400.0,
) -> tuple[list[PoseOutcome], int]:
    """Drive the core simulator to each goal pose in turn with the navigator on the world's own map (made before
    ``box``, if any, was put in the world), fed every laser scan; the pose is the true one (perfect localisation:
    this measures planning, following and the goal approach). The outcomes and the number of contacts."""
    grid = rasterize_world(world, 0.05, margin=0.2)
    sim = Simulator(world, SimulatorConfig(seed=seed), start)
    if box is not None:
        sim.add_box(box)
    navigator = Navigator(rrt_planner("rrt_star", time_budget), NavigatorConfig(), seed=seed)
    navigator.set_map(grid, 0.0)
    laser = sim.config.laser
    mount, angles = Pose2D(laser.mount_x, laser.mount_y, 0.0), laser.angles()
    steps = round(sim.config.physics_rate / 10.0)  # a 10 Hz controller
    outcomes = []
    for x, y, yaw in goals:
        t0 = sim.time
        navigator.set_goal(NavGoal(x, y, yaw), t0)
        while navigator.state is GoalState.ACTIVE and sim.time - t0 < goal_timeout_s:
            command = navigator.update(sim.ground_truth(), sim.time)
            sim.set_command(command.u, command.omega)
            for _ in range(steps):
                scan = sim.step()
                if scan is not None:
                    scanner = sim.ground_truth().compose(mount)
                    navigator.set_scan(*beam_ends(scanner, angles, scan.ranges, laser.range_min, laser.range_max))
        if navigator.state is GoalState.ACTIVE:
            navigator.cancel()
        state = {GoalState.REACHED: "reached", GoalState.FAILED: "failed"}.get(navigator.state, "timed out")
        elapsed = sim.time - t0
        sim.set_command(0.0, 0.0)
        sim.run(1.0)  # come to rest before the errors are measured
        truth = sim.ground_truth()
        error = abs(wrap_angle(yaw - truth.yaw))
        outcomes.append(PoseOutcome(state, math.hypot(x - truth.x, y - truth.y), error, elapsed))
    return outcomes, sim.contacts.events


def goal_accuracy_section(seeds: int, time_budget: float) -> str:
    """Office goals with headings over ``seeds`` seeds: success and the true errors against the tolerances."""
    world = load_world(WORLDS_DIR / "office.world")
    results = [
        known_map_run(world, Pose2D(-5.0, -5.0, 0.0), ACCURACY_GOALS, seed=seed, time_budget=time_budget)
        for seed in range(seeds)
    ]
    outcomes = [o for runs, _ in results for o in runs]
    within = sum(
        o.state == "reached" and o.distance_m <= XY_TOLERANCE and o.heading_rad <= YAW_TOLERANCE for o in outcomes
    )
    distances = [o.distance_m for o in outcomes]
    headings = [o.heading_rad for o in outcomes]
    header = [
        "goals",
        "reached within both tolerances",
        "contacts",
        "position error median / max (m)",
        "heading error median / max (rad)",
        "time per goal median (sim s)",
    ]
    row = [
        f"{len(outcomes)} ({seeds} seeds x {len(ACCURACY_GOALS)} office goals)",
        f"{within}/{len(outcomes)}",
        sum(contacts for _, contacts in results),
        f"{_median(distances):.3f} / {max(distances):.3f}",
        f"{_median(headings):.3f} / {max(headings):.3f}",
        _median([o.time_s for o in outcomes]),
    ]
    return (
        "Goal accuracy (`known_map_run`): the core simulator and navigator on the office's own map, true pose "
        f"(perfect localisation), goals with headings {[(x, y, round(t, 2)) for x, y, t in ACCURACY_GOALS]} in turn "
        f"from (-5, -5, 0); tolerances {XY_TOLERANCE} m and {YAW_TOLERANCE} rad; errors of the true pose 1 s "
        "after the goal ended.\n\n" + markdown_table(header, [row])
    )


def obstacle_section(seeds: int, office_seeds: int, time_budget: float) -> str:
    """Each :data:`BOX_CASES` over seeds (the office's long detour over ``office_seeds``): success without
    contact and time to the goal."""
    header = ["case", "seeds", "reached without contact", "contacts", "time to goal median (sim s)", "failures"]
    rows = []
    for name, case in BOX_CASES.items():
        runs = seeds if name != "office" else office_seeds
        world = load_world(WORLDS_DIR / case.world)
        ok, contacts, times, failures = 0, 0, [], set()
        for seed in range(runs):
            (outcome,), touched = known_map_run(
                world, case.start, (case.goal,), seed=seed, time_budget=time_budget, box=case.box
            )
            contacts += touched
            if outcome.state == "reached" and touched == 0:
                ok += 1
                times.append(outcome.time_s)
            else:
                failures.add(outcome.state)
        box = case.box
        rows.append(
            [
                f"{name}: {box.size_x:g} x {box.size_y:g} m box at ({box.x:g}, {box.y:g}); "
                f"({case.start.x:g}, {case.start.y:g}) -> {case.goal[:2]} {case.detour}",
                runs,
                f"{ok}/{runs}",
                contacts,
                _median(times),
                ", ".join(sorted(failures)) or "-",
            ]
        )
    return (
        "A box the map does not have (`known_map_run`, same set-up as above, RRT* "
        f"{time_budget} s per plan): put in the world after the map was made, across the direct route. The laser "
        "marks it, the blocked path is replanned. Target: >= 9 of 10 seeds reach the goal behind it without "
        "contact.\n\n" + markdown_table(header, rows)
    )
