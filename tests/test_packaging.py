"""The package as users meet it: catkin workspace build, the mrs-nav entry point, a ROS-free core."""

from __future__ import annotations

import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import mrs_nav
from mrs_nav.cli.main import SUBCOMMANDS
from tests.rosharness import REPO, ros_env


def test_mrs_nav_help_lists_every_subcommand() -> None:
    out = subprocess.run([sys.executable, "-m", "mrs_nav", "--help"], capture_output=True, text=True, check=True)
    for name in SUBCOMMANDS:
        assert name in out.stdout


def test_core_imports_without_rospy() -> None:
    """Every core module imports in a process where rospy, tf2 and message packages cannot be imported."""
    core = [
        m.name
        for m in pkgutil.walk_packages(mrs_nav.__path__, "mrs_nav.")
        if not m.name.startswith("mrs_nav.ros") and m.name != "mrs_nav.__main__"
    ]
    script = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        root = name.split('.')[0]\n"
        "        if root in ('rospy', 'tf', 'tf2_ros', 'roslib', 'genpy') or root.endswith('_msgs'):\n"
        "            raise ImportError('core imported ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        f"for m in {core!r}:\n"
        "    __import__(m)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, check=False)
    assert result.returncode == 0, result.stderr


@pytest.mark.ros
def test_catkin_make_builds_a_workspace_that_finds_the_package(tmp_path: Path) -> None:
    src = tmp_path / "ws" / "src"
    src.mkdir(parents=True)
    (src / "mrs_nav").symlink_to(REPO)
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "ROS_HOME": str(tmp_path / "ros")}
    script = (
        "set -e\n"
        "catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 > build.log 2>&1 || { tail -30 build.log; exit 1; }\n"
        "source devel/setup.bash\n"
        "rospack find mrs_nav\n"
        "/usr/bin/python3 -c 'import mrs_nav.maps.world, sys; print(mrs_nav.maps.world.__file__)'\n"
    )
    result = subprocess.run(
        ["bash", "-c", script], cwd=tmp_path / "ws", env=env, capture_output=True, text=True, check=False, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    found, module = result.stdout.split()[-2:]
    assert Path(found).resolve() == REPO
    assert Path(module).resolve() == REPO / "src" / "mrs_nav" / "maps" / "world.py"


def test_a_closed_pipe_is_not_an_error() -> None:
    """``mrs-nav plan --json | head -c 10``: the reader leaves early, the command exits without a traceback."""
    cmd = (
        f"{sys.executable} -m mrs_nav plan --world {REPO / 'worlds' / 'simple.world'} --planner rrt_star "
        "--start -1.5,-1.5,0 --goal 1.5,1.5 --seed 1 --iterations 300 --json | head -c 10"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    result = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, env=env, check=False)
    assert result.stdout == '{"success"'
    assert "Traceback" not in result.stderr, result.stderr


@pytest.mark.parametrize("launch", sorted((REPO / "launch").glob("*.launch")), ids=lambda p: p.name)
def test_roslaunch_reads_every_launch_file(launch: Path, tmp_path: Path) -> None:
    """roslaunch's own loader (``roslaunch --files``: parse, resolve every $(find)/$(arg)/$(eval), list the files
    included) accepts each launch file with its default arguments; XML that is not well formed, such as ``--``
    inside a comment, fails here rather than at a user's first launch."""
    args = ["robot:=tb3_0"] if launch.name == "multi_robot_one.launch" else []  # its one required argument
    env = ros_env("http://127.0.0.1:1", tmp_path)  # no master: --files only reads
    result = subprocess.run(
        ["roslaunch", "--files", str(launch), *args], capture_output=True, text=True, env=env, timeout=60, check=False
    )
    assert result.returncode == 0, result.stderr + result.stdout
    assert str(launch) in result.stdout
