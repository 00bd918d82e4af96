"""A localisation node killed with SIGKILL and started again by hand under the same name resumes from the last pose
it stored on the parameter server (AMCL's ``~initial_pose_*``), not from the launch pose: navigation.launch on the
office map, the launch pose wrong by metres, a 2D Pose Estimate at the truth, a drive, ``kill -9``, then
``rosrun mrs_nav localisation __name:=amcl``."""

from __future__ import annotations

import math
import os
import signal
import sys
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from mrs_nav.ros_processes import process
from tests.ros.driveharness import Drive
from tests.ros.test_localisation_node import START, WORLD, _publish_until_estimate, initial_pose_msg
from tests.rosharness import REPO, RosMaster, node_pid, wait_for

pytestmark = pytest.mark.ros

LAUNCH_POSE = (5.0, 2.0, math.pi / 2.0)  # what the localisation is told at launch: the east corridor, metres away
WITHIN = 0.3  # m, the restarted node's first /amcl_pose from the truth


def test_a_restarted_localisation_resumes_from_its_last_pose(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    rospy = rospy_node
    map_file = save_map(rasterize_world(load_world(WORLD), 0.05, 0.5), tmp_path / "office.yaml")
    x, y, yaw = LAUNCH_POSE
    args = [
        f"map_file:={map_file}",
        f"world:={WORLD}",
        f"x:={START.x}",
        f"y:={START.y}",
        f"yaw:={START.yaw}",
        f"initial_pose_x:={x}",
        f"initial_pose_y:={y}",
        f"initial_pose_a:={yaw}",
        "rviz:=false",
        "navigation:=false",
        "real_time_factor:=3",
        "lockstep:=true",
    ]
    with ros_master.launch("navigation.launch", *args) as proc:
        wait_for(lambda: proc.poll() is not None or rospy.get_time() > 0.5, 60.0, "/clock from the simulator")
        drive = Drive(rospy)
        try:
            _publish_until_estimate(rospy, drive, initial_pose_msg(rospy, START, (0.0025, 0.0025, 0.0003)))
            drive.drive(20.0, 300.0)  # about 4 m along the corridor loop
            standing = drive.now
            wait_for(lambda: drive.now > standing + 3.0, 60.0, "3 s of sim time standing (a pose stored meanwhile)")
            os.kill(node_pid(ros_master, "/amcl"), signal.SIGKILL)
            stored = rospy.get_param("/amcl/initial_pose_x"), rospy.get_param("/amcl/initial_pose_y")
            restarted = [sys.executable, str(REPO / "scripts" / "localisation"), "__name:=amcl"]
            log = tmp_path / "amcl-restarted.log"
            with process(restarted, ros_master.env, log):
                # The robot stands while the node starts, as it would once navigation found map->odom gone stale.
                wait_for(lambda: "localisation: map" in log.read_text(errors="replace"), 60.0, "the node's map")
                t0 = drive.now
                wait_for(lambda: drive.now > t0 + 1.0, 60.0, "1 s of sim time for the node's first scans")
                wait_for(lambda: drive.since(t0).size > 0 or drive.drive(0.4, 60.0) is not None, 120.0, "an /amcl_pose")
                first = drive.since(t0)[0]
        finally:
            drive.close()
        assert proc.poll() is None, "a required node died"
    print(f"the restarted node's first /amcl_pose: {first[1]:.3f} m from the truth")
    assert first[1] <= WITHIN, f"the restarted node's first /amcl_pose is {first[1]:.2f} m from the truth"
    assert math.hypot(stored[0] - x, stored[1] - y) > 3.0  # the stored pose is not the launch pose
    assert math.hypot(stored[0] - START.x, stored[1] - START.y) > 1.0  # nor the 2D Pose Estimate: it drove on
