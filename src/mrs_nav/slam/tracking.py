"""The front end's matching policy: what is done with a scan whose match near the odometry prediction is weak or
lost (:func:`match_in_grid`), for the SLAM's update (:class:`mrs_nav.slam.slam.Slam`) and the local track
(:mod:`mrs_nav.slam.local_track`) alike. The scan matcher (:mod:`mrs_nav.slam.matcher`) only matches in the window
it is given; searching again wider, all round, and holding a pose in doubt until the next scan confirms it is
decided here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mrs_nav.geometry import FloatArray, Pose2D, poses_agree
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.matcher import FIELD_MAX_DISTANCE, DistanceField, MatchResult, ScanMatcher, window_field
from mrs_nav.slam.matcher_kernels import NORMAL_RADIUS

# A match explaining fewer of the scan's points than this is lost, and searched for again widely (match_in_grid)
LOST_BELOW = 0.3
RECOVERY_SEARCH_M = 1.0  # m, half-width of that search's translation window; its headings: all round
RECOVERED_INLIERS = 0.5  # share of points the wide search must explain to be taken
# A pose the wide search finds is taken for a scan only when the search for the next scan asks for the same
# correction of its prediction, within this much (m, rad) (Recoveries)
RECOVERY_AGREES = (0.2, math.radians(3.0))
# A match explaining fewer of the scan's points than this is weak, and searched for again in a window of
# WINDOW_SIGMAS standard deviations of the odometry prediction (at most WINDOW_MAX, m and rad) where that is wider
# than the usual one; the wider search's match is taken where it explains WIDER_GAIN times as many (match_in_grid).
WEAK_BELOW = 0.5
WINDOW_SIGMAS = 3.0
WINDOW_MAX = (2.0, math.pi)
WIDER_GAIN = 1.5


def match_reach(matcher: ScanMatcher, resolution: float) -> float:
    """How far (m) beyond the scan's points at the prior :func:`match_in_grid` may read the grid: its widest
    translation window (the matcher's, the wider search's, the recovery search's), the distance field's reach,
    and the cells round the nearest walls whose hits give their normals (and one for rounding)."""
    window = max(matcher.search_linear, WINDOW_MAX[0], RECOVERY_SEARCH_M)
    return window + FIELD_MAX_DISTANCE + (NORMAL_RADIUS + 2) * resolution


@dataclass
class Recoveries:
    """The wide searches of one map's scans (:func:`match_in_grid`): the correction of its prediction that the
    last scan's search asked for, held until the next scan's search confirms or drops it (while it is held, the
    last scan is in doubt)."""

    # found pose o prior^-1 (a move of the map frame) of the last scan, when its search found one
    pending: Pose2D | None = None


def match_in_grid(  # noqa: PLR0917 - the local track and the SLAM call it alike, positionally
    matcher: ScanMatcher,
    grid: LogOddsGrid,
    points: FloatArray,
    prior: Pose2D,
    spread: tuple[float, float],
    recoveries: Recoveries | None = None,
) -> MatchResult:
    """``matcher``'s match of the scan ``points`` (laser frame) in ``grid`` near the laser pose ``prior``, whose
    odometry prediction has standard deviations ``spread`` (m, rad).

    A weak match (explaining fewer than :data:`WEAK_BELOW` of the points) is searched for again in a window of
    :data:`WINDOW_SIGMAS` times ``spread`` when that is wider than ``matcher``'s, with the same prior, and
    replaced where the wider match explains :data:`WIDER_GAIN` times as many points. Why: the window is sized for
    scans a few tens of centimetres apart; on a log whose scans are metres apart (Orebro's, 1 m median, up to 3 m)
    the odometry can be off by more than the window, and the best fit inside it is a wrong one (there, one scan
    3 m on from the last was mapped 0.7 m and 9 degrees off, its match explaining a quarter of its points, and
    the recovery search below found no better fit without the prior; the map was broken, ATE 1.5 m).
    Only weak matches are searched again: where odometry is good (FHW's scans are as far apart), a wider window
    over a crowd finds wrong fits that a strong match would not have been replaced by (FHW's map broke when every
    scan was searched so).

    When the match still explains fewer than :data:`LOST_BELOW` of the points, the scan is searched for again
    over every heading and :data:`RECOVERY_SEARCH_M` around ``prior``, without the odometry prior, and the result
    taken where it explains at least :data:`RECOVERED_INLIERS` of them and twice as many as the match so far.

    Why: odometry can miss a whole turn (the Seattle log has a scan after an unrecorded 80 degree turn; wheels
    slip, a robot is carried). Searched only near the odometry, such a scan fits nowhere (7 % of its points on
    walls), is mapped at the wrong heading, and the rest of the map is built on it, consistent with itself and
    wrong. On that log 95 % of the matches explain at least half of their points and 99 % at least 30 %, so the
    wide search runs only where it can help.

    With ``recoveries`` (the SLAM's whole map), a pose the wide search finds is taken only when the search for
    the next scan asks for the same correction of its prediction (:data:`RECOVERY_AGREES`); until then the scan
    is in doubt: ``recoveries.pending`` is set and the match returned is the one near the prediction. Why: a scan
    that sees mostly unmapped space (round a corner into a new corridor) explains few points anywhere, and a
    search over every heading finds some wrong pose that explains half. On the 13 public logs, of the four poses
    this search gave the whole map's scans at once, only Seattle's (odometry 80 degrees short) was right: the
    MIT Infinite Corridor's was turned 95 degrees at a corridor junction, FHW's and the Freiburg campus's moved
    1.5 m and 0.9 m along repeated structure, each where odometry was within 0.05 m and 2 degrees of the truth.
    A turn that odometry missed leaves the next scan lost the same way; these wrong fits were not repeated (the
    Infinite Corridor's four scans in doubt were none confirmed; Seattle's turn is taken one scan later).
    Without ``recoveries`` (the local track's submap of the last few metres) the pose is taken at once.
    """
    correction = None
    if recoveries is not None:
        correction, recoveries.pending = recoveries.pending, None
    match = matcher.match(window_field(grid, points, prior, matcher.search_linear), points, prior, spread)
    linear = min(max(matcher.search_linear, WINDOW_SIGMAS * spread[0]), max(matcher.search_linear, WINDOW_MAX[0]))
    angular = min(max(matcher.search_angular, WINDOW_SIGMAS * spread[1]), max(matcher.search_angular, WINDOW_MAX[1]))
    if match.inlier_fraction < WEAK_BELOW and (linear, angular) != (matcher.search_linear, matcher.search_angular):
        wider = ScanMatcher(matcher.sigma, linear, angular).match(
            window_field(grid, points, prior, linear), points, prior, spread
        )
        if wider.inlier_fraction >= WIDER_GAIN * match.inlier_fraction:
            match = wider
    if match.inlier_fraction >= LOST_BELOW or points.shape[0] < 3:
        return match
    wide = ScanMatcher(matcher.sigma, RECOVERY_SEARCH_M, math.pi)
    # The window holds the scan turned any way round the prior: a disc of its reach plus the search.
    reach = float(np.max(np.hypot(points[:, 0], points[:, 1]))) + RECOVERY_SEARCH_M + FIELD_MAX_DISTANCE
    bounds = (prior.x - reach, prior.y - reach, prior.x + reach, prior.y + reach)
    field = DistanceField(grid, bounds, FIELD_MAX_DISTANCE, math.ceil(FIELD_MAX_DISTANCE / grid.resolution) + 2)
    found = wide.match(field, points, prior, (1e3, 1e3))
    if found.inlier_fraction < max(RECOVERED_INLIERS, 2.0 * match.inlier_fraction):
        return match
    if recoveries is None or (
        correction is not None and poses_agree(correction.compose(prior), found.pose, RECOVERY_AGREES)
    ):
        return found
    recoveries.pending = found.pose.compose(prior.inverse())
    return match
