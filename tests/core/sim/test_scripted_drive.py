"""Scripted drives: the robot follows the office corridor loop without touching a wall."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.sim import LaserParams, Simulator, SimulatorConfig
from mrs_nav.sim.scripted_drive import OFFICE_CORRIDOR_LOOP, WaypointDriver

OFFICE = Path(__file__).resolve().parents[3] / "worlds" / "office.world"


def test_polyline_geometry() -> None:
    driver = WaypointDriver(OFFICE_CORRIDOR_LOOP)
    assert driver.length == pytest.approx(40.0)
    assert driver.progress(0.0, -5.3) == pytest.approx(5.0)
    assert driver.point_at(45.0) == pytest.approx((0.0, -5.0))  # wraps around the loop
    open_path = WaypointDriver([(0.0, 0.0), (1.0, 0.0)], loop=False)
    assert open_path.point_at(3.0) == (1.0, 0.0)
    assert open_path.command(Pose2D(1.0, 0.0)).v == 0.0  # arrived: stop


def test_the_robot_laps_the_office_corridor_without_contact() -> None:
    # the laser at 1 Hz only keeps the test quick: the drive does not use it
    sim = Simulator(load_world(OFFICE), SimulatorConfig(laser=LaserParams(rate=1.0)), Pose2D(-5.0, -5.0, 0.0))
    driver = WaypointDriver(OFFICE_CORRIDOR_LOOP)
    worst = travelled = 0.0
    previous = sim.ground_truth()
    for _ in range(4_400):  # 220 s: 40 m at up to 0.2 m/s, turning at the corners; control at 20 Hz
        pose = sim.ground_truth()
        travelled += math.hypot(pose.x - previous.x, pose.y - previous.y)
        previous = pose
        command = driver.command(pose)
        sim.set_command(command.v, command.omega)
        sim.run(0.05)
        worst = max(worst, abs(max(abs(pose.x), abs(pose.y)) - 5.0))  # distance off the corridor centre line
    assert sim.contacts.events == 0
    assert worst < 0.5
    assert travelled > 40.0  # a full lap


def test_bad_waypoints_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="at least two"):
        WaypointDriver([(0.0, 0.0)])
    with pytest.raises(InvalidInputError, match="differ"):
        WaypointDriver([(0.0, 0.0), (0.0, 0.0)], loop=False)
