"""The relations metric of Kummerle et al., "On measuring the accuracy of SLAM algorithms" (Autonomous Robots
27(4), 2009): the error of a trajectory on manually verified relative poses.

A relations file holds one relation a line, ``t1 t2 x y z roll pitch yaw``: the pose at time ``t2`` in the frame
of the pose at ``t1`` (metres, radians). For each relation the estimated relative pose ``d = inv(P(t1)) P(t2)``
is compared with the reference ``r``: ``e = inv(r) d``; the translational error is ``|e.xy|`` (m) and the
rotational error ``|e.yaw|`` (deg). The metric is their mean and standard deviation over the relations, as in
the published tables (gmapping 0.070 +- 0.083 m on the Intel log; Cartographer 0.0229 +- 0.0239 m).

Time: relation stamps are those of the raw log, a constant offset from the stamps of a corrected log; it is given
or found by the relations' own geometry (:mod:`.relation_offset`), which refuses when the evidence is weak.

A relation end between trajectory poses is bridged by odometry (:mod:`.bridging`). Relations with an end where
there is no odometry (outside its time span) are not scored (counted). Bridging puts a floor under the metric that
depends on the odometry, so :func:`relation_errors` of the reference trajectory itself is worth reporting beside a
result.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.eval.bridging import BridgedTrajectory, as_rows, relation_residuals
from mrs_nav.slam.eval.relation_offset import OffsetChoice, RelationArrays, find_offset
from mrs_nav.textfiles import bounded_lines, check_regular

MAX_RELATIONS = 1_000_000  # lines; the published files hold a few thousand
_MAX_LINE_CHARS = 4096  # a relation is two stamps and six numbers


class OdometryTrack(Protocol):
    """Odometry poses at increasing stamps (s), held ``tolerance`` s past its ends (as
    :class:`mrs_nav.replay.pose_track.PoseTrack`)."""

    stamps: list[float]
    poses: list[Pose2D]
    tolerance: float


@dataclass(frozen=True)
class Relation:
    """The pose at ``t2`` in the frame of the pose at ``t1`` (s, relation file's clock)."""

    t1: float
    t2: float
    delta: Pose2D


@dataclass(frozen=True)
class RelationErrors:
    """Mean and standard deviation of the translational (m) and rotational (deg) relation errors."""

    trans_mean_m: float
    trans_std_m: float
    rot_mean_deg: float
    rot_std_deg: float
    scored: int
    skipped: int
    offset: OffsetChoice

    def as_dict(self) -> dict[str, float | int | str]:
        return {
            "relations_trans_mean_m": self.trans_mean_m,
            "relations_trans_std_m": self.trans_std_m,
            "relations_rot_mean_deg": self.rot_mean_deg,
            "relations_rot_std_deg": self.rot_std_deg,
            "relations_scored": self.scored,
            "relations_skipped": self.skipped,
            "relations_offset_s": self.offset.offset_s,
            # how the offset was found, and the evidence: see mrs_nav.slam.eval.relation_offset
            "relations_offset_rule": self.offset.rule,
            "relations_offset_support": self.offset.support,
            "relations_offset_runner_up_s": self.offset.runner_up_s,
            "relations_offset_runner_up_support": self.offset.runner_up_support,
        }


def load_relations(path: Path) -> list[Relation]:
    """Read a relations file; a malformed line raises InvalidInputError naming ``file:line``."""
    relations: list[Relation] = []
    check_regular(path, "relations file")
    try:
        with path.open(encoding="utf-8", errors="replace") as handle:
            for number, line in enumerate(bounded_lines(handle, _MAX_LINE_CHARS, str(path)), start=1):
                words = line.split()
                if not words or words[0].startswith("#"):
                    continue
                relations.append(_relation(words, f"{path}:{number}"))
                if len(relations) > MAX_RELATIONS:
                    raise InvalidInputError(f"relations file {path} has more than {MAX_RELATIONS} relations")
    except OSError as err:
        raise InvalidInputError(f"cannot read relations file {path}: {err}") from None
    if not relations:
        raise InvalidInputError(f"relations file {path} holds no relation")
    return relations


def _relation(words: list[str], where: str) -> Relation:
    if len(words) != 8:
        raise InvalidInputError(f"{where}: a relation needs 8 numbers (t1 t2 x y z roll pitch yaw), got {len(words)}")
    try:
        t1, t2, x, y, _z, _roll, _pitch, yaw = (float(w) for w in words)
    except ValueError as err:
        raise InvalidInputError(f"{where}: malformed relation ({err})") from None
    if not all(math.isfinite(v) for v in (t1, t2, x, y, yaw)) or max(abs(x), abs(y)) > 1e5:
        raise InvalidInputError(f"{where}: relation values must be finite and within 100 km")
    return Relation(t1, t2, Pose2D(x, y, yaw))


def relation_arrays(relations: Sequence[Relation]) -> RelationArrays:
    """``relations`` as arrays (:class:`RelationArrays`)."""
    stamps = np.array([(r.t1, r.t2) for r in relations], dtype=np.float64).reshape(-1, 2)
    return RelationArrays(stamps, as_rows([r.delta for r in relations]))


def bridged(
    stamps: Sequence[float], poses: Sequence[Pose2D], odometry: OdometryTrack, odom_at_poses: Sequence[Pose2D]
) -> BridgedTrajectory:
    """The trajectory ``poses`` at ``stamps`` bridged by ``odometry`` (``odom_at_poses``: the odometry at each
    trajectory pose)."""
    if not (len(stamps) == len(poses) == len(odom_at_poses)) or len(stamps) < 2 or len(odometry.stamps) < 2:
        raise InvalidInputError("relations metric needs >= 2 trajectory poses with stamps and odometry")
    if any(b <= a for a, b in itertools.pairwise(stamps)):
        raise InvalidInputError("relations metric needs trajectory stamps in increasing order")
    return BridgedTrajectory.of(
        stamps,
        as_rows(poses),
        as_rows(odom_at_poses),
        odom_stamps=odometry.stamps,
        odom_poses=as_rows(odometry.poses),
        odom_tolerance=odometry.tolerance,
    )


def choose_offset(
    relations: Sequence[Relation], reference: BridgedTrajectory, given: float | None = None
) -> OffsetChoice:
    """The offset ``given``, or the one the relations' geometry finds on ``reference`` (see :func:`find_offset`)."""
    if given is not None:
        return OffsetChoice(given, "given")
    return find_offset(relation_arrays(relations), reference)


def relation_errors(
    relations: Sequence[Relation], trajectory: BridgedTrajectory, offset: OffsetChoice
) -> RelationErrors:
    """Score ``trajectory`` on ``relations`` at the clock ``offset`` (see the module doc)."""
    arrays = relation_arrays(relations)
    start, valid1 = trajectory.poses_at(arrays.t1 - offset.offset_s)
    end, valid2 = trajectory.poses_at(arrays.t2 - offset.offset_s)
    valid = valid1 & valid2
    if not valid.any():
        raise InvalidInputError(
            f"relations metric: no relation falls within the trajectory's time span (offset {offset.offset_s:.3f} s)"
        )
    trans, rot = relation_residuals(start[valid], end[valid], arrays.delta[valid])
    rot_deg = np.degrees(rot)
    return RelationErrors(
        float(trans.mean()),
        float(trans.std()),
        float(rot_deg.mean()),
        float(rot_deg.std()),
        trans.size,
        len(relations) - trans.size,
        offset,
    )
