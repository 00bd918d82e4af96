"""Whether a scan fits somewhere else in the map far better than near the current belief: the check that refutes
a given pose (a 2D Pose Estimate, the initial pose) that is wrong by metres.

The filter's own test of a lost pose is relative (the fast average fit falling below half the slow one, AMCL's
``w_fast / w_slow``): both averages start at the first scan's fit, so a pose wrong from the first scan never
looks lost. Issue 38: the initial pose left at the mapping start while the robot stood 11 m away in a corridor
much like the one at the start; the cloud settled on the look-alike, was called confident, and the goal was
reported reached 11 m from the robot. An absolute floor on the fit cannot tell that from a box or a person in
view, which lowers the fit at the true pose as much. Nor can a test that asks whether beams pass through walls
the map knows at the estimate: in the office's corridors the cloud shifts until few of them do (2-11 % of the
beams at the wrong estimate after one update, against up to 7 % at the truth).

This check compares instead: the best mean beam log-likelihood over a grid of poses covering the map's known
free space (every ``STRIDE_M`` and ``HEADINGS`` headings) against the best near the belief (its particles and the
grid poses within ``NEAR_M`` and ``NEAR_RAD`` of the estimate). Near the truth the two are equal (the belief's
own particles are closer to the truth than the grid), so a correct pose is never refuted, a look-alike that
fits as well does not refute it either, and an unmapped obstacle in view lowers both alike. A pose 1 m / 30 deg
off is near enough not to be refuted (the filter corrects it locally, or the user's next estimate does). Measured
on the office's saved map at 0.2 m spread: the issue's pose wrong by 11 m, 0.30-0.42 nats per beam on the first
update and 0.17-0.23 on the second (the cloud shifts to fit locally); a correct one within 0.3 m / 15 deg, at
most 0.0. Scoring the grid (about 70 000 poses for the office's saved map) takes about 0.1 s
of CPU: it runs only for the first few updates after a pose is given.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray, Pose2D, wrap_angles
from mrs_nav.localisation.likelihood_field import LikelihoodField

STRIDE_M = 0.2  # m between grid positions
HEADINGS = 36  # grid headings per position (10 degrees apart)
NEAR_M = 1.5  # m: grid poses this close to the estimate count as near it
NEAR_RAD = 0.8  # rad: and this close in heading
_BLOCK = 8192  # poses scored at once (bounds the memory of one update to some tens of MB)


class GlobalMatch:
    """The grid of candidate poses over a map's known free space, scored by a likelihood field."""

    def __init__(self, field: LikelihoodField, free_cells: npt.NDArray[np.intp]) -> None:
        self.field = field
        g = field.grid
        row, col = np.divmod(free_cells, g.width)
        every = max(1, round(STRIDE_M / g.resolution))
        on_grid = (row % every == 0) & (col % every == 0)
        x = g.origin[0] + (col[on_grid] + 0.5) * g.resolution
        y = g.origin[1] + (row[on_grid] + 0.5) * g.resolution
        headings = np.linspace(-math.pi, math.pi, HEADINGS, endpoint=False)
        self.candidates: FloatArray = np.column_stack(
            [np.repeat(x, HEADINGS), np.repeat(y, HEADINGS), np.tile(headings, x.size)]
        )

    def margin(self, estimate: Pose2D, particles: FloatArray, ex: FloatArray, ey: FloatArray, sigma: float) -> float:
        """How much better (nats per beam) the scan's endpoints ``ex``, ``ey`` (m, robot base frame) fit the best
        candidate anywhere than the best of the ``particles`` and the candidates near ``estimate``; <= 0 when the
        best place is near the belief."""
        c = self.candidates
        scores = self._scores(c, ex, ey, sigma)
        near = (np.hypot(c[:, 0] - estimate.x, c[:, 1] - estimate.y) <= NEAR_M) & (
            np.abs(wrap_angles(c[:, 2] - estimate.yaw)) <= NEAR_RAD
        )
        local = float(self._scores(particles, ex, ey, sigma).max())
        if np.any(near):
            local = max(local, float(scores[near].max()))
        return float(scores.max()) - local if scores.size else 0.0

    def _scores(self, poses: FloatArray, ex: FloatArray, ey: FloatArray, sigma: float) -> FloatArray:
        out = np.empty(len(poses))
        for start in range(0, len(poses), _BLOCK):
            p = poses[start : start + _BLOCK]
            cos, sin = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
            xs = p[:, 0, None] + cos * ex - sin * ey
            ys = p[:, 1, None] + sin * ex + cos * ey
            out[start : start + len(p)] = self.field.mean_log_p(xs, ys, sigma)
        return out
