"""Spinning in place on a saved map through the real nodes (issue 38): navigation.launch (simulator, map server,
localisation) on the office as a mapping drive round the ring corridor leaves it (the rooms unknown). The robot
stands on the east corridor where the issue's user put it down, the localisation is told a pose 0.28 m / 12 deg
off as a 2D Pose Estimate would, and the robot turns 3 full turns in place: every /amcl_pose after the first 5 s
of the spin (the filter's first updates move it from the given pose to the truth) stays within 0.15 m of the
ground truth. In real time: at max rate on a loaded machine the simulator outran the localisation node, which
then took a scan every few seconds of sim time, not the spin a robot's filter sees."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mrs_nav.geometry import Pose2D
from mrs_nav.localisation.sim_drive import SPIN_RATE
from mrs_nav.maps.map_io import save_map
from tests.core.localisation.test_filter import corridor_map
from tests.ros.driveharness import Drive, Spin
from tests.ros.test_localisation_node import WORLD
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

EAST = Pose2D(5.0, 2.0, math.pi / 2.0)  # where the robot stands (the east corridor)
GIVEN = Pose2D(EAST.x + 0.2, EAST.y - 0.2, EAST.yaw + math.radians(12.0))  # what the localisation is told
TURNS = 3.0
WITHIN = 0.15  # m, every /amcl_pose during the spin from the truth, once settled
SETTLE = 5.0  # s of sim time into the spin: the figures count from here (bench localisation's too)


def test_three_turns_in_place_keep_the_estimate_within_15_cm(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    # Before issue 38's localisation (77699ed) the estimate jumped along the corridor during the spin: 2.69 m off;
    # in a second run that node published no /amcl_pose in 90 s (none before the robot moved).
    rospy = rospy_node
    map_file = save_map(corridor_map(), tmp_path / "office_ring.yaml")
    args = [
        f"map_file:={map_file}",
        f"world:={WORLD}",
        f"x:={EAST.x}",
        f"y:={EAST.y}",
        f"yaw:={EAST.yaw}",
        f"initial_pose_x:={GIVEN.x}",
        f"initial_pose_y:={GIVEN.y}",
        f"initial_pose_a:={GIVEN.yaw}",
        "rviz:=false",
        "navigation:=false",
        "real_time_factor:=1",
    ]
    with ros_master.launch("navigation.launch", *args) as proc:
        drive = Drive(rospy, driver=Spin(SPIN_RATE))
        try:
            wait_for(lambda: proc.poll() is not None or drive.since(0.0).size > 0, 90.0, "the first /amcl_pose")
            assert proc.poll() is None, "roslaunch exited"
            start = drive.now
            spin = 2.0 * math.pi * TURNS / SPIN_RATE
            drive.drive(spin, 150.0)
            end = drive.now
            # the estimates of the spin's last scans, from a node that may lag on a loaded machine
            wait_for(lambda: drive.now > end + 2.0, 30.0, "2 s of sim time after the spin")
            errors = drive.since(start + SETTLE)
        finally:
            drive.close()
        assert proc.poll() is None, "a required node died"
    print(f"spin: {len(errors)} estimates, worst {errors[:, 1].max():.3f} m, {np.degrees(errors[:, 2].max()):.1f} deg")
    assert len(errors) >= 10, "the localisation updated fewer than 10 times in the settled part of the spin"
    assert errors[:, 1].max() <= WITHIN, f"an /amcl_pose {errors[:, 1].max():.2f} m from the truth during the spin"
