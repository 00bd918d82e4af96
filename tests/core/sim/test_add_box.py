"""A box put into the simulated world at run time: the laser sees it, the robot collides with it, bad ones refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import Box, load_world
from mrs_nav.sim import Simulator, SimulatorConfig
from tests.conftest import WORLDS


def test_an_added_box_is_seen_by_the_laser_and_joins_the_world() -> None:
    sim = Simulator(load_world(WORLDS / "simple.world"), SimulatorConfig(seed=0), Pose2D(-1.5, -1.5, 0.0))
    ahead = int(np.argmin(np.abs(sim.config.laser.angles())))  # the beam straight ahead
    before = sim.scan_now().ranges[ahead]
    sim.add_box(Box("in_the_way", -0.5, -1.5, 0.25, 0.0, 0.2, 0.6, 0.5))
    after = sim.scan_now().ranges[ahead]
    assert before > 3.0
    # the face at x = -0.6, seen from the laser 0.032 m behind the axle at x = -1.5
    assert after == pytest.approx(-0.6 - (-1.5 - 0.032), abs=0.05)
    assert sim.world.boxes[-1].name == "in_the_way"


@pytest.mark.parametrize("box", [Box("nan", math.nan, 0, 0, 0, 1, 1, 1), Box("flat", 0, 0, 0, 0, 1, 0.0, 1)])
def test_a_bad_box_is_refused(box: Box) -> None:
    sim = Simulator(load_world(WORLDS / "simple.world"), SimulatorConfig(seed=0), Pose2D(-1.5, -1.5, 0.0))
    with pytest.raises(InvalidInputError, match="box"):
        sim.add_box(box)
