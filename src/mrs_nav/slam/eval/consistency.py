"""Map-consistency figures that need no ground truth: where the scan end points land on the final map.

Every processed scan's end points (beams that hit something within the usable range) are placed with the scan's
final pose into the final map. In a consistent map they fall on occupied cells (or unknown ones at the map's
edges); where a corridor was mapped twice, rotated or shifted (a loop that did not close, a wrong closure), one
pass's walls lie in the other's free space, and its end points land on free cells.

:func:`free_endpoint_fraction` is the raw share of end points on free cells (log-odds < 0) with no occupied cell
within one cell: walls a few centimetres apart are the same wall at this resolution (scan noise, sub-cell
corrections of a pose graph). It also counts everything that moved: in a crowded hall (the Edmonton convention
centre, the FHW museum) people around the robot put 8-12 % of the end points there, up to 90 % of one scan's,
in maps that hold, as many as a map with a wrongly placed start (Orebro, 7 %).

:func:`doubled_wall_fraction` is the figure the broken-map line applies to: the share of end points that draw a
wall where the map has free space, at least :data:`WALL_PIECE_M` long and more than :data:`WALL_TOLERANCE_M`
from any wall of the map. A person, or two legs, is a piece of at most about half a metre in a scan, and the
beams that pass between people break a crowd into such pieces; a doubled wall is as long as the wall. On 13
public CARMEN logs it is at most 0.0014 for the six maps that hold and the three crowded ones, and was 0.011 for
Orebro's (the walls of its first scans doubled 0.3-1 m off, before the matcher's wider search for weak matches)
and 0.013-0.13 for the maps tens of metres off; Seattle's map
built on a scan placed at the wrong heading (ATE 2.8 m, raw figure 0.018) read 0.008. :data:`BROKEN_FRACTION`
is the line ``mrs-nav replay`` warns at and ``mrs-nav bench slam`` fails at.

:func:`duplicated_place_fraction` sees what end points on free cells cannot: a place mapped twice where the
second copy lies in space the first never saw (a room re-entered after a drift, drawn again beside itself, turned;
a corridor bent where its loop did not close). Every :data:`DUPLICATE_EVERY_M` of travel a node's scan is looked
for by place signature among the nodes at least :data:`DUPLICATE_APART_M` of travel from it and matched there as a
far loop closure is (:meth:`mrs_nav.slam.loop_closure.LoopCloser.match_at_node`); where it fits, twice in a row
with the same correction, more than :data:`DUPLICATE_OFF` from where the map has it, the place is in the map twice.
The share of checked nodes so is held to :data:`DUPLICATED_LINE`.

:func:`revisit_spread` is a finer figure for comparing trajectories of the same scans (this SLAM's against a
reference's): how closely end points of scans taken far apart in time agree; :func:`revisit_spread_by_distance`
splits it by how far apart the scans were taken, which is where a global deformation of one trajectory shows.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, poses_agree
from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.matcher import thin_points
from mrs_nav.slam.place import differences
from mrs_nav.slam.scan import BeamSplit
from mrs_nav.slam.slam import Slam, new_map

# Of the end points on doubled walls (doubled_wall_fraction): 3.5x the most any map that holds reached on 13 public
# logs (0.0014), below the least broken one (Orebro's, 0.011, before the matcher's wider search for weak matches).
BROKEN_FRACTION = 0.005
# m: end points this close to a wall of the map are on that wall (3 cells at 5 cm). A scan matched half a degree
# off puts a wall 15 m away 0.13 m off, as in the Edmonton hall; FHW has a wall doubled 0.1-0.2 m apart over 15 m,
# which this tolerates (at 0.075 m its figure is 0.006). Orebro's doubled walls are 0.3-1 m apart.
WALL_TOLERANCE_M = 0.15
WALL_PIECE_M = 1.0  # m: a piece of stray end points at least this long is a wall, not a person
WALL_GAP_M = 0.5  # m: consecutive end points of a scan farther apart are not one piece
DUPLICATE_EVERY_M = 2.0  # m of travel between the nodes duplicated_place_fraction checks
DUPLICATE_APART_M = 8.0  # m of travel at least between a node and the nodes it is looked for among
DUPLICATE_OFF = (0.5, math.radians(3.0))  # m, rad: a place found farther than this from the map's pose is doubled
# Of the checked nodes found elsewhere (duplicated_place_fraction): on 13 public logs the maps that hold read 0 but
# the MIT Infinite Corridor (0.0034: a look-alike stretch of corridor); maps with a loop left open 0.045-0.061.
DUPLICATED_LINE = 0.02
REVISIT_GAP = 60  # scans apart: what a scan's own neighbours in time see is not a revisit
REVISIT_REACH_M = 0.3  # m: farther apart, two end points are not the same wall
REVISIT_CELL_M = 0.05  # m: one end point per cell of this size per scan
REVISIT_NEIGHBOURS = 32  # nearest end points examined per end point
REVISIT_BAND_NEIGHBOURS = 128  # the same when only scans taken some distance apart qualify
REVISIT_CHUNK = 10_000  # end points per neighbour query (memory: a few chunk x neighbours x 16 bytes)
# Whether end points of scans ``mine`` may pair with end points of scans ``other`` (arrays of scan indices)
Qualifier = Callable[[npt.NDArray[np.int64], npt.NDArray[np.int64]], npt.NDArray[np.bool_]]


def free_endpoint_fraction(slam: Slam) -> float:
    """Share of the processed scans' end points on free cells, away from any wall, of the final map (0 if
    there are none)."""
    near = np.ones((3, 3), dtype=bool)  # free and not next to an occupied cell
    on_free = total = 0
    for xy in _placed_hits(slam):
        on_free += int(np.count_nonzero(_stray(slam.grid, xy, near)))
        total += int(xy.shape[0])
    return on_free / total if total else 0.0


def doubled_wall_fraction(slam: Slam) -> float:
    """Share of the processed scans' end points (0 if there are none) that lie on free cells of the final map
    more than :data:`WALL_TOLERANCE_M` from any occupied cell, in pieces at least :data:`WALL_PIECE_M` long: runs
    of consecutive end points of one scan, each within :data:`WALL_GAP_M` of the one before, measured from the
    first to the last. Moving people leave shorter pieces, doubled or turned walls do not."""
    return _doubled_fraction(slam.grid, _placed_hits(slam))


def is_broken(doubled: float, duplicated: float) -> bool:
    """Whether a map with these figures (:func:`doubled_wall_fraction`, :func:`duplicated_place_fraction`) is
    likely broken: either past its line."""
    return doubled > BROKEN_FRACTION or duplicated > DUPLICATED_LINE


def duplicated_place_fraction(slam: Slam) -> float:
    """The share of the nodes checked whose place the map holds twice (module doc), at the final poses; 0 without
    nodes to check."""
    nodes, loops = slam.nodes, slam.loop_closer
    signed = [j for j in range(len(nodes)) if loops.signature_of(nodes, j) is not None]
    if not signed:
        return 0.0
    travel = np.array([nodes[j].travelled for j in signed])
    signatures = np.array([loops.signature_of(nodes, j) for j in signed])
    checked = duplicated = 0
    last = -math.inf
    pending: Pose2D | None = None
    for k, i in enumerate(signed):
        record = nodes[i]
        if record.travelled - last < DUPLICATE_EVERY_M or record.beams is None:
            continue
        points = thin_points(record.beams.split().hit_points, slam.config.delta)
        if points.shape[0] < loops.config.min_points:
            continue
        last = record.travelled
        checked += 1
        apart = np.flatnonzero(np.abs(travel - record.travelled) >= DUPLICATE_APART_M)
        estimate = record.pose.compose(record.laser_pose)
        match = None
        if apart.size:
            j = signed[int(apart[np.argmin(differences(signatures[k], signatures[apart]))])]
            match = loops.match_at_node(nodes, j, [signed[a] for a in apart], points, estimate.yaw)
        if match is None:
            pending = None
            continue
        confirmed = pending is not None and poses_agree(pending.compose(estimate), match.pose, loops.config.far_agrees)
        pending = match.pose.compose(estimate.inverse())
        duplicated += confirmed and not poses_agree(match.pose, estimate, DUPLICATE_OFF)
    return duplicated / checked if checked else 0.0


def doubled_wall_fraction_at(config: SlamConfig, scans: Callable[[], Iterator[tuple[Pose2D, BeamSplit]]]) -> float:
    """:func:`doubled_wall_fraction` of the map the scans make at given laser poses (map frame) instead of a
    SLAM's: ``scans()`` yields each scan's laser pose and beams, the same on every call (it is called twice: the
    map is built, then its end points are looked up). The map is made as the SLAM makes one (``config``).

    Why: with a log's corrected poses (another SLAM's map of the same scans) it says how much of the figure the
    scene itself draws. Things that stood on one pass and were gone on the next (a parked car; on the Freiburg
    campus, whatever stood in its open squares) leave long pieces on free cells in any map of the log; a SLAM
    map with more than the corrected poses' map is worse than that SLAM's.
    Raises InvalidInputError when the poses take the map past its cell limit.
    """
    grid = new_map(config)
    for sensor, beams in scans():
        grid.integrate(sensor, beams)
    return _doubled_fraction(grid, (_end_points(sensor, beams) for sensor, beams in scans()))


def _doubled_fraction(grid: LogOddsGrid, hits: Iterable[FloatArray]) -> float:
    """:func:`doubled_wall_fraction` of end points ``hits`` (per scan, N x 2, in beam order) on ``grid``."""
    reach = max(1, math.floor(WALL_TOLERANCE_M / grid.resolution + 1e-9))
    offsets = np.arange(-reach, reach + 1)
    near = np.hypot(offsets[:, None], offsets[None, :]) <= reach
    on_walls = total = 0
    for xy in hits:
        total += int(xy.shape[0])
        flagged = _stray(grid, xy, near)
        if not flagged.any():
            continue
        joined = flagged[1:] & flagged[:-1] & (np.hypot(*np.diff(xy, axis=0).T) <= WALL_GAP_M)
        first = np.flatnonzero(flagged & ~np.r_[False, joined])
        last = np.flatnonzero(flagged & ~np.r_[joined, False])
        long = np.hypot(*(xy[last] - xy[first]).T) >= WALL_PIECE_M
        on_walls += int((last - first + 1)[long].sum())
    return on_walls / total if total else 0.0


def _stray(grid: LogOddsGrid, xy: FloatArray, near: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """Whether each point (N x 2, m) lies on a free cell with no occupied cell among the cells ``near`` it (a
    square mask centred on the point's cell), looked up at the points only: the whole map as dense arrays would
    cost more than the map's tiles (:mod:`mrs_nav.slam.grid`). Points off the map are not stray."""
    ix, iy = grid.cell_of(xy[:, 0], xy[:, 1])
    stray = grid.logodds_at(iy, ix) < 0.0
    reach = near.shape[0] // 2
    for dy, dx in np.argwhere(near) - reach:
        stray &= grid.logodds_at(iy + dy, ix + dx) <= 0.0
    return stray


def _placed_hits(slam: Slam) -> Iterator[FloatArray]:
    """Per processed scan with end points: the end points (N x 2, m) placed by its final pose, in beam order."""
    for record in slam.processed:
        if record.beams is None or record.beams.hit_ranges.size == 0:
            continue
        yield _end_points(record.pose.compose(record.laser_pose), record.beams.split())


def _end_points(sensor: Pose2D, beams: BeamSplit) -> FloatArray:
    """The end points (N x 2, m) of ``beams`` taken from the laser pose ``sensor``, in beam order."""
    angles = beams.hit_angles + sensor.yaw
    return np.stack(
        [sensor.x + beams.hit_ranges * np.cos(angles), sensor.y + beams.hit_ranges * np.sin(angles)], axis=1
    )


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
    xy, scan = _placed_end_points(sensor_poses, points)
    nearest = _nearest_qualifying(xy, scan, [lambda mine, other: np.abs(other - mine) >= min_gap], REVISIT_NEIGHBOURS)
    found = nearest[:, 0][np.isfinite(nearest[:, 0])]
    return float(np.median(found)) if found.size else math.nan


def revisit_spread_by_distance(
    sensor_poses: Sequence[Pose2D],
    points: Sequence[FloatArray],
    positions: FloatArray,
    bands: Sequence[tuple[float, float]],
    min_gap: int = REVISIT_GAP,
) -> list[tuple[float, int]]:
    """:func:`revisit_spread` split by how far apart (m) the two scans were taken: per band ``(low, high)``, the
    median distance from each end point to the nearest end point of a scan at least ``min_gap`` scans away whose
    position is ``low`` <= distance < ``high`` from its own, and how many end points had one.

    ``positions`` (N x 2) say where each scan was taken for choosing the pairs, so that two trajectories of the
    same scans are scored on the same pairs (give both the same positions). A global deformation of a trajectory
    (a building stretched by 0.5 % between two maps of it) leaves scans taken close together agreeing and puts
    those taken 10 m apart 5 cm off: it shows in the far bands only. The nearest qualifying end point is sought
    among the :data:`REVISIT_BAND_NEIGHBOURS` nearest of any scan.
    """
    where = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
    if where.shape[0] != len(points):
        raise InvalidInputError(f"revisit spread: {where.shape[0]} positions for {len(points)} scans")
    xy, scan = _placed_end_points(sensor_poses, points)

    def band(low: float, high: float) -> Qualifier:
        def qualifies(mine: npt.NDArray[np.int64], other: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
            apart = np.hypot(*(where[other] - where[mine]).transpose(2, 0, 1))
            qualified: npt.NDArray[np.bool_] = (np.abs(other - mine) >= min_gap) & (apart >= low) & (apart < high)
            return qualified

        return qualifies

    nearest = _nearest_qualifying(xy, scan, [band(low, high) for low, high in bands], REVISIT_BAND_NEIGHBOURS)
    out = []
    for column in nearest.T:
        found = column[np.isfinite(column)]
        out.append((float(np.median(found)) if found.size else math.nan, int(found.size)))
    return out


def _placed_end_points(
    sensor_poses: Sequence[Pose2D], points: Sequence[FloatArray]
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Every scan's end points, thinned to one per :data:`REVISIT_CELL_M` cell and placed by its pose, and the
    index of the scan each came from."""
    if len(sensor_poses) != len(points):
        raise InvalidInputError(f"revisit spread: {len(sensor_poses)} poses for {len(points)} scans")
    world, owner = [np.zeros((0, 2))], [np.zeros(0, dtype=np.int64)]
    for k, (pose, local) in enumerate(zip(sensor_poses, points, strict=True)):
        thinned = thin_points(np.asarray(local, dtype=np.float64).reshape(-1, 2), REVISIT_CELL_M)
        world.append(pose.apply(thinned))
        owner.append(np.full(thinned.shape[0], k, dtype=np.int64))
    return np.concatenate(world), np.concatenate(owner)


def _nearest_qualifying(
    xy: FloatArray, scan: npt.NDArray[np.int64], qualifiers: Sequence[Qualifier], neighbours: int
) -> FloatArray:
    """Per end point (rows) and qualifier (columns): the distance to the nearest of its ``neighbours`` nearest
    end points within :data:`REVISIT_REACH_M` whose scan qualifies (``qualifier(own scans, their scans)``), inf
    where none does. Queried in chunks: a whole log's neighbour lists at once would take gigabytes."""
    out = np.full((xy.shape[0], len(qualifiers)), np.inf)
    if xy.shape[0] == 0:
        return out
    tree = cKDTree(xy)
    for start in range(0, xy.shape[0], REVISIT_CHUNK):
        stop = min(start + REVISIT_CHUNK, xy.shape[0])
        distance, index = tree.query(xy[start:stop], k=neighbours, distance_upper_bound=REVISIT_REACH_M)
        # Missing neighbours come back with index == number of points: clamp before looking up their scan.
        other = scan[np.minimum(index, xy.shape[0] - 1)]
        mine = np.broadcast_to(scan[start:stop, None], other.shape)
        found = np.isfinite(distance)
        for column, qualifies in enumerate(qualifiers):
            out[start:stop, column] = np.where(found & qualifies(mine, other), distance, np.inf).min(axis=1)
    return out
