"""The whole stack headless in one process: simulator + SLAM + RRT* navigation through a sequence of goals.

This is what ``roslaunch mrs_nav rrt_navigation.launch`` runs as separate nodes, wired here through the core
libraries at the simulator's maximum rate, with no ROS master:

* the ODE simulator steps at its physics rate (100 Hz) and takes a scan every laser period (5 Hz);
* every scan goes to SLAM with the wheel odometry at that instant (SLAM decides which to process);
* every ``map_period_s`` the SLAM map is handed to the :class:`~mrs_nav.navigation.Navigator`, as the SLAM node
  publishes ``/map``;
* at ``control_rate_hz`` the navigator gets the SLAM pose estimate ``map->odom * odom`` (what tf gives the
  node) and its commands go to the simulator, as ``/cmd_vel`` does.

The map frame is the world frame: the simulator's odometry starts at the start pose in the world and SLAM's
map frame is the odometry frame of its first scan. Ground truth is only used for the metrics: the absolute
trajectory error of the SLAM pose and the map's agreement with the world.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import matplotlib
import numpy as np

from mrs_nav.atomic_write import atomic_path
from mrs_nav.config_files import node_default
from mrs_nav.control.path_following import cross_track_distance
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.rasterize import raster_frame
from mrs_nav.maps.world import World
from mrs_nav.navigation.navigator import GoalState, NavEvent, NavGoal, Navigator, NavigatorConfig, rrt_planner
from mrs_nav.sim import Scan, Simulator, SimulatorConfig
from mrs_nav.slam import Slam, SlamConfig
from mrs_nav.slam.eval.map_iou import map_iou
from mrs_nav.slam.scan import laser_scan_data
from mrs_nav.stack.track import BoundedTrack

matplotlib.use("Agg")  # headless: figures are files, never windows
import matplotlib.pyplot as plt

MAX_PATHS_KEPT = 500  # adopted plans kept for the figure (a demo's few goals adopt far fewer)


@dataclass(frozen=True)
class DemoConfig:
    """One headless run: the start pose and goals (map = world frame, m, rad) and the rates and budgets."""

    start: Pose2D
    goals: tuple[tuple[float, float], ...]
    seed: int = 0
    goal_timeout_s: float = 240.0  # sim seconds allowed per goal
    control_rate_hz: float = 10.0
    map_period_s: float | None = None  # None: the SLAM config's map_update_interval, as the SLAM node does
    planner: str = "rrt_star"
    plan_time_budget_s: float | None = 0.25
    plan_iterations: int | None = None
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    slam: SlamConfig = field(default_factory=SlamConfig)  # the SLAM node's defaults (config/slam.yaml)
    odom_noise: float = node_default("simulator", "odom_noise")  # as the simulator node's (config/simulator.yaml)

    @property
    def map_period(self) -> float:
        """Seconds between maps handed to the navigator."""
        return self.slam.map_update_interval if self.map_period_s is None else self.map_period_s

    def __post_init__(self) -> None:
        if not self.goals:
            raise InvalidInputError("the demo needs at least one goal")
        for x, y in self.goals:
            if not (math.isfinite(x) and math.isfinite(y)):
                raise InvalidInputError(f"goal ({x}, {y}) is not finite")
        for name in ("goal_timeout_s", "control_rate_hz", "map_period"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"demo {name} must be a positive number, got {value}")


class Recorder(Protocol):
    """Receives what a ROS recording of the same run would hold (e.g. to write a bag); times in sim seconds."""

    def scan(self, scan: Scan) -> None: ...

    def odometry(self, stamp: float, odom: Pose2D, v: float, omega: float, truth: Pose2D) -> None: ...

    def map_to_odom(self, stamp: float, correction: Pose2D) -> None: ...

    def command(self, stamp: float, u: float, omega: float) -> None: ...

    def map(self, stamp: float, grid: OccupancyGrid) -> None: ...

    def path(self, stamp: float, path: FloatArray) -> None: ...

    def goal(self, stamp: float, x: float, y: float) -> None: ...


@dataclass(frozen=True)
class GoalOutcome:
    """How one goal ended: ``state`` (reached, failed, refused or timed out), when, and the events logged."""

    goal: tuple[float, float]
    state: str
    time_s: float
    distance_m: float
    path_length_m: float
    travelled_m: float
    events: tuple[NavEvent, ...]


@dataclass(frozen=True)
class DemoResult:
    """Everything a run produced: outcomes, metrics and the data for the figure."""

    outcomes: tuple[GoalOutcome, ...]
    collisions: int
    sim_time_s: float
    wall_time_s: float
    ate_rmse_m: float
    map_iou: float  # occupied cells of the map and of the world over the observed cells, cell for cell
    map_iou_1cell: float  # the same within one cell: hits on a wall face that lies on a cell boundary fill both cells
    grid: OccupancyGrid
    truth: FloatArray  # (N, 3) ground-truth poses at the control rate (evenly thinned past 20,000)
    estimate: FloatArray  # (N, 3) SLAM poses at the same times
    paths: tuple[FloatArray, ...]  # every path the navigator adopted, in order
    cross_track_m: FloatArray  # distance of the true position to the path being followed, per control step

    @property
    def goals_reached(self) -> int:
        return sum(o.state == "reached" for o in self.outcomes)

    @property
    def success(self) -> bool:
        return self.goals_reached == len(self.outcomes) and self.collisions == 0


def slam_grid(slam: Slam) -> OccupancyGrid:
    """The SLAM map as an :class:`OccupancyGrid` (``nav_msgs/OccupancyGrid`` values)."""
    g = slam.grid
    return OccupancyGrid(g.to_occupancy(), g.resolution, (g.origin_x, g.origin_y, 0.0))


class Demo:
    """One run of the whole stack; :meth:`run` drives it through the goals."""

    def __init__(
        self,
        world: World,
        config: DemoConfig,
        recorder: Recorder | None = None,
        sim_config: SimulatorConfig | None = None,
    ) -> None:
        # The map is scored against the world rasterised at SLAM's resolution: refuse a world too large for that
        # now, not after the whole run.
        raster_frame(world, config.slam.delta)
        self.world = world
        self.config = config
        self.recorder = recorder
        sim_config = sim_config or SimulatorConfig(odom_noise=config.odom_noise, seed=config.seed)
        self.sim = Simulator(world, sim_config, config.start)
        laser = self.sim.config.laser
        # The live stack needs the map and the correction only; a kept trajectory would grow with every scan.
        self.slam = Slam(config.slam, Pose2D(laser.mount_x, laser.mount_y, 0.0), keep_trajectory=False)
        planner = rrt_planner(config.planner, config.plan_time_budget_s, config.plan_iterations)
        self.navigator = Navigator(planner, config.navigator, seed=config.seed)
        # True and estimated pose per control tick (x, y, yaw, x, y, yaw) and the cross-track distance, in bounded
        # memory (a long run keeps an evenly thinned record); the ATE and the distance travelled are summed as the
        # robot moves, so they stay exact however long the run.
        self._poses = BoundedTrack(6)
        self._cross = BoundedTrack(1)
        self._last_truth: Pose2D | None = None
        self._travelled = 0.0  # m
        self._squared_error = 0.0  # m^2, summed over the control ticks
        self._ticks = 0
        # The latest adopted plans, for the figure; a soak replans for hours, so older ones are let go.
        self._paths: deque[FloatArray] = deque(maxlen=MAX_PATHS_KEPT)
        self._last_map = -math.inf

    def pose_estimate(self) -> Pose2D:
        """The robot pose in the map frame as tf would give it: ``map->odom * odom->base_footprint``."""
        return self.slam.pose_at(self.sim.odometry().pose)

    def run(self, progress: Callable[[float], None] | None = None) -> DemoResult:
        """Go through every goal in turn; ``progress`` is called with the sim time after each goal."""
        wall0 = time.perf_counter()
        # stand still for a second first, so that SLAM has a first map when the first goal arrives (as it has
        # in a live session before anyone clicks a goal)
        self._idle(1.0)
        outcomes = []
        for goal in self.config.goals:
            outcomes.append(self.go_to(goal))
            if progress:
                progress(self.sim.time)
        grid = slam_grid(self.slam)
        poses = self._poses.array()
        return DemoResult(
            outcomes=tuple(outcomes),
            collisions=self.sim.contacts.events,
            sim_time_s=self.sim.time,
            wall_time_s=time.perf_counter() - wall0,
            ate_rmse_m=math.sqrt(self._squared_error / self._ticks) if self._ticks else math.nan,
            map_iou=map_iou(self.slam.grid, self.world),
            map_iou_1cell=map_iou(self.slam.grid, self.world, tolerance=1),
            grid=grid,
            truth=poses[:, :3],
            estimate=poses[:, 3:],
            paths=tuple(self._paths),
            cross_track_m=self._cross.array()[:, 0],
        )

    def go_to(self, goal: tuple[float, float]) -> GoalOutcome:
        """Drive to ``goal`` until reached, failed or ``goal_timeout_s`` (sim), then stand for a second."""
        nav, sim, cfg = self.navigator, self.sim, self.config
        t0 = sim.time
        travelled0 = self._travelled
        steps_per_control = max(1, round(sim.config.physics_rate / cfg.control_rate_hz))
        self._publish_map(force=True)
        if self.recorder:
            self.recorder.goal(sim.time, *goal)
        events = list(nav.set_goal(NavGoal(goal[0], goal[1]), sim.time))
        path_length = 0.0
        while nav.state is GoalState.ACTIVE and sim.time - t0 < cfg.goal_timeout_s:
            self._record_odometry()
            pose = self.pose_estimate()
            command = nav.update(pose, sim.time)
            events.extend(command.events)
            if command.path is not None:
                self._paths.append(command.path)
                path_length = float(np.sum(np.hypot(*np.diff(command.path[:, :2], axis=0).T)))
                if self.recorder:
                    self.recorder.path(sim.time, command.path)
            sim.set_command(command.u, command.omega)
            if self.recorder:
                self.recorder.command(sim.time, command.u, command.omega)
            self._track(pose)
            for _ in range(steps_per_control):
                self._step()
        state = {GoalState.REACHED: "reached", GoalState.FAILED: "failed", GoalState.ACTIVE: "timed out"}.get(
            nav.state, "refused"
        )
        if nav.state is GoalState.ACTIVE:
            nav.cancel()
        # let the robot come to rest before the next goal (the command watchdog stops it)
        self._idle(1.0)
        truth = sim.ground_truth()
        return GoalOutcome(
            goal=goal,
            state=state,
            time_s=sim.time - t0,
            distance_m=math.hypot(goal[0] - truth.x, goal[1] - truth.y),
            path_length_m=path_length,
            travelled_m=self._travelled - travelled0,
            events=tuple(events),
        )

    def _idle(self, seconds: float) -> None:
        """Run ``seconds`` of sim time with the robot commanded to stand still."""
        self.sim.set_command(0.0, 0.0)
        steps_per_control = max(1, round(self.sim.config.physics_rate / self.config.control_rate_hz))
        for _ in range(round(seconds * self.config.control_rate_hz)):
            self._record_odometry()
            for _ in range(steps_per_control):
                self._step()

    def _record_odometry(self) -> None:
        """Odometry, its tf and ground truth at the control rate (scans fall on control ticks)."""
        if self.recorder:
            odom = self.sim.odometry()
            self.recorder.odometry(self.sim.time, odom.pose, odom.v, odom.omega, self.sim.ground_truth())

    def _step(self) -> None:
        sim = self.sim
        scan = sim.step()
        if scan is None:
            return
        odom = sim.odometry()
        self.slam.add_scan(odom.pose, laser_scan_data(scan), scan.stamp)
        if self.recorder:
            self.recorder.scan(scan)
            self.recorder.map_to_odom(scan.stamp, self.slam.map_to_odom)
        self._publish_map()

    def _publish_map(self, force: bool = False) -> None:
        now = self.sim.time
        if not force and now - self._last_map < self.config.map_period:
            return
        self._last_map = now
        grid = slam_grid(self.slam)
        self.navigator.set_map(grid, now)
        if self.recorder:
            self.recorder.map(now, grid)

    def _track(self, estimate: Pose2D) -> None:
        truth = self.sim.ground_truth()
        if self._last_truth is not None:
            self._travelled += math.hypot(truth.x - self._last_truth.x, truth.y - self._last_truth.y)
        self._last_truth = truth
        self._squared_error += (truth.x - estimate.x) ** 2 + (truth.y - estimate.y) ** 2
        self._ticks += 1
        self._poses.append((truth.x, truth.y, truth.yaw, estimate.x, estimate.y, estimate.yaw))
        path = self.navigator.path
        if path is not None and self.navigator.state is GoalState.ACTIVE:
            self._cross.append((cross_track_distance([truth.x, truth.y], path),))


def save_figure(result: DemoResult, path: Path, title: str = "") -> Path:
    """A PNG of the SLAM map with every adopted path, the true trajectory and the SLAM estimate."""
    grid = result.grid
    image = np.full(grid.values.shape, 0.5)
    image[grid.values == 0] = 1.0
    image[grid.values >= 65] = 0.0
    xmin, ymin, xmax, ymax = grid.extent
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.imshow(image, cmap="gray", vmin=0, vmax=1, origin="lower", extent=(xmin, xmax, ymin, ymax))
    for i, p in enumerate(result.paths):
        ax.plot(p[:, 0], p[:, 1], color="tab:green", lw=1.0, alpha=0.35, label="plans" if i == 0 else None)
    ax.plot(result.truth[:, 0], result.truth[:, 1], color="tab:blue", lw=1.5, label="ground truth")
    ax.plot(result.estimate[:, 0], result.estimate[:, 1], "--", color="tab:orange", lw=1.0, label="SLAM estimate")
    for o in result.outcomes:
        ax.plot(*o.goal, marker="*", ms=14, color="tab:red" if o.state != "reached" else "tab:green", mec="k")
    if result.truth.size:
        ax.plot(result.truth[0, 0], result.truth[0, 1], "o", color="tab:blue", mec="k")
        pad = 1.0
        ax.set_xlim(
            min(result.truth[:, 0].min(), *(o.goal[0] for o in result.outcomes)) - pad,
            max(result.truth[:, 0].max(), *(o.goal[0] for o in result.outcomes)) + pad,
        )
        ax.set_ylim(
            min(result.truth[:, 1].min(), *(o.goal[1] for o in result.outcomes)) - pad,
            max(result.truth[:, 1].max(), *(o.goal[1] for o in result.outcomes)) + pad,
        )
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"{result.goals_reached}/{len(result.outcomes)} goals, {result.collisions} contacts")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    try:
        with atomic_path(path, "figure") as temp:
            fig.savefig(temp, format="png", dpi=110)
    finally:
        plt.close(fig)
    return path
