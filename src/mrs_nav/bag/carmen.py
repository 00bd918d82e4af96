"""Reading CARMEN robot logs: laser scans (``FLASER``) with the logged pose, and the robot's odometry (``ODOM``).

Line formats (CARMEN 0.7, the "old" laser format)::

    FLASER n r_0 .. r_{n-1} x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
    ODOM x y theta tv rv accel timestamp host logger_timestamp

Ranges in metres, poses in metres and radians. Beam angles follow CARMEN's own reader
(``carmen_string_to_robot_laser_message_orig``): the first beam at -90 degrees, the increment guessed from the
beam count by ``carmen_laser_guess_angle_increment`` (1 degree for 180/181 beams, 0.5 for 360/361, 0.25 for
400/401, otherwise 180 degrees over ``n - 1`` steps). Other message types are skipped. ``.gz`` files are read
compressed.

Every line this module reads is checked against stated limits (:data:`MAX_BEAMS`, :data:`MAX_RANGE_M`,
:data:`MAX_COORDINATE_M`, :data:`MAX_LOGGED_STAMP_S`); a bad one raises :class:`InvalidInputError` naming
``file:line`` and the field.

Odometry (:func:`odometry_increments`): in a "corrected" log both FLASER pose triples are the corrected
trajectory, and the ODOM lines between two scans hold the previous scan's corrected pose advanced by the wheel
odometry (the first ODOM line after a scan re-anchors the stream at that scan's pose). In a raw log the ODOM
stream simply continues. Both are read by one rule: the increment of scan ``k`` is the last ODOM pose before
it, expressed in the frame of the ODOM pose the stream had at scan ``k-1`` (its re-anchoring line if the next
line re-anchors, else the last ODOM line before that scan). A scan with no ODOM line since the previous one is
an odometry gap (``None``).
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
from mrs_nav.textfiles import bounded_lines, check_regular

MAX_BEAMS = 10_000  # beams per scan; the densest 2-D lasers give a few thousand
MAX_RANGE_M = 1_000.0  # m; no 2-D laser in these logs reaches a kilometre
MAX_COORDINATE_M = 100_000.0  # m; a pose farther out than 100 km is not a building
MAX_STAMP_S = 2.0**32  # s; ROS 1 time is an unsigned 32-bit second count
# s; a logged stamp farther from 0 is not a time. Logs count from other origins (the MIT Infinite Corridor log
# starts at -0.45 s, then prints 4.29497e+09: times wrapped at 2^32 and cut to six digits) and carry single
# glitched stamps (Freiburg 079, Seattle: one ODOM line at -0.96 or -1.63 s among stamps of thousands); the
# conversion makes ROS times of them (mrs_nav.bag.from_carmen).
MAX_LOGGED_STAMP_S = 1e12
MAX_LINE_CHARS = 64 * MAX_BEAMS  # a line of the longest scan's numbers, remissions and all, written out in full
ANCHOR_TOLERANCE = 1e-4  # m and rad: an ODOM line this close to a scan's pose re-anchors the stream


@dataclass(frozen=True)
class CarmenScan:
    """One FLASER record: time (s), ranges (m), the logged pose, the logged odometry pose, its line number."""

    timestamp: float
    ranges: FloatArray
    pose: Pose2D
    odom: Pose2D
    line: int = 0

    @property
    def angle_min(self) -> float:
        return -math.pi / 2.0

    @property
    def angle_increment(self) -> float:
        return carmen_angle_increment(self.ranges.size)


@dataclass(frozen=True)
class CarmenOdom:
    """One ODOM record: time (s) and the odometry pose."""

    timestamp: float
    pose: Pose2D
    line: int = 0


def carmen_angle_increment(beams: int) -> float:
    """CARMEN's guess of the angle between beams of a front laser with ``beams`` readings (rad)."""
    if beams in (180, 181):
        return math.pi / 180.0
    if beams in (360, 361):
        return math.pi / 360.0
    if beams in (400, 401):
        return math.pi / 720.0
    return math.pi / max(beams - 1, 1)


def _numbers(fields: list[str], where: str, what: str) -> list[float]:
    try:
        values = [float(v) for v in fields]
    except ValueError as err:
        raise InvalidInputError(f"{where}: malformed {what} ({err})") from None
    return values


def _stamp(value: float, where: str) -> float:
    if not (math.isfinite(value) and abs(value) < MAX_LOGGED_STAMP_S):
        raise InvalidInputError(f"{where}: timestamp {value} is not a time within +-1e12 s")
    return value


def _pose(values: list[float], where: str, what: str) -> Pose2D:
    x, y, yaw = values
    if not all(math.isfinite(v) for v in values) or max(abs(x), abs(y)) > MAX_COORDINATE_M or abs(yaw) > 1e3:
        raise InvalidInputError(f"{where}: {what} ({x}, {y}, {yaw}) is not finite or beyond {MAX_COORDINATE_M:g} m")
    return Pose2D(x, y, yaw)


def _fields(line: str, kind: str, where: str, least: int, missing: str) -> list[str]:
    """The words of a ``kind`` line, at least ``least`` of them (else ``missing`` says what is absent)."""
    fields = line.split()
    if not fields or fields[0] != kind:
        raise InvalidInputError(f"{where}: not a{'n' if kind[0] in 'AEIOU' else ''} {kind} line")
    if len(fields) < least:
        raise InvalidInputError(f"{where}: {kind} line {missing}")
    return fields


def parse_flaser(line: str, where: str = "line", number: int = 0) -> CarmenScan:
    """Parse one FLASER line; ``where`` names it in errors (e.g. ``"log.gz:12"``)."""
    fields = _fields(line, "FLASER", where, 2, "without a beam count")
    try:
        n = int(fields[1])
    except ValueError:
        raise InvalidInputError(f"{where}: FLASER beam count {fields[1]!r} is not an integer") from None
    if not 0 < n <= MAX_BEAMS:
        raise InvalidInputError(f"{where}: FLASER beam count {n} is not in 1..{MAX_BEAMS}")
    # n ranges, two pose triples and the stamp, then host and logger stamp (some writers leave those two out).
    if len(fields) not in (n + 9, n + 11):
        raise InvalidInputError(
            f"{where}: FLASER line with {n} beams has {len(fields)} fields, needs {n + 11} (or {n + 9}): "
            "the beam count does not fit the line"
        )
    ranges = np.array(_numbers(fields[2 : 2 + n], where, "FLASER range"), dtype=np.float64)
    bad = ~(np.isfinite(ranges) & (ranges >= 0.0) & (ranges <= MAX_RANGE_M))
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(f"{where}: FLASER range {i} is {ranges[i]}, not in 0..{MAX_RANGE_M:g} m")
    tail = _numbers(fields[2 + n : 2 + n + 7], where, "FLASER pose or timestamp")
    pose = _pose(tail[0:3], where, "FLASER pose")
    odom = _pose(tail[3:6], where, "FLASER odometry pose")
    return CarmenScan(_stamp(tail[6], where), ranges, pose, odom, number)


def parse_odom(line: str, where: str = "line", number: int = 0) -> CarmenOdom:
    """Parse one ODOM line; ``where`` names it in errors."""
    fields = _fields(line, "ODOM", where, 8, f"has only {len(line.split())} fields, needs 8 or more")
    values = _numbers(fields[1:8], where, "ODOM line")
    return CarmenOdom(_stamp(values[6], where), _pose(values[0:3], where, "ODOM pose"), number)


def read_records(path: Path) -> Iterator[CarmenScan | CarmenOdom]:
    """Yield the FLASER and ODOM records of a CARMEN log in file order."""
    opener = gzip.open if path.suffix == ".gz" else open
    check_regular(path, "CARMEN log")
    try:
        with opener(path, "rt", encoding="utf-8", errors="replace") as handle:
            for number, line in enumerate(bounded_lines(handle, MAX_LINE_CHARS, str(path)), start=1):
                # The type is the first word: "FLASERX" or "ODOMETRY" are other messages, skipped.
                kind = line.split(maxsplit=1)[0] if line.strip() else ""
                if kind == "FLASER":
                    yield parse_flaser(line, f"{path}:{number}", number)
                elif kind == "ODOM":
                    yield parse_odom(line, f"{path}:{number}", number)
    except (OSError, EOFError, UnicodeError) as err:
        raise InvalidInputError(f"cannot read CARMEN log {path}: {err}") from None


def read_flaser(path: Path) -> Iterator[CarmenScan]:
    """Yield the FLASER records of a CARMEN log in file order."""
    for record in read_records(path):
        if isinstance(record, CarmenScan):
            yield record


@dataclass(frozen=True)
class CarmenLog:
    """The scans of a log and, per scan, the odometry since the previous scan: ``(stamp, pose)`` of each ODOM
    line, the pose relative to the stream's pose at the previous scan (empty: a gap; empty for the first scan)."""

    scans: list[CarmenScan]
    odometry: list[list[tuple[float, Pose2D]]]
    odom_lines: int

    @property
    def increments(self) -> list[Pose2D | None]:
        """Per scan, the odometry increment since the previous scan (None: a gap; identity for the first)."""
        first: list[Pose2D | None] = [Pose2D(0.0, 0.0, 0.0)]
        return first + [path[-1][1] if path else None for path in self.odometry[1:]]

    @property
    def gaps(self) -> int:
        """Scans after the first with no odometry since the previous one."""
        return sum(not path for path in self.odometry[1:])


def read_log(path: Path) -> CarmenLog:
    """All scans of ``path`` with the odometry between them (see the module doc for the rule)."""
    scans: list[CarmenScan] = []
    odometry: list[list[tuple[float, Pose2D]]] = []
    base: CarmenOdom | None = None  # the stream's pose at the previous scan
    last: CarmenOdom | None = None  # the last ODOM line read
    since: list[CarmenOdom] = []  # ODOM lines since the previous scan
    odom_lines = 0
    for record in read_records(path):
        if isinstance(record, CarmenOdom):
            odom_lines += 1
            if scans and not since and base is not None and _same(record.pose, scans[-1].pose):
                base = record  # a corrected log re-anchoring the stream at the previous scan's pose
            else:
                since.append(record)
            last = record
            continue
        anchor = base
        odometry.append([(o.timestamp, o.pose.relative_to(anchor.pose)) for o in since] if scans and anchor else [])
        scans.append(record)
        base, since = last, []
        if base is None:  # no odometry before the first scan: the stream starts at the next line
            base = CarmenOdom(record.timestamp, record.pose)
    return CarmenLog(scans, odometry, odom_lines)


def _same(a: Pose2D, b: Pose2D) -> bool:
    return max(abs(a.x - b.x), abs(a.y - b.y), abs(a.yaw - b.yaw)) < ANCHOR_TOLERANCE
