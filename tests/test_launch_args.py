"""Every shipped launch file explains its arguments (``roslaunch --ros-args``), and TurtleBot3's arguments
(``model``, ``open_rviz``) do what a TurtleBot3 user expects: checked with Debian's roslaunch itself."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from xml.etree import ElementTree

import pytest

from mrs_nav.resources import CHECKOUT

LAUNCHES = sorted((CHECKOUT / "launch").glob("*.launch"))
# The TurtleBot3-style launch files: usable alone or on top of each other, with TurtleBot3's arguments.
STACK = ("simulation.launch", "slam.launch", "navigation.launch", "rrt_navigation.launch")


def _roslaunch(*args: str) -> subprocess.CompletedProcess[str]:
    """Debian's roslaunch on this checkout; none of these options contacts a master."""
    env = {**os.environ, "ROS_PACKAGE_PATH": str(CHECKOUT), "ROS_MASTER_URI": "http://127.0.0.1:1"}
    return subprocess.run(["roslaunch", *args], env=env, capture_output=True, text=True, timeout=60, check=False)


@pytest.mark.parametrize("launch", LAUNCHES, ids=lambda p: p.name)
def test_every_argument_a_user_can_set_carries_a_doc(launch: Path) -> None:
    undocumented = [
        arg.get("name")
        for arg in ElementTree.parse(launch).getroot().iter("arg")
        if arg.get("value") is None and not arg.get("doc")  # value= inside <include> passes one on
    ]
    assert not undocumented, f"{launch.name}: give doc= to {undocumented}"


@pytest.mark.parametrize("launch", LAUNCHES, ids=lambda p: p.name)
def test_roslaunch_ros_args_documents_every_argument(launch: Path) -> None:
    done = _roslaunch("--ros-args", "mrs_nav", launch.name)
    assert done.returncode == 0, done.stderr
    listed = [line for line in done.stdout.splitlines() if line.startswith("  ")]
    declared = {a.get("name") for a in ElementTree.parse(launch).getroot().iter("arg") if a.get("value") is None}
    assert len(listed) == len(declared), done.stdout
    assert "undocumented" not in done.stdout


@pytest.mark.parametrize("launch", STACK)
def test_the_stack_asks_for_no_argument(launch: str) -> None:
    """play and play_options were listed as required (an empty default reads as none to roslaunch)."""
    assert "Required Arguments" not in _roslaunch("--ros-args", "mrs_nav", launch).stdout


def _nodes(launch: str, *args: str) -> list[str]:
    done = _roslaunch("--nodes", "mrs_nav", launch, *args)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


@pytest.mark.parametrize("launch", STACK)
def test_open_rviz_false_starts_no_rviz(launch: str) -> None:
    shown = ("headless:=false",) if launch == "simulation.launch" else ()
    assert "/rviz" in _nodes(launch, *shown)
    assert "/rviz" not in _nodes(launch, *shown, "open_rviz:=false")


@pytest.mark.parametrize("launch", STACK)
def test_a_model_other_than_burger_is_refused_with_one_line(launch: str) -> None:
    assert _nodes(launch, "model:=burger")
    done = _roslaunch("--nodes", "mrs_nav", launch, "model:=waffle")
    assert done.returncode == 1
    said = [line for line in (done.stdout + done.stderr).splitlines() if "model" in line]
    assert len(said) == 1, done.stdout + done.stderr
    assert "model:=burger (mrs_nav simulates the TurtleBot3 Burger only; got model:=waffle)" in said[0]


@pytest.mark.parametrize("launch", ["slam.launch", "navigation.launch", "rrt_navigation.launch"])
def test_sim_false_starts_neither_simulator_nor_robot_state_publisher(launch: str) -> None:
    """On top of simulation.launch (or a robot) a second robot_state_publisher killed the first."""
    assert {"/simulator", "/robot_state_publisher"} <= set(_nodes(launch))
    assert not {"/simulator", "/robot_state_publisher"} & set(_nodes(launch, "sim:=false"))
