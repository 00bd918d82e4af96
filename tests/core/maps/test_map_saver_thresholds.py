"""map_saver's thresholds and a map SLAM produced: saved and loaded back, every cell keeps its class."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.map_io import load_map, save_map
from mrs_nav.maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid
from mrs_nav.maps.world import load_world
from mrs_nav.slam.eval.sim_drive import drive_with_slam
from tests.conftest import WORLDS


def test_occ_and_free_thresholds_decide_the_written_class(tmp_path: Path) -> None:
    grid = OccupancyGrid(np.array([[0, 19, 25, 26, 64, 65, 100, -1]], dtype=np.int8), 0.05)
    loaded = load_map(save_map(grid, tmp_path / "m.yaml", occupied_min=65, free_max=25))
    assert loaded.values.tolist() == [[0, 0, 0, UNKNOWN, UNKNOWN, OCCUPIED, OCCUPIED, UNKNOWN]]
    with pytest.raises(InvalidInputError, match="free"):
        save_map(grid, tmp_path / "bad.yaml", occupied_min=20, free_max=30)


def test_a_slam_map_round_trips_through_map_saver_files(tmp_path: Path) -> None:
    result = drive_with_slam(load_world(WORLDS / "simple.world"), Pose2D(-1.5, -1.5, 0.0), ((1.5, -1.5), (1.5, 1.5)))
    grid = OccupancyGrid(
        result.slam.grid.to_occupancy(),
        result.slam.grid.resolution,
        (result.slam.grid.origin_x, result.slam.grid.origin_y, 0.0),
    )
    loaded = load_map(save_map(grid, tmp_path / "arena.yaml", occupied_min=65, free_max=25))
    assert loaded.origin == pytest.approx(grid.origin)
    assert loaded.resolution == pytest.approx(grid.resolution)
    occupied = grid.values >= 65
    free = (grid.values >= 0) & (grid.values <= 25)
    assert occupied.sum() > 100  # walls and the cylinder were seen
    assert np.array_equal(loaded.values == OCCUPIED, occupied)
    assert np.array_equal(loaded.values == 0, free)
    assert np.array_equal(loaded.values == UNKNOWN, ~occupied & ~free)
