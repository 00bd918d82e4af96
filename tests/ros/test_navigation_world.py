"""``navigation.launch map_file:=`` simulates the world the map was saved in, and says so when told another
(it used to simulate the small arena under an office map without a word)."""

from __future__ import annotations

import xmlrpc.client
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.resources import WORLDS_DIR
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

ARGS = ("navigation:=false", "open_rviz:=false", "x:=-5", "y:=-5")


def _has_service(ros_master: RosMaster, name: str) -> bool:
    code, _, _ = xmlrpc.client.ServerProxy(ros_master.uri).lookupService("/pytest", name)
    return bool(code == 1)


def _launch_log(ros_master: RosMaster, before: set[Path]) -> Path:
    new = set(ros_master.log_dir.glob("navigation-*.log")) - before
    assert len(new) == 1, new
    return new.pop()


def test_the_maps_world_is_simulated_and_another_given_world_is_one_warning(
    ros_master: RosMaster, tmp_path: Path
) -> None:
    office = WORLDS_DIR / "office.world"
    grid = OccupancyGrid(np.zeros((400, 400), dtype=np.int8), 0.05, (-10.0, -10.0, 0.0))
    map_file = save_map(grid, tmp_path / "office.yaml", world=str(office))
    for world_arg, world, warned in (((), office, False), (("world:=simple",), WORLDS_DIR / "simple.world", True)):
        before = set(ros_master.log_dir.glob("navigation-*.log"))
        with ros_master.launch("navigation.launch", f"map_file:={map_file}", *world_arg, *ARGS) as proc:
            log = _launch_log(ros_master, before)
            wait_for(lambda: "simulator: " in log.read_text(errors="replace"), 90.0, "the simulator's world")  # noqa: B023
            wait_for(lambda: _has_service(ros_master, "/static_map"), 60.0, "the map server up (its check done)")
            assert proc.poll() is None
        text = log.read_text(errors="replace")
        assert f"simulator: {world}," in text
        warnings = [line for line in text.splitlines() if "was made in" in line]
        assert len(warnings) == (1 if warned else 0), text
        if warned:
            assert f"the map {map_file} was made in {office}, but the simulator runs {world}" in warnings[0]
