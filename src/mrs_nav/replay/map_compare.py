"""Agreement of two occupancy maps of the same place (a recorded ``/map`` and a replayed one).

Both grids are put on the lattice of the first (same resolution expected; cell centres of the second are
binned into it). Only cells known (not -1) in both maps are compared, so a map published a few scans before
the end of a recording is not penalised for what it had not yet seen:

* ``iou`` = |A ∩ B| / |A ∪ B| over the occupied cells A, B (1 when neither has any);
* ``iou_1cell`` = (|A ∩ dil(B)| + |B ∩ dil(A)|) / (|A| + |B|), dil = growth by one cell (8-neighbourhood):
  the share of occupied cells with a counterpart within one cell, symmetric in A and B.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.errors import InvalidInputError
from mrs_nav.maps.occupancy_grid import OccupancyGrid

BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class MapAgreement:
    """Occupied-cell IoU strict and within one cell, and the number of cells known in both maps."""

    iou: float
    iou_1cell: float
    common_known_cells: int


def _on_lattice(grid: OccupancyGrid, lattice: OccupancyGrid) -> tuple[BoolArray, BoolArray]:
    """Known and occupied masks of ``grid`` binned onto the cells of ``lattice``."""
    rows, cols = np.nonzero(grid.values >= 0)
    x0, y0, yaw = grid.origin
    u, v = (cols + 0.5) * grid.resolution, (rows + 0.5) * grid.resolution
    c, s = math.cos(yaw), math.sin(yaw)
    points = np.column_stack([x0 + c * u - s * v, y0 + s * u + c * v])
    lrow, lcol, inside = lattice.cells_of(points)
    occupied = grid.occupied_mask[rows, cols]
    known = np.zeros(lattice.values.shape, dtype=bool)
    occ = np.zeros(lattice.values.shape, dtype=bool)
    known[lrow[inside], lcol[inside]] = True
    occ[lrow[inside & occupied], lcol[inside & occupied]] = True
    return known, occ


def compare_maps(a: OccupancyGrid, b: OccupancyGrid) -> MapAgreement:
    """Agreement of ``b`` with ``a`` over the cells both know (see the module docstring)."""
    if not math.isclose(a.resolution, b.resolution, rel_tol=1e-6):
        raise InvalidInputError(f"maps have different resolutions: {a.resolution} m and {b.resolution} m")
    known_b, occ_b = _on_lattice(b, a)
    common = (a.values >= 0) & known_b
    occ_a = a.occupied_mask & common
    occ_b &= common
    union = int(np.count_nonzero(occ_a | occ_b))
    iou = 1.0 if union == 0 else int(np.count_nonzero(occ_a & occ_b)) / union
    ring = np.ones((3, 3), dtype=bool)
    total = int(np.count_nonzero(occ_a)) + int(np.count_nonzero(occ_b))
    matched = np.count_nonzero(occ_a & ndimage.binary_dilation(occ_b, ring)) + np.count_nonzero(
        occ_b & ndimage.binary_dilation(occ_a, ring)
    )
    iou_1cell = 1.0 if total == 0 else int(matched) / total
    return MapAgreement(iou, iou_1cell, int(np.count_nonzero(common)))
