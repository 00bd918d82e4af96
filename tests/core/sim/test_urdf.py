"""urdf/burger.urdf (for robot_state_publisher and rviz) and the simulator agree on the robot's geometry."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from mrs_nav.sim import BurgerParams, LaserParams

URDF = Path(__file__).resolve().parents[3] / "urdf" / "burger.urdf"


def _origin(root: ET.Element, joint: str) -> tuple[float, ...]:
    node = root.find(f"joint[@name='{joint}']/origin")
    assert node is not None, joint
    return tuple(float(v) for v in node.get("xyz", "0 0 0").split())


def test_urdf_frames_match_the_simulated_robot() -> None:
    root = ET.parse(URDF).getroot()
    robot, laser = BurgerParams(), LaserParams()
    base_z = _origin(root, "base_joint")[2]
    scan = _origin(root, "scan_joint")
    assert (scan[0], scan[1], base_z + scan[2]) == pytest.approx((laser.mount_x, laser.mount_y, laser.mount_z))
    left, right = _origin(root, "wheel_left_joint"), _origin(root, "wheel_right_joint")
    assert left[1] - right[1] == pytest.approx(robot.wheel_separation)
    assert base_z + left[2] == pytest.approx(robot.wheel_radius)  # the axle at wheel-radius height
    radius = root.find("link[@name='wheel_left_link']/visual/geometry/cylinder")
    assert radius is not None
    assert float(radius.get("radius", "0")) == pytest.approx(robot.wheel_radius)
    assert _origin(root, "caster_back_joint")[0] == pytest.approx(robot.caster_x)
