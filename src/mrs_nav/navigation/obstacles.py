"""Obstacles the laser sees that the map does not have (a box put in a corridor after mapping): marked for
planning, cleared again when the laser sees through them, and the check that keeps the robot from driving into
a beam return.

:class:`ScanObstacles` keeps a layer of marked cells over the map, as costmap_2d's obstacle layer does. Each scan
(in the map frame: the laser's position and the beam end points, ``hit`` where the beam returned) first clears
the marks on every cell a beam crosses up to ``raytrace_range_m`` from the laser (all of them, found by walking
the beam across the grid lines, up to the cell of its return, which is then marked again if it is still there),
then marks the cells of returns within ``obstacle_range_m`` that the map has as free and that lie farther than
``map_tolerance_m`` from every occupied cell of the map (so range noise on mapped walls marks nothing). Marking
reaches less far than clearing (costmap_2d's rule): a mark placed from one spot is crossed by the beams of the
next scans from about the same spot, and one placed from a pose a little off is still within their reach.
Returns in unknown cells are left to the map while SLAM explores (they are the walls it is about to add, and
marking them would re-inflate the planning grid at every scan); with ``mark_unknown`` (a static saved map, which
never fills its unknown cells) they are marked too, or the planner would keep planning through the unmapped
wall of a room it is in. The planner then sees the map with the marks as occupied (:meth:`ScanObstacles.apply`).

What ray tracing cannot clear: marks in cells no later beam crosses (behind a wall, seen from where the robot is
now, or beyond the clearing range). Such marks come from scans placed at a wrong pose; :mod:`.marking` decides
when scans may mark at all, and :meth:`ScanObstacles.clear` drops marks (move_base's ``clear_costmaps`` and its
clearing recoveries).
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
# m from the laser: returns up to here are marked, beams clear up to there (TurtleBot3 Burger's costmap values;
# the laser reaches 3.5 m).
OBSTACLE_RANGE_M = 3.0
RAYTRACE_RANGE_M = 3.5


class ScanObstacles:
    """The marked cells of one map (re-projected when a new map of another shape or origin comes)."""

    def __init__(
        self,
        map_tolerance_m: float = MAP_TOLERANCE_M,
        mark_unknown: bool = False,
        obstacle_range_m: float = OBSTACLE_RANGE_M,
        raytrace_range_m: float = RAYTRACE_RANGE_M,
    ) -> None:
        self.map_tolerance_m = map_tolerance_m
        self.mark_unknown = mark_unknown
        self.obstacle_range_m = obstacle_range_m
        self.raytrace_range_m = raytrace_range_m
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

    def add_scan(self, origin: npt.ArrayLike, ends: npt.ArrayLike, hit: npt.ArrayLike, mark: bool = True) -> bool:
        """Clear along the beams from ``origin`` (``(2,)``, m, map frame) to ``ends`` (``(N, 2)``) and, with
        ``mark``, mark the returns (``hit``, ``(N,)`` bool) not on the map. Whether the marks changed."""
        if self._raw is None or self.marks is None:
            return False
        o = np.asarray(origin, dtype=np.float64)[:2]
        e = np.asarray(ends, dtype=np.float64).reshape(-1, 2)
        returned = np.asarray(hit, dtype=bool).reshape(-1)
        before = self.marks.copy()
        lengths = np.hypot(*(e - o).T)
        if before.any():  # nothing to clear otherwise: the common case costs no ray casting
            # a beam longer than the clearing range clears up to it, and its end cell is not a return there
            scale = np.minimum(1.0, self.raytrace_range_m / np.maximum(lengths, 1e-9))
            rows, cols = beam_cells(self._raw, o, o + scale[:, None] * (e - o), returned & (scale >= 1.0))
            self.marks[rows, cols] = False
        if mark:
            self._mark(e[returned & (lengths <= self.obstacle_range_m)])
        return not np.array_equal(before, self.marks)

    def clear(self, around: npt.ArrayLike | None = None, beyond_m: float = 0.0) -> int:
        """Drop the marks farther than ``beyond_m`` from ``around`` (``(2,)``, m, map frame; None: all of them),
        as move_base's clearing recoveries do. How many cells were unmarked."""
        if self._raw is None or self.marks is None or not self.marks.any():
            return 0
        rows, cols = np.nonzero(self.marks)
        if around is not None:
            centres = cell_centres(self._raw, rows, cols)
            p = np.asarray(around, dtype=np.float64)[:2]
            far = np.hypot(centres[:, 0] - p[0], centres[:, 1] - p[1]) > beyond_m
            rows, cols = rows[far], cols[far]
        self.marks[rows, cols] = False
        return int(rows.size)

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


def beam_cells(
    grid: OccupancyGrid, origin: FloatArray, ends: FloatArray, returned: BoolArray
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Rows and columns (inside ``grid``) of every cell the beams from ``origin`` (``(2,)``) to ``ends``
    (``(N, 2)``) cross, without the end cell of a beam that ``returned`` (``(N,)``): each beam is cut where it
    crosses a grid line and the cell of each piece's middle taken, so no cell it touches is skipped (a beam
    sampled at fixed steps can skip the corner of a cell, and with it a diagonal line of marks)."""
    x0, y0, yaw = grid.origin
    c, s = math.cos(yaw), math.sin(yaw)
    points = np.vstack((origin[None, :], ends)) - (x0, y0)
    uv = np.column_stack((c * points[:, 0] + s * points[:, 1], -s * points[:, 0] + c * points[:, 1]))
    uv /= grid.resolution  # in cells, along the grid's columns and rows
    start, stop = uv[0], uv[1:]
    n = stop.shape[0]
    pieces = [np.zeros(n), np.ones(n)]
    beams = [np.arange(n), np.arange(n)]
    for axis in (0, 1):
        low = np.floor(np.minimum(start[axis], stop[:, axis]))
        counts = (np.floor(np.maximum(start[axis], stop[:, axis])) - low).astype(np.intp)
        beam = np.repeat(np.arange(n), counts)
        lines = low[beam] + 1.0 + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        span = stop[beam, axis] - start[axis]
        pieces.append((lines - start[axis]) / np.where(span == 0.0, 1.0, span))
        beams.append(beam)
    t, beam = np.concatenate(pieces), np.concatenate(beams)
    order = np.argsort(beam * 2.0 + t)  # by beam, then along it (t lies in [0, 1])
    t, beam = t[order], beam[order]
    same = beam[1:] == beam[:-1]
    middle = (t[1:] + t[:-1])[same] / 2.0
    which = beam[1:][same]
    last = np.ones(which.size, dtype=bool)  # the piece that ends a beam holds its end cell
    last[:-1] = which[1:] != which[:-1]
    keep = ~(last & returned[which])
    middle, which = middle[keep], which[keep]
    cells = start + middle[:, None] * (stop[which] - start)
    col, row = np.floor(cells[:, 0]).astype(np.intp), np.floor(cells[:, 1]).astype(np.intp)
    inside = (col >= 0) & (col < grid.width) & (row >= 0) & (row < grid.height)
    return row[inside], col[inside]


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
