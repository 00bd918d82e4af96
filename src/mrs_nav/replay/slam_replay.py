"""Running SLAM over a bag's scans and odometry offline, with metrics against ``/ground_truth/odom``.

The topics and frames are found by :func:`mrs_nav.replay.bag_frames.resolve_frames`: scans on ``/scan`` (or
another topic), odometry from ``/odom`` or, in a bag without it, from tf ``odom -> base frame``, the laser's
mounting from the bag's transforms. Each scan is paired with the odometry pose interpolated at its stamp (scans
wait for the next odometry message rather than being dropped).

Pairing needs time to move on: a scan stamped at or before the previous scan, or an odometry message stamped at
or before the previous one, cannot be told apart from its predecessor. Such messages are skipped and counted;
when they are more than :data:`MAX_UNPAIRED_FRACTION` of their topic (constant or few-valued stamps), the bag
is refused with a :class:`BagError`: every scan would be paired with the same odometry pose and the map would
be garbage with plausible figures.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mrs_nav.atomic_write import atomic_path, write_text
from mrs_nav.bag import topics
from mrs_nav.bag.io import read_messages
from mrs_nav.bag.messages import pose_from_odometry, stamp_of
from mrs_nav.errors import BagError, InvalidInputError, MrsNavError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.map_io import save_map
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.replay.bag_frames import BagFrames, BagNames, frame_name, resolve_frames, transform_pose
from mrs_nav.replay.pose_track import PoseTrack
from mrs_nav.slam.config import MAX_COORDINATE_M, SlamConfig
from mrs_nav.slam.eval.consistency import (
    doubled_wall_fraction,
    duplicated_place_fraction,
    free_endpoint_fraction,
    is_broken,
)
from mrs_nav.slam.eval.cost import cost_along, mapped_area_m2
from mrs_nav.slam.eval.metrics import TrajectoryErrors, align_se2, trajectory_errors
from mrs_nav.slam.eval.relations import Relation, bridged, choose_offset, relation_errors
from mrs_nav.slam.scan import BeamSplit, split_beams
from mrs_nav.slam.slam import Slam

TRUTH_TOPIC = topics.GROUND_TRUTH
TF_TOPIC = topics.TF
MAX_UNPAIRED_FRACTION = 0.1
MIN_TRUTH_FRACTION = 0.9
PLOT_MAX_PIXELS = 1600  # map cells a side in slam_map.png; the 8-inch figure at 100 dpi shows about 700


@dataclass
class SlamReplay:
    """What a replay produced: the SLAM state, the processed poses and the timing (CPU ms per processed scan)."""

    slam: Slam
    frames: BagFrames
    stamps: list[float] = field(default_factory=list)
    estimate: list[Pose2D] = field(default_factory=list)
    odometry: list[Pose2D] = field(default_factory=list)
    # Ground truth at each scan's stamp; None where the bag has none near it (a recording starts its topics one
    # by one, so the first scans may precede the first truth message).
    truth: list[Pose2D | None] = field(default_factory=list)
    ms_per_scan: list[float] = field(default_factory=list)
    scans_read: int = 0
    scans_rejected: int = 0
    first_rejection: str = ""
    scans_out_of_order: int = 0
    last_scan_stamp: float = -math.inf
    odom_read: int = 0
    odom_out_of_order: int = 0
    odom_rejected: int = 0
    poses_invalid: int = 0  # odometry or ground-truth messages with non-finite values, skipped
    first_invalid_pose: str = ""
    bag_duration_s: float = 0.0
    cpu_s: float = 0.0
    wall_s: float = 0.0
    odom_track: PoseTrack = field(default_factory=PoseTrack)

    def truth_pairs(self) -> tuple[list[Pose2D], list[Pose2D]]:
        """The estimated and true poses of the scans that have ground truth."""
        pairs = [(e, t) for e, t in zip(self.estimate, self.truth, strict=False) if t is not None]
        return [e for e, _ in pairs], [t for _, t in pairs]

    @property
    def has_truth(self) -> bool:
        """Truth for at least 2 scans and most of them: an error over a fragment of the run would mislead."""
        paired = sum(t is not None for t in self.truth)
        return paired >= 2 and paired >= MIN_TRUTH_FRACTION * len(self.estimate)

    def errors(self) -> TrajectoryErrors | None:
        return trajectory_errors(*self.truth_pairs()) if self.has_truth else None

    def reject(self, reason: str) -> None:
        """Count a scan that could not be used; the first reason is kept for the user."""
        self.scans_rejected += 1
        self.first_rejection = self.first_rejection or reason

    def relation_errors(self, relations: list[Relation], offset: float | None = None) -> dict[str, Any]:
        """The relations metric (:mod:`mrs_nav.slam.eval.relations`) of the SLAM trajectory, and of the bag's ground
        truth bridged the same way (``relations_reference_*``: the floor the bridging leaves) when it has one.

        The clock offset is ``offset`` or found on the ground truth when the bag has it for every scan, else on the
        odometry: never on the trajectory being scored, which would pick the offset that flatters it."""
        stamps, odometry = self.stamps, self.odometry
        estimate = [p.pose for p in self.slam.processed]
        truth = [t for t in self.truth if t is not None]
        reference = truth if len(truth) == len(estimate) else None
        anchor = bridged(stamps, reference or odometry, self.odom_track, odometry)
        choice = choose_offset(relations, anchor, offset)
        mine = relation_errors(relations, bridged(stamps, estimate, self.odom_track, odometry), choice)
        out: dict[str, Any] = mine.as_dict()
        if reference is not None:
            # The truth's own odometry is unknown: it is bridged with the same wheel odometry.
            floor = relation_errors(relations, anchor, choice)
            out["relations_reference_trans_mean_m"] = floor.trans_mean_m
            out["relations_reference_rot_mean_deg"] = floor.rot_mean_deg
        return out

    def summary(self) -> dict[str, Any]:
        """The JSON summary printed by ``mrs-nav replay --slam --json`` (error fields None without truth)."""
        errors = self.errors()
        ms = np.asarray(self.ms_per_scan) if self.ms_per_scan else np.full(1, math.nan)
        cost = cost_along(self.ms_per_scan) if self.ms_per_scan else None
        return {
            "scans": len(self.estimate),
            "scans_skipped": self.scans_out_of_order + self.scans_rejected,
            # left out while a pose found far from the odometry waited for the next scan (mrs_nav.slam.tracking)
            "scans_in_doubt": self.slam.scans_in_doubt,
            "loops_closed": self.slam.loop_closer.closed,
            "loops_rejected": self.slam.loop_closer.rejected,
            "loops_solved": self.slam.loop_closer.solved,
            "free_endpoint_fraction": free_endpoint_fraction(self.slam),
            # The broken-map lines are on the doubled walls and the places mapped twice: the free end points also
            # count moving people.
            "doubled_wall_fraction": (doubled := doubled_wall_fraction(self.slam)),
            "duplicated_place_fraction": (duplicated := duplicated_place_fraction(self.slam)),
            "map_broken": is_broken(doubled, duplicated),
            "ms_per_scan_median": float(np.median(ms)),
            "ms_per_scan_p95": float(np.percentile(ms, 95)),
            # Along the log (mrs_nav.slam.eval.cost): the first and last tenth of the scans' medians, their ratio
            "ms_per_scan_first_tenth_median": cost.first_median_ms if cost else None,
            "ms_per_scan_last_tenth_median": cost.last_median_ms if cost else None,
            "ms_per_scan_growth": cost.growth if cost else None,
            "ms_per_scan_p95_over_median": cost.tail if cost else None,
            "mapped_area_m2": mapped_area_m2(self.slam.grid),
            "slam_held_bytes": self.slam.held_bytes,  # the map's arrays and the beams kept to rebuild it
            # CPU time, not wall time: on a shared machine the wall clock measures the neighbours.
            "realtime_factor": self.bag_duration_s / self.cpu_s if self.cpu_s > 0 else None,
            "ate_rmse_m": errors.ate_rmse_m if errors else None,
            "ate_rmse_deg": errors.ate_rmse_deg if errors else None,
            "rpe_trans_mean_m": errors.rpe_trans_mean_m if errors else None,
            "rpe_rot_mean_deg": errors.rpe_rot_mean_deg if errors else None,
        }


def replay_slam(
    bag: Path,
    config: SlamConfig,
    progress: Callable[[int], None] | None = None,
    names: BagNames | None = None,
) -> SlamReplay:
    """Run SLAM over ``bag``'s scans and odometry (``names``: which topics and frames; default: mrs_nav's); uses
    ``/ground_truth/odom`` if present."""
    frames = resolve_frames(bag, names or BagNames())
    result = SlamReplay(Slam(config, frames.mounting), frames)
    odom, truth = result.odom_track, PoseTrack()
    pending: deque[tuple[float, Any]] = deque()
    first_stamp = last_stamp = math.nan
    start, wall_start = time.process_time(), time.perf_counter()
    scan_topic, odometry_topic = frames.names.scan_topic, frames.odometry_topic or TF_TOPIC
    for topic, _, msg in read_messages(bag, [scan_topic, odometry_topic, TRUTH_TOPIC]):
        if topic == scan_topic:
            readings = [(stamp_of(msg), msg)]
            result.scans_read += 1
            pending.append(readings[0])
            if progress is not None:
                progress(1)
        elif topic == odometry_topic:
            readings = _odometry(msg, frames)
            for stamp, reading in readings:
                result.odom_read += 1
                if (pose := _pose_or_none(reading, stamp, topic, result)) is not None:
                    _add_odometry(result, stamp, pose)
        else:
            readings = [(stamp_of(msg), msg)]
            if (pose := _pose_or_none(msg, readings[0][0], topic, result)) is not None:
                truth.add(readings[0][0], pose)
        if readings:
            first_stamp = readings[0][0] if math.isnan(first_stamp) else first_stamp
            last_stamp = readings[-1][0]
        # A scan is processed once odometry reaches its stamp; earlier scans never wait on later ones.
        while pending and odom.latest >= pending[0][0]:
            _process(result, *pending.popleft(), odom, truth)
    while pending:
        _process(result, *pending.popleft(), odom, truth)
    # Loop closure may have corrected poses since they were recorded: the map and the trajectory follow.
    result.slam.finish()
    result.estimate = [p.pose for p in result.slam.processed]
    result.cpu_s = time.process_time() - start
    result.wall_s = time.perf_counter() - wall_start
    _check_pairing(bag, result)
    result.bag_duration_s = 0.0 if math.isnan(first_stamp) else last_stamp - first_stamp
    # Ground truth that arrived after its scan (e.g. recorded at a lower rate) is matched now.
    result.truth = [truth.at(t) for t in result.stamps]
    return result


def _odometry(msg: Any, frames: BagFrames) -> list[tuple[float, Any]]:
    """(stamp, reading) of the odometry in a message: a ``nav_msgs/Odometry``, or the ``odom -> base`` transforms
    of a ``tf2_msgs/TFMessage`` (none when it holds other edges only)."""
    if frames.odometry_topic is not None:
        return [(stamp_of(msg), msg)]
    parent, child = frames.names.odom_frame, frames.odom_child
    return [
        (stamp_of(tf), tf)
        for tf in msg.transforms
        if frame_name(tf.child_frame_id) == child and frame_name(tf.header.frame_id) == parent
    ]


def _add_odometry(result: SlamReplay, stamp: float, pose: Pose2D) -> None:
    """Take an odometry pose of the frame the odometry moves, as the base frame's pose."""
    if result.frames.base_in_odom_child is not None:
        pose = pose.compose(result.frames.base_in_odom_child)
    if stamp <= result.odom_track.latest:
        result.odom_out_of_order += 1
    elif max(abs(pose.x), abs(pose.y)) > MAX_COORDINATE_M:
        # One wild reading must not be interpolated into its neighbours' scans: drop it.
        result.odom_rejected += 1
    else:
        result.odom_track.add(stamp, pose)


def truth_scans(bag: Path, result: SlamReplay) -> Callable[[], Iterator[tuple[Pose2D, BeamSplit]]] | None:
    """The scans ``result`` processed, read from ``bag`` again, each at its ground-truth laser pose and with its
    beams split as the SLAM split them (for :func:`mrs_nav.slam.eval.consistency.doubled_wall_fraction_at`); None
    without truth for most of them (:attr:`SlamReplay.has_truth`)."""
    if not result.has_truth:
        return None
    truth = {stamp: pose for stamp, pose in zip(result.stamps, result.truth, strict=True) if pose is not None}
    slam = result.slam

    def scans() -> Iterator[tuple[Pose2D, BeamSplit]]:
        left = dict(truth)  # a later scan with a processed one's stamp was skipped as out of order
        for _, _, msg in read_messages(bag, [result.frames.names.scan_topic]):
            pose = left.pop(stamp_of(msg), None)
            if pose is not None:
                scan = result.frames.scan(msg)
                usable = slam.config.usable_range(scan.range_max)
                yield pose.compose(slam.laser_pose), split_beams(scan, usable, slam.config.maxRange)

    return scans


def _pose_or_none(msg: Any, stamp: float, topic: str, result: SlamReplay) -> Pose2D | None:
    """The pose of an odometry message, or None (counted, the first reason kept) when its values are not finite:
    one bad message is skipped, not the replay."""
    try:
        return pose_from_odometry(msg) if hasattr(msg, "pose") else transform_pose(msg)
    except InvalidInputError as err:
        result.poses_invalid += 1
        result.first_invalid_pose = result.first_invalid_pose or f"{topic} at {stamp:.3f} s: {err}"
        return None


def _check_pairing(bag: Path, result: SlamReplay) -> None:
    for what, bad, total in (
        ("scans", result.scans_out_of_order, result.scans_read),
        ("odometry messages", result.odom_out_of_order, result.odom_read),
    ):
        if bad > MAX_UNPAIRED_FRACTION * total:
            raise BagError(
                f"bag {bag}: {bad} of {total} {what} are stamped at or before the previous one, so scans cannot be "
                "paired with distinct odometry; fix the stamps (carmen2bag repairs a CARMEN log's)"
            )


def _process(result: SlamReplay, stamp: float, msg: Any, odom: PoseTrack, truth: PoseTrack) -> None:
    if stamp <= result.last_scan_stamp:
        result.scans_out_of_order += 1
        return
    result.last_scan_stamp = stamp
    where = f"scan on {result.frames.names.scan_topic} (frame '{result.frames.laser_frame}') at {stamp:.3f} s"
    pose = odom.at(stamp)
    if pose is None:
        result.reject(f"{where}: no odometry within {odom.tolerance} s")
        return
    t0 = time.process_time()
    try:
        done = result.slam.add_scan(pose, result.frames.scan(msg), stamp)
    except MrsNavError as err:
        result.reject(f"{where}: {err}")
        return
    if done is None:
        return
    result.ms_per_scan.append(1000.0 * (time.process_time() - t0))
    result.stamps.append(stamp)
    result.estimate.append(done.pose)
    result.odometry.append(pose)


def output_paths(out_dir: Path, name: str = "slam_map") -> dict[str, Path]:
    """The files :func:`write_outputs` writes into ``out_dir`` (``map_image``: the .pgm beside the map)."""
    return {
        "map_yaml": out_dir / f"{name}.yaml",
        "map_image": out_dir / f"{name}.pgm",
        "trajectory": out_dir / "trajectory.csv",
        "png": out_dir / f"{name}.png",
    }


def write_outputs(result: SlamReplay, out_dir: Path, name: str = "slam_map") -> dict[str, Path]:
    """Write the map (map_server format), the trajectory (CSV) and a PNG of both; return their paths."""
    grid = result.slam.grid
    # Trajectory poses are refreshed from the SLAM state, which loop closure may have corrected since.
    estimate = [p.pose for p in result.slam.processed]
    occupancy = OccupancyGrid(grid.to_occupancy(), grid.resolution, (grid.origin_x, grid.origin_y, 0.0))
    paths = output_paths(out_dir, name)
    yaml = save_map(occupancy, paths["map_yaml"])
    csv = paths["trajectory"]
    lines = ["stamp,x,y,yaw,odom_x,odom_y,odom_yaw,truth_x,truth_y,truth_yaw"]
    for i, (t, est, od) in enumerate(zip(result.stamps, estimate, result.odometry, strict=True)):
        gt = result.truth[i] if i < len(result.truth) else None
        gt_text = f"{gt.x:.4f},{gt.y:.4f},{gt.yaw:.5f}" if gt else ",,"
        lines.append(f"{t:.6f},{est.x:.4f},{est.y:.4f},{est.yaw:.5f},{od.x:.4f},{od.y:.4f},{od.yaw:.5f},{gt_text}")
    write_text(csv, "\n".join(lines) + "\n", "trajectory")
    png = paths["png"]
    _plot(result, estimate, occupancy.values, png)
    return {"map_yaml": yaml, "trajectory": csv, "png": png}


def _plot(result: SlamReplay, estimate: list[Pose2D], occ: npt.NDArray[np.int8], png: Path) -> None:
    """Draw the map (``occ``: the grid's occupancy values, taken once for the map file and this, as large as
    the map's extent) and the trajectories."""
    # Imported here: matplotlib adds ~0.3 s to every start of mrs-nav, and only this output needs it.
    from matplotlib.figure import Figure  # noqa: PLC0415

    grid = result.slam.grid
    extent = (grid.origin_x, grid.origin_x + grid.width * grid.resolution)
    extent_y = (grid.origin_y, grid.origin_y + grid.height * grid.resolution)
    fig = Figure(figsize=(8, 8))
    ax = fig.add_subplot()
    # As RGB bytes, not grey levels through a colour map: matplotlib maps and resamples those in float64 RGBA,
    # 0.13 GB for the 1600-pixel image of the Freiburg campus map, RGB bytes 7 MB.
    ax.imshow(np.repeat(_shades(occ)[:, :, None], 3, axis=2), origin="lower", extent=(*extent, *extent_y))
    est = np.array([[p.x, p.y] for p in estimate])
    if est.size:
        ax.plot(est[:, 0], est[:, 1], "b-", lw=1.0, label="SLAM")
        odo = np.array([[p.x, p.y] for p in result.odometry])
        odo_in_map = estimate[0].compose(result.odometry[0].inverse()).apply(odo)
        ax.plot(odo_in_map[:, 0], odo_in_map[:, 1], "r:", lw=0.8, label="odometry")
        if result.has_truth:
            # Ground truth is drawn in the map frame: the rigid fit of truth onto the estimate.
            paired_estimate, paired_truth = result.truth_pairs()
            gt = np.array([[p.x, p.y] for p in paired_truth])
            gt_in_map = align_se2(gt, np.array([[p.x, p.y] for p in paired_estimate])).apply(gt)
            ax.plot(gt_in_map[:, 0], gt_in_map[:, 1], "g--", lw=0.8, label="ground truth")
        xs, ys = est[:, 0], est[:, 1]
        known = occ >= 0
        cols, rows = np.flatnonzero(known.any(axis=0)), np.flatnonzero(known.any(axis=1))
        if cols.size:
            xs = np.concatenate([xs, grid.origin_x + cols[[0, -1]] * grid.resolution])
            ys = np.concatenate([ys, grid.origin_y + rows[[0, -1]] * grid.resolution])
        ax.set_xlim(float(xs.min()) - 1.0, float(xs.max()) + 1.0)
        ax.set_ylim(float(ys.min()) - 1.0, float(ys.max()) + 1.0)
        ax.legend(loc="upper right")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"SLAM map and trajectories ({len(estimate)} scans)")
    with atomic_path(png, "figure") as temp:
        fig.savefig(temp, format="png", dpi=100, bbox_inches="tight")


def _shades(occ: npt.NDArray[np.int8]) -> npt.NDArray[np.uint8]:
    """The map as grey levels (occupied 0, unknown 204, free 255), reduced by whole blocks to at most
    :data:`PLOT_MAX_PIXELS` a side, each block as dark as its darkest cell so that thin walls stay drawn.

    Why: matplotlib resamples the image in float64 RGBA, 32 bytes a cell: on a 250 m hall at 5 cm (19 M cells)
    drawing the whole grid took 1.8 GB, more than the SLAM itself.
    """
    shades = np.full(occ.shape, 204, dtype=np.uint8)
    shades[occ == 100] = 0
    shades[occ == 0] = 255
    block = -(-max(occ.shape) // PLOT_MAX_PIXELS)
    if block == 1:
        return shades
    height, width = -(-occ.shape[0] // block) * block, -(-occ.shape[1] // block) * block
    padded = np.pad(shades, ((0, height - occ.shape[0]), (0, width - occ.shape[1])), constant_values=204)
    reduced: npt.NDArray[np.uint8] = padded.reshape(height // block, block, width // block, block).min(axis=(1, 3))
    return reduced
