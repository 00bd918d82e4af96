"""The shipped worlds load, have the promised size, and the robot can start and drive in them."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import load_world
from mrs_nav.sim import Simulator

WORLDS = Path(__file__).resolve().parents[3] / "worlds"


def test_office_is_about_20_m_square_with_rooms_and_furniture() -> None:
    world = load_world(WORLDS / "office.world")
    xmin, ymin, xmax, ymax = world.bounds()
    assert xmax - xmin == pytest.approx(20.0, abs=0.5)
    assert ymax - ymin == pytest.approx(20.0, abs=0.5)
    assert len(world.boxes) > 30
    assert world.cylinders


def test_cluttered_room_has_many_cylinders_and_boxes() -> None:
    world = load_world(WORLDS / "cluttered.world")
    assert len(world.cylinders) >= 20
    assert len(world.boxes) - 4 >= 10  # four walls, the rest clutter


@pytest.mark.parametrize(
    ("name", "start"),
    [("office.world", Pose2D(-5.0, -5.0, 0.0)), ("cluttered.world", Pose2D(-4.0, -4.0, 0.785))],
)
def test_robot_drives_from_the_suggested_start(name: str, start: Pose2D) -> None:
    sim = Simulator(load_world(WORLDS / name), start=start)
    for _ in range(300):
        sim.set_command(0.2, 0.0)
        sim.step()
    assert sim.contacts.events == 0
    assert sim.ground_truth().position @ [1, 1] > start.position @ [1, 1]
