"""SLAM-lite: a gmapping substitute with one pose hypothesis and scan-to-map matching.

Each processed scan is predicted from odometry, aligned to the map built so far (:mod:`mrs_nav.slam.matcher`)
and added to it (:mod:`mrs_nav.slam.grid`). Scans are processed only when the robot has moved or turned enough
or enough time has passed (gmapping's ``linearUpdate``, ``angularUpdate``, ``temporalUpdate``).

Frames: ``map`` is the frame of the first processed pose's odometry (``map -> odom`` starts as identity);
``odom`` is the odometry frame; poses of the robot are of its base frame; ``laser_pose`` is base -> laser.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.slam.config import MAX_COORDINATE_M, MAX_MAP_CELLS, SlamConfig
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.matcher import DistanceField, MatchResult, ScanMatcher, thin_points
from mrs_nav.slam.scan import BeamSplit, LaserScanData, split_beams

MIN_POINTS = 10  # fewer end points than this: trust odometry, the match would be noise
FIELD_MAX_DISTANCE = 0.5  # m, truncation of the distance field
MIN_SPREAD_M = 0.01  # m, floor of the odometry prediction's position spread
MIN_SPREAD_RAD = math.radians(0.5)  # floor of its heading spread


@dataclass(frozen=True)
class ProcessedScan:
    """One processed scan: its time (s), the corrected base pose in the map, the odometry pose, the match."""

    stamp: float
    pose: Pose2D
    odom: Pose2D
    match: MatchResult | None


class Slam:
    """Online 2-D SLAM over (odometry pose, laser scan) pairs."""

    def __init__(
        self, config: SlamConfig | None = None, laser_pose: Pose2D | None = None, history: int | None = None
    ) -> None:
        self.config = config or SlamConfig()
        self.laser_pose = laser_pose or Pose2D(0.0, 0.0, 0.0)
        c = self.config
        self.grid = LogOddsGrid(
            c.delta,
            (c.xmin, c.ymin, c.xmax, c.ymax),
            grows=c.map_grows,
            lfree=c.lfree,
            loccupied=c.loccupied,
            lmax=c.lmax,
            max_cells=MAX_MAP_CELLS,
        )
        self.matcher = ScanMatcher(c.sigma, c.search_linear, c.search_angular)
        # Every processed scan, for offline use (replay's trajectory); ``history`` keeps only that many of the
        # latest (the gates need the last one) so that a run of hours does not grow without end.
        self.processed: list[ProcessedScan] | deque[ProcessedScan] = [] if history is None else deque(maxlen=history)
        self._map_to_odom = Pose2D(0.0, 0.0, 0.0)

    @property
    def map_to_odom(self) -> Pose2D:
        """The correction ``map -> odom`` after the last processed scan."""
        return self._map_to_odom

    def pose_at(self, odom: Pose2D) -> Pose2D:
        """Best estimate of the base pose in the map for an odometry pose (map->odom * odom)."""
        return self._map_to_odom.compose(odom)

    def wants(self, odom: Pose2D, stamp: float) -> bool:
        """Whether a scan at this odometry pose and time passes the update gates."""
        if not self.processed:
            return True
        last = self.processed[-1]
        c = self.config
        moved = odom.relative_to(last.odom)
        if math.hypot(moved.x, moved.y) >= c.linearUpdate or abs(moved.yaw) >= c.angularUpdate:
            return True
        return c.temporalUpdate > 0.0 and stamp - last.stamp >= c.temporalUpdate

    def add_scan(
        self, odom: Pose2D, scan: LaserScanData, stamp: float, laser_pose: Pose2D | None = None
    ) -> ProcessedScan | None:
        """Process a scan taken at odometry pose ``odom`` if the gates allow; return what was done or None.

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
        points = _points(beams)
        if self.processed and points.shape[0] >= MIN_POINTS:
            sensor_prior = predicted.compose(mount)
            match = self._match(points, sensor_prior, self._spread(odom))
            pose = match.pose.compose(mount.inverse())
        else:
            pose = predicted
        self.grid.integrate(pose.compose(mount), beams)
        self._map_to_odom = pose.compose(odom.inverse())
        record = ProcessedScan(stamp, pose, odom, match)
        self.processed.append(record)
        return record

    def _spread(self, odom: Pose2D) -> tuple[float, float]:
        """Standard deviations (m, rad) of the odometry prediction since the last processed scan."""
        c = self.config
        moved = odom.relative_to(self.processed[-1].odom)
        travelled, turned = math.hypot(moved.x, moved.y), abs(moved.yaw)
        return (
            MIN_SPREAD_M + c.srr * travelled + c.srt * turned,
            MIN_SPREAD_RAD + c.str * travelled + c.stt * turned,
        )

    def _match(self, points: FloatArray, sensor_prior: Pose2D, spread: tuple[float, float]) -> MatchResult:
        thinned = thin_points(points, self.config.delta)
        c, s = math.cos(sensor_prior.yaw), math.sin(sensor_prior.yaw)
        wx = sensor_prior.x + c * thinned[:, 0] - s * thinned[:, 1]
        wy = sensor_prior.y + s * thinned[:, 0] + c * thinned[:, 1]
        # The window covers the predicted scan plus the linear search; points that the angular search swings
        # farther out fall in the padding, where they score nothing, which is what a wrong heading deserves.
        reach = self.config.search_linear + FIELD_MAX_DISTANCE
        margin = reach
        bounds = (
            float(wx.min()) - margin,
            float(wy.min()) - margin,
            float(wx.max()) + margin,
            float(wy.max()) + margin,
        )
        pad = math.ceil(reach / self.config.delta) + 2
        field = DistanceField(self.grid, bounds, FIELD_MAX_DISTANCE, pad)
        return self.matcher.match(field, thinned, sensor_prior, spread)


def _points(beams: BeamSplit) -> FloatArray:
    return np.stack([beams.hit_ranges * np.cos(beams.hit_angles), beams.hit_ranges * np.sin(beams.hit_angles)], axis=1)
