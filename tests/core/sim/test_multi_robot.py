"""Several robots in one ODE world: they see each other in their scans, collide, and a far robot changes nothing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import World, load_world
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.sim import LaserParams, MultiRobotSimulator, Simulator, SimulatorConfig
from tests.conftest import WORLDS

EMPTY = World("empty", (), ())
EXACT = SimulatorConfig(laser=LaserParams(noise_sigma=0.0))


def _drive(sim: MultiRobotSimulator, commands: list[tuple[float, float]], seconds: float) -> None:
    """Hold each robot's command (re-sent every 0.1 s so the watchdog never stops it) for ``seconds``."""
    for step in range(round(seconds * sim.config.physics_rate)):
        if step % 10 == 0:
            for robot, (v, omega) in zip(sim.robots, commands, strict=True):
                robot.set_command(v, omega)
        sim.step()


def test_first_robot_of_a_fleet_runs_exactly_as_a_lone_robot_while_the_others_stay_out_of_sight() -> None:
    world = load_world(WORLDS / "office.world")
    config = SimulatorConfig(odom_noise=0.01, seed=7)
    lone = Simulator(world, config, Pose2D(-5.0, -5.0, 0.0))
    # the second robot is 10 m away, far beyond the 3.5 m laser range, and parked
    fleet = MultiRobotSimulator(world, config, [Pose2D(-5.0, -5.0, 0.0), Pose2D(5.0, -5.0, math.pi)])
    first = fleet.robots[0]
    for step in range(300):
        if step % 10 == 0:
            lone.set_command(0.2, 0.3)
            first.set_command(0.2, 0.3)
        scan = lone.step()
        fleet_scan = fleet.step()[0]
        assert (scan is None) == (fleet_scan is None)
        if scan is not None and fleet_scan is not None:
            np.testing.assert_array_equal(scan.ranges, fleet_scan.ranges)
    assert first.ground_truth() == lone.ground_truth()
    assert first.odometry() == lone.odometry()
    # the second robot drew its own noise: its odometry is not the first robot's stream replayed
    assert fleet.robots[1].ground_truth().x == pytest.approx(5.0, abs=1e-3)


def test_each_laser_sees_the_other_robots_cylinder_and_never_its_own_chassis() -> None:
    fleet = MultiRobotSimulator(EMPTY, EXACT, [Pose2D(0.0, 0.0, 0.0), Pose2D(1.0, 0.0, math.pi / 2.0)])
    mount_x = EXACT.laser.mount_x
    first = fleet.robots[0].scan_now().ranges
    # beam 0 points along +x from the scanner (at x = mount_x) to the other chassis, centred at x = 1
    assert first[0] == pytest.approx(1.0 - mount_x - BURGER_RADIUS, abs=1e-6)
    seen = np.isfinite(first)
    # the other robot (radius 0.105 m at 1.032 m) spans asin(0.105 / 1.032) = +-5.8 degrees: beams -5..5 hit,
    # nothing else in an empty world does
    assert np.flatnonzero(seen).tolist() == [0, 1, 2, 3, 4, 5, 355, 356, 357, 358, 359]
    second = fleet.robots[1].scan_now().ranges
    # the second robot faces +y, so the first robot is on its left (beam 90, pointing along -x); its own scanner
    # sits 0.032 m behind its centre, at y = -0.032, so the beam meets the first chassis off its axis
    assert second[90] == pytest.approx(1.0 - math.sqrt(BURGER_RADIUS**2 - mount_x**2), abs=1e-6)
    hits = np.flatnonzero(np.isfinite(second))
    assert 10 <= hits.size <= 13
    assert hits.min() >= 83
    assert hits.max() <= 97


def test_robots_driven_into_each_other_collide_count_the_contact_and_do_not_pass_through() -> None:
    fleet = MultiRobotSimulator(
        EMPTY, EXACT, [Pose2D(-0.5, 0.0, 0.0), Pose2D(0.5, 0.0, math.pi)], names=["tb3_0", "tb3_1"]
    )
    _drive(fleet, [(0.2, 0.0), (0.2, 0.0)], 5.0)
    a, b = fleet.robots
    gap = math.dist((a.ground_truth().x, a.ground_truth().y), (b.ground_truth().x, b.ground_truth().y))
    assert gap > 2.0 * BURGER_RADIUS - 0.01  # pushed against each other, not through
    assert a.contacts.events >= 1
    assert b.contacts.events >= 1
    assert a.contacts.obstacles == {"tb3_1"}
    assert b.contacts.obstacles == {"tb3_0"}
    assert a.chassis_height == pytest.approx(0.1025, abs=0.005)


def test_robots_apart_never_touch_and_a_wall_contact_is_only_the_driving_robots() -> None:
    world = load_world(WORLDS / "simple.world")  # inner wall faces at +-2 m
    fleet = MultiRobotSimulator(world, EXACT, [Pose2D(1.5, -1.5, 0.0), Pose2D(-1.5, -1.5, 0.0)])
    _drive(fleet, [(0.2, 0.0), (0.0, 0.0)], 4.0)
    hit, parked = fleet.robots
    assert hit.contacts.events == 1
    assert hit.contacts.obstacles.isdisjoint({"robot_0", "robot_1"})  # a wall, not the parked robot
    assert parked.contacts.events == 0


def test_overlapping_starts_and_a_teleport_onto_another_robot_are_refused() -> None:
    with pytest.raises(InvalidInputError, match=r"start pose \(0.000, 0.000\) of robot tb3_0 .*overlaps tb3_1"):
        MultiRobotSimulator(EMPTY, EXACT, [Pose2D(0.0, 0.0, 0.0), Pose2D(0.15, 0.0, 0.0)], names=["tb3_0", "tb3_1"])
    with pytest.raises(InvalidInputError, match="distinct name"):
        MultiRobotSimulator(EMPTY, EXACT, [Pose2D(0.0, 0.0, 0.0), Pose2D(1.0, 0.0, 0.0)], names=["a", "a"])
    fleet = MultiRobotSimulator(EMPTY, EXACT, [Pose2D(0.0, 0.0, 0.0), Pose2D(1.0, 0.0, 0.0)])
    with pytest.raises(InvalidInputError, match=r"pose \(0.900, 0.000\).*overlaps robot_1"):
        fleet.robots[0].teleport(Pose2D(0.9, 0.0, 0.0))
    assert fleet.robots[0].ground_truth().x == pytest.approx(0.0, abs=1e-9)
