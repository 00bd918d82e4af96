import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.replay.map_compare import compare_maps

RES = 0.05


def _room(shift_cells: int = 0, origin=(0.0, 0.0, 0.0), size: int = 40) -> OccupancyGrid:
    """Free square room of ``size`` cells with occupied walls; the right wall moved by ``shift_cells``."""
    values = np.zeros((size, size), dtype=np.int8)
    values[0, :] = values[-1, :] = values[:, 0] = 100
    values[:, size - 5 + shift_cells] = 100
    return OccupancyGrid(values, RES, origin)


def test_identical_maps_agree_fully():
    agreement = compare_maps(_room(), _room())
    assert (agreement.iou, agreement.iou_1cell) == (1.0, 1.0)
    assert agreement.common_known_cells == 40 * 40


def test_a_wall_one_cell_off_counts_only_in_the_strict_iou():
    agreement = compare_maps(_room(), _room(shift_cells=1))
    walls = 2 * 40 + (40 - 2)  # top, bottom and left walls (corners once), whose cells agree
    moved = 40 - 2  # the inner wall's cells not on the top and bottom walls
    assert agreement.iou == pytest.approx(walls / (walls + 2 * moved))
    assert agreement.iou_1cell == 1.0


def test_only_cells_known_in_both_maps_count():
    partial = _room().values.copy()
    partial[:, 20:] = -1  # not yet seen: the right wall is unknown
    moved = _room(shift_cells=2)
    agreement = compare_maps(OccupancyGrid(partial, RES), moved)
    assert agreement.iou == 1.0
    assert agreement.common_known_cells == 40 * 20


def test_grids_with_other_origins_are_compared_in_the_map_frame():
    big = np.full((60, 60), -1, dtype=np.int8)
    big[10:50, 5:45] = _room().values  # the same room, in a larger grid starting 5 and 10 cells earlier
    agreement = compare_maps(_room(), OccupancyGrid(big, RES, (-5 * RES, -10 * RES, 0.0)))
    assert (agreement.iou, agreement.common_known_cells) == (1.0, 40 * 40)


def test_resolutions_must_match():
    with pytest.raises(InvalidInputError, match=r"different resolutions: 0\.05 m and 0\.1 m"):
        compare_maps(_room(), OccupancyGrid(np.zeros((3, 3), dtype=np.int8), 0.1))
