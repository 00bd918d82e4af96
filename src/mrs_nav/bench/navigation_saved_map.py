"""Navigation on a map the stack made itself (issue 38), in process: the office mapped by SLAM once round the ring
corridor (:func:`mrs_nav.bench.localisation_saved_map.saved_office_map`), the robot put down at the five starts
of ``bench localisation``'s saved-map section and a 2D Pose Estimate within 0.3 m / 15 deg of the truth, then one
goal, the issue's (-3, -5) in the south corridor.

The closed loop is the core of what ``navigation.launch`` runs, without ROS: the core simulator, the particle
filter (:class:`mrs_nav.localisation.ParticleFilter`) fed the simulator's odometry and every scan, its
``map -> odom`` correction moved only while it is confident (as the localisation node does), and the navigator
(RRT*, ``mark_unknown`` as navigation.launch sets it) on the estimated pose, with the marking gate
(:class:`mrs_nav.navigation.marking.MarkingGate`) told every estimate's covariance: scans mark only while the
localisation is confident, and a goal reached while it is not ends FAILED. The nodes add message passing and
timing, not behaviour; the ROS tests cover those.

Reported per start: goals reached with the true pose within 0.10 m, and the largest true distance from the goal
of any run the navigator called reached (target: none over 0.15 m). Then the wrong initial pose: the robot on the
east corridor while the filter is told the mapping start, metres away: every outcome, and whether any run was
called reached away from the goal.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass

import numpy as np

from mrs_nav.bench.localisation_saved_map import RVIZ_COVARIANCE, STARTS, given_pose
from mrs_nav.bench.results import markdown_table
from mrs_nav.geometry import Pose2D
from mrs_nav.localisation import LocalisationConfig, ParticleFilter
from mrs_nav.localisation.sim_drive import beam_scan
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.world import World
from mrs_nav.navigation.config import NavigatorConfig
from mrs_nav.navigation.goal import EventKind, NavGoal
from mrs_nav.navigation.marking import MarkingGate
from mrs_nav.navigation.navigator import GoalState, Navigator, rrt_planner
from mrs_nav.navigation.obstacles import beam_ends
from mrs_nav.sim.simulator import Simulator, SimulatorConfig

GOAL = (-3.0, -5.0)  # the move_base goal, in the south corridor
MAPPING_START = Pose2D(-5.0, -5.0, 0.0)  # where the filter is told the robot is in the wrong-pose case
WRONG_POSE_START = STARTS[0]  # the east corridor (5, 2, 90 deg), as in the issue
REACHED_WITHIN = 0.10  # m: a goal counts as reached within this true distance
SUCCEEDED_MAX = 0.15  # m: no run called reached may end farther than this from the goal
GOAL_TIMEOUT = 240.0  # s of sim time per goal
CONTROL_PERIOD = 0.1  # s: the navigation node's 10 Hz


@dataclass(frozen=True)
class GoalRun:
    """One goal: how the navigator ended it (``reached``, ``failed: why`` or ``timed out``) and the true distance
    (m) from the goal 1 s after."""

    outcome: str
    distance: float

    @property
    def reached(self) -> bool:
        return self.outcome == "reached"


def navigate(world: World, grid: OccupancyGrid, start: Pose2D, given: Pose2D, *, seed: int, budget: float) -> GoalRun:
    """The robot at ``start`` (world frame), the filter told ``given`` with rviz's spread, then :data:`GOAL`."""
    sim = Simulator(world, SimulatorConfig(odom_noise=0.01, seed=seed), start)
    pf = ParticleFilter(grid, LocalisationConfig(seed=seed))
    pf.set_pose(given, np.diag(RVIZ_COVARIANCE))
    gate = MarkingGate()
    gate.reset(0.0)
    correction = given.compose(sim.odometry().pose.inverse())  # map -> odom
    navigator = Navigator(rrt_planner("rrt_star", budget), NavigatorConfig(mark_unknown=True), seed=seed)
    navigator.set_map(grid, 0.0)
    navigator.set_goal(NavGoal(*GOAL), 0.0)
    laser = sim.config.laser
    mount, angles = Pose2D(laser.mount_x, laser.mount_y, 0.0), laser.angles()
    steps = round(sim.config.physics_rate * CONTROL_PERIOD)
    failure = "timed out"
    while navigator.state is GoalState.ACTIVE and sim.time < GOAL_TIMEOUT:
        pose = correction.compose(sim.odometry().pose)
        command = navigator.update(pose, sim.time, doubt=gate.doubt())
        failure = next((e.message for e in command.events if e.kind is EventKind.FAILED), failure)
        sim.set_command(command.u, command.omega)
        for _ in range(steps):
            scan = sim.step()
            if scan is None:
                continue
            odom = sim.odometry().pose
            if pf.update(odom, beam_scan(scan)):
                estimate = pf.estimate()
                gate.report(sim.time, estimate.covariance)
                if estimate.confident:  # the node moves map -> odom only then
                    correction = estimate.pose.compose(odom.inverse())
            scanner = correction.compose(odom).compose(mount)
            ends = beam_ends(scanner, angles, scan.ranges, laser.range_min, laser.range_max)
            navigator.set_scan(*ends, gate.may_mark(sim.time))
    if navigator.state is GoalState.ACTIVE:
        navigator.cancel()
    sim.set_command(0.0, 0.0)
    sim.run(1.0)
    truth = sim.ground_truth()
    outcome = "reached" if navigator.state is GoalState.REACHED else f"failed: {failure}"
    return GoalRun(outcome, math.hypot(truth.x - GOAL[0], truth.y - GOAL[1]))


def saved_map_navigation_section(world: World, grid: OccupancyGrid, seeds: int, budget: float) -> str:
    """Per start: goals reached within :data:`REACHED_WITHIN` and the worst reached; then the wrong-pose case."""
    rows: list[list[object]] = []
    passed = True
    for start in STARTS:
        runs = [
            navigate(world, grid, start, given_pose(start, seed), seed=seed, budget=budget)
            for seed in range(1, seeds + 1)
        ]
        within = sum(r.reached and r.distance <= REACHED_WITHIN for r in runs)
        worst = max((r.distance for r in runs if r.reached), default=math.nan)
        passed &= within >= math.ceil(0.95 * seeds) and not worst > SUCCEEDED_MAX
        others = Counter(_short(r.outcome) for r in runs if not r.reached)
        rows.append(
            [
                f"({start.x:g}, {start.y:g}, {math.degrees(start.yaw):.0f} deg)",
                f"{within}/{len(runs)}",
                worst,
                "; ".join(f"{n}x {what}" for what, n in others.items()) or "-",
            ]
        )
    wrong = [navigate(world, grid, WRONG_POSE_START, MAPPING_START, seed=s, budget=budget) for s in range(1, seeds + 1)]
    false_success = sum(r.reached and r.distance > SUCCEEDED_MAX for r in wrong)
    outcomes = Counter(
        f"{_short(r.outcome)} ({'at' if r.distance <= SUCCEEDED_MAX else 'away from'} the goal)" for r in wrong
    )
    header = ["start", f"reached within {REACHED_WITHIN} m", "worst reached [m]", "not reached"]
    return (
        f"### Navigation on the saved map of the office (issue 38), seeds 1-{seeds} per start\n\n"
        + "In process (`mrs_nav.bench.navigation_saved_map`): the core simulator, particle filter and RRT* "
        + "navigator as navigation.launch composes them, on the office mapped by the stack's SLAM once round the "
        + f"ring; a 2D Pose Estimate within 0.3 m / 15 deg of the truth, then the goal {GOAL}. Targets: reached "
        + f"within {REACHED_WITHIN} m in >= 95 % of runs per start, none reached farther than {SUCCEEDED_MAX} m: "
        + f"**{'PASS' if passed else 'FAIL'}**.\n\n"
        + markdown_table(header, rows)
        + f"\n\nWrong initial pose (robot at ({WRONG_POSE_START.x:g}, {WRONG_POSE_START.y:g}), the filter told "
        + f"the mapping start ({MAPPING_START.x:g}, {MAPPING_START.y:g})): "
        + "; ".join(f"{n}x {what}" for what, n in outcomes.items())
        + f". Reached away from the goal: {false_success} of {seeds} (target none: "
        + f"**{'FAIL' if false_success else 'PASS'}**).\n"
    )


def _short(outcome: str) -> str:
    """An outcome without the parenthesised numbers that differ run to run (places, distances, spreads), to
    count alike ones together and keep the reason: "failed: goal failed: reached by the estimate but the
    localisation is not confident"."""
    return re.sub(r" \([^()]*\)", "", outcome)
