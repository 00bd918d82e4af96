"""The project's worlds are SDF that Gazebo itself would load: checked with libsdformat, Gazebo's own parser.

Gazebo is not packaged for Debian 12, but its SDF parser is (libsdformat12). A small C++ program built at test
time loads each world through ``sdf::Root::Load`` and prints every error; ``model://ground_plane`` and
``model://sun`` resolve to minimal copies of Gazebo's stock models in ``tests/sdformat/models``.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from mrs_nav.maps.world import load_world
from tests.rosharness import REPO

HERE = REPO / "tests" / "sdformat"
WORLDS = sorted((REPO / "worlds").glob("*.world"))


@pytest.fixture(scope="module")
def sdf_check(tmp_path_factory: pytest.TempPathFactory) -> Path:
    flags = subprocess.run(
        ["pkg-config", "--cflags", "--libs", "sdformat12"], capture_output=True, text=True, check=True
    ).stdout.split()
    exe = tmp_path_factory.mktemp("sdformat") / "sdf_check"
    subprocess.run(["g++", "-std=c++17", str(HERE / "sdf_check.cc"), *flags, "-o", str(exe)], check=True)
    return exe


def _check(exe: Path, world: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(exe), str(HERE / "models"), str(world)], capture_output=True, text=True, check=False)


@pytest.mark.parametrize("world", WORLDS, ids=[w.stem for w in WORLDS])
def test_libsdformat_loads_the_world_and_so_does_ours(sdf_check: Path, world: Path) -> None:
    result = _check(sdf_check, world)
    assert result.returncode == 0, result.stdout + result.stderr
    ours = load_world(world)
    assert ours.boxes or ours.cylinders


def test_the_checker_rejects_malformed_sdf(sdf_check: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.world"
    bad.write_text(
        '<sdf version="1.6"><world name="w"><model name="m"><static>true</static><link name="l">'
        '<collision name="c"><geometry><box><size>1 1</size></box></geometry></collision></link></model>'
        "</world></sdf>"
    )
    result = _check(sdf_check, bad)
    assert result.returncode == 1
    assert "size" in result.stdout
