"""The potential-field follower under a real roslaunch with the simulator (sim time at max rate, in lockstep)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.ros.navharness import FOOTPRINT_RADIUS, StatusLog, TruthTrack
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

# Sim time at max rate, in lockstep: the simulator never runs more than one control period past the last
# /cmd_vel, so the 10 Hz controller (and the simulator's 0.3 s command watchdog) keeps up however fast the machine is.
MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
SIM_TIME_BOUND = 90.0  # s, the core tests take 30-55 s


def stale_ticks(rows: np.ndarray) -> tuple[int, int]:
    """(ticks, ticks that acted on the very pose of the tick before) between the robot's first and last motion
    in the node's trajectory: the robot moves every tick, so an unchanged pose is a stale one."""
    poses = np.column_stack((rows["x"], rows["y"], rows["yaw"]))
    changed = np.abs(np.diff(poses, axis=0)).max(axis=1) > 0.0
    moving = np.flatnonzero(changed)
    drive = changed[moving[0] : moving[-1] + 1]
    return drive.size, int(np.count_nonzero(~drive))


@pytest.mark.parametrize("obstacles", ["world", "scan"])
def test_the_course_arena_goal_is_reached_without_contact(
    obstacles: str, ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    rospy = rospy_node
    truth = TruthTrack(rospy, "simple.world")
    status = StatusLog(rospy, "/potential_field_navigation/status")
    trajectory = tmp_path / "plots" / "trajectory.csv"
    try:
        with ros_master.launch(
            "potential_field_navigation.launch",
            *MAX_RATE,
            "goal_x:=1.5",
            "goal_y:=1.5",
            "seed:=1",
            f"obstacles:={obstacles}",
            f"trajectory_file:={trajectory}",
        ) as proc:
            # the simulator runs freely until the controller's first command: time the trip from the goal's
            # acceptance (the node's start), not from the simulator's
            wait_for(lambda: proc.poll() is not None or status.has("active"), 60.0, "the goal to be accepted")
            accepted_at = rospy.get_time()
            wait_for(lambda: proc.poll() is not None or status.has("reached"), 120.0, "the goal to be reached")
            assert proc.poll() is None, "roslaunch exited"
            reached_at = rospy.get_time()
        _, x, y = truth.last()
        assert math.hypot(x - 1.5, y - 1.5) <= 0.2
        assert reached_at - accepted_at < SIM_TIME_BOUND
        assert truth.min_clearance() > FOOTPRINT_RADIUS
        assert truth.contacts == 0
        # as the course's plotting reads it
        rows = np.genfromtxt(trajectory, delimiter=",", names=True)
        assert rows.dtype.names == ("t", "x", "y", "yaw")
        assert rows.size > 100
        assert math.hypot(rows["x"][0] + 1.5, rows["y"][0] + 1.5) < 0.05
        assert math.hypot(rows["x"][-1] - 1.5, rows["y"][-1] - 1.5) <= 0.2
        # Each tick acts on a fresh pose. With Nagle's algorithm on ground_truth/odom 30-75 % of the ticks (up to 9
        # in a row, 0.9 s) reused the pose of the tick before while the clock and the commands ran on, and the
        # follower once touched the cylinder.
        ticks, stale = stale_ticks(rows)
        assert stale <= 0.05 * ticks, f"{stale} of {ticks} ticks acted on the pose of the tick before"
    finally:
        truth.close()
        status.close()
