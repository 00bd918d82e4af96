"""Converting a CARMEN log into a ROS 1 bag that the SLAM replay (and ``rosbag play``) can use.

Topics written (frames of REP 105): ``/scan`` (``sensor_msgs/LaserScan`` in ``base_scan``, the log's beam
geometry), ``/ground_truth/odom`` (the log's corrected poses, ``map -> base_footprint``), ``/odom`` and ``/tf``
(``odom -> base_footprint``: odometry integrated from ground-truth increments with the odometry motion model's
noise, see :mod:`mrs_nav.motion_model`) and ``/tf_static`` (``base_footprint -> base_scan``, identity: the
logged poses are the laser's). Bag time is the log's timestamp; odometry shares each scan's stamp.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrs_nav.bag.carmen import CarmenScan, read_flaser
from mrs_nav.bag.io import BagWriter
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, laser_scan_message, odometry_message, tf_message
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.motion_model import OdometryNoise, noisy_odometry
from mrs_nav.slam.scan import LaserScanData

TF = "tf2_msgs/msg/TFMessage"


@dataclass(frozen=True)
class ConversionSummary:
    """What a conversion wrote: scan count and the log's duration in seconds."""

    scans: int
    duration_s: float


def carmen_to_bag(
    log: Path,
    bag: Path,
    noise: OdometryNoise,
    seed: int,
    *,
    max_range: float | None = None,
    progress: Callable[[int], None] | None = None,
) -> ConversionSummary:
    """Write the FLASER records of ``log`` to ``bag``; ``max_range`` defaults to the log's largest reading."""
    scans: list[CarmenScan] = list(read_flaser(log))
    if not scans:
        raise InvalidInputError(f"CARMEN log {log} has no FLASER lines")
    limit = max_range if max_range is not None else max(float(np.max(s.ranges)) for s in scans)
    odom = noisy_odometry([s.pose for s in scans], noise, np.random.default_rng(seed))
    with BagWriter(bag) as writer:
        first = scans[0].timestamp
        writer.write(
            "/tf_static",
            TF,
            _ns(first),
            tf_message(Pose2D(0.0, 0.0, 0.0), first, "base_footprint", "base_scan"),
            latching=True,
        )
        for seq, (scan, pose) in enumerate(zip(scans, odom, strict=True)):
            t = scan.timestamp
            data = LaserScanData(scan.angle_min, scan.angle_increment, 0.0, limit, scan.ranges)
            writer.write("/odom", ODOMETRY, _ns(t), odometry_message(pose, t, "odom", "base_footprint", seq))
            writer.write("/tf", TF, _ns(t), tf_message(pose, t, "odom", "base_footprint"))
            truth = odometry_message(scan.pose, t, "map", "base_footprint", seq)
            writer.write("/ground_truth/odom", ODOMETRY, _ns(t), truth)
            writer.write("/scan", LASER_SCAN, _ns(t), laser_scan_message(data, t, "base_scan", seq))
            if progress is not None:
                progress(1)
    return ConversionSummary(len(scans), scans[-1].timestamp - first)


def _ns(seconds: float) -> int:
    return round(seconds * 1e9)
