"""Converting a CARMEN log into a ROS 1 bag that the SLAM replay (and ``rosbag play``) can use.

Topics written (frames of REP 105): ``/scan`` (``sensor_msgs/LaserScan`` in ``base_scan``, CARMEN's beam
geometry), ``/ground_truth/odom`` (the log's FLASER poses, ``map -> base_footprint``; in a corrected log that is
another SLAM's output, a reference rather than ground truth), ``/odom`` and ``/tf`` (``odom -> base_footprint``)
and ``/tf_static`` (``base_footprint -> base_scan``, identity: the logged poses are the laser's). Bag time is
the scan's timestamp; odometry shares each scan's stamp.

Odometry: by default the robot's real odometry, integrated from the log's ODOM increments
(:func:`mrs_nav.bag.carmen.read_log`) starting at the first scan's pose, one ``/odom`` per ODOM line that falls
between two scans in time order plus one at each scan's stamp; a scan with no odometry since the
previous one (a gap) repeats the previous odometry pose, so the scan matcher has to find that motion alone.
``odom_scale`` (linear, angular) multiplies every increment: a correction of the wheels' calibration, or a
known miscalibration to see how a SLAM result depends on the odometry.
With ``noise`` given (``--odom synthetic``), or when the log has no ODOM lines at all or gaps at more than half
its scans (:data:`MAX_GAP_FRACTION`), odometry is synthesised
from the logged poses' increments with the odometry motion model's noise (:mod:`mrs_nav.motion_model`).

Stamps: scans must be strictly increasing in time. A scan stamped at or before its predecessor (duplicate,
constant or backwards stamps) is restamped: a run of such scans is spread evenly between the last good stamp and
the next later one (at the end of the log, at the median of the log's increasing intervals, 1 s when there are
none); the repairs are counted in a note. The scans' order in the file is kept. A log with more than half of
its scans so stamped has no timing to repair: its scans are restamped 1 s apart and its odometry is written at
the scans only. ROS time is not negative: a log
whose first scan is stamped before 0 is shifted to start there, with a note.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrs_nav.atomic_write import check_not_inputs
from mrs_nav.bag.carmen import MAX_STAMP_S, CarmenLog, CarmenScan, read_log
from mrs_nav.bag.io import BagWriter
from mrs_nav.bag.messages import LASER_SCAN, ODOMETRY, laser_scan_message, odometry_message, tf_message
from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.motion_model import DEFAULT_ALPHAS, OdometryNoise, noisy_odometry
from mrs_nav.slam.scan import LaserScanData

TF = "tf2_msgs/msg/TFMessage"
FALLBACK_INTERVAL_S = 1.0  # scan interval used to restamp a log whose stamps carry no timing
# A log with more than half of its scans stamped at or before their predecessor has no timing to repair
# (constant, two-valued or wrapped stamps: CSAIL's two values 10,000 s apart, Belgioioso's and Freiburg campus's
# one value): every scan is restamped FALLBACK_INTERVAL_S apart.
MAX_RESTAMPED_FRACTION = 0.5
# Readings within 1 % of the log's largest are the laser's "no return" when the largest recurs (no_return_limit)
NO_RETURN_BAND = 0.01
NO_RETURN_REPEATS = 10
# A log with odometry gaps at more than half its scans has no odometry to speak of (Orebro's ODOM lines all
# re-anchor at a scan's pose): it is treated like a log without ODOM lines.
MAX_GAP_FRACTION = 0.5
ODOM_SCALE_RANGE = (0.5, 2.0)  # a wheel calibration off by more than a factor of 2 is a wrong number, not a fix


@dataclass(frozen=True)
class ConversionSummary:
    """What a conversion wrote: scan count, the (repaired) log's duration in seconds, which odometry, and notes
    on what was repaired or assumed (one line each, for ``NOTE:`` output)."""

    scans: int
    duration_s: float
    odometry: str
    notes: tuple[str, ...] = ()


def carmen_to_bag(
    log: Path,
    bag: Path,
    noise: OdometryNoise | None = None,
    seed: int = 0,
    *,
    max_range: float | None = None,
    odom_scale: tuple[float, float] = (1.0, 1.0),
    progress: Callable[[int], None] | None = None,
) -> ConversionSummary:
    """Write the scans of ``log`` to ``bag`` (replacing it); odometry from the log unless ``noise`` is given.

    ``max_range`` defaults to the laser's "no return" reading (:func:`no_return_limit`); readings at or past it
    are no return.
    ``odom_scale`` multiplies the log's odometry increments (linear, angular); synthetic odometry is not scaled.
    """
    low, high = ODOM_SCALE_RANGE
    if not all(low <= f <= high for f in odom_scale):
        raise InvalidInputError(f"odometry scale {odom_scale}: each factor must be in {low:g}..{high:g}")
    if noise is not None and odom_scale != (1.0, 1.0):
        raise InvalidInputError("the odometry scale applies to the log's odometry only, not to synthetic odometry")
    check_not_inputs([("bag", bag)], [("CARMEN log", log)])
    content = read_log(log)
    scans = content.scans
    if not scans:
        raise InvalidInputError(f"CARMEN log {log} has no FLASER lines")
    notes: list[str] = []
    stamps, timed = _scan_stamps(log, scans, notes)
    kind, odom, between = _odometry(
        log, content, stamps, timed=timed, noise=noise, seed=seed, odom_scale=odom_scale, notes=notes
    )
    if stamps[-1] - stamps[0] >= MAX_STAMP_S:
        raise InvalidInputError(f"CARMEN log {log}: its scans span more than 2^32 s, beyond ROS time")
    if stamps[-1] >= MAX_STAMP_S:
        raise InvalidInputError(f"CARMEN log {log}: its last scan is stamped past 2^32 s, beyond ROS time")
    if stamps[0] < 0.0:
        shift = -stamps[0]
        notes.append(f"{log}: the first scan is stamped {stamps[0]:.6g} s; every stamp shifted by +{shift:.6g} s")
        stamps = [t + shift for t in stamps]
        between = [[(t + shift, pose) for t, pose in path] for path in between]
    if max_range is None:
        limit, band = no_return_limit(scans)
        if band:
            notes.append(
                f"{log}: {band} readings of {limit:.6g}..{max(float(np.max(s.ranges)) for s in scans):.6g} m (within "
                f"{NO_RETURN_BAND:.0%} of the largest) taken as 'no return': range_max {limit:.6g} m"
            )
    else:
        limit = max_range
    if not limit > 0.0:
        raise InvalidInputError(f"CARMEN log {log}: every range is 0, so the laser's range limit is unknown")
    _write(bag, scans, stamps, (odom, between), limit=limit, progress=progress)
    return ConversionSummary(len(scans), stamps[-1] - stamps[0], kind, tuple(notes))


def _scan_stamps(log: Path, scans: list[CarmenScan], notes: list[str]) -> tuple[list[float], bool]:
    """The scans' repaired stamps (:func:`repaired_stamps`), and whether the log's stamps carry timing at all
    (if not, the scans are restamped :data:`FALLBACK_INTERVAL_S` apart); what was done is added to ``notes``."""
    stamps, restamped, interval = repaired_stamps([s.timestamp for s in scans])
    timed = restamped <= MAX_RESTAMPED_FRACTION * len(scans)
    if not timed:
        stamps = [i * FALLBACK_INTERVAL_S for i in range(len(scans))]
        notes.append(
            f"{log}: {restamped} of {len(scans)} scans were stamped at or before the previous scan, so the log's "
            f"stamps carry no timing: every scan restamped {FALLBACK_INTERVAL_S:g} s after the previous one, "
            "odometry written at the scans only"
        )
    elif restamped:
        notes.append(
            f"{log}: {restamped} of {len(scans)} scans were stamped at or before the previous scan; restamped "
            f"evenly between their good neighbours (at the end of the log: {interval:.3f} s apart, the median "
            "increasing interval)"
        )
    return stamps, timed


def _odometry(
    log: Path,
    content: CarmenLog,
    stamps: list[float],
    *,
    timed: bool,
    noise: OdometryNoise | None,
    seed: int,
    odom_scale: tuple[float, float],
    notes: list[str],
) -> tuple[str, list[Pose2D], list[list[tuple[float, Pose2D]]]]:
    """``(kind, odometry at the scans, odometry between them)``: the log's own, or synthetic when ``noise`` is
    given or the log's odometry is missing or mostly gaps; what was done is added to ``notes``."""
    scans = content.scans
    if noise is None and content.odom_lines == 0:
        notes.append(f"{log}: no ODOM lines; odometry synthesised from the logged poses with the default noise")
        noise = OdometryNoise.of(DEFAULT_ALPHAS)
    elif noise is None and content.gaps > MAX_GAP_FRACTION * (len(scans) - 1):
        notes.append(
            f"{log}: {content.gaps} of {len(scans)} scans have no odometry since the previous scan (the ODOM lines "
            "only repeat the scans' poses); odometry synthesised from the logged poses with the default noise"
        )
        noise = OdometryNoise.of(DEFAULT_ALPHAS)
    if noise is not None:
        odom = noisy_odometry([s.pose for s in scans], noise, np.random.default_rng(seed))
        return "synthetic", odom, [[] for _ in scans]
    odom, between = log_odometry(content, stamps, odom_scale)
    if not timed:  # the ODOM lines' own stamps cannot be placed among the new ones
        between = [[] for _ in scans]
    if content.gaps:
        notes.append(f"{log}: {content.gaps} scans have no odometry since the previous scan; odometry held there")
    return "log", odom, between


def no_return_limit(scans: list[CarmenScan]) -> tuple[float, int]:
    """The laser's "no return" reading: the lowest reading within :data:`NO_RETURN_BAND` of the log's largest,
    and how many readings lie in that band below the largest; the largest alone where it occurs fewer than
    :data:`NO_RETURN_REPEATS` times (a sentinel recurs, a far wall's exact reading rarely does).

    Why a band: lasers report "no return" as their limit, but not always as one number (Seattle's SICK gives
    81.87, 81.89 and 81.91 m, Acapulco's 51.14-51.16 m, Orebro's 32.759-32.767 m). Taking only the largest as
    the limit made every other one a wall 80 m away: a ring of false hits that grew the map tenfold and pulled
    the scan matcher.
    """
    largest = max(float(np.max(s.ranges)) for s in scans)
    if sum(int(np.count_nonzero(s.ranges == largest)) for s in scans) < NO_RETURN_REPEATS:
        return largest, 0  # no sentinel: a closed room's farthest wall
    floor = largest * (1.0 - NO_RETURN_BAND)
    banded = [s.ranges[s.ranges >= floor] for s in scans]
    limit = min((float(r.min()) for r in banded if r.size), default=largest)
    return limit, sum(int(np.count_nonzero(r < largest)) for r in banded)


def log_odometry(
    content: CarmenLog, stamps: list[float], scale: tuple[float, float] = (1.0, 1.0)
) -> tuple[list[Pose2D], list[list[tuple[float, Pose2D]]]]:
    """Odometry poses at the scans, integrated from the log's increments (each scaled by ``scale``, linear and
    angular) from the first scan's pose (a gap holds the pose), and per scan the odometry of the ODOM lines
    stamped strictly between the previous scan's (repaired) stamp and its own, in increasing time (lines out of
    that order are left out)."""
    odom = [content.scans[0].pose]
    between: list[list[tuple[float, Pose2D]]] = [[]]
    linear, angular = scale
    for k, scan_path in enumerate(content.odometry[1:], start=1):
        path = [(t, Pose2D(p.x * linear, p.y * linear, p.yaw * angular)) for t, p in scan_path]
        previous = odom[-1]
        odom.append(previous.compose(path[-1][1]) if path else previous)
        inside: list[tuple[float, Pose2D]] = []
        for stamp, relative in path[:-1]:
            if max(stamps[k - 1], inside[-1][0] if inside else -math.inf) < stamp < stamps[k]:
                inside.append((stamp, previous.compose(relative)))
        between.append(inside)
    return odom, between


def repaired_stamps(stamps: list[float]) -> tuple[list[float], int, float]:
    """Strictly increasing stamps by the module's rule: (stamps, how many were changed, the interval used).

    A run of scans stamped at or before the last good stamp is spread evenly between that stamp and the next
    later one, so one late scan does not push every following scan off its own (good) stamp; a run at the end
    of the log continues at the median increasing interval.
    """
    steps = np.diff(np.asarray(stamps, dtype=np.float64))
    rising = steps[steps > 0.0]
    interval = float(np.median(rising)) if rising.size else FALLBACK_INTERVAL_S
    out = list(stamps)
    changed = 0
    i = 1
    while i < len(out):
        if out[i] > out[i - 1]:
            i += 1
            continue
        end = i  # the run of bad stamps is out[i:end]
        while end < len(out) and out[end] <= out[i - 1]:
            end += 1
        step = (out[end] - out[i - 1]) / (end - i + 1) if end < len(out) else interval
        for j in range(i, end):
            out[j] = out[i - 1] + (j - i + 1) * step
        changed += end - i
        i = end
    return out, changed, interval


def _write(
    bag: Path,
    scans: list[CarmenScan],
    stamps: list[float],
    odometry: tuple[list[Pose2D], list[list[tuple[float, Pose2D]]]],
    *,
    limit: float,
    progress: Callable[[int], None] | None,
) -> None:
    """Write the bag; an existing bag is replaced only by a whole new one (:class:`BagWriter`)."""
    with BagWriter(bag) as writer:
        first = stamps[0]
        writer.write(
            "/tf_static",
            TF,
            _ns(first),
            tf_message(Pose2D(0.0, 0.0, 0.0), first, "base_footprint", "base_scan"),
            latching=True,
        )
        odom_seq = 0
        for seq, (scan, t, pose, between) in enumerate(zip(scans, stamps, *odometry, strict=True)):
            for odom_t, odom_pose in [*between, (t, pose)]:
                msg = odometry_message(odom_pose, odom_t, "odom", "base_footprint", odom_seq)
                writer.write("/odom", ODOMETRY, _ns(odom_t), msg)
                writer.write("/tf", TF, _ns(odom_t), tf_message(odom_pose, odom_t, "odom", "base_footprint"))
                odom_seq += 1
            data = LaserScanData(scan.angle_min, scan.angle_increment, 0.0, limit, scan.ranges)
            truth = odometry_message(scan.pose, t, "map", "base_footprint", seq)
            writer.write("/ground_truth/odom", ODOMETRY, _ns(t), truth)
            writer.write("/scan", LASER_SCAN, _ns(t), laser_scan_message(data, t, "base_scan", seq))
            if progress is not None:
                progress(1)


def _ns(seconds: float) -> int:
    return round(seconds * 1e9)
