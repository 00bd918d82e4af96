"""Trajectory simplification by collision-free shortcuts with back-tracking (assignment Figure 6).

Given waypoints ``p_0 .. p_{N-1}`` and a checker saying which straight segments are collision free:

1. From the last kept point ``p_i``, walk forward along the trajectory while the shortcut ``p_i p_j`` stays
   free, and keep the last waypoint ``p_j`` of that run (at least ``p_{i+1}``).
2. Back-track: while the kept point before last can see the newest one directly (``k_{m-2} k_m`` free),
   drop ``k_{m-1}``.
3. Repeat until the last waypoint is kept.

Every segment of the result was checked free, so the simplified path is collision free whenever the checker
is; it is not the shortest path (its corners are trajectory points) but it removes the random walk's noise.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray

#: ``free(starts (M, 2), ends (M, 2)) -> (M,) bool``: whether each straight segment is collision free.
SegmentChecker = Callable[[FloatArray, FloatArray], npt.NDArray[np.bool_]]


def simplify_path(points: npt.ArrayLike, free: SegmentChecker, *, backtrack: bool = True) -> FloatArray:
    """The simplified ``(K, 2)`` polyline through a subset of ``points`` ``(N, >=2)``, endpoints kept.

    ``backtrack=False`` skips step 2 (to show what back-tracking adds).

    Where the input itself crosses an obstacle and no shortcut avoids it, the result keeps the input's
    segment: the simplification never makes a path worse, but it cannot repair one.
    """
    pts = np.asarray(points, dtype=np.float64)[:, :2]
    n = pts.shape[0]
    if n <= 2:
        return pts.copy()
    kept = [0]
    i = 0
    while i < n - 1:
        later = np.arange(i + 1, n)
        visible = free(np.repeat(pts[i : i + 1], later.size, axis=0), pts[later])
        blocked = np.flatnonzero(~visible)
        # the end of the run of free segments p_i p_{i+1}, p_i p_{i+2}, ... (at least one step forward)
        j = int(later[blocked[0] - 1]) if blocked.size and blocked[0] > 0 else (i + 1 if blocked.size else n - 1)
        kept.append(j)
        while backtrack and len(kept) >= 3 and bool(free(pts[kept[-3]][None, :], pts[kept[-1]][None, :])[0]):
            del kept[-2]
        i = j
    return pts[kept].copy()
