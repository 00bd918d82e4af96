"""Localisation on a scripted drive through a simulated world (the core simulator, no ROS): tests and benchmarks.

The robot follows waypoints by pure pursuit on its true pose (the driver is not under test); the filter gets
the simulator's wheel odometry and every scan, and each filter update is scored against the true pose. An
optional kidnapping teleports the robot mid-drive without its odometry noticing.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray, Pose2D, wrap_angle
from mrs_nav.localisation.config import LocalisationConfig
from mrs_nav.localisation.filter import BeamScan, ParticleFilter, PoseEstimate
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.maps.world import World
from mrs_nav.sim.laser import Scan
from mrs_nav.sim.scripted_drive import WaypointDriver
from mrs_nav.sim.simulator import Simulator, SimulatorConfig

COMMAND_PERIOD = 0.1  # s between driver commands
SPIN_RATE = 1.0  # rad/s of a spin in place (the Burger turns at up to 2.84)
CONVERGED_M = 0.1  # m: position error below which the filter counts as converged
CONVERGED_RAD = math.radians(10.0)  # and heading error below this


def beam_scan(scan: Scan) -> BeamScan:
    """The filter's view of a simulated scan, with the laser's mounting."""
    p = scan.params
    return BeamScan(scan.ranges, p.angles(), p.range_min, p.range_max, Pose2D(p.mount_x, p.mount_y, 0.0))


@dataclass(frozen=True)
class Kidnap:
    """Teleport the robot to ``pose`` (world frame) just after sim time ``at`` (s)."""

    at: float
    pose: Pose2D


@dataclass(frozen=True)
class LocalisationRun:
    """Per filter update: sim time (s), position and heading errors (m, rad), particles, CPU time (s), the
    estimate's own standard deviations (m along its widest axis, rad) and whether the filter was confident."""

    times: FloatArray
    position_errors: FloatArray
    heading_errors: FloatArray
    particles: FloatArray
    cpu_s: FloatArray
    position_sigmas: FloatArray
    heading_sigmas: FloatArray
    confident: npt.NDArray[np.bool_]

    def within_sigmas(self, k: float = 3.0, since: float = 0.0) -> float:
        """Share of the updates at or after ``since`` whose errors lie within ``k`` of the estimate's own
        standard deviations (position and heading both): 1 for a covariance that never understates the error."""
        keep = self.times >= since
        ok = (self.position_errors <= k * self.position_sigmas) & (self.heading_errors <= k * self.heading_sigmas)
        return float(np.mean(ok[keep])) if np.any(keep) else 1.0

    def converged_at(self, since: float = 0.0) -> float | None:
        """The first update time >= ``since`` from which every later update is within the converged bounds."""
        ok = (self.position_errors < CONVERGED_M) & (self.heading_errors < CONVERGED_RAD) & (self.times >= since)
        later = self.times >= since
        bad = np.flatnonzero(later & ~ok)
        if not np.any(ok):
            return None
        if bad.size == 0:
            return float(self.times[later][0])
        if bad[-1] + 1 >= len(self.times):
            return None
        return float(self.times[bad[-1] + 1])

    def rms(self, since: float = 0.0) -> tuple[float, float]:
        """RMS position (m) and heading (rad) error of the updates at or after ``since``."""
        keep = self.times >= since
        return (
            float(np.sqrt(np.mean(self.position_errors[keep] ** 2))),
            float(np.sqrt(np.mean(self.heading_errors[keep] ** 2))),
        )


def drive_and_localise(
    world: World,
    grid: OccupancyGrid,
    start: Pose2D,
    waypoints: Sequence[tuple[float, float]],
    duration: float,
    *,
    config: LocalisationConfig | None = None,
    initial: Pose2D | None = None,
    initial_covariance: Sequence[float] = (0.0025, 0.0025, 0.0003),
    sim_config: SimulatorConfig | None = None,
    kidnap: Kidnap | None = None,
    spin_turns: float = 0.0,
) -> LocalisationRun:
    """Drive the ``waypoints`` loop from ``start`` for ``duration`` s of sim time with the filter running, after
    ``spin_turns`` full turns in place (counter-clockwise at ``SPIN_RATE``).

    The filter starts about ``initial`` (map frame) with the diagonal ``initial_covariance`` (m^2, m^2, rad^2),
    or, when ``initial`` is None, spread over the whole free space (global localisation).
    """
    sim = Simulator(world, sim_config or SimulatorConfig(odom_noise=0.01, seed=1), start)
    pf = ParticleFilter(grid, config)
    if initial is None:
        pf.global_localisation()
    else:
        pf.set_pose(initial, np.diag(initial_covariance))
    driver = WaypointDriver(list(waypoints))
    steps_per_command = max(1, round(COMMAND_PERIOD * sim.config.physics_rate))
    rows: list[tuple[float, ...]] = []
    kidnapped = kidnap is None
    spin_time = 2.0 * math.pi * spin_turns / SPIN_RATE
    while sim.time < duration:
        if not kidnapped and kidnap is not None and sim.time > kidnap.at:
            sim.teleport(kidnap.pose)
            kidnapped = True
        if sim.time < spin_time:
            sim.set_command(0.0, SPIN_RATE)
        else:
            command = driver.command(sim.ground_truth())
            sim.set_command(command.v, command.omega)
        for _ in range(steps_per_command):
            scan = sim.step()
            if scan is None:
                continue
            t0 = time.process_time()
            updated = pf.update(sim.odometry().pose, beam_scan(scan))
            cpu = time.process_time() - t0
            if updated:
                rows.append((sim.time, *_scored(pf.estimate(), sim.ground_truth()), len(pf.particles), cpu))
    t = np.array(rows, dtype=np.float64).reshape(-1, 8)
    return LocalisationRun(t[:, 0], t[:, 1], t[:, 2], t[:, 6], t[:, 7], t[:, 3], t[:, 4], t[:, 5] > 0.0)


def _scored(estimate: PoseEstimate, truth: Pose2D) -> tuple[float, float, float, float, float]:
    """Position and heading errors, the estimate's standard deviations (widest position axis, heading) and 1.0
    if it is confident."""
    est, cov = estimate.pose, estimate.covariance
    sd_xy = math.sqrt(max(0.0, float(np.linalg.eigvalsh(cov[:2, :2])[-1])))
    sd_yaw = math.sqrt(max(0.0, float(cov[2, 2])))
    error = math.hypot(est.x - truth.x, est.y - truth.y)
    return error, abs(wrap_angle(est.yaw - truth.yaw)), sd_xy, sd_yaw, float(estimate.confident)
