"""Loop closure: where the latest scan meets an older part of the pose graph, found near the graph's estimate or,
after a long drive without one, by place signature (:class:`LoopCloser`, owned by :class:`mrs_nav.slam.slam.Slam`).

Near loops: every :attr:`LoopConfig.every_m` of travel while the graph is growing (the scan is a new node, or the
last node is at most :attr:`LoopConfig.growing_m` of travel back), the scan is matched against a submap of the nodes
taken near the closest older node that is at least :attr:`LoopConfig.min_travel_m` of travel back (within
:attr:`LoopConfig.radius_m`), with a wide search and no odometry prior; a scan that closes a loop becomes a node.
Once the robot only drives where nodes are, the map it matches against already holds the loop. A match that
explains at least :attr:`LoopConfig.min_inliers` of the scan's points, pins the pose in every direction, and fits
clearly better than the scan fits where the graph puts it (:func:`ambiguous_loop_match`) is a candidate edge; the
graph is optimised with it and the edge kept only if every edge then agrees within the gate and the rise of the
least-squares cost passes a chi-square test (:mod:`mrs_nav.slam.posegraph`; else it is rejected as a false
candidate); a closure whose poses already satisfy every edge is kept without a solve.

Far loops: once :attr:`LoopConfig.far_after_m` of travel has passed without a closure, the drift can exceed what
the near search reaches (the MIT Infinite Corridor log came back to its start 13 m off after a 719 m loop, and
closed nothing). When the near attempt closes nothing then, the older nodes within :meth:`LoopCloser.far_radius` of
the estimate are ranked by place signature (:mod:`mrs_nav.slam.place`: it does not depend on the drifted pose), and
the scan is matched at the best one's position (the estimate's heading, a :attr:`LoopConfig.far_search_m` window)
against a submap of the older nodes near it by place, held to the near match's tests. The match is taken only when
the next attempt's asks for the same correction of the estimate (:attr:`LoopConfig.far_agrees`): a look-alike place
seldom fits twice in a row with one correction. The edge then goes through the same graph tests.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, poses_agree
from mrs_nav.slam.config import MAX_MAP_CELLS, SlamConfig
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.grid_kernels import IntArray
from mrs_nav.slam.keyframes import NodeTable, ProcessedScan, apart
from mrs_nav.slam.matcher import DistanceField, MatchResult, ScanMatcher, thin_points, window_field
from mrs_nav.slam.place import SIGNATURE_SIZE, Signature, differences, signature

# What the SLAM does with a verified loop match (Slam's): add the edge from node j to the scan at the laser pose
# found; None when the optimised graph refused it, else whether the optimisation moved the graph.
CloseLoop = Callable[[ProcessedScan, int, MatchResult], bool | None]


@dataclass(frozen=True)
class LoopConfig:
    """Loop closure's tuning (module doc). Internal to the SLAM, set from the public logs' replays: not node
    parameters, so not in ``config/slam.yaml`` (that is :class:`mrs_nav.slam.config.SlamConfig`'s)."""

    every_m: float = 1.0  # m of travel between loop closure attempts
    min_travel_m: float = 8.0  # m of travel back before a pose can close a loop (nearer ones are already in the map)
    radius_m: float = 3.0  # m: how far the older pose may be from the current estimate
    # m of travel either side of the older pose whose scans make the submap. Wider ones give more right matches that
    # pass the gate (Acapulco at 12 m: 109 of 140 matches right, their median share of explained points 0.52 against
    # 0.25), but over the 13 public logs (bench slam-sweep) 6 m broke FHW's map and 12 m did with one node per 0.25 m
    # kept, not per 0.5 m or every node: FHW's weak matches after a closure go either way, so a wider submap is not
    # yet safe. A submap by place (the 24 older nodes nearest the estimate, within 6 m) with a gate of 0.3, the
    # search widened with the travel since the last closure and weak matches held to a typical edge's cost rise took
    # Acapulco from 1.69 to 0.16 m (its doubled walls 0.0050, at the line), but Freiburg 079 and the campus fell
    # under 20x real time (a rebuild after most of the extra closures) and the campus's ATE doubled.
    submap_m: float = 2.0
    search_m: float = 1.0  # m, half-width of the loop match's search (the drift it can correct)
    search_rad: float = math.radians(20.0)  # rad, its heading half-width
    # m of travel without a closure before loops are also sought by place signature. Over the 13 public logs (bench
    # slam-sweep) 15 m gave the same Infinite Corridor and Acapulco maps and more closures elsewhere (CSAIL's ATE
    # 0.137 -> 0.151 m); sought at every attempt that had nodes this far back, the Freiburg campus fell under 20x
    # real time.
    far_after_m: float = 30.0
    # Far loops: an older node is a candidate within radius_m plus this share of the travel since it (the Infinite
    # Corridor's 13 m after 719 m is 1.8 %)
    far_drift: float = 0.025
    far_search_m: float = 1.5  # m, half-width of a far loop match's search round the node its signature picked
    far_submap_m: float = 6.0  # m: a far loop's submap is of the older nodes within this of that node ...
    # ... the nearest this many: each far attempt maps them into a submap of its own, and with 24 the Freiburg
    # campus's 1015 attempts took 18 s of CPU, its replay 19.6x real time (23.1x without far loops, the same host
    # and hour); 21.6x with 12, the Infinite Corridor's map the same within 0.04 m
    far_submap_nodes: int = 12
    far_agrees: tuple[float, float] = (0.2, math.radians(2.0))  # m, rad: two far matches in a row, one correction
    min_inliers: float = 0.75  # share of scan points within 1.5 cells of the submap's walls
    min_spread: float = 0.1  # weakest-direction constraint of a loop match (weakest_constraint): no corridors
    # A loop match more than distinct_m (m) from where refining the scan in place (at the graph's estimate) ends
    # must fit clearly better than it fits there: its score times ambiguity must exceed the score in place.
    distinct_m: float = 0.1
    ambiguity: float = 0.9
    min_points: int = 40  # thinned points at least: a scan of a bare corridor end proves nothing
    sigma: tuple[float, float] = (0.05, math.radians(1.5))  # m, rad: standard deviations of a verified loop edge
    after_closure_m: float = 3.0  # m of travel after a closure before the next attempt (the map there is fresh)

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            for number in value if isinstance(value, tuple) else (value,):
                if not (isinstance(number, int | float) and number >= 0.0):
                    raise InvalidInputError(f"loop closure setting {field.name} must be >= 0, got {value!r}")

    @property
    def growing_m(self) -> float:
        """m of travel after the last new node in which loops are still sought: two attempts' worth."""
        return 2.0 * self.every_m


class LoopCloser:
    """Finds loop closures of the latest scan against the graph's older nodes (module doc) and keeps count.

    The SLAM's graph (its nodes) is passed in; what a verified match does to it is the SLAM's (:data:`CloseLoop`).
    """

    def __init__(self, slam_config: SlamConfig, config: LoopConfig) -> None:
        self.config = config
        self._delta = slam_config.delta
        self.near_matcher = ScanMatcher(slam_config.sigma, config.search_m, config.search_rad)  # no odometry prior
        self.far_matcher = ScanMatcher(slam_config.sigma, config.far_search_m, config.search_rad)
        self.closed = 0
        self.rejected = 0
        self.solved = 0  # closures that moved the graph: the others already agreed with it
        self._last_attempt = 0.0  # travel (m) at the last attempt
        self._last_closure = 0.0  # travel (m) at the last closure
        # The correction of the estimate (a move of the map frame) that the last far loop match asked for
        self._far_pending: Pose2D | None = None
        # Place signatures of nodes, as far loops ask for them: a row per node, and per node 0 (not asked for yet),
        # 1 (its row holds it) or -1 (none: too few points). Rows of one array, not a dict of arrays: the far
        # search compares the scan with every older node near enough, without a Python pass over them.
        self._signature_rows: npt.NDArray[np.float32] = np.empty((0, SIGNATURE_SIZE), dtype=np.float32)
        self._signed: npt.NDArray[np.int8] = np.zeros(0, dtype=np.int8)
        self._table = NodeTable()  # the nodes' positions and travel, for the searches over them

    def due(self, nodes: Sequence[ProcessedScan], travelled: float) -> bool:
        """Whether to look for a loop at ``travelled`` (m) with these ``nodes`` (module doc); an attempt it allows
        counts as made."""
        c = self.config
        growing = bool(nodes) and travelled - nodes[-1].travelled <= c.growing_m
        if not (growing and travelled - self._last_attempt >= c.every_m):
            return False
        self._last_attempt = travelled
        return True

    def attempt(
        self, nodes: Sequence[ProcessedScan], current: ProcessedScan, thinned: FloatArray, close: CloseLoop
    ) -> None:
        """Look for a loop closure of the latest scan ``current`` (``thinned``: its end points as the matcher takes
        them), near where the graph puts it and, after a long drive without one, by its place signature; a
        verified match goes to ``close``."""
        c = self.config
        if thinned.shape[0] < c.min_points:
            return
        _, travel = self._table.of(nodes)
        old = np.flatnonzero(current.travelled - travel >= c.min_travel_m)
        if not old.size:
            return
        near = self._near_match(nodes, current, thinned, old)
        if near is not None and self._close(current, *near, close):
            return
        if current.travelled - self._last_closure >= c.far_after_m:
            far = self._far_match(nodes, current, thinned, old)
            if far is not None:
                self._close(current, *far, close)
        else:
            self._far_pending = None

    def _near_match(
        self, nodes: Sequence[ProcessedScan], current: ProcessedScan, thinned: FloatArray, old: IntArray
    ) -> tuple[int, MatchResult] | None:
        """A loop match against the submap of the older node nearest the graph's estimate: that node and the
        match, or None."""
        c = self.config
        xy, travel = self._table.of(nodes)
        j = int(old[np.argmin(np.hypot(xy[old, 0] - current.pose.x, xy[old, 1] - current.pose.y))])
        nearest = nodes[j]
        if apart(nearest.pose, current.pose) > c.radius_m:
            return None
        submap = [nodes[i] for i in old[np.abs(travel[old] - nearest.travelled) <= c.submap_m]]
        sensor_prior = current.pose.compose(current.laser_pose)
        match = self._verified_match(self.near_matcher, submap, thinned, sensor_prior)
        return None if match is None else (j, match)

    def _far_match(
        self, nodes: Sequence[ProcessedScan], current: ProcessedScan, thinned: FloatArray, old: IntArray
    ) -> tuple[int, MatchResult] | None:
        """A loop match after a drift too large for the near search (module doc, far loops): at the older node
        within :meth:`far_radius` of the estimate whose place signature is nearest the scan's, matched by place;
        that node and the match when the last attempt's match asked for the same correction of the estimate, else
        None (this one's correction is kept for the next)."""
        pending, self._far_pending = self._far_pending, None
        xy, travel = self._table.of(nodes)
        distance = np.hypot(xy[old, 0] - current.pose.x, xy[old, 1] - current.pose.y)
        within = old[distance <= self.far_radius(current, travel[old])]
        mine = signature(thinned)
        self._grow_signatures(len(nodes))
        for k in within[self._signed[within] == 0]:
            self.signature_of(nodes, int(k))
        signed = within[self._signed[within] > 0]
        if mine is None or not signed.size:
            return None
        j = int(signed[int(np.argmin(differences(mine, self._signature_rows[signed])))])
        estimate = current.pose.compose(current.laser_pose)
        match = self.match_at_node(nodes, j, old, thinned, estimate.yaw)
        if match is None:
            return None
        correction = match.pose.compose(estimate.inverse())
        if pending is None or not poses_agree(pending.compose(estimate), match.pose, self.config.far_agrees):
            self._far_pending = correction
            return None
        return j, match

    def _close(self, current: ProcessedScan, j: int, match: MatchResult, close: CloseLoop) -> bool:
        """Hand the loop match of ``current`` at node ``j`` to ``close``, and count it; whether it held."""
        solved = close(current, j, match)
        if solved is None:
            self.rejected += 1
            return False
        c = self.config
        self.closed += 1
        self.solved += solved
        self._last_attempt = current.travelled + c.after_closure_m - c.every_m
        self._last_closure = current.travelled
        self._far_pending = None
        return True

    def far_radius(self, current: ProcessedScan, older_travel: FloatArray) -> FloatArray:
        """How far (m) from the estimate of ``current`` the estimates of older nodes, at travel ``older_travel``
        (m), may have drifted: :attr:`LoopConfig.radius_m` plus :attr:`LoopConfig.far_drift` of the travel between
        them."""
        return self.config.radius_m + self.config.far_drift * (current.travelled - older_travel)

    def match_at_node(
        self,
        nodes: Sequence[ProcessedScan],
        j: int,
        others: Sequence[int] | IntArray,
        points: FloatArray,
        heading: float,
    ) -> MatchResult | None:
        """Where the scan ``points`` (thinned, laser frame) fits round node ``j``'s laser position at the laser
        heading ``heading``: matched (:attr:`LoopConfig.far_search_m`, :attr:`LoopConfig.search_rad`) against the
        nodes of ``others`` within :attr:`LoopConfig.far_submap_m` of node ``j`` (the nearest
        :attr:`LoopConfig.far_submap_nodes`), and held to a loop match's tests (:meth:`_verified_match`); None
        where it does not fit so."""
        c = self.config
        place = nodes[j]
        xy, _ = self._table.of(nodes)
        near = np.asarray(others, dtype=np.int64)
        distance = np.hypot(xy[near, 0] - place.pose.x, xy[near, 1] - place.pose.y)
        keep = distance <= c.far_submap_m
        near, distance = near[keep], distance[keep]
        submap = [nodes[i] for i in near[np.argsort(distance, kind="stable")][: c.far_submap_nodes]]
        there = place.pose.compose(place.laser_pose)
        return self._verified_match(self.far_matcher, submap, points, Pose2D(there.x, there.y, heading))

    def signature_of(self, nodes: Sequence[ProcessedScan], j: int) -> Signature | None:
        """Node ``j``'s place signature (:mod:`mrs_nav.slam.place`), computed when first asked for (a node's beams
        never change, only its pose)."""
        self._grow_signatures(len(nodes))
        if self._signed[j] == 0:
            beams = nodes[j].beams
            points = thin_points(beams.split().hit_points, self._delta) if beams is not None else np.empty((0, 2))
            found = signature(points)
            self._signed[j] = -1 if found is None else 1
            if found is not None:
                self._signature_rows[j] = found
        return self._signature_rows[j] if self._signed[j] > 0 else None

    def _grow_signatures(self, nodes: int) -> None:
        """Room for the signatures of ``nodes`` nodes (doubled when full: O(nodes) copies over a log in all)."""
        if nodes > len(self._signed):
            size = max(nodes, 2 * len(self._signed))
            rows = np.empty((size, SIGNATURE_SIZE), dtype=np.float32)  # 2 KB a node
            signed = np.zeros(size, dtype=np.int8)
            rows[: len(self._signed)] = self._signature_rows
            signed[: len(self._signed)] = self._signed
            self._signature_rows, self._signed = rows, signed

    def _verified_match(
        self, matcher: ScanMatcher, submap: list[ProcessedScan], thinned: FloatArray, prior: Pose2D
    ) -> MatchResult | None:
        """``matcher``'s match of the scan in the ``submap`` near the laser pose ``prior`` when it is a loop
        candidate: it explains :attr:`LoopConfig.min_inliers` of the points, pins the pose in every direction and
        fits clearly better than elsewhere near ``prior`` (:func:`ambiguous_loop_match`); else None."""
        matched = self._match_submap(matcher, submap, thinned, prior)
        if matched is None:
            return None
        match, field = matched
        c = self.config
        if (
            match.inlier_fraction < c.min_inliers
            or weakest_constraint(field, thinned, match.pose) < c.min_spread
            or ambiguous_loop_match(matcher, field, thinned, match, prior, c)
        ):
            return None
        return match

    def _match_submap(
        self, matcher: ScanMatcher, submap: list[ProcessedScan], points: FloatArray, prior: Pose2D
    ) -> tuple[MatchResult, DistanceField] | None:
        """The scan ``points`` matched by ``matcher`` against a grid of the ``submap`` scans only, without an
        odometry prior."""
        grid = LogOddsGrid(
            self._delta, (prior.x - 1.0, prior.y - 1.0, prior.x + 1.0, prior.y + 1.0), max_cells=MAX_MAP_CELLS
        )
        for record in submap:
            if record.beams is not None:
                grid.integrate(record.pose.compose(record.laser_pose), record.beams.split())
        field = window_field(grid, points, prior, matcher.search_linear)
        if field.empty:
            return None
        return matcher.match(field, points, prior, (1e3, 1e3)), field


def ambiguous_loop_match(  # noqa: PLR0917 - the matcher's inputs, then the settings
    matcher: ScanMatcher,
    field: DistanceField,
    points: FloatArray,
    match: MatchResult,
    prior: Pose2D,
    config: LoopConfig,
) -> bool:
    """Whether the scan ``points`` (laser frame) fits the loop submap's ``field`` at another place almost as well
    as at the loop ``match`` that ``matcher`` found: where refining from ``prior`` (where the graph puts the
    laser) ends, when that is not where the match is.

    Why: in a corridor with regular doors, or a hall seen through one opening, a scan fits two places about
    equally well, and the wide loop search returns whichever scored higher by a hair. The weakest-direction
    check passes when the aliasing is along a direction the scan still constrains a little. A closure is only
    worth moving the graph for when the scans prefer the new place clearly (:attr:`LoopConfig.ambiguity`); when
    both fit, the graph's own estimate, which every earlier edge supports, stands. A drifted graph whose local
    refinement slides onto the match is not ambiguous: both found the same place.
    """
    if apart(match.pose, prior) <= config.distinct_m:
        return False
    spread = (matcher.search_linear, matcher.search_angular)
    local = matcher.refine(field, points, prior, prior=prior, spread=spread)
    if apart(match.pose, local) <= config.distinct_m:
        return False
    return config.ambiguity * match.score <= matcher.evaluate(field, points, local).score


def weakest_constraint(field: DistanceField, points: FloatArray, pose: Pose2D) -> float:
    """How well the surfaces under the matched ``points`` pin the pose in its weakest direction: the smallest
    eigenvalue of the mean outer product of their normals (0 in a straight corridor, 0.5 in a corner)."""
    wx, wy = pose.apply(points).T
    _, _, normal = field.nearest_surface(wx, wy)
    normal = normal[np.isfinite(normal)]
    if normal.size < 3:
        return 0.0
    n = np.stack([np.cos(normal), np.sin(normal)], axis=1)
    return float(np.linalg.eigvalsh(n.T @ n / normal.size)[0])
