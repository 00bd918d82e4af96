"""SLAM-lite: a gmapping substitute with one pose hypothesis, scan-to-map matching and loop closure.

Each processed scan is predicted from odometry, aligned to the map built so far (:mod:`mrs_nav.slam.matcher`)
and added to it (:mod:`mrs_nav.slam.grid`). Scans are processed only when the robot has moved or turned enough
or enough time has passed (gmapping's ``linearUpdate``, ``angularUpdate``, ``temporalUpdate``).

Keyframes: memory and work are bounded by the mapped extent, not by time. A processed scan becomes a node of a
pose graph (:mod:`mrs_nav.slam.posegraph`), keeping its beams, only where no node is already within
:data:`KEYFRAME_RADIUS_M` and :data:`KEYFRAME_HEADING_RAD` of its matched pose; a scan in a covered place is
still matched against the map and integrated into it (pose and ``map -> odom`` stay corrected), and its beams are
kept with its nearest node only while that node keeps fewer than :data:`SCANS_KEPT_PER_NODE` (the map is rebuilt
from the nodes' scans and these).
Consecutive nodes are linked by the local track's motion between them with loop closure on
(:mod:`mrs_nav.slam.local_track`: the scans matched against the last few metres only, so that the drift of a
loop reaches the graph instead of going into the step that met the old place), else by the relative pose of
their matched poses. With ``keep_trajectory`` (replay,
evaluation) every processed scan is also remembered, as a pose relative to its nearest node, so the whole
trajectory follows loop closures; the live stack and node keep only the graph.

Loop closure (``loop_closure``): every :data:`LOOP_EVERY_M` of travel while the graph is growing (the scan is a
new node, or the last node is at most :data:`LOOP_GROWING_M` of travel back), the scan is matched against a
submap of the nodes taken near the closest older node that is at least :data:`LOOP_MIN_TRAVEL_M` of travel back
(within :data:`LOOP_RADIUS_M`), with a wide search and no odometry prior; a scan that closes a loop becomes a
node. Once the robot only drives where nodes are, the map it matches against already holds the loop. A match
that explains at least :data:`LOOP_MIN_INLIERS` of the scan's points, pins the pose in every direction, and fits
clearly better than the scan fits where the graph puts it (:func:`ambiguous_loop_match`) is a candidate edge; the
graph is optimised with it and the edge kept only if every edge then agrees within the gate and the rise of the
least-squares cost passes a chi-square test (:mod:`mrs_nav.slam.posegraph`; else it is rejected as a false
candidate); a closure whose poses already satisfy every edge is kept without a solve. When the
optimisation moved a node by more than :data:`REBUILD_AFTER_CELLS` cells from where the map has it, the map is
rebuilt from the nodes' corrected poses; ``map -> odom`` follows the corrected latest pose.

Far loop closures: once :data:`LOOP_FAR_AFTER_M` of travel has passed without a closure, the drift can exceed what
the near search reaches (the MIT Infinite Corridor log came back to its start 13 m off after a 719 m loop, and
closed nothing). When the near attempt closes nothing then, the older nodes within :func:`far_radius` of the
estimate are ranked by place signature (:mod:`mrs_nav.slam.place`: it does not depend on the drifted pose), and the
scan is matched at the best one's position (the estimate's heading, a :data:`LOOP_FAR_SEARCH_M` window) against a
submap of the older nodes near it by place, held to the near match's tests. The match is taken only when the next
attempt's asks for the same correction of the estimate (:data:`LOOP_FAR_AGREES`): a look-alike place seldom fits
twice in a row with one correction. The edge then goes through the same graph tests.

Rebuilds are lazy (:meth:`Slam.rebuild_map`): the map's tiles are marked out of date and drawn again
(:meth:`mrs_nav.slam.grid.LogOddsGrid.redraw`) only where they are read: before a scan is matched, the tiles
within its reach plus :data:`REDRAW_MARGIN_M`, and the whole map when it is read as a whole (:attr:`Slam.grid`,
:meth:`Slam.finish`). A scan is matched and mapped only where the map is up to date, and a tile is drawn from the
scans and poses of the rebuild that left it out of date, so every map read gives what a rebuild of the whole map
at the closure would have given, to the bit; but a rebuild costs only the region the robot reaches before the
next closure (Freiburg campus: 130 s of CPU for 29 full rebuilds of some 1670 scans each).

Frames: ``map`` is the frame of the first processed pose's odometry (``map -> odom`` starts as identity);
``odom`` is the odometry frame; poses of the robot are of its base frame; ``laser_pose`` is base -> laser.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, poses_agree
from mrs_nav.slam.config import MAX_COORDINATE_M, MAX_MAP_CELLS, SlamConfig
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.local_track import LocalTrack
from mrs_nav.slam.matcher import DistanceField, MatchResult, ScanMatcher, thin_points, window_field
from mrs_nav.slam.place import Signature, differences, signature
from mrs_nav.slam.posegraph import Edge, close_loop
from mrs_nav.slam.scan import LaserScanData, StoredBeams, split_beams
from mrs_nav.slam.tracking import Recoveries, match_in_grid, match_reach

MIN_POINTS = 10  # fewer end points than this: trust odometry, the match would be noise
MIN_SPREAD_M = 0.01  # m, floor of the odometry prediction's position spread
MIN_SPREAD_RAD = math.radians(0.5)  # floor of its heading spread
LOOP_EVERY_M = 1.0  # m of travel between loop closure attempts
LOOP_MIN_TRAVEL_M = 8.0  # m of travel back before a pose can close a loop (nearer ones are already in the map)
LOOP_RADIUS_M = 3.0  # m: how far the older pose may be from the current estimate
# m of travel either side of the older pose whose scans make the submap. Wider ones give more right matches that pass
# the gate (Acapulco at 12 m: 109 of 140 matches right, their median share of explained points 0.52 against 0.25),
# but over the 13 public logs (bench slam-sweep) 6 m broke FHW's map and 12 m did with one node per 0.25 m kept,
# not per 0.5 m or every node: FHW's weak matches after a closure go either way, so a wider submap is not yet safe.
# A submap by place (the 24 older nodes nearest the estimate, within 6 m) with a gate of 0.3, the search widened
# with the travel since the last closure and weak matches held to a typical edge's cost rise took Acapulco from
# 1.69 to 0.16 m (its doubled walls 0.0050, at the line), but Freiburg 079 and the campus fell under 20x real time
# (a rebuild after most of the extra closures) and the campus's ATE doubled.
LOOP_SUBMAP_M = 2.0
LOOP_SEARCH_M = 1.0  # m, half-width of the loop match's search (the drift it can correct)
LOOP_SEARCH_RAD = math.radians(20.0)
# m of travel without a closure before loops are also sought by place signature. Over the 13 public logs (bench
# slam-sweep) 15 m gave the same Infinite Corridor and Acapulco maps and more closures elsewhere (CSAIL's ATE 0.137 ->
# 0.151 m); sought at every attempt that had nodes this far back, the Freiburg campus fell under 20x real time.
LOOP_FAR_AFTER_M = 30.0
# Far loops: an older node is a candidate within LOOP_RADIUS_M plus this share of the travel since it (the Infinite
# Corridor's 13 m after 719 m is 1.8 %)
LOOP_FAR_DRIFT = 0.025
LOOP_FAR_SEARCH_M = 1.5  # m, half-width of a far loop match's search round the node its signature picked
LOOP_FAR_SUBMAP_M = 6.0  # m: a far loop's submap is of the older nodes within this of that node ...
# ... the nearest this many: each far attempt maps them into a submap of its own, and with 24 the Freiburg campus's
# 1015 attempts took 18 s of CPU, its replay 19.6x real time (23.1x without far loops, the same host and hour); 21.6x
# with 12, the Infinite Corridor's map the same within 0.04 m
LOOP_FAR_SUBMAP_NODES = 12
LOOP_FAR_AGREES = (0.2, math.radians(2.0))  # m, rad: two far matches in a row must ask for the same correction
LOOP_MIN_INLIERS = 0.75  # share of scan points within 1.5 cells of the submap's walls
LOOP_MIN_SPREAD = 0.1  # weakest-direction constraint of a loop match (see _weakest_constraint): no corridors
# A loop match more than LOOP_DISTINCT_M from where refining the scan in place (at the graph's estimate) ends
# must fit clearly better than it fits there: its score times LOOP_AMBIGUITY must exceed the score in place.
LOOP_DISTINCT_M = 0.1
LOOP_AMBIGUITY = 0.9
LOOP_MIN_POINTS = 40  # thinned points at least: a scan of a bare corridor end proves nothing
SEQUENTIAL_SIGMA = (0.03, math.radians(1.0))  # m, rad: scan-matched motion between consecutive nodes ...
SEQUENTIAL_PER_M = 0.5  # ... this far apart; farther apart, it grows with the root of the travel (a random walk)
LOOP_SIGMA = (0.05, math.radians(1.5))  # m, rad: a verified loop match
LOOP_AFTER_CLOSURE_M = 3.0  # m of travel after a closure before the next attempt (the map there is fresh)
# Rebuild the map once a pose it was built from is this many cells off. At 2 a closure could leave walls mapped
# twice, 2 cells apart, in the published map until the next large move (Intel: 0.10 m after a closure, 4
# rebuilds); at 1, 0.04 m at most, for 8-10 rebuilds of up to 0.15 s CPU each on Intel (713 nodes and 882 scans
# stored at the last one).
REBUILD_AFTER_CELLS = 1.0
# m beyond a scan's reach up to which the map's out-of-date tiles are drawn when the scan reaches one of them: a
# region drawn at a time, not a strip per scan (each drawing passes over the rebuild's scans once; module doc)
REDRAW_MARGIN_M = 4.0
# A node per place and heading, at the update gates' scale (linearUpdate, angularUpdate 0.2): while exploring,
# every processed scan (0.2 m or 0.2 rad apart) is still a node; the heading tolerance is wider because the
# laser sees all round, so the same place crossed in another direction rarely needs another node.
KEYFRAME_RADIUS_M = 0.15  # m
KEYFRAME_HEADING_RAD = math.radians(30.0)
LOOP_GROWING_M = 2.0 * LOOP_EVERY_M  # m of travel after the last new node in which loops are still sought
# Scans in a covered place kept with their nearest node, for rebuilding the map: rebuilt from the nodes alone, the
# office loop's map lost 0.013-0.03 of its IoU with the world (360 beams) and 0.05-0.09 (90 beams), 171 of its
# 410 scans being nodes. Bounded per node, so that memory still follows the mapped extent, not the time spent.
SCANS_KEPT_PER_NODE = 2


@dataclass(frozen=True)
class ProcessedScan:
    """One processed scan: its time (s), the corrected base pose in the map, the odometry pose, the match, the
    laser mounting used, its beams and the path length so far."""

    stamp: float
    pose: Pose2D
    odom: Pose2D
    match: MatchResult | None
    laser_pose: Pose2D = dataclasses.field(default_factory=lambda: Pose2D(0.0, 0.0, 0.0))
    beams: StoredBeams | None = None  # kept to rebuild the map after loop closure
    travelled: float = 0.0  # m of path from the first processed scan (by the estimate)


@dataclass(frozen=True)
class _Tracked:
    """A processed scan of the trajectory: its pose relative to node ``node`` of the graph (its own when it is
    that node), so that it follows the node when a loop closure corrects it."""

    stamp: float
    node: int
    is_node: bool
    relative: Pose2D
    odom: Pose2D
    match: MatchResult | None
    laser_pose: Pose2D
    travelled: float


class Slam:
    """Online 2-D SLAM over (odometry pose, laser scan) pairs."""

    def __init__(
        self, config: SlamConfig | None = None, laser_pose: Pose2D | None = None, *, keep_trajectory: bool = True
    ) -> None:
        self.config = config or SlamConfig()
        self.laser_pose = laser_pose or Pose2D(0.0, 0.0, 0.0)
        c = self.config
        self._grid = new_map(c)
        self.matcher = ScanMatcher(c.sigma, c.search_linear, c.search_angular)
        self._recoveries = Recoveries()
        self.loop_matcher = ScanMatcher(c.sigma, LOOP_SEARCH_M, LOOP_SEARCH_RAD)  # wide search, no odometry prior
        self.far_matcher = ScanMatcher(c.sigma, LOOP_FAR_SEARCH_M, LOOP_SEARCH_RAD)
        self.nodes: list[ProcessedScan] = []  # the pose graph's nodes (keyframes), with their beams
        self.edges: list[Edge] = []
        self.last: ProcessedScan | None = None  # the latest processed scan
        self.keep_trajectory = keep_trajectory
        self._trajectory: list[_Tracked] = []
        self.loops_closed = 0
        self.loops_rejected = 0
        # Closures that moved the graph: the others already agreed with it (the drift went in some other way)
        self.loops_solved = 0
        self.clipped_in_rebuild = 0  # scans mapped clipped at the cell limit by rebuilds (rebuild_map)
        self.scans_in_doubt = 0  # scans left out while a pose found far from odometry waited (match_in_grid)
        self._last_loop_attempt = 0.0
        self._last_closure = 0.0  # travel (m) at the last loop closure
        # The correction of the estimate (a move of the map frame) that the last far loop match asked for
        self._far_pending: Pose2D | None = None
        self._signatures: dict[int, Signature | None] = {}  # place signatures of nodes, as far loops ask for them
        self._mapped: list[Pose2D] = []  # the pose each node was mapped at
        # per node: scans in its place (SCANS_KEPT_PER_NODE), as (laser pose in the node's frame, beams)
        self._kept: list[list[tuple[Pose2D, StoredBeams]]] = []
        # The last rebuild's scans (laser pose in the map, beams), in its order, while the map has tiles to draw
        # from them (rebuild_map), and each one's reach: x, y, farthest beam (m)
        self._redraw_scans: list[tuple[Pose2D, StoredBeams]] = []
        self._redraw_reach: FloatArray = np.empty((0, 3))
        self._map_to_odom = Pose2D(0.0, 0.0, 0.0)
        # With loop closure, consecutive nodes are linked by the local track's motion (mrs_nav.slam.local_track)
        self._local = LocalTrack(c, self.matcher) if c.loop_closure else None
        # each node's local-track pose, travel and summed variances of the steps taken blind
        self._node_local: list[tuple[Pose2D, float, tuple[float, float]]] = []
        # The nodes' (x, y, yaw) for _nearest_node, in the first _node_count rows, and the node list they are of:
        # extended as nodes are appended, taken anew when a loop closure replaces the list (made from the whole
        # list for every scan, they cost 1 ms a scan on the Freiburg 079 log, 6 % of its CPU). Rows to spare,
        # doubled when full: copied into a new array for every node, they would cost O(nodes^2) over a log.
        self._node_poses: FloatArray = np.empty((0, 3))
        self._node_count = 0
        self._node_poses_of = self.nodes

    @property
    def processed(self) -> list[ProcessedScan]:
        """Every processed scan at its corrected pose (beams only on nodes); only the nodes when the trajectory
        is not kept."""
        if not self.keep_trajectory:
            return list(self.nodes)
        out = []
        for t in self._trajectory:
            if t.is_node:
                out.append(self.nodes[t.node])
            else:
                pose = self.nodes[t.node].pose.compose(t.relative)
                out.append(ProcessedScan(t.stamp, pose, t.odom, t.match, t.laser_pose, None, t.travelled))
        return out

    @property
    def grid(self) -> LogOddsGrid:
        """The map (log-odds), every tile a rebuild left out of date drawn first (:meth:`rebuild_map`)."""
        self._redraw(None)
        return self._grid

    @property
    def stored_scans(self) -> int:
        """How many scans' beams are kept (the nodes' and those kept beside them): bounded by the mapped extent."""
        return len(self.nodes) + sum(len(kept) for kept in self._kept)

    @property
    def map_to_odom(self) -> Pose2D:
        """The correction ``map -> odom`` after the last processed scan."""
        return self._map_to_odom

    def pose_at(self, odom: Pose2D) -> Pose2D:
        """Best estimate of the base pose in the map for an odometry pose (map->odom * odom)."""
        return self._map_to_odom.compose(odom)

    def wants(self, odom: Pose2D, stamp: float) -> bool:
        """Whether a scan at this odometry pose and time passes the update gates."""
        last = self.last
        if last is None:
            return True
        c = self.config
        moved = odom.relative_to(last.odom)
        if math.hypot(moved.x, moved.y) >= c.linearUpdate or abs(moved.yaw) >= c.angularUpdate:
            return True
        return c.temporalUpdate > 0.0 and stamp - last.stamp >= c.temporalUpdate

    def add_scan(
        self, odom: Pose2D, scan: LaserScanData, stamp: float, laser_pose: Pose2D | None = None
    ) -> ProcessedScan | None:
        """Process a scan taken at odometry pose ``odom`` if the gates allow; return what was done, or None when
        the gates leave it out or its pose is in doubt (:class:`mrs_nav.slam.tracking.Recoveries`; nothing changes).

        ``laser_pose``: base -> laser of this scan when it is not the usual mounting (a scan in another frame).
        Raises InvalidInputError, with the state unchanged, when the pose is far outside any building or the map
        would grow past its cell limit.
        """
        mount = laser_pose or self.laser_pose
        if not self.wants(odom, stamp):
            return None
        c = self.config
        beams = split_beams(scan, c.usable_range(scan.range_max), c.maxRange)
        predicted = self.pose_at(odom)
        if max(abs(predicted.x), abs(predicted.y)) > MAX_COORDINATE_M:
            raise InvalidInputError(
                f"odometry pose ({odom.x:.6g}, {odom.y:.6g}) puts the robot beyond {MAX_COORDINATE_M:g} m in the map"
            )
        match = None
        points = beams.hit_points
        thinned = thin_points(points, c.delta)
        spread = self._spread(odom, self.last) if self.last is not None else (MIN_SPREAD_M, MIN_SPREAD_RAD)
        reach = max(float(beams.hit_ranges.max(initial=0.0)), float(beams.free_ranges.max(initial=0.0)))
        if self.last is not None and points.shape[0] >= MIN_POINTS:
            sensor_prior = predicted.compose(mount)
            self._redraw_around(sensor_prior, reach + match_reach(self.matcher, c.delta))  # what the match reads
            match = match_in_grid(self.matcher, self._grid, thinned, sensor_prior, spread, self._recoveries)
            if self._recoveries.pending is not None:
                self.scans_in_doubt += 1
                return None  # neither the match nor the pose found far from it is trusted: the next scan decides
            pose = match.pose.compose(mount.inverse())
        else:
            pose = predicted

        self._redraw_around(pose.compose(mount), reach + c.delta)
        self._grid.integrate(pose.compose(mount), beams)
        if self._local is not None:  # after the map took the scan: a refused scan changes nothing
            enough = points.shape[0] >= MIN_POINTS
            self._local.update(odom, thinned if enough else thinned[:0], beams, mount=mount, spread=spread)
        self._map_to_odom = pose.compose(odom.inverse())
        last = self.last
        travelled = 0.0 if last is None else last.travelled + math.hypot(pose.x - last.pose.x, pose.y - last.pose.y)
        record = ProcessedScan(stamp, pose, odom, match, mount, StoredBeams.of(beams), travelled)
        nearest = self._nearest_node(pose)
        if nearest is None:
            self._add_node(record)
        else:
            self._track(record, nearest)
        self.last = record
        nodes = len(self.nodes)
        growing = bool(self.nodes) and travelled - self.nodes[-1].travelled <= LOOP_GROWING_M
        if c.loop_closure and growing and travelled - self._last_loop_attempt >= LOOP_EVERY_M:
            self._last_loop_attempt = travelled
            self._try_loop(record, thinned)
        if nearest is not None and len(self.nodes) == nodes:  # a scan that closed a loop is a node of its own
            self._keep(record, nearest)
        return self.last

    def _nearest_node(self, pose: Pose2D) -> int | None:
        """The nearest node within the keyframe radius and heading of ``pose``, or None when the place is new."""
        if not self.nodes:
            return None
        if self._node_poses_of is not self.nodes:
            self._node_count, self._node_poses_of = 0, self.nodes
        count, nodes = self._node_count, len(self.nodes)
        if count < nodes:
            if nodes > len(self._node_poses):
                grown = np.empty((max(nodes, 2 * len(self._node_poses)), 3))
                grown[:count] = self._node_poses[:count]
                self._node_poses = grown
            self._node_poses[count:nodes] = [(n.pose.x, n.pose.y, n.pose.yaw) for n in self.nodes[count:]]
            self._node_count = nodes
        xy = self._node_poses[:nodes]
        distance = np.hypot(xy[:, 0] - pose.x, xy[:, 1] - pose.y)
        turned = np.abs(np.remainder(xy[:, 2] - pose.yaw + math.pi, math.tau) - math.pi)
        distance[(distance >= KEYFRAME_RADIUS_M) | (turned >= KEYFRAME_HEADING_RAD)] = np.inf
        best = int(np.argmin(distance))
        return best if math.isfinite(distance[best]) else None

    def _sequential(self, record: ProcessedScan) -> Edge:
        """The edge from the last node to ``record`` as the next node: the local track's motion between them
        with loop closure (why: mrs_nav.slam.local_track), else their matched poses' relative pose.

        The local track's steps taken on odometry alone (scans with too few end points to match) add their
        prediction's variance (:meth:`_spread`: odometry's ``srr``, ``srt``, ``str``, ``stt``) to the edge's: a
        loop's correction then goes where nothing but odometry was seen. In the drive out of a room into open
        space and back (tests), with the matcher's spread on those steps the poses in the open ended up to 0.47 m
        off and the room's second visit 14 mm; with odometry's, 0.22 m and 4 mm."""
        k = len(self.nodes)
        local = self._local
        if local is None or local.pose is None or not self._node_local:
            return Edge(k - 1, k, record.pose.relative_to(self.nodes[-1].pose), *SEQUENTIAL_SIGMA)
        previous, travelled, (blind_xy, blind_yaw) = self._node_local[-1]
        scale = math.sqrt(max(1.0, (local.travelled - travelled) / SEQUENTIAL_PER_M))
        sigma_xy, sigma_yaw = SEQUENTIAL_SIGMA
        now_xy, now_yaw = local.blind_variance
        return Edge(
            k - 1,
            k,
            local.pose.relative_to(previous),
            math.sqrt((sigma_xy * scale) ** 2 + now_xy - blind_xy),
            math.sqrt((sigma_yaw * scale) ** 2 + now_yaw - blind_yaw),
        )

    def _append_node(self, record: ProcessedScan) -> None:
        if self._local is not None and self._local.pose is not None:
            self._node_local.append((self._local.pose, self._local.travelled, self._local.blind_variance))
        self.nodes.append(record)
        self._mapped.append(record.pose)
        self._kept.append([])

    def _add_node(self, record: ProcessedScan) -> None:
        """Make ``record`` a graph node linked to the previous node (:meth:`_sequential`)."""
        k = len(self.nodes)
        if k:
            self.edges.append(self._sequential(record))
        self._append_node(record)
        self._track(record, k)

    def _track(self, record: ProcessedScan, node: int) -> None:
        """Remember ``record`` in the trajectory, relative to ``node``, when the trajectory is kept."""
        if not self.keep_trajectory:
            return
        is_node = self.nodes[node] is record
        relative = record.pose.relative_to(self.nodes[node].pose)
        self._trajectory.append(
            _Tracked(
                record.stamp, node, is_node, relative, record.odom, record.match, record.laser_pose, record.travelled
            )
        )

    def _keep(self, record: ProcessedScan, node: int) -> None:
        """Keep the beams of ``record``, a scan in the place of ``node``, for rebuilding the map (while the node
        has room: :data:`SCANS_KEPT_PER_NODE`)."""
        kept = self._kept[node]
        if record.beams is not None and len(kept) < SCANS_KEPT_PER_NODE:
            laser = record.pose.compose(record.laser_pose).relative_to(self.nodes[node].pose)
            kept.append((laser, record.beams))

    def _try_loop(self, current: ProcessedScan, thinned: FloatArray) -> None:
        """Look for a loop closure of the latest scan (``thinned``: its end points as the matcher takes them,
        module doc), near where the graph puts it and, after a long drive without one, by its place signature;
        optimise and rebuild when one holds."""
        if thinned.shape[0] < LOOP_MIN_POINTS:
            return
        old = [j for j, r in enumerate(self.nodes) if current.travelled - r.travelled >= LOOP_MIN_TRAVEL_M]
        if not old:
            return
        if self._try_near_loop(current, thinned, old):
            return
        if current.travelled - self._last_closure >= LOOP_FAR_AFTER_M:
            self._try_far_loop(current, thinned, old)
        else:
            self._far_pending = None

    def _try_near_loop(self, current: ProcessedScan, thinned: FloatArray, old: list[int]) -> bool:
        """A loop closure against the submap of the older node nearest the graph's estimate; whether one held."""
        j = min(old, key=lambda i: _apart(self.nodes[i].pose, current.pose))
        nearest = self.nodes[j]
        if _apart(nearest.pose, current.pose) > LOOP_RADIUS_M:
            return False
        submap = [self.nodes[i] for i in old if abs(self.nodes[i].travelled - nearest.travelled) <= LOOP_SUBMAP_M]
        sensor_prior = current.pose.compose(current.laser_pose)
        match = self._verified_match(self.loop_matcher, submap, thinned, sensor_prior)
        return match is not None and self._close(current, j, match)

    def _try_far_loop(self, current: ProcessedScan, thinned: FloatArray, old: list[int]) -> None:
        """A loop closure after a drift too large for the near search (module doc, far loop closures):
        the older node within :func:`far_radius` of the estimate whose place signature is nearest the scan's,
        matched by place; taken when the next attempt's match asks for the same correction of the estimate."""
        pending, self._far_pending = self._far_pending, None
        within = [j for j in old if _apart(self.nodes[j].pose, current.pose) <= far_radius(current, self.nodes[j])]
        mine = signature(thinned)
        signed = [(j, s) for j in within if (s := self.signature_of(j)) is not None]
        if mine is None or not signed:
            return
        scores = differences(mine, np.array([s for _, s in signed]))
        j = signed[int(np.argmin(scores))][0]
        estimate = current.pose.compose(current.laser_pose)
        match = self.match_at_node(j, old, thinned, estimate.yaw)
        if match is None:
            return
        correction = match.pose.compose(estimate.inverse())
        if pending is None or not poses_agree(pending.compose(estimate), match.pose, LOOP_FAR_AGREES):
            self._far_pending = correction
            return
        self._close(current, j, match)

    def match_at_node(self, j: int, others: list[int], points: FloatArray, heading: float) -> MatchResult | None:
        """Where the scan ``points`` (thinned, laser frame) fits round node ``j``'s laser position at the laser
        heading ``heading``: matched (:data:`LOOP_FAR_SEARCH_M`, :data:`LOOP_SEARCH_RAD`) against the nodes of
        ``others`` within :data:`LOOP_FAR_SUBMAP_M` of node ``j`` (the nearest :data:`LOOP_FAR_SUBMAP_NODES`), and
        held to a loop match's tests (:meth:`_verified_match`); None where it does not fit so."""
        place = self.nodes[j]
        submap = sorted(
            (self.nodes[i] for i in others if _apart(self.nodes[i].pose, place.pose) <= LOOP_FAR_SUBMAP_M),
            key=lambda r: _apart(r.pose, place.pose),
        )[:LOOP_FAR_SUBMAP_NODES]
        there = place.pose.compose(place.laser_pose)
        return self._verified_match(self.far_matcher, submap, points, Pose2D(there.x, there.y, heading))

    def signature_of(self, j: int) -> Signature | None:
        """Node ``j``'s place signature (:mod:`mrs_nav.slam.place`), computed when first asked for."""
        if j not in self._signatures:
            beams = self.nodes[j].beams
            points = thin_points(beams.split().hit_points, self.config.delta) if beams is not None else np.empty((0, 2))
            self._signatures[j] = signature(points)
        return self._signatures[j]

    def _verified_match(
        self, matcher: ScanMatcher, submap: list[ProcessedScan], thinned: FloatArray, prior: Pose2D
    ) -> MatchResult | None:
        """``matcher``'s match of the scan in the ``submap`` near the laser pose ``prior`` when it is a loop
        candidate: it explains :data:`LOOP_MIN_INLIERS` of the points, pins the pose in every direction and fits
        clearly better than elsewhere near ``prior`` (:func:`ambiguous_loop_match`); else None."""
        matched = self._match_submap(matcher, submap, thinned, prior)
        if matched is None:
            return None
        match, field = matched
        if (
            match.inlier_fraction < LOOP_MIN_INLIERS
            or _weakest_constraint(field, thinned, match.pose) < LOOP_MIN_SPREAD
            or ambiguous_loop_match(matcher, field, thinned, match, prior)
        ):
            return None
        return match

    def _close(self, current: ProcessedScan, j: int, match: MatchResult) -> bool:
        """Add the loop edge from node ``j`` to ``current`` at the laser pose ``match`` found for it, if the
        graph optimised with it holds (:func:`mrs_nav.slam.posegraph.close_loop`); whether it did."""
        is_node = self.nodes[-1] is current
        k = len(self.nodes) - 1 if is_node else len(self.nodes)
        poses = [r.pose for r in self.nodes] + ([] if is_node else [current.pose])
        edges = self.edges
        if not is_node:
            edges = [*edges, self._sequential(current)]
        found = match.pose.compose(current.laser_pose.inverse())
        edge = Edge(j, k, found.relative_to(self.nodes[j].pose), *LOOP_SIGMA)
        closed = close_loop(poses, edges, edge)
        if closed is None:
            self.loops_rejected += 1
            return False
        if not is_node:
            # The scan that closes the loop becomes a node: it is the loop edge's end.
            self.edges.append(edges[-1])
            self._append_node(current)
            if self.keep_trajectory:
                self._trajectory[-1] = dataclasses.replace(
                    self._trajectory[-1], node=k, is_node=True, relative=Pose2D(0.0, 0.0, 0.0)
                )
        self.loops_closed += 1
        self.loops_solved += closed.poses != poses
        self._last_loop_attempt = current.travelled + LOOP_AFTER_CLOSURE_M - LOOP_EVERY_M
        self._last_closure = current.travelled
        self._far_pending = None
        self.edges.append(edge)
        self.nodes = [dataclasses.replace(r, pose=p) for r, p in zip(self.nodes, closed.poses, strict=True)]
        self.last = self.nodes[-1]
        self._map_to_odom = self.last.pose.compose(self.last.odom.inverse())
        # Smaller corrections are within a cell of the map; rebuilding costs a pass over every node.
        if self.map_lag() > REBUILD_AFTER_CELLS * self.config.delta:
            self.rebuild_map()
        return True

    def map_lag(self) -> float:
        """How far (m) the poses the map was built from are, at most, from the current estimates."""
        return max(
            (_apart(m, r.pose) for m, r in zip(self._mapped, self.nodes, strict=True)),
            default=0.0,
        )

    def finish(self) -> None:
        """Bring the map up to the latest corrected poses (after the last scan of a log), all of it drawn."""
        if self.map_lag() > 0.0:
            self.rebuild_map()
        self._redraw(None)

    def _match_submap(
        self, matcher: ScanMatcher, submap: list[ProcessedScan], points: FloatArray, prior: Pose2D
    ) -> tuple[MatchResult, DistanceField] | None:
        """The scan ``points`` matched by ``matcher`` against a grid of the ``submap`` scans only, without an
        odometry prior."""
        c = self.config
        grid = LogOddsGrid(
            c.delta, (prior.x - 1.0, prior.y - 1.0, prior.x + 1.0, prior.y + 1.0), max_cells=MAX_MAP_CELLS
        )
        for record in submap:
            if record.beams is not None:
                grid.integrate(record.pose.compose(record.laser_pose), record.beams.split())
        field = window_field(grid, points, prior, matcher.search_linear)
        if field.empty:
            return None
        return matcher.match(field, points, prior, (1e3, 1e3)), field

    def rebuild_map(self) -> None:
        """Map every node's scan, and the scans kept with it, again at its (corrected) pose, into a cleared map.

        Lazily (module doc): the grid grows now as that rebuild would grow it, scan by scan, and every tile is
        marked out of date, to be drawn from these scans at these poses where it is read. A scan that its
        corrected pose would take past the map's cell limit is mapped clipped to the map as it is (counted in
        ``clipped_in_rebuild``): a rebuild that stopped there would leave the map half drawn (the MIT Infinite
        Corridor log ended so, and its whole replay was lost).
        """
        scans = []
        for record, kept in zip(self.nodes, self._kept, strict=True):
            if record.beams is not None:
                scans.append((record.pose.compose(record.laser_pose), record.beams))
            scans.extend((record.pose.compose(laser), beams) for laser, beams in kept)
        reach = np.array([(sensor.x, sensor.y, _farthest(beams)) for sensor, beams in scans], dtype=np.float64).reshape(
            -1, 3
        )
        grid = self._grid
        # Only a scan reaching past the grid's edge cells can grow it (LogOddsGrid.ensure_contains); the grid
        # only grows, so those beyond the edge now are the only ones to look at, in order.
        res, margin = grid.resolution, 1e-6
        inside = (
            (reach[:, 0] - reach[:, 2] - margin >= grid.origin_x)
            & (reach[:, 1] - reach[:, 2] - margin >= grid.origin_y)
            & (reach[:, 0] + reach[:, 2] + margin <= grid.origin_x + (grid.width - 1) * res)
            & (reach[:, 1] + reach[:, 2] + margin <= grid.origin_y + (grid.height - 1) * res)
        )
        for k in np.flatnonzero(~inside):
            sensor, beams = scans[k]
            box = grid.scan_box(sensor, beams.split())
            if box is None:
                continue
            try:
                grid.ensure_contains(*box)
            except InvalidInputError:  # past the cell limit: the scan is drawn clipped to the map
                self.clipped_in_rebuild += 1
        grid.invalidate()
        self._redraw_scans, self._redraw_reach = scans, reach
        self._mapped = [r.pose for r in self.nodes]

    def _redraw_around(self, sensor: Pose2D, reach: float) -> None:
        """Draw the map's out-of-date tiles (:meth:`rebuild_map`) if any lies within ``reach`` (m) of ``sensor``:
        those within ``reach`` plus :data:`REDRAW_MARGIN_M`."""
        if self._grid.stale_tiles == 0:
            return
        if self._grid.stale_regions((sensor.x - reach, sensor.y - reach, sensor.x + reach, sensor.y + reach)):
            wide = reach + REDRAW_MARGIN_M
            self._redraw((sensor.x - wide, sensor.y - wide, sensor.x + wide, sensor.y + wide))

    def _redraw(self, box: tuple[float, float, float, float] | None) -> None:
        """Draw the map's out-of-date tiles within ``box`` (m; None: all of them) from the last rebuild's scans
        that reach them."""
        grid = self._grid
        rects = grid.stale_regions(box)
        if not rects:
            return
        x, y, r = self._redraw_reach.T
        near = np.zeros(x.size, dtype=np.bool_)
        for rect in rects:
            x0, y0, x1, y1 = grid.tiles_box(rect)
            near |= (x + r >= x0) & (x - r <= x1) & (y + r >= y0) & (y - r <= y1)
        grid.redraw(rects, ((self._redraw_scans[k][0], self._redraw_scans[k][1].split()) for k in np.flatnonzero(near)))
        if grid.stale_tiles == 0:  # all drawn: the scans stay only with their nodes
            self._redraw_scans, self._redraw_reach = [], np.empty((0, 3))

    def _spread(self, odom: Pose2D, last: ProcessedScan) -> tuple[float, float]:
        """Standard deviations (m, rad) of the odometry prediction since the ``last`` processed scan."""
        c = self.config
        moved = odom.relative_to(last.odom)
        travelled, turned = math.hypot(moved.x, moved.y), abs(moved.yaw)
        return (
            MIN_SPREAD_M + c.srr * travelled + c.srt * turned,
            MIN_SPREAD_RAD + c.str * travelled + c.stt * turned,
        )


def new_map(config: SlamConfig) -> LogOddsGrid:
    """An empty map as the SLAM starts one: ``config``'s resolution, initial extent, growth and log-odds."""
    c = config
    return LogOddsGrid(
        c.delta,
        (c.xmin, c.ymin, c.xmax, c.ymax),
        grows=c.map_grows,
        lfree=c.lfree,
        loccupied=c.loccupied,
        lmax=c.lmax,
        max_cells=MAX_MAP_CELLS,
    )


def ambiguous_loop_match(
    matcher: ScanMatcher, field: DistanceField, points: FloatArray, match: MatchResult, prior: Pose2D
) -> bool:
    """Whether the scan ``points`` (laser frame) fits the loop submap's ``field`` at another place almost as well
    as at the loop ``match`` that ``matcher`` found: where refining from ``prior`` (where the graph puts the
    laser) ends, when that is not where the match is.

    Why: in a corridor with regular doors, or a hall seen through one opening, a scan fits two places about
    equally well, and the wide loop search returns whichever scored higher by a hair. The weakest-direction
    check passes when the aliasing is along a direction the scan still constrains a little. A closure is only
    worth moving the graph for when the scans prefer the new place clearly (:data:`LOOP_AMBIGUITY`); when both
    fit, the graph's own estimate, which every earlier edge supports, stands. A drifted graph whose local
    refinement slides onto the match is not ambiguous: both found the same place.
    """
    if _apart(match.pose, prior) <= LOOP_DISTINCT_M:
        return False
    spread = (matcher.search_linear, matcher.search_angular)
    local = matcher.refine(field, points, prior, prior=prior, spread=spread)
    if _apart(match.pose, local) <= LOOP_DISTINCT_M:
        return False
    return LOOP_AMBIGUITY * match.score <= matcher.evaluate(field, points, local).score


def far_radius(current: ProcessedScan, older: ProcessedScan) -> float:
    """How far (m) from the estimate of ``current`` the estimate of an ``older`` node may have drifted:
    :data:`LOOP_RADIUS_M` plus :data:`LOOP_FAR_DRIFT` of the travel between them."""
    return LOOP_RADIUS_M + LOOP_FAR_DRIFT * (current.travelled - older.travelled)


def _farthest(beams: StoredBeams) -> float:
    """The longest beam (m) of a kept scan: how far from the laser it can change the map."""
    return max(float(beams.hit_ranges.max(initial=0.0)), beams.free_range if beams.free_angles.size else 0.0)


def _apart(a: Pose2D, b: Pose2D) -> float:
    """Distance (m) between two poses' positions."""
    return math.hypot(a.x - b.x, a.y - b.y)


def _weakest_constraint(field: DistanceField, points: FloatArray, pose: Pose2D) -> float:
    """How well the surfaces under the matched ``points`` pin the pose in its weakest direction: the smallest
    eigenvalue of the mean outer product of their normals (0 in a straight corridor, 0.5 in a corner)."""
    wx, wy = pose.apply(points).T
    _, _, normal = field.nearest_surface(wx, wy)
    normal = normal[np.isfinite(normal)]
    if normal.size < 3:
        return 0.0
    n = np.stack([np.cos(normal), np.sin(normal)], axis=1)
    return float(np.linalg.eigvalsh(n.T @ n / normal.size)[0])
