"""A map-consistency figure that needs no ground truth: the share of scan end points that land on free cells.

Every processed scan's end points (beams that hit something within the usable range) are placed with the scan's
final pose into the final map. In a consistent map they fall on occupied cells (or unknown ones at the map's
edges); where a corridor was mapped twice, rotated or shifted (a loop that did not close, a wrong closure), one
pass's walls lie in the other's free space, and its end points land on free cells. The fraction of end points on
free cells (log-odds < 0) with no occupied cell within one cell is the figure: walls a few centimetres apart
are the same wall at this resolution (scan noise, sub-cell corrections of a pose graph), walls doubled by more
than a cell are not. It is a fraction of a percent in a good map (moving people, glass) and much more in a
broken one. :data:`BROKEN_FRACTION` is the line ``mrs-nav bench slam`` fails at.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mrs_nav.slam.slam import Slam

BROKEN_FRACTION = 0.05


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
