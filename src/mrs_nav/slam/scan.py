"""A planar laser scan as plain data, and its split into hits and free-space-only beams.

As in gmapping: NaN, readings below ``range_min`` and readings at or beyond the range limit (``+inf`` is "no
return" in REP 117; SICK lasers report their maximum) are ignored, since a missing return says nothing reliable
about where free space ends (glass, black surfaces). Readings beyond the usable range ``maxUrange`` but within
the limit clear free space up to ``maxUrange`` and mark no obstacle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray

if TYPE_CHECKING:  # only its fields are read: the simulator's kernels are not loaded with the SLAM's
    from mrs_nav.sim.laser import Scan

MAX_BEAMS = 100_000  # beams per scan; 2-D lasers give at most a few thousand


@dataclass(frozen=True)
class LaserScanData:
    """Ranges (m) of beams at ``angle_min + i * angle_increment`` (rad) in the laser frame."""

    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: FloatArray

    def __post_init__(self) -> None:
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            if not math.isfinite(getattr(self, name)):
                raise InvalidInputError(f"laser scan {name} must be finite, got {getattr(self, name)}")
        if self.range_max <= self.range_min or self.range_min < 0.0:
            raise InvalidInputError(f"laser scan range limits are invalid: {self.range_min}..{self.range_max}")
        if self.ranges.ndim != 1:
            raise InvalidInputError(f"laser scan ranges must be one-dimensional, got shape {self.ranges.shape}")

    @classmethod
    def from_message_fields(
        cls,
        *,
        angle_min: float,
        angle_max: float,
        angle_increment: float,
        range_min: float,
        range_max: float,
        ranges: FloatArray,
    ) -> LaserScanData:
        """A scan from the fields of a ``sensor_msgs/LaserScan``, rejecting ranges that do not fit its angles."""
        for name, value in (("angle_min", angle_min), ("angle_max", angle_max), ("angle_increment", angle_increment)):
            if not math.isfinite(value):
                raise InvalidInputError(f"laser scan {name} must be finite, got {value}")
        if angle_increment == 0.0:
            raise InvalidInputError(f"laser scan has angle_increment {angle_increment}")
        span = (angle_max - angle_min) / angle_increment
        if not -1.0 < span < MAX_BEAMS:
            raise InvalidInputError(
                f"laser scan angles {angle_min:.4g}..{angle_max:.4g} step {angle_increment:.4g} make {span:.3g} beams, "
                f"not 1..{MAX_BEAMS}"
            )
        expected = round(span) + 1
        if ranges.size != expected:
            raise InvalidInputError(
                f"laser scan has {ranges.size} ranges but its angles {angle_min:.4f}..{angle_max:.4f} "
                f"step {angle_increment:.5f} need {expected}"
            )
        return cls(angle_min, angle_increment, range_min, range_max, np.asarray(ranges, dtype=np.float64))

    @property
    def angles(self) -> FloatArray:
        return np.asarray(self.angle_min + self.angle_increment * np.arange(self.ranges.size), dtype=np.float64)


@dataclass(frozen=True)
class BeamSplit:
    """Beams of a scan sorted by what they say about the world, in the laser frame.

    ``hit_*``: beams that ended on an obstacle within the usable range (angle rad, range m).
    ``free_*``: beams that only clear free space, up to ``free_ranges`` (longer than the usable range).
    """

    hit_angles: FloatArray
    hit_ranges: FloatArray
    free_angles: FloatArray
    free_ranges: FloatArray

    @property
    def hit_points(self) -> FloatArray:
        """The hit beams' end points in the laser frame (N x 2, m)."""
        return np.stack([self.hit_ranges * np.cos(self.hit_angles), self.hit_ranges * np.sin(self.hit_angles)], axis=1)


@dataclass(frozen=True)
class StoredBeams:
    """A :class:`BeamSplit` as kept for the scans the map is rebuilt from after a loop closure (the graph's
    nodes and a few beside each): angles and ranges in float32 (micro-radians and micrometres at building scale,
    far below a map cell) and the free-space beams' common length once: half the float64 arrays' bytes (2.6 KB
    for a 360-beam scan instead of 5.2 KB), so the node's memory grows half as fast with the mapped extent."""

    hit_angles: npt.NDArray[np.float32]
    hit_ranges: npt.NDArray[np.float32]
    free_angles: npt.NDArray[np.float32]
    free_range: float

    @classmethod
    def of(cls, beams: BeamSplit) -> StoredBeams:
        free_range = float(beams.free_ranges[0]) if beams.free_ranges.size else 0.0
        return cls(
            beams.hit_angles.astype(np.float32),
            beams.hit_ranges.astype(np.float32),
            beams.free_angles.astype(np.float32),
            free_range,
        )

    def split(self) -> BeamSplit:
        """The beams again, in float64."""
        return BeamSplit(
            self.hit_angles.astype(np.float64),
            self.hit_ranges.astype(np.float64),
            self.free_angles.astype(np.float64),
            np.full(self.free_angles.size, self.free_range, dtype=np.float64),
        )

    @property
    def nbytes(self) -> int:
        return int(self.hit_angles.nbytes + self.hit_ranges.nbytes + self.free_angles.nbytes)


def split_beams(scan: LaserScanData, max_usable: float, max_range: float = 0.0) -> BeamSplit:
    """Classify the beams of ``scan``.

    ``max_usable`` is gmapping's ``maxUrange``; ``max_range`` (``0``: the scan's ``range_max``) is gmapping's
    ``maxRange``, where a reading means "no return".
    """
    r = np.asarray(scan.ranges, dtype=np.float64)
    a = scan.angles
    limit = scan.range_max if max_range <= 0.0 else min(max_range, scan.range_max)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(r) & (r >= scan.range_min) & (r < limit)
    usable = min(max_usable, limit)
    hit = valid & (r < usable)
    free = valid & (r >= usable)
    return BeamSplit(
        hit_angles=a[hit],
        hit_ranges=r[hit],
        free_angles=a[free],
        free_ranges=np.full(int(free.sum()), usable, dtype=np.float64),
    )


def laser_scan_data(scan: Scan) -> LaserScanData:
    """The SLAM core's view of a simulated scan."""
    p = scan.params
    return LaserScanData(p.angle_min, p.angle_increment, p.range_min, p.range_max, scan.ranges)
