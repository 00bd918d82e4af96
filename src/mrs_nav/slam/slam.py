"""SLAM-lite: a gmapping substitute with one pose hypothesis, scan-to-map matching and loop closure.

Each processed scan is predicted from odometry, aligned to the map built so far (:mod:`mrs_nav.slam.matcher`)
and added to it (:mod:`mrs_nav.slam.grid`). Scans are processed only when the robot has moved or turned enough
or enough time has passed (gmapping's ``linearUpdate``, ``angularUpdate``, ``temporalUpdate``).

Keyframes (:mod:`mrs_nav.slam.keyframes`): memory and work are bounded by the mapped extent, not by time. A
processed scan becomes a node of a pose graph (:mod:`mrs_nav.slam.posegraph`), keeping its beams, only in a place
and heading no node covers yet; a scan in a covered place is still matched against the map and integrated into it
(pose and ``map -> odom`` stay corrected), and a few such scans' beams are kept with its nearest node (the map is
rebuilt from the nodes' scans and these).
Consecutive nodes are linked by the local track's motion between them with loop closure on
(:mod:`mrs_nav.slam.local_track`: the scans matched against the last few metres only, so that the drift of a
loop reaches the graph instead of going into the step that met the old place), else by the relative pose of
their matched poses. With ``keep_trajectory`` (replay,
evaluation) every processed scan is also remembered, as a pose relative to its nearest node, so the whole
trajectory follows loop closures; the live stack and node keep only the graph.

Loop closure (``loop_closure``): a :class:`mrs_nav.slam.loop_closure.LoopCloser` looks for the latest scan in older
parts of the graph, near the graph's estimate and, after a long drive without a closure, by place signature; a
scan that closes a loop becomes a node, and the graph is optimised with the edge when it holds. When the
optimisation moved a node by more than :data:`REBUILD_AFTER_CELLS` cells from where the map has it, the map is
rebuilt from the nodes' corrected poses; ``map -> odom`` follows the corrected latest pose.

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
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.config import MAX_COORDINATE_M, MAX_MAP_CELLS, SlamConfig
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.keyframes import KeyframeConfig, NodeIndex, ProcessedScan, apart
from mrs_nav.slam.local_track import LocalTrack
from mrs_nav.slam.loop_closure import LoopCloser, LoopConfig
from mrs_nav.slam.matcher import MatchResult, ScanMatcher, thin_points
from mrs_nav.slam.posegraph import Edge, close_loop
from mrs_nav.slam.scan import LaserScanData, StoredBeams, split_beams
from mrs_nav.slam.tracking import Recoveries, match_in_grid, match_reach

MIN_POINTS = 10  # fewer end points than this: trust odometry, the match would be noise
MIN_SPREAD_M = 0.01  # m, floor of the odometry prediction's position spread
MIN_SPREAD_RAD = math.radians(0.5)  # floor of its heading spread
SEQUENTIAL_SIGMA = (0.03, math.radians(1.0))  # m, rad: scan-matched motion between consecutive nodes ...
SEQUENTIAL_PER_M = 0.5  # ... this far apart; farther apart, it grows with the root of the travel (a random walk)
# Rebuild the map once a pose it was built from is this many cells off. At 2 a closure could leave walls mapped
# twice, 2 cells apart, in the published map until the next large move (Intel: 0.10 m after a closure, 4
# rebuilds); at 1, 0.04 m at most, for 8-10 rebuilds of up to 0.15 s CPU each on Intel (713 nodes and 882 scans
# stored at the last one).
REBUILD_AFTER_CELLS = 1.0
# m beyond a scan's reach up to which the map's out-of-date tiles are drawn when the scan reaches one of them: a
# region drawn at a time, not a strip per scan (each drawing passes over the rebuild's scans once; module doc)
REDRAW_MARGIN_M = 4.0


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
    """Online 2-D SLAM over (odometry pose, laser scan) pairs.

    ``loops`` and ``keyframes``: the loop closure's and the keyframes' tuning (internal, not node parameters;
    their defaults are the dataclasses' own).
    """

    def __init__(
        self,
        config: SlamConfig | None = None,
        laser_pose: Pose2D | None = None,
        *,
        keep_trajectory: bool = True,
        loops: LoopConfig | None = None,
        keyframes: KeyframeConfig | None = None,
    ) -> None:
        self.config = config or SlamConfig()
        self.laser_pose = laser_pose or Pose2D(0.0, 0.0, 0.0)
        c = self.config
        self._grid = new_map(c)
        self.matcher = ScanMatcher(c.sigma, c.search_linear, c.search_angular)
        self._recoveries = Recoveries()
        self.loop_closer = LoopCloser(c, loops or LoopConfig())
        self.keyframes = keyframes or KeyframeConfig()
        self.nodes: list[ProcessedScan] = []  # the pose graph's nodes (keyframes), with their beams
        self.edges: list[Edge] = []
        self.last: ProcessedScan | None = None  # the latest processed scan
        self.keep_trajectory = keep_trajectory
        self._trajectory: list[_Tracked] = []
        self.clipped_in_rebuild = 0  # scans mapped clipped at the cell limit by rebuilds (rebuild_map)
        self.scans_in_doubt = 0  # scans left out while a pose found far from odometry waited (match_in_grid)
        self._mapped: list[Pose2D] = []  # the pose each node was mapped at
        # per node: scans in its place (KeyframeConfig.scans_kept_per_node), as (laser pose in the node's frame, beams)
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
        self._node_index = NodeIndex(self.keyframes)

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
    def held_bytes(self) -> int:
        """Bytes of what grows with the area mapped: the map's arrays (:attr:`LogOddsGrid.nbytes`) and the beams
        kept to rebuild it (the nodes' and those kept beside them). Not counted: the pose graph's records and edges
        (a few hundred bytes a node), the local track's two submaps (bounded by their travel) and, in a replay,
        the trajectory (a record per processed scan: it grows with time, by design)."""
        beams = sum(r.beams.nbytes for r in self.nodes if r.beams is not None)
        beams += sum(b.nbytes for kept in self._kept for _, b in kept)
        return self._grid.nbytes + beams

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
        # either way in time: after sim time went back (a bag played again) the last stamp lies ahead of the clock
        return c.temporalUpdate > 0.0 and abs(stamp - last.stamp) >= c.temporalUpdate

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
        nearest = self._node_index.nearest(self.nodes, pose)
        if nearest is None:
            self._add_node(record)
        else:
            self._track(record, nearest)
        self.last = record
        nodes = len(self.nodes)
        if c.loop_closure and self.loop_closer.due(self.nodes, travelled):
            self.loop_closer.attempt(self.nodes, record, thinned, self._close)
        if nearest is not None and len(self.nodes) == nodes:  # a scan that closed a loop is a node of its own
            self._keep(record, nearest)
        return self.last

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
        has room: :attr:`KeyframeConfig.scans_kept_per_node`)."""
        kept = self._kept[node]
        if record.beams is not None and len(kept) < self.keyframes.scans_kept_per_node:
            laser = record.pose.compose(record.laser_pose).relative_to(self.nodes[node].pose)
            kept.append((laser, record.beams))

    def _close(self, current: ProcessedScan, j: int, match: MatchResult) -> bool | None:
        """Add the loop edge from node ``j`` to ``current`` at the laser pose ``match`` found for it, if the
        graph optimised with it holds (:func:`mrs_nav.slam.posegraph.close_loop`; the loop closer's
        :data:`mrs_nav.slam.loop_closure.CloseLoop`): None if it did not, else whether it moved the graph."""
        is_node = self.nodes[-1] is current
        k = len(self.nodes) - 1 if is_node else len(self.nodes)
        poses = [r.pose for r in self.nodes] + ([] if is_node else [current.pose])
        edges = self.edges
        if not is_node:
            edges = [*edges, self._sequential(current)]
        found = match.pose.compose(current.laser_pose.inverse())
        edge = Edge(j, k, found.relative_to(self.nodes[j].pose), *self.loop_closer.config.sigma)
        closed = close_loop(poses, edges, edge)
        if closed is None:
            return None
        if not is_node:
            # The scan that closes the loop becomes a node: it is the loop edge's end.
            self.edges.append(edges[-1])
            self._append_node(current)
            if self.keep_trajectory:
                self._trajectory[-1] = dataclasses.replace(
                    self._trajectory[-1], node=k, is_node=True, relative=Pose2D(0.0, 0.0, 0.0)
                )
        self.edges.append(edge)
        moved = closed.poses != poses
        if not moved:
            # Kept without a solve (most closures: the scan was matched onto the old place): no pose changed, so
            # neither does the map's lag, nor anything made from the node list (its indexes are extended, not
            # made anew). Copying every node for it cost 3-6 ms a closure on the Intel log, growing with the graph.
            return False
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
            (apart(m, r.pose) for m, r in zip(self._mapped, self.nodes, strict=True)),
            default=0.0,
        )

    def finish(self) -> None:
        """Bring the map up to the latest corrected poses (after the last scan of a log), all of it drawn."""
        if self.map_lag() > 0.0:
            self.rebuild_map()
        self._redraw(None)

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


def _farthest(beams: StoredBeams) -> float:
    """The longest beam (m) of a kept scan: how far from the laser it can change the map."""
    return max(float(beams.hit_ranges.max(initial=0.0)), beams.free_range if beams.free_angles.size else 0.0)
