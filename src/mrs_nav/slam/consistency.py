"""A map-consistency figure that needs no ground truth: the share of scan end points that land on free cells.

Every processed scan's end points (beams that hit something within the usable range) are placed with the scan's
final pose into the final map. In a consistent map they fall on occupied cells (or unknown ones at the map's
edges); where a corridor was mapped twice, rotated or shifted (a loop that did not close, a wrong closure), one
pass's walls lie in the other's free space, and its end points land on free cells. The fraction of end points on
free cells (log-odds < 0) with no occupied cell within one cell is the figure: walls a few centimetres apart
are the same wall at this resolution (scan noise, sub-cell corrections of a pose graph), walls doubled by more
than a cell are not. It is a fraction of a percent in a good map (moving people, glass) and much more in a
broken one. :data:`BROKEN_FRACTION` is the line ``mrs-nav bench slam`` fails at.

:func:`revisit_spread` is a finer figure for comparing trajectories of the same scans (this SLAM's against a
reference's): how closely end points of scans taken far apart in time agree.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.matcher import thin_points
from mrs_nav.slam.slam import Slam

BROKEN_FRACTION = 0.05
REVISIT_GAP = 60  # scans apart: what a scan's own neighbours in time see is not a revisit
REVISIT_REACH_M = 0.3  # m: farther apart, two end points are not the same wall
REVISIT_CELL_M = 0.05  # m: one end point per cell of this size per scan
REVISIT_NEIGHBOURS = 32  # nearest end points examined per end point


def free_endpoint_fraction(slam: Slam) -> float:
    """Share of the processed scans' end points on free cells, away from any wall, of the final map (0 if
    there are none)."""
    grid = slam.grid
    # Free and not next to an occupied cell (3 x 3 neighbourhood).
    stray = (grid.logodds < 0.0) & ~ndimage.binary_dilation(grid.logodds > 0.0, np.ones((3, 3), dtype=bool))
    on_free = total = 0
    for record in slam.processed:
        if record.beams is None or record.beams.hit_ranges.size == 0:
            continue
        sensor = record.pose.compose(record.laser_pose)
        beams = record.beams.split()
        angles = beams.hit_angles + sensor.yaw
        x = sensor.x + beams.hit_ranges * np.cos(angles)
        y = sensor.y + beams.hit_ranges * np.sin(angles)
        ix, iy = grid.cell_of(x, y)
        inside = (ix >= 0) & (ix < grid.width) & (iy >= 0) & (iy < grid.height)
        on_free += int(np.count_nonzero(stray[iy[inside], ix[inside]]))
        total += int(x.size)
    return on_free / total if total else 0.0


def revisit_spread(sensor_poses: Sequence[Pose2D], points: Sequence[FloatArray], min_gap: int = REVISIT_GAP) -> float:
    """How well scans taken far apart in time agree where they see the same walls, with no reference: the
    median distance (m) from each end point to the nearest end point of a scan at least ``min_gap`` scans
    away, over the end points that have one within :data:`REVISIT_REACH_M`.

    ``points``: each scan's end points in its sensor frame (N x 2), placed by ``sensor_poses``. Two
    trajectories of the same scans compare by it: the one whose revisits agree better has the smaller figure
    (a closed loop that still leaves walls a few centimetres apart, or a map stretched against its scans,
    raises it). End points are thinned to one per :data:`REVISIT_CELL_M` cell per scan, which bounds the
    memory of the neighbour search.
    """
    if len(sensor_poses) != len(points):
        raise InvalidInputError(f"revisit spread: {len(sensor_poses)} poses for {len(points)} scans")
    world, owner = [], []
    for k, (pose, local) in enumerate(zip(sensor_poses, points, strict=True)):
        thinned = thin_points(np.asarray(local, dtype=np.float64).reshape(-1, 2), REVISIT_CELL_M)
        world.append(pose.apply(thinned))
        owner.append(np.full(thinned.shape[0], k))
    xy, scan = np.concatenate(world), np.concatenate(owner)
    if xy.shape[0] == 0:
        return math.nan
    distance, index = cKDTree(xy).query(xy, k=REVISIT_NEIGHBOURS, distance_upper_bound=REVISIT_REACH_M)
    found = np.isfinite(distance)
    # Missing neighbours come back with index == number of points: clamp before looking up their scan.
    far = found & (np.abs(scan[np.minimum(index, xy.shape[0] - 1)] - scan[:, None]) >= min_gap)
    nearest = np.where(far, distance, np.inf).min(axis=1)
    nearest = nearest[np.isfinite(nearest)]
    return float(np.median(nearest)) if nearest.size else math.nan
