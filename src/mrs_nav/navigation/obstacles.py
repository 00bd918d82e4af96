"""Obstacles the laser sees that the map does not have (a box put in a corridor after mapping): marked for
planning, cleared again when the laser sees through them, and the check that keeps the robot from driving into
a beam return.

:class:`ScanObstacles` keeps a layer of marked cells over the map. Each scan (in the map frame: the laser's
position and the beam end points, ``hit`` where the beam returned) first clears the marks on the cells every
beam passed through (up to the cell before its return), then marks the cells of returns that the map has as
free and that lie farther than ``map_tolerance_m`` from every occupied cell of the map (so range noise on mapped
walls marks nothing). Returns in unknown cells are left to the map while SLAM explores (they are the walls it is
about to add, and marking them would re-inflate the planning grid at every scan); with ``mark_unknown`` (a static
saved map, which never fills its unknown cells) they are marked too, or the planner would keep planning through
the unmapped wall of a room it is in. The planner then sees the map with the marks as occupied
(:meth:`ScanObstacles.apply`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OCCUPIED, BoolArray, OccupancyGrid
from mrs_nav.navigation.plan_worker import cell_centres

# Returns this close to a mapped obstacle are that obstacle (range noise, drift of the pose estimate); up to the
# inflation distance this hides nothing from the planner, which keeps that far from the mapped obstacle anyway.
MAP_TOLERANCE_M = 0.2


class ScanObstacles:
    """The marked cells of one map (re-projected when a new map of another shape or origin comes)."""

    def __init__(self, map_tolerance_m: float = MAP_TOLERANCE_M, mark_unknown: bool = False) -> None:
        self.map_tolerance_m = map_tolerance_m
        self.mark_unknown = mark_unknown
        self._raw: OccupancyGrid | None = None
        self._markable: BoolArray | None = None  # free (or unknown) on the map and away from its obstacles
        self.marks: BoolArray | None = None

    def set_map(self, raw: OccupancyGrid) -> None:
        """Take a new map, keeping the marks where they are in the world."""
        old, marks = self._raw, self.marks
        self._raw = raw
        reach = max(1, math.ceil(self.map_tolerance_m / raw.resolution))
        open_cells = ~raw.occupied_mask if self.mark_unknown else raw.free_mask
        self._markable = open_cells & ~ndimage.binary_dilation(raw.occupied_mask, iterations=reach)
        self.marks = np.zeros(raw.values.shape, dtype=bool)
        if old is None or marks is None or not marks.any():
            return
        if old.values.shape == raw.values.shape and old.origin == raw.origin and old.resolution == raw.resolution:
            self.marks = marks & self._markable
            return
        rows, cols = np.nonzero(marks)
        self._mark(cell_centres(old, rows, cols))

    def add_scan(self, origin: npt.ArrayLike, ends: npt.ArrayLike, hit: npt.ArrayLike) -> bool:
        """Clear along the beams from ``origin`` (``(2,)``, m, map frame) to ``ends`` (``(N, 2)``) and mark the
        returns (``hit``, ``(N,)`` bool) not on the map. Whether the marks changed."""
        if self._raw is None or self.marks is None:
            return False
        o = np.asarray(origin, dtype=np.float64)[:2]
        e = np.asarray(ends, dtype=np.float64).reshape(-1, 2)
        returned = np.asarray(hit, dtype=bool).reshape(-1)
        before = self.marks.copy()
        if before.any():  # nothing to clear otherwise: the common case costs no ray casting
            self._clear(o, e, returned)
        self._mark(e[returned])
        return not np.array_equal(before, self.marks)

    def _clear(self, o: FloatArray, e: FloatArray, returned: BoolArray) -> None:
        """Unmark the cells the beams from ``o`` to ``e`` passed through."""
        assert self._raw is not None
        assert self.marks is not None
        raw = self._raw
        # sample each beam every half cell up to one cell short of its return (the whole beam when none)
        lengths = np.hypot(*(e - o).T)
        reach = np.where(returned, lengths - raw.resolution, lengths)
        step = raw.resolution / 2.0
        counts = np.maximum(np.floor(reach / step).astype(np.intp), 0)
        if counts.sum():
            beam = np.repeat(np.arange(e.shape[0]), counts)
            t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) * step
            direction = (e - o) / np.maximum(lengths, 1e-9)[:, None]
            rows, cols, inside = raw.cells(o + t[:, None] * direction[beam])
            self.marks[rows[inside], cols[inside]] = False

    def _mark(self, points: FloatArray) -> None:
        assert self._raw is not None
        assert self.marks is not None
        assert self._markable is not None
        rows, cols, inside = self._raw.cells(points)
        rows, cols = rows[inside], cols[inside]
        new = self._markable[rows, cols]
        self.marks[rows[new], cols[new]] = True

    def apply(self, raw: OccupancyGrid) -> OccupancyGrid:
        """``raw`` with the marked cells occupied (``raw`` itself when nothing is marked)."""
        if self.marks is None or self.marks.shape != raw.values.shape or not self.marks.any():
            return raw
        values = raw.values.copy()
        values[self.marks] = OCCUPIED
        return OccupancyGrid(values, raw.resolution, raw.origin)


def beam_ends(
    laser: Pose2D, angles: npt.ArrayLike, ranges: npt.ArrayLike, range_min: float, range_max: float
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """A laser scan from the scanner pose ``laser`` (map frame) as :meth:`ScanObstacles.add_scan` takes it: the
    laser's position ``(2,)``, the end points ``(N, 2)`` of the beams that saw something (at the return, or at
    ``range_max`` for a beam without one: +inf or beyond ``range_max``, REP 117) and which of them returned.
    NaN and too-short beams saw nothing and are left out."""
    a = np.asarray(angles, dtype=np.float64)
    r = np.asarray(ranges, dtype=np.float64)
    hit = np.isfinite(r) & (r >= range_min) & (r <= range_max)
    keep = hit | np.isposinf(r) | (np.isfinite(r) & (r > range_max))
    reach = np.where(hit, r, range_max)[keep]
    heading = laser.yaw + a[keep]
    ends = np.column_stack((laser.x + reach * np.cos(heading), laser.y + reach * np.sin(heading)))
    return np.array([laser.x, laser.y]), ends, hit[keep]


def return_ahead(pose: Pose2D, returns: FloatArray, robot_radius: float, clearance_m: float) -> bool:
    """Whether a beam return (``(N, 2)``, map frame) lies in the robot's way: ahead of its centre, within
    ``robot_radius`` of its line of travel and within ``robot_radius + clearance_m`` of its centre."""
    if returns.shape[0] == 0:
        return False
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    dx, dy = returns[:, 0] - pose.x, returns[:, 1] - pose.y
    forward, lateral = c * dx + s * dy, -s * dx + c * dy
    close = np.hypot(dx, dy) <= robot_radius + clearance_m
    return bool(np.any((forward > 0.0) & (np.abs(lateral) <= robot_radius) & close))
