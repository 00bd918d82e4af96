"""Teleporting the simulated robot (the kidnapped-robot test): the true pose jumps, the odometry does not."""

from __future__ import annotations

import math

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.sim import Simulator, SimulatorConfig
from tests.conftest import WORLDS


def test_teleport_moves_the_robot_but_not_its_odometry_and_it_drives_on() -> None:
    sim = Simulator(load_world(WORLDS / "office.world"), SimulatorConfig(), Pose2D(-5.0, -5.0, 0.0))
    sim.set_command(0.2, 0.0)
    sim.run(1.0)
    odom = sim.odometry().pose
    sim.teleport(Pose2D(5.0, 0.0, math.pi / 2.0))
    truth = sim.ground_truth()
    assert (truth.x, truth.y, truth.yaw) == pytest.approx((5.0, 0.0, math.pi / 2.0), abs=1e-9)
    sim.step()
    assert sim.odometry().pose.x == pytest.approx(odom.x, abs=1e-3)  # one step's drift, not 10 m
    for _ in range(10):  # re-sent at 10 Hz, as a controller does: the watchdog never stops it
        sim.set_command(0.2, 0.0)
        sim.run(0.1)
    after = sim.ground_truth()
    assert after.y > 0.05
    assert after.x == pytest.approx(5.0, abs=0.02)
    assert sim.chassis_height == pytest.approx(0.1025, abs=0.005)


def test_teleport_into_a_wall_is_refused_and_the_robot_stays() -> None:
    sim = Simulator(load_world(WORLDS / "office.world"), SimulatorConfig(), Pose2D(-5.0, -5.0, 0.0))
    with pytest.raises(InvalidInputError, match=r"pose \(0.000, -10.000\).*overlaps"):
        sim.teleport(Pose2D(0.0, -10.0, 0.0))
    truth = sim.ground_truth()
    assert (truth.x, truth.y) == pytest.approx((-5.0, -5.0), abs=1e-6)
