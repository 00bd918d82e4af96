"""Reading CARMEN robot logs (FLASER lines): laser scans with the robot pose at each scan.

Line format (CARMEN 0.7): ``FLASER n r_0 .. r_{n-1} x y theta odom_x odom_y odom_theta timestamp host
logger_timestamp``; ranges in metres, beams spread evenly over 180 degrees starting at -90 degrees, poses in
metres and radians. In "corrected" logs ``x y theta`` is the corrected (ground-truth) laser pose. Other message
types are skipped. Files may be gzip-compressed (``.gz``).
"""

from __future__ import annotations

import gzip
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D

FLASER_FOV = math.pi  # CARMEN front lasers: 180 degrees


@dataclass(frozen=True)
class CarmenScan:
    """One FLASER record: time (s), ranges (m), the logged pose and the logged odometry pose."""

    timestamp: float
    ranges: FloatArray
    pose: Pose2D
    odom: Pose2D

    @property
    def angle_min(self) -> float:
        return -FLASER_FOV / 2.0

    @property
    def angle_increment(self) -> float:
        return FLASER_FOV / self.ranges.size


def parse_flaser(line: str, where: str = "line") -> CarmenScan:
    """Parse one FLASER line; ``where`` names it in errors (e.g. ``"log.gz:12"``)."""
    fields = line.split()
    if not fields or fields[0] != "FLASER":
        raise InvalidInputError(f"{where}: not a FLASER line")
    try:
        n = int(fields[1])
        if n <= 0 or len(fields) < 2 + n + 7:
            raise InvalidInputError(f"{where}: FLASER line with {n} beams has only {len(fields)} fields")
        ranges = np.array([float(v) for v in fields[2 : 2 + n]], dtype=np.float64)
        x, y, th, ox, oy, oth, stamp = (float(v) for v in fields[2 + n : 2 + n + 7])
        return CarmenScan(stamp, ranges, Pose2D(x, y, th), Pose2D(ox, oy, oth))
    except (ValueError, IndexError) as err:  # IndexError: a line with nothing after "FLASER"
        raise InvalidInputError(f"{where}: malformed FLASER line ({err})") from None


def read_flaser(path: Path) -> Iterator[CarmenScan]:
    """Yield the FLASER records of a CARMEN log in file order."""
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", encoding="utf-8", errors="replace") as handle:
            for number, line in enumerate(handle, start=1):
                if line.startswith("FLASER"):
                    yield parse_flaser(line, f"{path}:{number}")
    except (OSError, EOFError) as err:
        raise InvalidInputError(f"cannot read CARMEN log {path}: {err}") from None
