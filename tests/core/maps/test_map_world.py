"""A saved map names the world it was made in; navigation.launch takes it from there and says when they differ."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mrs_nav.errors import MapFileError
from mrs_nav.maps.map_io import load_map, save_map
from mrs_nav.maps.map_world import disagreement, saved_world, world_of_map, world_path
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.resources import CHECKOUT, WORLDS_DIR

GRID = OccupancyGrid(np.zeros((4, 5), dtype=np.int8), 0.05, (0.0, 0.0, 0.0))
OFFICE = str(WORLDS_DIR / "office.world")


def test_the_saved_map_keeps_its_world_and_map_server_still_reads_it(tmp_path: Path) -> None:
    path = save_map(GRID, tmp_path / "office.yaml", world=OFFICE)
    assert "mrs_nav_world: " in path.read_text()
    assert saved_world(path) == Path(OFFICE)
    assert world_of_map(path) == Path(OFFICE)
    assert load_map(path).values.shape == (4, 5)


def test_a_map_without_its_world_says_what_to_give(tmp_path: Path) -> None:
    path = save_map(GRID, tmp_path / "old.yaml")
    assert saved_world(path) is None
    assert disagreement(path, OFFICE) is None
    with pytest.raises(MapFileError, match=r"old.yaml does not name the world it was made in .*give world:=FILE"):
        world_of_map(path)


def test_the_shipped_map_names_its_world() -> None:
    assert world_of_map(CHECKOUT / "maps" / "simple.yaml") == WORLDS_DIR / "simple.world"


def test_another_world_than_the_maps_is_one_line_naming_both(tmp_path: Path) -> None:
    path = save_map(GRID, tmp_path / "office.yaml", world=OFFICE)
    assert disagreement(path, OFFICE) is None
    assert disagreement(path, "office") is None  # the simulator's bare names
    assert disagreement(path, str(path)) is None  # the world taken from the map itself
    note = disagreement(path, str(WORLDS_DIR / "simple.world"))
    assert note is not None
    assert "\n" not in note
    assert f"was made in {OFFICE}, but the simulator runs {WORLDS_DIR / 'simple.world'}" in note


def test_bare_names_are_the_package_worlds() -> None:
    assert world_path("office") == WORLDS_DIR / "office.world"
    assert world_path("office.world") == WORLDS_DIR / "office.world"
    assert world_path("/tmp/x.world") == Path("/tmp/x.world")
